"""manipkit.validate: each invalid description gets a message naming the element."""

import pytest

import manipkit
from manipkit.errors import DescriptionError
from manipkit.validate import parse_urdf

LINKS = '<link name="base"/><link name="arm"/>'


def joint(kind="revolute", parent="base", child="arm", axis="0 0 1", limit='lower="-1" upper="1" effort="1" velocity="1"', origin="0 0 0", name="j1"):
    limit_xml = f"<limit {limit}/>" if limit is not None else ""
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{origin}"/><axis xyz="{axis}"/>{limit_xml}</joint>')


def robot(body):
    return f'<robot name="t">{body}</robot>'


def test_valid_description_passes():
    assert parse_urdf(robot(LINKS + joint()), "t.urdf").get("name") == "t"


@pytest.mark.parametrize(
    "text, fragment",
    [
        ('<robot name="t"><link name="a"></robot>', "t.urdf: malformed XML at line 1, column"),
        ("<model/>", "root element is <model>, expected <robot>"),
        (robot(""), "no <link> elements"),
        (robot('<link name="a"/><link name="a"/>'), "two <link> elements are named 'a'"),
        (robot(LINKS + joint(parent="nope")), "joint 'j1' parent link 'nope' does not exist; links are: base, arm"),
        (robot(LINKS + joint(child="nope")), "joint 'j1' child link 'nope' does not exist"),
        (robot(LINKS + joint(kind="hinge")), "joint 'j1' has type 'hinge'; valid types: revolute, continuous"),
        (robot(LINKS + joint(axis="0 0 0")), "joint 'j1' has axis '0 0 0'; an axis must be a non-zero vector"),
        (robot(LINKS + joint(axis="0 nan 1")), "joint 'j1' axis is '0 nan 1'; numbers must be finite"),
        (robot(LINKS + joint(origin="0 0")), "joint 'j1' origin xyz is '0 0'; expected 3 numbers"),
        (robot(LINKS + joint(limit='lower="1" upper="-1" effort="1" velocity="1"')), "lower limit 1 above upper limit -1"),
        (robot(LINKS + joint(limit=None)), "revolute joint 'j1' has no <limit>"),
        (robot(LINKS + '<link name="c"/>' + joint()), "2 root links (base, c)"),
        (robot(LINKS + joint() + joint(name="j2", parent="arm", child="base")), "every link has a parent"),
        (robot(LINKS + joint() + joint(name="j2", parent="base", child="arm")), "link 'arm' is the child of two joints"),
    ],
)
def test_invalid_description_message_names_the_problem(text, fragment):
    with pytest.raises(DescriptionError, match=None) as info:
        parse_urdf(text, "t.urdf")
    assert fragment in str(info.value)


def test_zero_axis_is_refused_before_pinocchio_accepts_it(tmp_path):
    # Pinocchio alone would load this model and give wrong kinematics.
    path = tmp_path / "zero_axis.urdf"
    path.write_text(robot(LINKS + joint(kind="continuous", axis="0 0 0", limit=None)))
    with pytest.raises(DescriptionError, match="zero_axis.urdf: joint 'j1' has axis '0 0 0'"):
        manipkit.load(path)
