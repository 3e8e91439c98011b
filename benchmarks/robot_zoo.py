"""Robot zoo: every robot of Gepetto's ``example-robot-data`` 6.0.0 through morphkit, unedited (issue 66's table).

Per robot (URDF, with the SRDF the collection pairs it with): does ``read_morphology`` read it; its base; feet
found against legs expected, hands/tools found against arms expected; the **stance height** (the root above the
lowest foot point at the rest pose) against the same height at the SRDF's reference ``group_state``
(``standing``, else ``half_sitting``, ...; joint values over q = 0 as Pinocchio's reference configurations,
judged only for standing / half-sitting states); the largest |joint| of the rest pose (the ±π check); for legged
robots 1,500 synthesised frames (``--frames``) and their quality report's foot sliding (cm/s, mean while in
contact) and deepest shape under the ground (mm). Legged robots pass with one foot per leg, a hand per arm, the
height within 10 % of the SRDF's, every rest joint within ±π, sliding < 1 cm/s and nothing > 5 mm under; arms
with a fixed base and a hand/tool per arm; wheeled robots are judged by the wheels issue (not counted).

Run: ``python benchmarks/robot_zoo.py [--robots DIR] [--only a1,go2] [--frames 1500] [--out FILE]``. Without
``--robots`` the wheel is fetched with ``pip download --no-deps example-robot-data==6.0.0`` into morphkit's cache
folder and unzipped there. Each robot runs in its own subprocess under ``--timeout`` seconds.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import shutil
import subprocess
import sys
import time
import warnings
import xml.etree.ElementTree as ET
import zipfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from datetime import date
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.io.srdf import STATE_PREFERENCE  # the SRDF state the URDF reader takes as the rest pose, first found

ERD_VERSION = "6.0.0"
ROBOTS_SUBDIR = Path("cmeel.prefix/share/example-robot-data/robots")

HEIGHT_TOLERANCE = 0.10
"""Standing height within this fraction of the SRDF's."""
JOINT_BOUND = math.pi
"""Every rest joint within ±π (no multi-turn stance)."""
SLIDING_MAX_CM_S = 1.0
UNDER_MAX_MM = 5.0

STANDING_STATES = ("standing", "half_sitting", "standing_with_arm_home", "standing_with_arm_up", "straight_standing")
"""Reference states that are stances: only these judge the standing height."""


@dataclass(frozen=True)
class Robot:
    name: str
    kind: str  # "quadruped", "biped", "arm", "wheeled"
    urdf: str  # relative to the robots folder
    srdf: str | None
    legs: int
    arms: int


