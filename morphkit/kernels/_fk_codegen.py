"""Source generator for the per-morphology FK kernels (see ``docs/design/fk-kernels.md``).

The generated kernel is straight-line scalar code: one thread walks the joints of one pose
in topological order. The model's constants (joint origins, axes, mimic coefficients, wheel
slots) are baked in as literals and every product with a literal zero or one is removed at
generation time, which a compiler may not do itself (``0 * x`` is not ``0`` in IEEE arithmetic).
A unit axis therefore costs a sparse quaternion product, an identity origin rotation costs
nothing, and a fixed-base root is folded away entirely.
"""

from __future__ import annotations

import hashlib

import numpy as np

from morphkit.graph.types import BaseType, JointType
from morphkit.model.kinematic_model import KinematicModel

__all__ = ["GENERATOR_VERSION", "generate_source"]

GENERATOR_VERSION = 1
"""Bumped whenever the generated code changes for the same model (part of the source hash)."""

Val = float | str
"""A symbolic scalar: a Python float (a constant, folded at generation time) or a kernel local's name."""

Quat = tuple[Val, Val, Val, Val]
Vec = tuple[Val, Val, Val]

_IDENTITY: Quat = (0.0, 0.0, 0.0, 1.0)
_ZERO: Vec = (0.0, 0.0, 0.0)


