"""manipkit.app.viewer.path_scene and `manipkit path --view-html`: the tool path drawn and the arm animated along the plan.

Independent sources: the planned poses (what the polyline must join), `Robot.transform` of the planned rows
(where every visual and triad must be at each keyframe, with Pinocchio's geometry placements relative to their
parent frames), and meshcat's drawing commands read back out of the standalone HTML (base64 msgpack, decoded
here with umsgpack). The quaternion -> matrix formula is written here.
"""

import base64
import math
import re

import numpy as np
import pytest
import umsgpack
from cli_helper import run_cli

import manipkit
from manipkit.app.viewer.path_scene import UNTIMED_STEP, path_scene, write_path_html
from manipkit.errors import OptionError
from manipkit.paths.poses import line_poses
from manipkit.spatial.transforms import transform_from_xyz_rpy

LINE = ([0.4, 0.1, 0.4], [0.5, -0.1, 0.3])  # m, the tool pointing down (rpy pi, 0, 0)
LINE_ARGS = ["--line", "0.4", "0.1", "0.4", "3.14159", "0", "0", "0.5", "0.1", "0.4", "3.14159", "0", "0"]


@pytest.fixture(scope="module")
def ur5():
    return manipkit.load("ur5")


@pytest.fixture(scope="module")
def planned(ur5):
    poses = line_poses(*(transform_from_xyz_rpy(p, [math.pi, 0, 0]) for p in LINE), step=0.02)
    plan = manipkit.plan_path(ur5, poses, base="base_link", tip="tool0", speed=0.1)
    assert plan.feasible
    chain = ur5.chain("base_link", "tool0")
    return poses, plan, np.array([chain.full(q) for q in plan.q])


def meshcat_commands(html: str) -> list[dict]:
    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(blob)) for blob in blobs]


def vertices(command: dict) -> np.ndarray:
    """Positions (N, 3) of a meshcat line or point cloud command (float32, column-major 3 x N)."""
    attributes = command["object"]["geometries"][0]["data"]["attributes"]
    return np.frombuffer(attributes["position"]["array"].data, dtype=np.float32).reshape(-1, 3)


def matrix(position, quaternion) -> np.ndarray:
    """T from a position and a unit quaternion (x, y, z, w), the rotation written out (Shoemake)."""
    x, y, z, w = quaternion
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = position
    return T


def keyframes(commands: list[dict]) -> dict[str, tuple[np.ndarray, list[np.ndarray]]]:
    """scene path -> (key times in s, one T_root_node per key) of the page's one animation."""
    [command] = [c for c in commands if c["type"] == "set_animation"]
    assert command["options"]["play"] is True and command["options"]["repetitions"] == math.inf  # in a loop
    out = {}
    for entry in command["animations"]:
        clip = entry["clip"]
        tracks = {track["name"]: track["keys"] for track in clip["tracks"]}
        positions, quaternions = tracks[".position"], tracks[".quaternion"]
        times = np.array([key["time"] for key in positions]) / clip["fps"]
        np.testing.assert_array_equal(times, np.array([key["time"] for key in quaternions]) / clip["fps"])
        out[entry["path"]] = (times, [matrix(p["value"], q["value"]) for p, q in zip(positions, quaternions)])
    return out


def test_the_page_draws_the_path_through_the_planned_poses(ur5, planned, tmp_path):
    poses, plan, rows = planned
    commands = meshcat_commands(write_path_html(ur5, tmp_path / "p.html", poses, rows, base="base_link", tip="tool0",
                                                times=plan.t).read_text())
    objects = {c["path"]: c for c in commands if c["type"] == "set_object"}
    origins = poses[:, :3, 3]
    for path in ("/meshcat/path/line", "/meshcat/path/waypoints"):
        drawn = vertices(objects[path])
        # WebGL vertices are float32: each is the pose's translation rounded to the nearest float32, no more
        np.testing.assert_array_equal(drawn, origins.astype(np.float32))
        assert np.abs(drawn - origins).max() <= 2.0 ** -24 * np.abs(origins).max()
    assert objects["/meshcat/path/line"]["object"]["object"]["type"] == "Line"
    assert "/meshcat/path/first_failure" not in objects  # a path that can be followed has no failure mark
    placed = {c["path"]: np.array(c["matrix"]).reshape(4, 4).T for c in commands if c["type"] == "set_transform"}
    np.testing.assert_allclose(placed["/meshcat/path"], ur5.transform(ur5.root_link, "base_link", rows[0]),
                               atol=1e-12)
    # the tip's triad, animated (float64 keys): on every planned pose to 1e-9, in the root frame
    times, tip = keyframes(commands)["/meshcat/manipkit/frame_b"]
    T_root_base = ur5.transform(ur5.root_link, "base_link", rows[0])
    for T, pose in zip(tip, poses):
        np.testing.assert_allclose(T[:3, 3], (T_root_base @ pose)[:3, 3], atol=1e-9)
        np.testing.assert_allclose(T[:3, :3], (T_root_base @ pose)[:3, :3], atol=1e-9)
    np.testing.assert_allclose(times, plan.t, atol=1e-12)