# The files as example-robot-data's own loaders (robots_loader.py) pair them.
ROBOTS: tuple[Robot, ...] = (
    Robot("a1", "quadruped", "a1_description/urdf/a1.urdf", "a1_description/srdf/a1.srdf", 4, 0),
    Robot("anymal", "quadruped", "anymal_b_simple_description/robots/anymal.urdf",
          "anymal_b_simple_description/srdf/anymal.srdf", 4, 0),
    Robot("anymal_c", "quadruped", "anymal_c_simple_description/urdf/anymal.urdf",
          "anymal_c_simple_description/srdf/anymal.srdf", 4, 0),
    Robot("anymal_kinova", "quadruped", "anymal_b_simple_description/robots/anymal-kinova.urdf",
          "anymal_b_simple_description/srdf/anymal-kinova.srdf", 4, 1),
    Robot("b1", "quadruped", "b1_description/urdf/b1.urdf", "b1_description/srdf/b1.srdf", 4, 0),
    Robot("b1_z1", "quadruped", "b1_description/urdf/b1-z1.urdf", "b1_description/srdf/b1-z1.srdf", 4, 1),
    Robot("go1", "quadruped", "go1_description/urdf/go1.urdf", "go1_description/srdf/go1.srdf", 4, 0),
    Robot("go2", "quadruped", "go2_description/urdf/go2.urdf", "go2_description/srdf/go2.srdf", 4, 0),
    Robot("hyq", "quadruped", "hyq_description/robots/hyq_no_sensors.urdf", "hyq_description/srdf/hyq.srdf", 4, 0),
    Robot("laikago", "quadruped", "laikago_description/urdf/laikago.urdf", None, 4, 0),
    Robot("solo12", "quadruped", "solo_description/robots/solo12.urdf", "solo_description/srdf/solo.srdf", 4, 0),
    Robot("bolt", "biped", "bolt_description/robots/bolt.urdf", "bolt_description/srdf/bolt.srdf", 2, 0),
    Robot("g1", "biped", "g1_description/urdf/g1_29dof_rev_1_0.urdf", None, 2, 2),
    Robot("icub_reduced", "biped", "icub_description/robots/icub_reduced.urdf", "icub_description/srdf/icub.srdf",
          2, 2),
    Robot("romeo", "biped", "romeo_description/urdf/romeo.urdf", "romeo_description/srdf/romeo.srdf", 2, 2),
    Robot("simple_humanoid", "biped", "simple_humanoid_description/urdf/simple_humanoid.urdf",
          "simple_humanoid_description/srdf/simple_humanoid.srdf", 2, 2),
    Robot("talos_reduced", "biped", "talos_data/robots/talos_reduced.urdf", "talos_data/srdf/talos.srdf", 2, 2),
    # IHMC's Alex is an upper body (spine, neck, two arms; no legs in the file, and the collection loads it
    # without a free flyer): judged as arms, though issue 66 lists it among the bipeds.
    Robot("alex_nub_hands", "arm", "alex_description/urdf/alex_nub_hands.urdf",
          "alex_description/srdf/alex_nub_hands.srdf", 0, 2),
    Robot("panda", "arm", "panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf", 0, 1),
    Robot("ur5", "arm", "ur_description/urdf/ur5_robot.urdf", "ur_description/srdf/ur5.srdf", 0, 1),
    Robot("kinova", "arm", "kinova_description/robots/kinova.urdf", "kinova_description/srdf/kinova.srdf", 0, 1),
    Robot("xarm7", "arm", "xarm_description/urdf/xarm7.urdf", "xarm_description/srdf/xarm7.srdf", 0, 1),
    Robot("z1", "arm", "z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf", 0, 1),
    Robot("so100", "arm", "so_arm_description/urdf/so100.urdf", None, 0, 1),
    Robot("baxter", "arm", "baxter_description/urdf/baxter.urdf", "baxter_description/srdf/baxter_manipulation.srdf",
          0, 2),
    Robot("tiago", "wheeled", "tiago_description/robots/tiago.urdf", None, 0, 1),
    Robot("tiago_pro", "wheeled", "tiago_pro_description/robots/tiago_pro.urdf", None, 0, 2),
    Robot("pr2", "wheeled", "pr2_description/urdf/pr2.urdf", "pr2_description/srdf/pr2.srdf", 0, 2),
)
LEGGED = ("quadruped", "biped")


# ---- SRDF --------------------------------------------------------------------------------------------------
def srdf_state(path: str | os.PathLike[str]) -> tuple[str, dict[str, float]] | None:
    """The reference ``group_state`` of an SRDF (first of :data:`STATE_PREFERENCE`): its name and joint values
    (1-number joints only; a floating root's 7 numbers are skipped). ``None`` without one."""
    root = ET.parse(path).getroot()
    states: dict[str, dict[str, float]] = {}
    for gs in root.iter("group_state"):
        name = gs.get("name", "")
        values = states.setdefault(name, {})
        for j in gs.iter("joint"):
            parts = (j.get("value") or "").split()
            if len(parts) == 1 and j.get("name"):
                values[j.get("name")] = float(parts[0])
    for name in STATE_PREFERENCE:
        if name in states:
            return name, states[name]
    return None


def _foot_points(m: Any, q: np.ndarray) -> np.ndarray:
    """Foot end-effector points [F, 3] at coordinates ``q``, root at the origin (as ``Morphology.rest_points``)."""
    from morphkit.conventions import transform_multiply
    from morphkit.graph import EndEffectorRole
    from morphkit.graph.kinematics import link_poses

    poses = link_poses(m, np.asarray(q, dtype=float)[None], root_at_origin=True)[0]
    pts = [transform_multiply(poses[m.link_index(ee.link)], np.array([*ee.offset, 0, 0, 0, 1]))[:3]
           for ee in m.end_effectors if ee.role == EndEffectorRole.FOOT]
    return np.array(pts).reshape(-1, 3)


