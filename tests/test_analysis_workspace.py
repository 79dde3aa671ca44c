"""Tests of manipkit.analysis.workspace (planar part): sampled tool points against the analytic radii, plots.

Conventions: planar arms in the x-y plane, joints about +z, radians and metres;
the analytic reachable annulus is [|l1 - l2|, l1 + l2] for 2R and
[max(0, 2 l_max - sum), sum] for 3R.
"""

from __future__ import annotations

import struct
from pathlib import Path
from xml.etree import ElementTree

import numpy as np
import pytest

import manipkit
from manipkit.analysis.workspace import (
    planar_link_lengths,
    planar_workspace,
    plot_planar_workspace,
    sample_planar_workspace,
)
from manipkit.closed_form.planar import PlanarArmError
from manipkit.errors import OutputError
from manipkit.kinematics.robot import Robot

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_size(data: bytes) -> tuple[int, int]:
    """(width, height) from the IHDR chunk that must follow the PNG signature."""
    assert data[:8] == PNG_SIGNATURE
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


@pytest.mark.parametrize(
    "lengths, r_min, r_max",
    [
        ((1.0, 0.6), 0.4, 1.6),  # 2R: |1 - 0.6|, 1 + 0.6
        ((4.0, 2.0, 1.0), 1.0, 7.0),  # seed 004: 4 - 2 - 1, 4 + 2 + 1
        ((1.0, 2.0, 4.0), 1.0, 7.0),  # longest last: 4 - 2 - 1
        ((1.0, 1.0, 0.5), 0.0, 2.5),  # the two short links reach past each other: a disc
    ],
)
def test_sampled_points_lie_in_the_reachable_annulus_and_reach_its_edges(lengths, r_min, r_max):
    assert planar_workspace(lengths).reachable == (r_min, r_max)
    r = np.hypot(*sample_planar_workspace(lengths, 20000, rng=np.random.default_rng(1)).T)
    assert np.all(r >= r_min - 1e-12) and np.all(r <= r_max + 1e-12)
    # uniform joint angles come close to both circles: within 1% of the outer radius
    assert r.max() >= r_max - 0.01 * r_max
    assert r.min() <= r_min + 0.01 * r_max


def test_sample_planar_workspace_is_reproducible_with_a_seed():
    first = sample_planar_workspace([4, 2, 1], 50, rng=7)
    again = sample_planar_workspace([4, 2, 1], 50, rng=np.random.default_rng(7))
    assert first.shape == (50, 2)
    assert np.array_equal(first, again)
    assert not np.array_equal(first, sample_planar_workspace([4, 2, 1], 50, rng=8))


@pytest.mark.parametrize(
    "lengths, n, message",
    [
        ([1.0, 1.0, 1.0, 1.0], 10, "lengths must be 2 or 3 link lengths"),
        ([1.0, -1.0], 10, "l2 = -1.0 is not a valid link length"),
        ("ab", 10, "lengths must be 2 or 3 numbers"),
        ([1.0, 1.0], 2.5, "n = 2.5 must be a whole number"),
    ],
)
def test_sample_planar_workspace_rejects_bad_input(lengths, n, message):
    with pytest.raises(PlanarArmError, match=message):
        sample_planar_workspace(lengths, n, rng=0)


def test_plot_planar_workspace_writes_a_png(tmp_path):
    (tmp_path / "figures").mkdir()
    out = plot_planar_workspace([4.0, 2.0, 1.0], tmp_path / "figures" / "ws.png", n_samples=2000)
    assert out == tmp_path / "figures" / "ws.png"
    width, height = png_size(out.read_bytes())
    assert width > 400 and height > 400


def test_plot_planar_workspace_writes_an_svg_for_a_2r_arm(tmp_path):
    out = plot_planar_workspace([1.0, 0.6], tmp_path / "ws.svg", n_samples=500, configurations=4)
    text = out.read_text(encoding="utf-8")
    ElementTree.fromstring(text.encode("utf-8"))  # well-formed XML
    assert "<svg" in text
    # matplotlib keeps each text as a comment beside its glyph paths; the title carries the radii
    # |1 - 0.6| = 0.4 and 1 + 0.6 = 1.6, and a 2R arm with unequal links has no dexterous point
    assert "<!-- reachable 0.4 ≤ r ≤ 1.6; dexterous empty -->" in text
    assert text.count("<image") == 1  # the samples are one raster image, not 500 vector dots


def test_plot_planar_workspace_is_reproducible(tmp_path):
    a = plot_planar_workspace([1.0, 1.0, 0.5], tmp_path / "a.png", n_samples=1000, seed=3)
    b = plot_planar_workspace([1.0, 1.0, 0.5], tmp_path / "b.png", n_samples=1000, seed=3)
    assert a.read_bytes() == b.read_bytes()


