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

GENERATOR_VERSION = 2
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


def _body(model: KinematicModel, e: _Emitter, store: str, *, frames: bool = False) -> None:
    """Emit the FK of one pose ``b``; ``store`` formats the per-link write from ``{link}``, ``{p}``, ``{r}``.

    With ``frames``, also store each moving joint's frame rotation in world (``frames[b, j]``) for
    :func:`_vjp_body`.
    """
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
        if X[6] == 1.0 and not np.any(X[3:6]):
            Xq = _IDENTITY
        # Joint frame in world: p_J = p_P + R_P X_p, r_J = r_P X_q.
        pj = e.add(pp, e.rotate(rp, Xp, f"o{c}"), f"pj{c}") if any(Xp) else pp
        rj = rp if Xq == _IDENTITY else e.qmul(rp, Xq, f"rj{c}")
        if frames and jt != JointType.FIXED:
            e.lines.append(f"frames[b, {j}] = Q({', '.join(e.value(v) for v in rj)})")
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


def _vjp_body(model: KinematicModel, e: _Emitter) -> None:
    r"""Emit the vector–Jacobian product of the link positions for one pose ``b``.

    With $w_l$ the cotangent of link position $p_l$, the reverse sweep accumulates over each
    subtree the force $F_c = \sum w_l$ and the moment $M_c = \sum p_l \times w_l$; the torque
    about joint $j$'s centre is $\tau = M_c - p_c \times F_c$. Then a revolute joint with world
    axis $a$ gets $a \cdot \tau$, a prismatic one $a \cdot F_c$, a spherical joint (and the
    floating base) the quaternion gradient of the rotation increment
    $\delta\phi = 2\,\mathrm{vec}(\delta n \otimes n^*)$ mapped through the normalisation:
    $\partial\ell/\partial v = 2 (n_w \tau_J + \tau_J \times n_v) / |q|$,
    $\partial\ell/\partial w = -2\, n_v \cdot \tau_J / |q|$ with $\tau_J$ the torque in the
    joint frame; mimic joints pass $m\,g$ to their target.
    """
    L, J = model.link_count, model.joint_count
    grads: dict[int, list[str]] = {}

    def add(k: int, expr: str) -> None:
        grads.setdefault(k, []).append(expr)

    for link in range(L):
        e.lines.append(f"P{link} = pos[b, {link}]")
        e.lines.append(f"F{link} = adj[b, {link}]")
        e.lines.append(f"M{link} = wp.cross(P{link}, F{link})")

    def quat_grad(prefix: str, s: int, tau_joint: str) -> None:
        e.lines.append(f"{prefix}v = V(q[b, {s}], q[b, {s + 1}], q[b, {s + 2}])")
        e.lines.append(f"{prefix}w = q[b, {s + 3}]")
        e.lines.append(f"{prefix}i = S(1.0) / wp.sqrt(wp.dot({prefix}v, {prefix}v) + {prefix}w * {prefix}w)")
        e.lines.append(f"{prefix}gv = ({tau_joint} * ({prefix}w * {prefix}i) + wp.cross({tau_joint}, {prefix}v * "
                       f"{prefix}i)) * (S(2.0) * {prefix}i)")
        e.lines.append(f"{prefix}gw = -S(2.0) * {prefix}i * {prefix}i * wp.dot({prefix}v, {tau_joint})")
        for k in range(3):
            add(s + k, f"{prefix}gv[{k}]")
        add(s + 3, f"{prefix}gw")

    qs = model.joint_q_start
    for j in reversed(range(J)):
        jt = JointType(int(model.joint_type[j]))
        c, parent = j + 1, int(model.joint_parent[j])
        wheel = int(model.joint_wheel[j])
        if jt != JointType.FIXED and wheel < 0:
            axis = ", ".join(e.lit(v) for v in model.joint_axis[j])
            if jt == JointType.SPHERICAL:
                e.lines.append(f"t{c} = wp.quat_rotate_inv(frames[b, {j}], M{c} - wp.cross(P{c}, F{c}))")
                quat_grad(f"s{c}", int(qs[j]), f"t{c}")
            else:
                e.lines.append(f"a{c} = wp.quat_rotate(frames[b, {j}], V({axis}))")
                if jt == JointType.PRISMATIC:
                    e.lines.append(f"g{c} = wp.dot(a{c}, F{c})")
                else:
                    e.lines.append(f"g{c} = wp.dot(a{c}, M{c} - wp.cross(P{c}, F{c}))")
                target = int(model.joint_mimic_target[j])
                if target >= 0:
                    add(int(qs[target]), f"{e.lit(model.joint_mimic_multiplier[j])} * g{c}")
                else:
                    add(int(qs[j]), f"g{c}")
        e.lines.append(f"F{parent} = F{parent} + F{c}")
        e.lines.append(f"M{parent} = M{parent} + M{c}")

    base = BaseType(model.base_type)
    if base != BaseType.FIXED:
        e.lines.append("t0 = M0 - wp.cross(P0, F0)")
        add(0, "F0[0]")
        add(1, "F0[1]")
        if base == BaseType.FLOATING:
            add(2, "F0[2]")
            quat_grad("s0", 3, "t0")
        else:
            add(2, "t0[2]")
    for k in sorted(grads):
        e.lines.append(f"adj_q[b, {k}] = adj_q[b, {k}] + " + " + ".join(grads[k]))