def stance_height(m: Any, q: np.ndarray) -> float | None:
    """The root's height above its lowest foot point [m] at ``q`` (None without feet)."""
    feet = _foot_points(m, q)
    return float(-feet[:, 2].min()) if len(feet) else None


def state_q(m: Any, values: dict[str, float]) -> tuple[np.ndarray, int]:
    """Coordinates of an SRDF state: q = 0 (identity base and balls) with the state's joint values, as
    Pinocchio's reference configurations; and how many of the state's joints the morphology has as coordinates."""
    from morphkit.graph import BaseType, JointType

    q = np.zeros(m.coordinate_count)
    if m.base == BaseType.FLOATING:
        q[6] = 1.0
    starts = m.joint_q_start
    used = 0
    for ji, j in enumerate(m.joints):
        if j.type == JointType.SPHERICAL and not m.is_driven(j):
            q[starts[ji] + 3] = 1.0
        elif j.name in values and starts[ji + 1] - starts[ji] == 1:
            q[starts[ji]] = values[j.name]
            used += 1
    return q, used


def max_rest_joint(m: Any) -> float:
    """The largest |value| [rad] of a revolute or continuous joint at the rest pose (0 without one)."""
    from morphkit.graph import JointType

    q = m.rest_q()
    starts = m.joint_q_start
    vals = [abs(q[starts[ji]]) for ji, j in enumerate(m.joints)
            if not m.is_driven(j) and j.type in (JointType.REVOLUTE, JointType.CONTINUOUS)]
    return float(max(vals)) if vals else 0.0


# ---- one robot ---------------------------------------------------------------------------------------------
def measure_robot(robot: Robot, robots_dir: str | os.PathLike[str], *, frames: int = 1500,
                  seed: int = 0) -> dict[str, Any]:
    """Everything the table shows of one robot (``frames = 0``: no synthesis). Never raises on the robot's
    account: a reading or synthesis error is the row's text."""
    from morphkit.graph import BaseType, EndEffectorRole
    from morphkit.io import read_morphology

    t0 = time.perf_counter()
    row: dict[str, Any] = {"name": robot.name, "kind": robot.kind, "legs_expected": robot.legs,
                           "arms_expected": robot.arms, "urdf": robot.urdf, "srdf": robot.srdf}
    urdf = Path(robots_dir) / robot.urdf
    if not urdf.is_file():
        row["read"] = f"not found: {robot.urdf}"
        return row
    try:
        m = read_morphology(urdf)
    except Exception as e:  # the row says why
        row["read"] = (str(e).strip().splitlines() or [type(e).__name__])[0].replace(f"{Path(robots_dir)}{os.sep}", "")
        row["seconds"] = round(time.perf_counter() - t0, 1)
        return row
    row["read"] = "ok"
    row["base"] = BaseType(m.base).name.lower()
    row["feet"] = len(m.ee_by_role(EndEffectorRole.FOOT))
    row["hands"] = sum(1 for e in m.end_effectors if e.role.on_arm)
    row["heads"] = len(m.ee_by_role(EndEffectorRole.HEAD))
    row["max_rest_joint"] = round(max_rest_joint(m), 3)
    h = stance_height(m, m.rest_q())
    row["height"] = None if h is None else round(h, 4)
    if robot.srdf is not None and (Path(robots_dir) / robot.srdf).is_file():
        state = srdf_state(Path(robots_dir) / robot.srdf)
        if state is not None:
            row["srdf_state"] = state[0]
            q, used = state_q(m, state[1])
            row["srdf_joints"] = f"{used}/{len(state[1])}"
            hs = stance_height(m, q)
            row["srdf_height"] = None if hs is None else round(hs, 4)
            if h is not None and hs is not None and hs > 1e-6:
                row["height_ratio"] = round(h / hs, 4)
            if robot.kind in LEGGED and hs is not None and hs > 1e-6:
                # The stance the anatomy searches where no SRDF is beside the file (laikago, the G1, most MJCFs),
                # judged against the same SRDF height: the reader alone would pass by taking the SRDF's pose.
                from morphkit.io.urdf import read_urdf

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    alone = read_urdf(urdf, srdf=False)
                hs_alone = stance_height(alone, state_q(alone, state[1])[0])
                h_alone = stance_height(alone, alone.rest_q())
                if h_alone is not None and hs_alone is not None and hs_alone > 1e-6:
                    row["searched_ratio"] = round(h_alone / hs_alone, 4)
    if robot.kind in LEGGED and frames > 0:
        from morphkit.synth import synthesize
        from morphkit.synth.report import quality_report
        try:
            result = synthesize(m, frames=frames, fps=30.0, seed=seed, progress=False)
            report = quality_report(result)
            row["sliding_cm_s"] = report["foot_sliding_cm_s"]
            row["under_mm"] = report["penetration_mm"]
            row["deepest_link"] = report.get("deepest_link")
        except Exception as e:
            row["synth"] = (str(e).strip().splitlines() or [type(e).__name__])[0]
    row["seconds"] = round(time.perf_counter() - t0, 1)
    return row


