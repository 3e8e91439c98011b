"""Numbers and references a description may not hold, refused by the builder with the file and line: joint
limits beyond ±MAX_LIMIT (±1e308 overflowed the samplers) — except a revolute joint beyond it on both sides,
which vendor files write for a hinge that turns freely and which reads as continuous —, a joint that mimics
itself."""

from __future__ import annotations

from pathlib import Path

import pytest

from morphkit.cli import main
from morphkit.errors import GraphError, SourceLocation
from morphkit.graph import JointType, Limit, Mimic, MorphologyBuilder
from morphkit.graph.builder import MAX_LIMIT
from morphkit.io.urdf import parse_urdf
from morphkit.io.yaml_format import parse_yaml

_YAML = """\
name: arm
base: fixed
root: base
links:
  base: {shapes: [{type: box, size: [0.1, 0.1, 0.1]}]}
  a: {shapes: [{type: sphere, radius: 0.05}]}
joints:
  j: {type: {kind}, parent: base, child: a, axis: [0, 0, 1],
      limit: {lower: {lo}, upper: {hi}}}
end_effectors:
  tip: {link: a, role: hand}
"""


def _yaml(kind: str, lo: str, hi: str) -> str:
    return _YAML.replace("{kind}", kind).replace("{lo}", lo).replace("{hi}", hi)


@pytest.mark.parametrize(("kind", "lo", "hi"), [("prismatic", "-1e308", "1e308"), ("revolute", "-1.5e6", "0"),
                                               ("prismatic", "-1.5e6", "0"), ("revolute", "0", "2e6"),
                                               ("prismatic", "0", "2e6")])
def test_a_limit_beyond_the_bound_is_refused_at_its_line(kind: str, lo: str, hi: str):
    with pytest.raises(GraphError, match=r"joint 'j': limit \[.*\] beyond ±1e\+06 \(rad or m\)") as info:
        parse_yaml(_yaml(kind, lo, hi), source="arm.yaml")
    assert info.value.location == SourceLocation("arm.yaml", 8)
    assert ("continuous" in info.value.message) == (kind == "revolute")


def test_limits_up_to_the_bound_read_and_a_continuous_joint_ignores_its_limit():
    m = parse_yaml(_yaml("revolute", f"{-MAX_LIMIT}", f"{MAX_LIMIT}"), source="arm.yaml")
    assert (m.joints[0].limit.lower, m.joints[0].limit.upper) == (-1e6, 1e6)
    assert parse_yaml(_yaml("continuous", "-1e308", "1e308"), source="arm.yaml").joints[0].limit is None


@pytest.mark.parametrize("big", ["1e16", "1e308"])
def test_a_urdf_hinge_unlimited_by_huge_limits_reads_as_continuous(big: str):
    """example-robot-data's iris drone writes its rotors' limits as ±1e16: a hinge that turns freely."""
    text = f"""<robot name="r">
  <link name="base"/>
  <link name="a"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-{big}" upper="{big}"/></joint>
</robot>"""
    with pytest.warns(UserWarning, match=r"r.urdf:4: joint 'j': limit .* read as unlimited"):
        m = parse_urdf(text, source="r.urdf")
    assert m.joints[0].type == JointType.CONTINUOUS and m.joints[0].limit is None


def test_a_urdf_limit_beyond_the_bound_on_one_side_is_refused_at_its_line():
    text = """<robot name="r">
  <link name="base"/>
  <link name="a"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="1e308"/></joint>
</robot>"""
    with pytest.raises(GraphError, match="beyond") as info:
        parse_urdf(text, source="r.urdf")
    assert info.value.location == SourceLocation("r.urdf", 4)


def test_the_cli_refuses_1e308_limits_with_one_line(tmp_path: Path, capsys):
    path = tmp_path / "arm.yaml"
    path.write_text(_yaml("prismatic", "-1e308", "1e308"))
    for argv in (["info", str(path)], ["synth", str(path), "--frames", "30", "--out", str(tmp_path / "out")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: {path}:8: joint 'j': limit [-1e+308, 1e+308] beyond") and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def _two_joints(mimic: str) -> MorphologyBuilder:
    b = MorphologyBuilder("m", source="m.yaml")
    for n in ("base", "a", "b"):
        b.add_link(n)
    b.add_joint_revolute("j1", "base", "a", limit=Limit(-1, 1))
    b.add_joint_revolute("j2", "a", "b", limit=Limit(-1, 1), mimic=Mimic(mimic), location=SourceLocation("m.yaml", 7))
    return b


def test_a_joint_that_mimics_itself_says_so():
    with pytest.raises(GraphError, match="joint 'j2' mimics itself") as info:
        _two_joints("j2").build()
    assert info.value.location == SourceLocation("m.yaml", 7) and "unknown" not in info.value.message
    with pytest.raises(GraphError, match="joint 'j2' mimics unknown joint 'j9'"):
        _two_joints("j9").build()
    assert _two_joints("j1").build().joint("j2").mimic.joint == "j1"


def test_a_urdf_self_mimic_says_so_at_its_line(tmp_path: Path, capsys):
    path = tmp_path / "sm.urdf"
    path.write_text("""<robot name="sm">
  <link name="base"/>
  <link name="a"/>
  <link name="b"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><limit lower="-1" upper="1"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><limit lower="-1" upper="1"/>
    <mimic joint="j2"/></joint>
</robot>""")
    assert main(["info", str(path)]) == 2
    assert capsys.readouterr().err == f"error: {path}:6: joint 'j2' mimics itself; a mimic follows another joint\n"
