"""The inertia audit (manipkit.statics.audit): a crafted URDF per defect, flagged by link and reason; the bundled
arms as they ship; the grade carried with torque and payload answers."""

import json

import pytest
from cli_helper import run_cli

import manipkit
from manipkit.statics.audit import inertia_audit

GOOD = '<inertial><origin xyz="0 0 0.15"/><mass value="2"/><inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.004"/></inertial>'
BOX = '<collision><origin xyz="0 0 0.15"/><geometry><box size="0.08 0.08 0.3"/></geometry></collision>'


def arm(link2_inertial=GOOD, link2_geometry=BOX, effort='effort="50"', link3=None) -> str:
    """A 3-link arm about y; link2 carries the defect under test, link1 and link3 are sound (2 kg, a 8x8x30 cm box)."""
    def joint(name, parent, child, z):
        return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="0 0 {z}"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" {effort} velocity="1"/>'
                '</joint>')

    sound3 = link3 or GOOD.replace('value="2"', 'value="1.5"') + BOX
    return ('<robot name="crafted"><link name="base_link"/>'
            f'<link name="link1">{GOOD}{BOX}</link><link name="link2">{link2_inertial}{link2_geometry}</link>'
            f'<link name="link3">{sound3}</link>'
            + joint("j1", "base_link", "link1", 0.1) + joint("j2", "link1", "link2", 0.3)
            + joint("j3", "link2", "link3", 0.3) + '</robot>')


def inertial(mass, xyz="0 0 0.15", ixx=0.02, iyy=0.02, izz=0.004):
    return (f'<inertial><origin xyz="{xyz}"/><mass value="{mass}"/><inertia ixx="{ixx}" ixy="0" ixz="0" '
            f'iyy="{iyy}" iyz="0" izz="{izz}"/></inertial>')


def audit_of(text, **kwargs):
    return inertia_audit(manipkit.Robot.from_urdf(text), **kwargs)


def test_the_sound_arm_passes():
    report = audit_of(arm())
    assert report.grade == "A" and report.findings == () and report.geometry_checked


@pytest.mark.parametrize("text, check, grade", [
    (arm(link2_inertial=""), "mass_missing", "C"),
    (arm(link2_inertial=inertial(0)), "mass_zero", "C"),
    (arm(link2_inertial=inertial(1e-5)), "mass_tiny", "B"),
    (arm(link2_inertial=inertial(2, ixx=-0.01)), "inertia_not_psd", "C"),
    (arm(link2_inertial=inertial(2, xyz="0 0 0", ixx=0.01, iyy=0.01, izz=0.03)), "triangle_inequality", "C"),
    # 0.01 + 0.01 < 0.03, but shifted by m (|c|^2 1 - c c^T) = diag(0.04, 0.04, 0) of c = (0, 0, 0.2), m = 1:
    (arm(link2_inertial=inertial(1, xyz="0 0 0.2", ixx=0.01, iyy=0.01, izz=0.03)), "parallel_axis_shift", "C"),
    (arm(link2_inertial=inertial(2, xyz="0 0 0.9")), "cog_outside_geometry", "B"),
    (arm(link2_inertial=inertial(150)), "density_implausible", "B"),  # 150 kg in 1.9 litres: 78 000 kg/m^3
    (arm(link2_inertial=inertial(2, izz=1.676, ixx=1.7, iyy=1.7)), "gyration_implausible", "B"),  # izz = 1.676
    (arm(effort='effort="0"'), "effort_zero", "B"),
])
def test_each_defect_is_flagged_by_link_and_reason(text, check, grade):
    report = audit_of(text)
    where = "j2" if check.startswith("effort") else "link2"
    assert check in [f.check for f in report.by_link(where)], [f.as_dict() for f in report.findings]
    assert report.grade == grade
    if not check.startswith("effort"):
        assert not report.by_link("link1") and not report.by_link("link3")


def test_placeholder_values_repeated_over_links():
    same = inertial(1.0, ixx=0.001, iyy=0.001, izz=0.001)
    report = audit_of(arm(link2_inertial=same, link3=same + BOX).replace(GOOD, same, 1))
    assert sorted(f.link for f in report.findings if f.check == "placeholder_repeated") == ["link1", "link2", "link3"]


def test_a_missing_effort_limit_is_flagged_by_joint():
    text = arm().replace('<joint name="j3" type="revolute">', '<joint name="j3" type="continuous">')
    text = text.replace('<axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="50" velocity="1"/></joint></robot>',
                        '<axis xyz="0 1 0"/></joint></robot>')
    report = audit_of(text)
    assert [f.check for f in report.by_link("j3")] == ["effort_missing"]


def test_a_frame_link_without_inertial_or_geometry_is_no_finding():
    text = arm().replace("</robot>", '<link name="tool0"/><joint name="tool" type="fixed"><parent link="link3"/>'
                         '<child link="tool0"/><origin xyz="0 0 0.3"/></joint></robot>')
    assert audit_of(text).grade == "A"


def test_iiwa14_passes_and_panda_and_ur5_are_described_truthfully(iiwa14, panda, load_robot):
    assert inertia_audit(iiwa14).grade == "A"
    report = inertia_audit(panda)
    # panda_link1: ixx = 0.70337 kg m^2 for 4.97 kg, a radius of gyration of 0.38 m in a link about 0.33 m across
    assert [(f.link, f.check) for f in report.findings] == [("panda_link1", "gyration_implausible")]
    assert report.grade == "B"
    ur5 = inertia_audit(load_robot("ur5"))
    # UR's cylinder approximations: the wrist links' CoG at their origin, izz = 0.22 kg m^2 for 1.2 kg
    assert {(f.link, f.check) for f in ur5.findings} >= {("wrist_1_link", "gyration_implausible"),
                                                         ("wrist_3_link", "cog_outside_geometry")}
    assert ur5.grade == "B"


def test_inertia_command_json_has_one_record_per_finding_with_the_grade(tmp_path):
    path = tmp_path / "crafted.urdf"
    path.write_text(arm(link2_inertial=inertial(0)))
    result = run_cli("manipkit", "inertia", "--robot", str(path), "--format", "json", status=0)
    data = json.loads(result.stdout)
    assert data["grade"] == "C"
    assert [(r["link"], r["check"], r["grade"]) for r in data["findings"]] == [("link2", "mass_zero", "C")]
    assert data["findings"][0]["numbers"] == {"mass": 0.0}
    torques = json.loads(run_cli("manipkit", "torques", "--robot", str(path), "--format", "json", status=0).stdout)
    assert torques["inertia_grade"] == "C"
    text = run_cli("manipkit", "payload", "--robot", str(path), status=0).stdout
    line = next(line for line in text.splitlines() if line.startswith("inertia grade: C"))
    command = line.split("; ")[-1].removesuffix(" lists them)")
    listed = run_cli(*command.split(), status=0).stdout  # the printed command reproduces the findings
    assert "error: link2: mass_zero:" in listed


def test_the_grade_is_carried_with_torque_and_capacity_answers(tmp_path, iiwa14):
    from manipkit.statics.capacity import payload_capacity
    from manipkit.statics.torques import static_torques

    robot = manipkit.Robot.from_urdf(arm(link2_inertial=inertial(0)))
    assert static_torques(robot, [0.1, 0.2, 0.3]).inertia_grade == "C"
    assert payload_capacity(robot, [0.1, 0.2, 0.3]).inertia_grade == "C"
    assert static_torques(iiwa14, iiwa14.q()).inertia_grade == "A"