def judge(row: dict[str, Any]) -> tuple[bool | None, list[str]]:
    """Pass / fail / not judged (None: wheeled) and the reasons it fails, per issue 66's targets."""
    kind = row["kind"]
    if kind == "wheeled":
        return None, ["judged by the wheels issue"]
    if row.get("read") != "ok":
        return False, ["not read"]
    why: list[str] = []
    if kind in LEGGED:
        if row["base"] != "floating":
            why.append(f"{row['base']} base")
        if row["feet"] != row["legs_expected"]:
            why.append(f"feet {row['feet']}/{row['legs_expected']}")
        if row["hands"] != row["arms_expected"]:
            why.append(f"hands {row['hands']}/{row['arms_expected']}")
        ratio = row.get("height_ratio")
        if ratio is not None and row.get("srdf_state") in STANDING_STATES and abs(ratio - 1.0) > HEIGHT_TOLERANCE:
            why.append(f"height {100 * (ratio - 1):+.0f} %")
        searched = row.get("searched_ratio")
        if searched is not None and row.get("srdf_state") in STANDING_STATES and abs(searched - 1.0) > HEIGHT_TOLERANCE:
            why.append(f"searched stance {100 * (searched - 1):+.0f} %")
        if row["max_rest_joint"] > JOINT_BOUND:
            why.append(f"joint {row['max_rest_joint']:.1f} rad")
        if "synth" in row:
            why.append("synthesis failed")
        if row.get("sliding_cm_s") is not None and row["sliding_cm_s"] >= SLIDING_MAX_CM_S:
            why.append(f"sliding {row['sliding_cm_s']:.1f} cm/s")
        if row.get("under_mm") is not None and row["under_mm"] > UNDER_MAX_MM:
            why.append(f"{row['under_mm']:.0f} mm under")
    else:
        if row["base"] != "fixed":
            why.append(f"{row['base']} base")
        if row["hands"] != row["arms_expected"]:
            why.append(f"hands {row['hands']}/{row['arms_expected']}")
    return not why, why


# ---- the table ---------------------------------------------------------------------------------------------
def _f(v: Any, fmt: str) -> str:
    return "–" if v is None else format(v, fmt)


def _ratio(r: dict[str, Any]) -> str:
    """The height ratio; in parentheses where the SRDF state is not a stance (not judged)."""
    text = _f(r.get("height_ratio"), ".2f")
    return text if r.get("height_ratio") is None or r.get("srdf_state") in STANDING_STATES else f"({text})"