_SCALAR = {
    "float32": ("wp.float32", "wp.transform", "wp.vec3", "wp.quat"),
    "float64": ("wp.float64", "wp.transformd", "wp.vec3d", "wp.quatd"),
}


def generate_source(model: KinematicModel, dtype_name: str) -> str:
    """Python source of a module with the generated FK kernels.

    ``fk_transforms`` and ``fk_positions`` have the signature ``(q, wheel_q, wheel_batched, offset,
    out)``: thread ``i`` computes pose ``b = i + offset`` from ``q[b]`` (and
    ``wheel_q[b * wheel_batched]``) and writes ``out[b, link]`` (a transform, or the link origin).
    ``fk_positions_frames`` also writes each moving joint's world rotation ``frames[b, j]``, which
    ``fk_positions_vjp(q, pos, frames, adj, offset, adj_q)`` uses to add the analytic
    vector–Jacobian product of the positions to ``adj_q`` (forward-only kernels, no Warp adjoint).
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
    e = _Emitter()
    _body(model, e, "out[b, {link}] = V({p})", frames=True)
    kernels.append(
        "@wp.kernel(enable_backward=False)\n"
        "def fk_positions_frames(\n"
        f"    q: wp.array2d[{scalar}],\n"
        f"    wheel_q: wp.array2d[{scalar}],\n"
        "    wheel_batched: int,\n"
        "    offset: int,\n"
        f"    out: wp.array2d[{vec3}],\n"
        f"    frames: wp.array2d[{quat}],\n"
        "):\n"
        "    b = wp.tid() + offset\n" + "".join(f"    {line}\n" for line in e.lines)
    )
    e = _Emitter()
    _vjp_body(model, e)
    kernels.append(
        "@wp.kernel(enable_backward=False)\n"
        "def fk_positions_vjp(\n"
        f"    q: wp.array2d[{scalar}],\n"
        f"    pos: wp.array2d[{vec3}],\n"
        f"    frames: wp.array2d[{quat}],\n"
        f"    adj: wp.array2d[{vec3}],\n"
        "    offset: int,\n"
        f"    adj_q: wp.array2d[{scalar}],\n"
        "):\n"
        "    b = wp.tid() + offset\n" + "".join(f"    {line}\n" for line in e.lines)
    )
    key = hashlib.sha1("\n".join(kernels).encode()).hexdigest()[:16]
    header = (
        # No creature name here: the module is named by a hash of this source, and skeletons with the same
        # structure (every clip of one mocap rig, say) must share one compiled module.
        f"# Generated by morphkit.kernels.fk (generator v{GENERATOR_VERSION}): "
        f"{model.base_type.name.lower()} base, {model.joint_count} joints, {dtype_name}. Do not edit.\n"
        f"# body hash: {key}\n"
        "import warp as wp\n\n"
        f"S = {scalar}\nV = {vec3}\nQ = {quat}\nTF = {transform}\n\n\n"
    )
    return header + "\n\n".join(kernels)