def test_plot_planar_workspace_creates_no_folder(tmp_path):
    # issue 15: parents were made silently (`workspace --plot /nonexistent/x.png` created /nonexistent/)
    with pytest.raises(OutputError) as caught:
        plot_planar_workspace([1.0, 1.0], tmp_path / "no_such_folder" / "ws.png", n_samples=10)
    assert str(caught.value) == f"cannot write {tmp_path / 'no_such_folder' / 'ws.png'}: no such folder {tmp_path / 'no_such_folder'}"
    assert list(tmp_path.iterdir()) == []


def test_plot_planar_workspace_refuses_a_folder(tmp_path):
    with pytest.raises(OutputError, match=r": it is a folder; give a file name$"):
        plot_planar_workspace([1.0, 1.0], tmp_path, n_samples=10)


def test_plot_planar_workspace_reports_a_full_disk(tmp_path, monkeypatch):
    # the disk fills while matplotlib writes: one line, the old plot kept, no partial file left beside it
    import errno

    import matplotlib.figure

    def fill_the_disk(self, target, **kwargs):
        Path(target).write_bytes(b"\x89PNG half")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", fill_the_disk)
    plot = tmp_path / "plot.png"
    plot.write_bytes(b"old plot")
    with pytest.raises(OutputError) as caught:
        plot_planar_workspace([1.0, 1.0], plot, n_samples=10)
    assert str(caught.value) == f"cannot write {plot}: No space left on device"
    assert plot.read_bytes() == b"old plot" and [p.name for p in tmp_path.iterdir()] == ["plot.png"]


def test_plot_planar_workspace_rejects_an_unknown_format(tmp_path):
    with pytest.raises(PlanarArmError, match=r"cannot write 'ws.jpg': use a file name ending in .png or .svg"):
        plot_planar_workspace([1.0, 1.0], tmp_path / "ws.jpg")


# ----------------------------------------------------------------------
# planar_link_lengths: lengths read off a URDF chain
# ----------------------------------------------------------------------


def two_joint_urdf(*, second_type="revolute", second_axis="0 0 1", second_xyz="1 0 0") -> str:
    """base_link -joint1 (about z)-> link1 -joint2-> link2 -ee_joint (x = 0.5)-> ee_link."""
    return f"""<?xml version="1.0"?>
<robot name="hand_arm">
  <link name="base_link"/><link name="link1"/><link name="link2"/><link name="ee_link"/>
  <joint name="joint1" type="revolute">
    <parent link="base_link"/><child link="link1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <joint name="joint2" type="{second_type}">
    <parent link="link1"/><child link="link2"/><origin xyz="{second_xyz}"/><axis xyz="{second_axis}"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <joint name="ee_joint" type="fixed">
    <parent link="link2"/><child link="ee_link"/><origin xyz="0.5 0 0"/>
  </joint>
</robot>
"""


def test_planar_link_lengths_of_the_bundled_arms_are_their_xacro_lengths():
    assert planar_link_lengths(manipkit.load("planar_3r")) == (4.0, 2.0, 1.0)  # the defaults l1, l2, l3
    assert planar_link_lengths(manipkit.load("planar_2r", l1=0.7, l2=0.3)) == pytest.approx((0.7, 0.3), abs=1e-15)


def test_planar_link_lengths_of_a_hand_written_arm():
    # joint2 sits 1 m along x from joint1, the tip 0.5 m further
    assert planar_link_lengths(Robot.from_urdf(two_joint_urdf())) == (1.0, 0.5)


def test_planar_link_lengths_rejects_a_prismatic_joint():
    robot = Robot.from_urdf(two_joint_urdf(second_type="prismatic", second_axis="1 0 0"))
    with pytest.raises(PlanarArmError, match="^joint 'joint2' is prismatic; the planar workspace needs revolute joints$"):
        planar_link_lengths(robot)


def test_planar_link_lengths_rejects_axes_that_are_not_parallel():
    robot = Robot.from_urdf(two_joint_urdf(second_axis="0 1 0"))
    with pytest.raises(PlanarArmError, match="^robot 'hand_arm': the joint axes are not parallel, so it is not a planar arm$"):
        planar_link_lengths(robot)


def test_planar_link_lengths_rejects_joints_out_of_one_plane():
    robot = Robot.from_urdf(two_joint_urdf(second_xyz="1 0 0.2"))  # joint2 0.2 m above joint1's plane
    with pytest.raises(PlanarArmError, match="^robot 'hand_arm': the joints do not lie in one plane, so it is not a planar arm$"):
        planar_link_lengths(robot)


def test_planar_link_lengths_rejects_an_arm_with_five_joints():
    with pytest.raises(PlanarArmError, match="has 5 joints from base_link to ee_link; the planar workspace needs a 2R or 3R arm"):
        planar_link_lengths(manipkit.load("course_arm"))