def format_table(rows: list[dict[str, Any]]) -> str:
    """The markdown table of measured rows, then the line ``N of M pass`` (wheeled robots not counted)."""
    lines = ["| robot | class | read | base | feet | hands/tools | SRDF state | height rest / SRDF [m] | ratio | "
             "searched / SRDF | max \\|q\\| rest [rad] | sliding [cm/s] | under [mm] | s | verdict |",
             "|---|---|---|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        ok, why = judge(r)
        verdict = "—" if ok is None else ("pass" if ok else "**fail**")
        if why and ok is not None and not ok:
            verdict += ": " + ", ".join(why)
        elif ok is None:
            verdict = why[0]
        read = r.get("read", "–").replace("|", "\\|")
        legged = r["kind"] in LEGGED
        synth = r.get("synth")
        sliding = _f(r.get("sliding_cm_s"), ".3g") if synth is None else "error: " + synth.replace("|", "\\|")
        lines.append(" | ".join([
            f"| {r['name']}", r["kind"], read, r.get("base", "–"),
            f"{r['feet']}/{r['legs_expected']}" if "feet" in r else "–",
            f"{r['hands']}/{r['arms_expected']}" if "hands" in r else "–",
            r.get("srdf_state") or ("no SRDF" if r.get("srdf") is None else "no group_state"),
            f"{_f(r.get('height'), '.3f')} / {_f(r.get('srdf_height'), '.3f')}" if legged else "–",
            _ratio(r) if legged else "–",
            _f(r.get("searched_ratio"), ".2f") if legged else "–",
            _f(r.get("max_rest_joint"), ".2f"),
            sliding if legged else "–",
            _f(r.get("under_mm"), ".1f") if legged else "–",
            _f(r.get("seconds"), ".0f"),
            verdict + " |"]))
    judged = [judge(r)[0] for r in rows]
    counted = [ok for ok in judged if ok is not None]
    lines.append("")
    lines.append(f"{sum(1 for ok in counted if ok)} of {len(counted)} pass"
                 + (f" ({len(judged) - len(counted)} wheeled not judged here)" if len(counted) < len(judged) else ""))
    return "\n".join(lines) + "\n"


def fetch_robots() -> Path:
    """The installed package's robots folder (the dev extra installs 6.0.0), else the wheel's in morphkit's cache,
    downloaded and unzipped on first use."""
    import sysconfig
    from importlib.metadata import PackageNotFoundError, version

    from morphkit._folder_lock import hold_run_folder
    from morphkit.cache import cache_dir

    installed = Path(sysconfig.get_paths()["purelib"]) / ROBOTS_SUBDIR
    with contextlib.suppress(PackageNotFoundError):
        if version("example-robot-data") == ERD_VERSION and installed.is_dir():
            return installed

    root = cache_dir("robot_zoo", f"example-robot-data-{ERD_VERSION}")
    robots = root / "unzipped" / ROBOTS_SUBDIR
    if robots.is_dir():  # only ever a whole extraction: it is renamed into place (below)
        return robots
    root.mkdir(parents=True, exist_ok=True)
    with hold_run_folder(root):  # a second run is refused while this one unpacks
        return _download_and_unzip(root, robots)


def _download_and_unzip(root: Path, robots: Path) -> Path:
    if robots.is_dir():
        return robots
    wheel_dir = root / "wheel"
    wheel_dir.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", f"example-robot-data=={ERD_VERSION}",
           "-d", str(wheel_dir)]
    print("downloading: " + " ".join(cmd), file=sys.stderr)
    subprocess.run(cmd, check=True, stdout=sys.stderr)
    wheels = sorted(wheel_dir.glob(f"example_robot_data-{ERD_VERSION}-*.whl"))
    if not wheels:
        raise SystemExit(f"no example_robot_data {ERD_VERSION} wheel in {wheel_dir}")
    print(f"unzipping {wheels[0]} -> {root / 'unzipped'}", file=sys.stderr)
    partial = root / "unzipping"
    shutil.rmtree(partial, ignore_errors=True)  # an interrupted earlier extraction
    with zipfile.ZipFile(wheels[0]) as z:
        z.extractall(partial)
    partial.rename(root / "unzipped")
    return robots