class _Emitter:
    """Collects kernel lines; folds constants and drops zero terms."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.count = 0

    @staticmethod
    def lit(v: float) -> str:
        return f"S({float(v)!r})"

    def lin(self, terms: list[tuple[float, tuple[Val, ...]]]) -> Val:
        """Expression of ``sum(sign * prod(factors))``, or a float when every term is constant."""
        const = 0.0
        parts: list[tuple[str, str]] = []
        for sign, factors in terms:
            coef = float(sign)
            names: list[str] = []
            for f in factors:
                if isinstance(f, str):
                    names.append(f)
                else:
                    coef *= float(f)
            if coef == 0.0:
                continue
            if not names:
                const += coef
                continue
            body = " * ".join(names)
            if abs(coef) != 1.0:
                body = f"{self.lit(abs(coef))} * {body}"
            parts.append(("-" if coef < 0 else "+", body))
        if not parts:
            return const
        if const != 0.0:
            parts.append(("-" if const < 0 else "+", self.lit(abs(const))))
        text = parts[0][1] if parts[0][0] == "+" else f"-{parts[0][1]}"
        for op, body in parts[1:]:
            text += f" {op} {body}"
        return text

    def bind(self, prefix: str, expr: Val) -> Val:
        """A local holding ``expr`` (constants stay constants, plain names are not copied)."""
        if isinstance(expr, float):
            return expr
        if expr.isidentifier():
            return expr
        name = f"{prefix}_{self.count}"
        self.count += 1
        self.lines.append(f"{name} = {expr}")
        return name

    def value(self, v: Val) -> str:
        return self.lit(v) if isinstance(v, float) else v

    # ---- quaternion algebra on symbolic values ----------------------------------------------
    def qmul(self, a: Quat, b: Quat, prefix: str) -> Quat:
        """Hamilton product ``a * b`` (xyzw)."""
        ax, ay, az, aw = a
        bx, by, bz, bw = b
        x = self.lin([(1, (aw, bx)), (1, (ax, bw)), (1, (ay, bz)), (-1, (az, by))])
        y = self.lin([(1, (aw, by)), (-1, (ax, bz)), (1, (ay, bw)), (1, (az, bx))])
        z = self.lin([(1, (aw, bz)), (1, (ax, by)), (-1, (ay, bx)), (1, (az, bw))])
        w = self.lin([(1, (aw, bw)), (-1, (ax, bx)), (-1, (ay, by)), (-1, (az, bz))])
        return (self.bind(prefix + "x", x), self.bind(prefix + "y", y), self.bind(prefix + "z", z),
                self.bind(prefix + "w", w))

    def rotate(self, q: Quat, v: Vec, prefix: str) -> Vec:
        """``q`` applied to ``v``: $v + w t + u \\times t$ with $t = 2 u \\times v$."""
        if all(isinstance(c, float) and c == 0.0 for c in v):
            return _ZERO
        ux, uy, uz, w = q
        vx, vy, vz = v
        tx = self.bind(prefix + "tx", self.lin([(2, (uy, vz)), (-2, (uz, vy))]))
        ty = self.bind(prefix + "ty", self.lin([(2, (uz, vx)), (-2, (ux, vz))]))
        tz = self.bind(prefix + "tz", self.lin([(2, (ux, vy)), (-2, (uy, vx))]))
        x = self.lin([(1, (vx,)), (1, (w, tx)), (1, (uy, tz)), (-1, (uz, ty))])
        y = self.lin([(1, (vy,)), (1, (w, ty)), (1, (uz, tx)), (-1, (ux, tz))])
        z = self.lin([(1, (vz,)), (1, (w, tz)), (1, (ux, ty)), (-1, (uy, tx))])
        return self.bind(prefix + "x", x), self.bind(prefix + "y", y), self.bind(prefix + "z", z)

    def add(self, a: Vec, b: Vec, prefix: str) -> Vec:
        return tuple(  # type: ignore[return-value]
            self.bind(prefix + c, self.lin([(1, (ai,)), (1, (bi,))])) for c, ai, bi in zip("xyz", a, b, strict=True)
        )

    def scale(self, v: Vec, s: Val, prefix: str) -> Vec:
        return tuple(self.bind(prefix + c, self.lin([(1, (vi, s))])) for c, vi in zip("xyz", v, strict=True))  # type: ignore[return-value]

    def normalized(self, q: Quat, prefix: str) -> Quat:
        n2 = self.lin([(1, (c, c)) for c in q])
        inv = self.bind(prefix + "n", f"S(1.0) / wp.sqrt({self.value(n2)})")
        return tuple(self.bind(prefix + c, self.lin([(1, (qc, inv))])) for c, qc in zip("xyzw", q, strict=True))  # type: ignore[return-value]


def _const(v: float) -> float:
    return float(v)


def _body(model: KinematicModel, e: _Emitter, store: str) -> None:
    """Emit the FK of one pose ``b``; ``store`` formats the per-link write from ``{link}``, ``{p}``, ``{r}``."""
    coord: dict[int, str] = {}

    def qv(i: int) -> str:
        if i not in coord:
            coord[i] = e.bind(f"q{i}", f"q[b, {i}]")  # type: ignore[assignment]
        return coord[i]

    def emit_store(link: int, p: Vec, r: Quat) -> None:
        e.lines.append(store.format(link=link, p=", ".join(e.value(c) for c in p),
                                    r=", ".join(e.value(c) for c in r)))

    base = BaseType(model.base_type)
    if base == BaseType.FLOATING:
        p0: Vec = (qv(0), qv(1), qv(2))
        r0: Quat = e.normalized((qv(3), qv(4), qv(5), qv(6)), "r0")
    elif base in (BaseType.PLANAR, BaseType.WHEELED):
        p0 = (qv(0), qv(1), 0.0)
        h = e.bind("yaw_h", e.lin([(0.5, (qv(2),))]))
        r0 = (0.0, 0.0, e.bind("r0z", f"wp.sin({h})"), e.bind("r0w", f"wp.cos({h})"))  # type: ignore[assignment]
    else:
        p0, r0 = _ZERO, _IDENTITY
    poses: list[tuple[Vec, Quat]] = [(p0, r0)]
    emit_store(0, p0, r0)

    qs = model.joint_q_start
    for j in range(model.joint_count):
        jt = JointType(int(model.joint_type[j]))
        c = j + 1
        pp, rp = poses[int(model.joint_parent[j])]
        X = model.joint_X_parent[j]
        Xp: Vec = tuple(_const(v) for v in X[:3])  # type: ignore[assignment]
        Xq: Quat = tuple(_const(v) for v in X[3:])  # type: ignore[assignment]
        if np.allclose(np.abs(X[6]), 1.0, rtol=0, atol=0) and not np.any(X[3:6]):
            Xq = _IDENTITY
        # Joint frame in world: p_J = p_P + R_P X_p, r_J = r_P X_q.
        pj = e.add(pp, e.rotate(rp, Xp, f"o{c}"), f"pj{c}") if any(Xp) else pp
        rj = rp if Xq == _IDENTITY else e.qmul(rp, Xq, f"rj{c}")
        axis = tuple(_const(v) for v in model.joint_axis[j])
        if jt in (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC):
            target = int(model.joint_mimic_target[j])
            wheel = int(model.joint_wheel[j])
            if target >= 0:
                value = e.bind(f"m{c}", e.lin([(float(model.joint_mimic_multiplier[j]), (qv(int(qs[target])),)),
                                               (float(model.joint_mimic_offset[j]), ())]))
            elif wheel >= 0:
                value = e.bind(f"w{c}", f"wheel_q[b * wheel_batched, {wheel}]")
            else:
                value = qv(int(qs[j]))
            if jt == JointType.PRISMATIC:
                direction = e.rotate(rj, axis, f"a{c}")  # type: ignore[arg-type]
                pc = e.add(pj, e.scale(direction, value, f"d{c}"), f"p{c}")
                rc = rj
            else:
                h = e.bind(f"h{c}", e.lin([(0.5, (value,))]))
                if isinstance(h, float):
                    s, co = float(np.sin(h)), float(np.cos(h))
                else:
                    s, co = e.bind(f"s{c}", f"wp.sin({h})"), e.bind(f"c{c}", f"wp.cos({h})")
                motion: Quat = (*(e.lin([(a, (s,))]) for a in axis), co)  # type: ignore[assignment]
                motion = tuple(e.bind(f"mq{c}", m) for m in motion)  # type: ignore[assignment]
                pc, rc = pj, e.qmul(rj, motion, f"r{c}")
        elif jt == JointType.SPHERICAL:
            s0 = int(qs[j])
            motion = e.normalized((qv(s0), qv(s0 + 1), qv(s0 + 2), qv(s0 + 3)), f"sq{c}")
            pc, rc = pj, e.qmul(rj, motion, f"r{c}")
        else:
            pc, rc = pj, rj
        poses.append((pc, rc))
        emit_store(c, pc, rc)


_SCALAR = {
    "float32": ("wp.float32", "wp.transform", "wp.vec3", "wp.quat"),
    "float64": ("wp.float64", "wp.transformd", "wp.vec3d", "wp.quatd"),
}


def generate_source(model: KinematicModel, dtype_name: str) -> str:
    """Python source of a module with the kernels ``fk_transforms`` and ``fk_positions``.

    Both have the signature ``(q, wheel_q, wheel_batched, offset, out)``: thread ``i`` computes
    pose ``b = i + offset`` from ``q[b]`` (and ``wheel_q[b * wheel_batched]``) and writes
    ``out[b, link]`` (a transform, or the link origin).
    """
    scalar, transform, vec3, quat = _SCALAR[dtype_name]
    kernels: list[str] = []
    for name, out_type, store in (
        ("fk_transforms", transform, "out[b, {link}] = TF(V({p}), Q({r}))"),
        ("fk_positions", vec3, "out[b, {link}] = V({p})"),
    ):
        e = _Emitter()
        _body(model, e, store)
        kernels.append(
            "@wp.kernel\n"
            f"def {name}(\n"
            f"    q: wp.array2d[{scalar}],\n"
            f"    wheel_q: wp.array2d[{scalar}],\n"
            "    wheel_batched: int,\n"
            "    offset: int,\n"
            f"    out: wp.array2d[{out_type}],\n"
            "):\n"
            "    b = wp.tid() + offset\n" + "".join(f"    {line}\n" for line in e.lines)
        )
    key = hashlib.sha1("\n".join(kernels).encode()).hexdigest()[:16]
    header = (
        f"# Generated by morphkit.kernels.fk (generator v{GENERATOR_VERSION}) for {model.name!r}: "
        f"{model.base_type.name.lower()} base, {model.joint_count} joints, {dtype_name}. Do not edit.\n"
        f"# body hash: {key}\n"
        "import warp as wp\n\n"
        f"S = {scalar}\nV = {vec3}\nQ = {quat}\nTF = {transform}\n\n\n"
    )
    return header + "\n\n".join(kernels)