def test_every_keyframe_places_each_link_where_robot_transform_puts_it(ur5, planned, tmp_path):
    poses, plan, rows = planned
    commands = meshcat_commands(write_path_html(ur5, tmp_path / "p.html", poses, rows, base="base_link", tip="tool0",
                                                times=plan.t).read_text())
    frames = keyframes(commands)
    visual = ur5.visual_model(missing_meshes="draw")
    model = ur5.model
    assert len(frames) == len(visual.geometryObjects) + 3  # every visual, both triads, the path folder
    for geometry in visual.geometryObjects:
        times, drawn = frames[f"/meshcat/pinocchio/visuals/{geometry.name}"]
        np.testing.assert_allclose(times, plan.t, atol=1e-12)
        frame = model.frames[geometry.parentFrame]
        T_frame_geometry = np.linalg.inv(frame.placement.homogeneous) @ geometry.placement.homogeneous
        assert frame.parentJoint == geometry.parentJoint
        for T, row in zip(drawn, rows):
            expected = ur5.transform(ur5.root_link, frame.name, row) @ T_frame_geometry
            np.testing.assert_allclose(T, expected, atol=1e-9)
    for path in ("/meshcat/manipkit/frame_a", "/meshcat/path"):  # the base's triad, and the path drawn in the base
        for T, row in zip(frames[path][1], rows):
            np.testing.assert_allclose(T, ur5.transform(ur5.root_link, "base_link", row), atol=1e-9)
    # the arm starts on the first row: its placements as drawn (mesh scale on the columns) are the first keyframe's
    placed = {c["path"]: np.array(c["matrix"]).reshape(4, 4).T for c in commands if c["type"] == "set_transform"}
    for geometry in visual.geometryObjects:
        path = f"/meshcat/pinocchio/visuals/{geometry.name}"
        np.testing.assert_allclose(placed[path] / np.append(geometry.meshScale, 1.0), frames[path][1][0], atol=1e-12)


def test_an_untimed_path_plays_at_a_fixed_step_and_a_failed_one_marks_its_waypoint(ur5, planned, tmp_path):
    poses, _, rows = planned
    commands = meshcat_commands(write_path_html(ur5, tmp_path / "u.html", poses, rows, base="base_link",
                                                tip="tool0").read_text())
    times, _ = keyframes(commands)["/meshcat/manipkit/frame_b"]
    np.testing.assert_allclose(times, UNTIMED_STEP * np.arange(len(poses)), atol=1e-12)
    commands = meshcat_commands(write_path_html(ur5, tmp_path / "f.html", poses, base="base_link", tip="tool0",
                                                first_failure=3).read_text())
    assert not any(c["type"] == "set_animation" for c in commands)
    placed = {c["path"]: np.array(c["matrix"]).reshape(4, 4).T for c in commands if c["type"] == "set_transform"}
    np.testing.assert_array_equal(placed["/meshcat/path/first_failure"][:3, 3], poses[3, :3, 3])


def test_refusals(ur5, planned, tmp_path):
    poses, plan, rows = planned
    with pytest.raises(OptionError, match="rows: give one finite whole-robot joint vector per pose"):
        path_scene(ur5, poses, rows[:-1], base="base_link", tip="tool0")
    with pytest.raises(OptionError, match="times: give .* finite times that increase"):
        path_scene(ur5, poses, rows, base="base_link", tip="tool0", times=plan.t[::-1])
    with pytest.raises(OptionError, match="poses: give finite T_base_tip"):
        path_scene(ur5, poses[:, :3], base="base_link", tip="tool0")
    with pytest.raises(OptionError, match="first_failure 99"):
        path_scene(ur5, poses, base="base_link", tip="tool0", first_failure=99)


def test_cli_writes_the_page_and_says_what_it_holds(tmp_path):
    out = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", *LINE_ARGS, "--step", "0.02", "--speed",
                  "0.1", "--view-html", tmp_path / "p.html", status=0).stdout
    assert f"path view written to {tmp_path / 'p.html'} (the arm along the joint path, at the waypoint times, " \
           "in a loop)" in out
    commands = meshcat_commands((tmp_path / "p.html").read_text())
    times, _ = keyframes(commands)["/meshcat/manipkit/frame_b"]
    assert len(times) == 6 and times[-1] == pytest.approx(0.1 / 0.1, abs=1e-9)  # 0.1 m at 0.1 m/s, 0.02 m a step
    # a path that leaves the reach: the page still draws it, with its first failure marked
    out = run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", "--line", "0.5", "0.1", "0.4", "3.14159",
                  "0", "0", "1.0", "0.1", "0.4", "3.14159", "0", "0", "--step", "0.05", "--view-html",
                  tmp_path / "f.html", status=1).stdout
    first = re.search(r"no candidate survives at waypoint (\d+)", out).group(1)
    assert f"(the path only, waypoint {first} marked red: no joint path to animate)" in out
    commands = meshcat_commands((tmp_path / "f.html").read_text())
    assert any(c["path"] == "/meshcat/path/first_failure" for c in commands if c["type"] == "set_object")