def _run_one(robot: Robot, robots_dir: Path, frames: int, seed: int, timeout: float) -> dict[str, Any]:
    """One robot in a subprocess (a hang or a crash is the row's text, not the end of the table)."""
    cmd = [sys.executable, __file__, "--worker", robot.name, "--robots", str(robots_dir), "--frames", str(frames),
           "--seed", str(seed)]
    t0 = time.perf_counter()
    base = {"name": robot.name, "kind": robot.kind, "legs_expected": robot.legs, "arms_expected": robot.arms,
            "urdf": robot.urdf, "srdf": robot.srdf}
    try:
        done = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {**base, "read": f"timed out after {timeout:g} s", "seconds": round(time.perf_counter() - t0, 1)}
    lines = done.stdout.strip().splitlines()
    if done.returncode != 0 or not lines:
        err = [ln for ln in done.stderr.strip().splitlines() if ln.strip()]
        return {**base, "read": f"worker exit {done.returncode}: {err[-1] if err else ''}",
                "seconds": round(time.perf_counter() - t0, 1)}
    row = json.loads(lines[-1])
    row["seconds"] = round(time.perf_counter() - t0, 1)  # with the interpreter's start
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=Path, help="the unzipped wheel's robots folder (default: download it)")
    parser.add_argument("--only", help=f"comma-separated robot names (default: all {len(ROBOTS)})")
    parser.add_argument("--frames", type=int, default=1500, help="synthesised frames per legged robot (0: none)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=1, help="robots measured at once (default 1)")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per robot (default 600)")
    parser.add_argument("--out", type=Path, help="also write the table to this file (atomically)")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON to this file")
    parser.add_argument("--sheet", type=Path, help="also draw every robot read at its rest pose into this PNG "
                        "(the render extra; one tile per robot, labelled with its verdict)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    by_name = {r.name: r for r in ROBOTS}
    if args.worker:  # one robot, one JSON line on stdout
        out = sys.stdout
        with contextlib.redirect_stdout(sys.stderr):  # Warp's module-load messages
            row = measure_robot(by_name[args.worker], args.robots, frames=args.frames, seed=args.seed)
        out.write(json.dumps(row) + "\n")
        return 0

    robots = list(ROBOTS)
    if args.only:
        names = [n.strip() for n in args.only.split(",") if n.strip()]
        unknown = [n for n in names if n not in by_name]
        if unknown:
            parser.error(f"unknown robot(s) {', '.join(unknown)} (known: {', '.join(by_name)})")
        robots = [by_name[n] for n in names]
    robots_dir = args.robots if args.robots is not None else fetch_robots()
    if not robots_dir.is_dir():
        parser.error(f"--robots {robots_dir}: no such folder")
    print(f"robot zoo: {len(robots)} robots from {robots_dir}, {args.frames} frames each legged, "
          f"{args.jobs} at a time", file=sys.stderr)
    t0 = time.perf_counter()

    def one(robot: Robot) -> dict[str, Any]:
        row = _run_one(robot, robots_dir, args.frames, args.seed, args.timeout)
        ok, why = judge(row)
        print(f"  {robot.name}: {'pass' if ok else ('-' if ok is None else 'fail: ' + ', '.join(why))} "
              f"({row.get('seconds', 0):.0f} s)", file=sys.stderr, flush=True)
        return row

    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        rows = list(pool.map(one, robots))
    wall = time.perf_counter() - t0
    table = format_table(rows)
    print(table, end="")
    print(f"wall time {wall:.0f} s ({date.today().isoformat()})", file=sys.stderr)
    if args.out is not None or args.json is not None:
        from morphkit._atomic import atomic_write_text
        if args.out is not None:
            atomic_write_text(args.out, table)
        if args.json is not None:
            atomic_write_text(args.json, json.dumps(rows, indent=2) + "\n")
    if args.sheet is not None:
        draw_sheet(rows, robots_dir, args.sheet)
    return 0


def draw_sheet(rows: list[dict[str, Any]], robots_dir: Path, out: Path, *, tile: tuple[int, int] = (320, 240)) -> None:
    """One tile per robot read: its rest pose seen from the front left, labelled with its name and verdict."""
    from morphkit.io import read_morphology
    from morphkit.render import contact_sheet, iter_turntable_frames, write_image

    frames, labels = [], []
    for r in rows:
        if r.get("read") != "ok":
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # missing meshes: drawn as the links' other shapes or stand-ins
            m = read_morphology(Path(robots_dir) / r["urdf"])
            (frame,) = list(iter_turntable_frames(m, frames=1, size=tile, start_deg=-35.0, progress=False))
        ok, _ = judge(r)
        frames.append(frame)
        labels.append(f"{r['name']}: {'pass' if ok else ('wheeled' if ok is None else 'fail')}")
    write_image(contact_sheet(frames, columns=7, labels=labels), out)
    print(f"sheet: {out}", file=sys.stderr)


if __name__ == "__main__":
    raise SystemExit(main())
