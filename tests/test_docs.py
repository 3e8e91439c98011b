"""The documentation site builds with `mkdocs build --strict`, its API reference covers every public name, and the
"define a new creature" guide works when followed literally: its commands are read from the page and run."""

from __future__ import annotations

import ast
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS_EXTRA = ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python")
GUIDE = ROOT / "docs" / "guides" / "new-creature.md"
# The one change made to the guide's commands: the training preset (`quick` takes minutes).
SUBSTITUTIONS = {"--preset quick": "--preset smoke"}


def _missing_docs_extra() -> str | None:
    for name in DOCS_EXTRA:
        try:
            if importlib.util.find_spec(name) is None:
                return name
        except ModuleNotFoundError:
            return name
    return None


def _public_exports() -> dict[str, list[str]]:
    """Every public module's literal ``__all__``, read from the source (the reference's contract)."""
    out: dict[str, list[str]] = {}
    for path in sorted((ROOT / "morphkit").rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        name = ".".join(parts)
        if any(p.startswith("_") for p in parts) or name in ("morphkit", "morphkit.cli") or name.startswith(
            "morphkit.commands"
        ):
            continue
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
                out[name] = list(ast.literal_eval(node.value))
    return out


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    missing = _missing_docs_extra()
    if missing:
        pytest.skip(f"the docs extra is not installed ({missing}): pip install -e '.[docs]'")
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    cmd = [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return out


def test_mkdocs_build_strict_passes(site: Path):
    assert (site / "index.html").is_file()
    assert (site / "guides" / "new-creature" / "index.html").is_file()


def test_api_reference_documents_every_public_name(site: Path):
    html = "\n".join(p.read_text() for p in (site / "api").rglob("index.html"))
    ids = set(re.findall(r'id="(morphkit\.[\w.]+)"', html))
    missing = []
    for module, names in _public_exports().items():
        parts = module.split(".")
        owners = [".".join(parts[:i]) for i in range(2, len(parts) + 1)]  # the module or a package above it
        for name in names:
            if name.startswith("__"):
                continue
            # On the page of the module, of a package above it, or (a package's lazy or submodule-shadowed
            # export) of the module inside it that defines the name.
            if not any(i.endswith(f".{name}") and (i[: -len(name) - 1] in owners or i.startswith(module + "."))
                       for i in ids):
                missing.append(f"{module}.{name}")
    assert not missing, f"not in the API reference: {missing[:20]}"


def _fenced(text: str, lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", text, re.S | re.M)


def _shared_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The motion cache the examples' test uses too (tests/test_examples.py): the embedded human motion and the
    critter's synthesised data are made once per session, as on a user's machine."""
    path = tmp_path_factory.getbasetemp() / "motion_cache"
    path.mkdir(exist_ok=True)
    return path


def test_guide_yaml_is_the_examples_critter():
    """The creature written by the guide is the one examples/new_creature.py uses."""
    first = _fenced(GUIDE.read_text(), "bash")[0]
    heredoc = re.search(r"<<'EOF'\n(.*?)^EOF$", first, re.S | re.M)
    assert heredoc is not None, "the guide's first command writes critter.yaml with a heredoc"
    assert heredoc.group(1) == (ROOT / "examples" / "critter.yaml").read_text()


def test_guide_error_example_is_what_the_reader_says(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """The guide's example error (the knee's limits swapped) is the reader's message, line included."""
    from morphkit.errors import MorphkitError
    from morphkit.io import read_morphology

    shown = next(b for b in _fenced(GUIDE.read_text(), "text") if b.startswith("error:")).strip()
    joint, lower, upper = re.search(r"joint '(\w+)': limit lower (\S+) > upper (\S+)", shown).groups()
    lines = (ROOT / "examples" / "critter.yaml").read_text().splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.lstrip().startswith(f"{joint}:"))
    span = next(i for i in range(at, len(lines)) if "limit:" in lines[i])
    original = f"lower: {upper}, upper: {lower}"
    assert original in lines[span]
    lines[span] = lines[span].replace(original, f"lower: {lower}, upper: {upper}")  # swapped
    (tmp_path / "critter.yaml").write_text("\n".join(lines) + "\n")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(MorphkitError) as err:
        read_morphology("critter.yaml")
    assert f"error: {err.value}" == shown


def _run_guide(guide: Path, substitutions: dict[str, str], cwd: Path, *, env: dict[str, str] | None = None,
               timeout: int = 900) -> subprocess.CompletedProcess:
    """A guide's fenced bash blocks, joined in order with ``substitutions`` applied (each must still be on the
    page), run as one script in ``cwd`` that stops at the first failing command; it must succeed."""
    script = "\n".join(_fenced(guide.read_text(), "bash"))
    for old, new in substitutions.items():
        assert old in script, f"{guide.name} no longer says {old!r}: update its substitutions"
        script = script.replace(old, new)
    env = {**os.environ, **(env or {}),
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    proc = subprocess.run(["bash", "-euo", "pipefail", "-c", script], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout, check=False)
    assert proc.returncode == 0, f"{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
    return proc


def test_new_creature_guide_runs_as_written(tmp_path: Path, tmp_path_factory: pytest.TempPathFactory):
    """Every fenced bash block of the guide, in order, in an empty folder, as one script that stops at the first
    failing command (the only change: SUBSTITUTIONS)."""
    for module in ("pyrender", "imageio"):
        if importlib.util.find_spec(module) is None:
            pytest.skip(f"the render extra is not installed ({module}): pip install -e '.[render]'")
    assert len(_fenced(GUIDE.read_text(), "bash")) >= 6, "the guide lost its commands"
    _run_guide(GUIDE, SUBSTITUTIONS, tmp_path,
               env={"MORPHKIT_CACHE_DIR": str(_shared_cache(tmp_path_factory)), "PYOPENGL_PLATFORM": "egl"})
    for name in ("critter.png", "critter_walk.npz", "critter_walk.png", "critter_clip.npz", "critter_clip.bvh",
                 "compare.png"):
        assert (tmp_path / name).stat().st_size > 0, f"the guide promises {name}"
    assert (tmp_path / "runs" / "critter" / "retarget" / "checkpoint.pt").is_file()


MJCF_GUIDE = ROOT / "docs" / "guides" / "import-mjcf.md"
# The MJCF guide's changes: fewer frames, and no training (dm_control's dog trains in tests/retarget/test_ace.py).
MJCF_SUBSTITUTIONS = {"--frames 3000": "--frames 200",
                      "morphkit train ace $DOG --preset quick --out runs/dm_dog": "true"}


def test_mjcf_guide_runs_as_written(tmp_path: Path):
    """The MuJoCo guide's commands on dm_control's dog, read from the page: the model is read, synthesised,
    exported as qpos MuJoCo replays, written as YAML and back as MJCF that MuJoCo compiles to the same bodies."""
    mujoco = pytest.importorskip("mujoco")
    pytest.importorskip("dm_control")
    import numpy as np

    assert len(_fenced(MJCF_GUIDE.read_text(), "bash")) == 1
    _run_guide(MJCF_GUIDE, MJCF_SUBSTITUTIONS, tmp_path, timeout=600)
    qpos = np.load(tmp_path / "dog_synth.qpos.npy")
    import dm_control

    original = mujoco.MjModel.from_xml_path(str(Path(dm_control.__file__).parent / "suite" / "dog.xml"))
    assert qpos.shape == (200, original.nq) and np.isfinite(qpos).all()
    written = mujoco.MjModel.from_xml_path(str(tmp_path / "dog.xml"))
    assert written.nbody >= 60  # the dog's bodies, with the links of joints off their body's origin


ROBOT_GUIDE = ROOT / "docs" / "guides" / "bring-your-own-robot.md"
# The robot guide's changes: fewer frames, the smoke preset, contact sheets for videos, and the MJCF's own
# training left out (the URDF's shows the path; dm_control's dog trains in tests/retarget/test_ace.py).
ROBOT_SUBSTITUTIONS = {"--frames 3000": "--frames 200", "--preset quick": "--preset smoke",
                       "--frames 300 --seed 7": "--frames 60 --seed 7",
                       "--out aliengo_clip.mp4": "--contact-sheet --out aliengo_clip.png",
                       "morphkit train ace $QUADRUPED --preset smoke --out runs/quadruped": "true",
                       "morphkit retarget --run runs/quadruped": "true",
                       "morphkit render $QUADRUPED --motion": "true"}


def test_robot_guide_runs_as_written(tmp_path: Path, tmp_path_factory: pytest.TempPathFactory):
    """Issue 46: the bring-your-own-robot guide on the unedited vendor files, read from the page, in order."""
    pytest.importorskip("pybullet_data", reason="pybullet (the dev extra) ships the URDF")
    pytest.importorskip("dm_control")
    for module in ("pyrender", "imageio"):
        if importlib.util.find_spec(module) is None:
            pytest.skip(f"the render extra is not installed ({module}): pip install -e '.[render]'")
    proc = _run_guide(ROBOT_GUIDE, ROBOT_SUBSTITUTIONS, tmp_path,
                      env={"MORPHKIT_CACHE_DIR": str(_shared_cache(tmp_path_factory)), "PYOPENGL_PLATFORM": "egl"})
    assert "4: FR_toe (foot" in proc.stdout and "locomotion=legged, legs=4" in proc.stdout
    assert "rest pose: searched" in proc.stdout
    for name in ("aliengo_stance.png", "human_clip.npz", "aliengo_clip.npz", "aliengo_clip.png"):
        assert (tmp_path / name).stat().st_size > 0, f"the guide promises {name}"


def test_gallery_script_smoke(tmp_path: Path):
    """docs/gallery/make_gallery.py (the only source of the gallery's pictures) still runs: one turntable sheet."""
    if importlib.util.find_spec("pyrender") is None:
        pytest.skip("the render extra is not installed (pyrender): pip install -e '.[render]'")
    cmd = [sys.executable, str(ROOT / "docs" / "gallery" / "make_gallery.py"), "--smoke", "--out", str(tmp_path)]
    env = {**os.environ, "PYOPENGL_PLATFORM": "egl"}
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    from PIL import Image

    with Image.open(tmp_path / "spot_turntable.png") as sheet:  # four 240 x 180 views side by side
        assert sheet.width >= 4 * 240 and sheet.height >= 180


def test_getting_started_shows_the_readme_setup_commands():
    """The getting-started page quotes README's two set-up commands as they are."""
    readme = _fenced((ROOT / "README.md").read_text(), "bash")[0]
    page = _fenced((ROOT / "docs" / "getting-started.md").read_text(), "text")[0]
    assert page.split() == readme.split()
