"""README opens with exactly the two set-up commands, and CI runs the second verbatim."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_readme_two_setup_commands_and_ci_uses_the_test_line():
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```bash\n(.*?)```", text, re.S)
    assert block is not None and text.index(block.group(0)) < 200, "README must open with the set-up block"
    lines = [ln for ln in block.group(1).splitlines() if ln.strip()]
    assert len(lines) == 2
    # The first installs morphkit and runs the main job (ACE on the embedded default human motion).
    assert lines[0].startswith("pip install") and "examples/ace_train.py" in lines[0]
    assert lines[1].startswith("pip install") and "pytest" in lines[1]
    ci = (ROOT / ".ci" / "run").read_text()
    # .ci/run picks the README line that installs and runs pytest; it must be this one.
    pattern = re.search(r"grep -m1 -E '([^']+)' README.md", ci)
    assert pattern is not None
    matches = [ln for ln in text.splitlines() if re.search(pattern.group(1), ln)]
    assert matches and matches[0] == lines[1]
    assert "torch==2.13.0" in ci


def test_readme_python_snippet_runs():
    """The torch snippet runs as written (every name it uses is defined in it) and gradients reach q."""
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "README shows how to use morphkit from Python"
    for block in blocks:
        scope: dict = {}
        exec(compile(block, "README.md", "exec"), scope)
    q, feet = scope["q"], scope["feet"]
    assert q.grad is not None and q.grad.shape == q.shape and feet.shape[-1] == 3
