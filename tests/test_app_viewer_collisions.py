"""The viewer's collision checks (issue 23): the report at each pose, its words, the links tinted, the floor.

The report comes from :mod:`manipkit.kinematics.collisions` (checked there
against Pinocchio + coal, tests/test_kinematics_collisions.py); here the
viewer must show that report, in the words ``manipkit collisions`` prints,
and tint exactly the visuals of the links in contact. The course arm's
shoulder at 3.0 rad folds the upper arm back into the base (found with
``manipkit.collisions`` over each joint from -pi to pi); its pairs in contact
are checked below by coal alone. The browser side (red pixels) is in
tests/test_app_viewer_browser.py.
"""

import base64
import http.client
import json
import re

import numpy as np
import pytest
from cli_helper import run_cli

import manipkit
from manipkit.app.viewer import VISUALS_ROOT, ViewerState, collision_view, open_view, visual_model, write_static
from manipkit.errors import CollisionError
from manipkit.kinematics.collisions import collisions

FOLDED = {"shoulder_joint": 3.0}
NO_COLLISIONS_URDF = (
    '<robot name="bare"><link name="base_link"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual></link>'
    '<link name="ee_link"><visual><geometry><sphere radius="0.05"/></geometry></visual></link>'
    '<joint name="j1" type="revolute"><parent link="base_link"/><child link="ee_link"/><origin xyz="0 0 0.3"/>'
    '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>'
)
UNAVAILABLE = ("collisions unavailable: robot 'bare' has no <collision> elements, so collisions cannot be checked for "
               "it; add <collision> geometry (box, cylinder, sphere or mesh) to its links")


@pytest.fixture(scope="module")
def course_arm():
    return manipkit.load("course_arm")


@pytest.fixture
def bare(tmp_path):
    path = tmp_path / "bare.urdf"
    path.write_text(NO_COLLISIONS_URDF)
    return path


def coal_distance(robot, link_a: str, link_b: str, q) -> float:
    """Signed distance (m) of two links' collision shapes at q by Pinocchio and coal alone (negative: contact)."""
    import coal
    import pinocchio as pin

    model = pin.buildGeomFromUrdfString(robot.model, robot.urdf, pin.GeometryType.COLLISION)
    data, geom_data = robot.model.createData(), model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(q))
    pin.updateGeometryPlacements(robot.model, data, model, geom_data)
    names = [robot.model.frames[o.parentFrame].name for o in model.geometryObjects]
    a, b = names.index(link_a), names.index(link_b)
    result = coal.DistanceResult()
    coal.distance(model.geometryObjects[a].geometry, geom_data.oMg[a], model.geometryObjects[b].geometry,
                  geom_data.oMg[b], coal.DistanceRequest(), result)
    return float(result.min_distance)


def test_folded_course_arm_is_in_contact_by_coal_alone(course_arm):
    q = course_arm.q(FOLDED)
    assert coal_distance(course_arm, "base_link", "bicep", q) < -0.05  # the upper arm 6 cm into the base
    assert coal_distance(course_arm, "base_link", "bicep", course_arm.q()) > 0.05  # and clear of it at the start


def _report_part(stdout: str) -> str:
    """``manipkit collisions``' report lines, without the lines after it on what was left out and the geometry."""
    lines = stdout.splitlines(keepends=True)
    end = next(i for i, line in enumerate(lines) if line.startswith(("SRDF ", "no SRDF", "geometry: ")))
    return "".join(lines[:end])


def test_readout_is_the_report_in_the_words_of_manipkit_collisions(course_arm):
    state = ViewerState(course_arm, q=course_arm.q(FOLDED), collisions=collision_view(course_arm, "self,floor"))
    snapshot = state.snapshot()
    cli = run_cli("manipkit", "collisions", "--q", "shoulder_joint=3.0", "--floor", "0", "--geometry", "hulls",
                  status=0).stdout
    assert snapshot["collisions_text"] == _report_part(cli).rstrip("\n")
    report = collisions(course_arm, course_arm.q(FOLDED), floor=0.0)
    answer = snapshot["collisions"]
    assert answer["in_collision"] is True and answer["available"] is True
    assert answer["pairs"] == report.as_dict()["pairs"] and answer["min_distance"] == report.as_dict()["min_distance"]
    assert answer["checked"] == ["self", "floor"] and answer["floor"] == 0.0
    pairs = {(p["link1"], p["link2"]) for p in answer["pairs"]}
    assert ("base_link", "bicep") in pairs
    for a, b in pairs - {p for p in pairs if "floor" in p}:  # each self pair in contact by coal alone
        assert coal_distance(course_arm, a, b, course_arm.q(FOLDED)) < 0
    assert answer["links"] == sorted({n for p in pairs for n in p} - {"floor"})
    json.dumps(snapshot)  # JSON-ready


def test_free_pose_says_collision_free_with_the_closest_pair(course_arm):
    state = ViewerState(course_arm, collisions=collision_view(course_arm, "self"))
    lines = state.snapshot()["collisions_text"].splitlines()
    assert lines[0] == "robot course_arm: collision-free (10 link pairs checked, hulls geometry)"
    # the closest pair at the start: bicep - elbow, 0.1352 m apart (also by coal alone)
    assert lines[1] == "closest pair: bicep - elbow, distance 0.1352 m"
    assert coal_distance(course_arm, "bicep", "elbow", course_arm.q()) == pytest.approx(0.13522, abs=1e-5)


def test_tints_are_the_visuals_of_the_links_in_contact(course_arm):
    visual = visual_model(course_arm)
    state = ViewerState(course_arm, collisions=collision_view(course_arm, "self"))
    assert set(state.collision_tints(visual).values()) == {False}
    state.set_joints(FOLDED)
    tints = state.collision_tints(visual)
    # course_arm's visuals are named <link>_0; in contact: base_link with bicep and with bottom_wrist
    assert {path for path, tinted in tints.items() if tinted} == {
        f"{VISUALS_ROOT}/{name}_0" for name in ("base_link", "bicep", "bottom_wrist")}
    assert set(tints) == {f"{VISUALS_ROOT}/{g.name}" for g in visual.geometryObjects}
    state.set_joint("shoulder_joint", 0.5)
    assert set(state.collision_tints(visual).values()) == {False}


def test_without_checks_the_view_says_and_tints_nothing(course_arm):
    state = ViewerState(course_arm, q=course_arm.q(FOLDED))
    snapshot = state.snapshot()
    assert snapshot["collisions"] is None and snapshot["collisions_text"] == ""
    assert state.collision_tints(visual_model(course_arm)) == {} and state.collision_report() is None
    assert collision_view(course_arm, "none") is None


def test_a_robot_without_collision_geometry_gets_one_line_never_collision_free(bare):
    robot = manipkit.load(bare)
    view = collision_view(robot, "self,floor")
    state = ViewerState(robot, collisions=view)
    for value in (0.0, 0.9):
        state.set_joint("j1", value)
        snapshot = state.snapshot()
        assert snapshot["collisions_text"] == UNAVAILABLE
        assert snapshot["collisions"] == {"available": False, "unavailable": UNAVAILABLE.split(": ", 1)[1]}
        assert state.collision_tints(visual_model(robot)) == {}
    assert "collision-free" not in json.dumps(state.snapshot())


@pytest.mark.parametrize("what, kwargs, message", [
    ("walls", {}, "collisions 'walls': give self, floor, self,floor or none"),
    ("floor", {"floor": None}, "collisions 'floor' needs a floor height in metres, not None"),
    ("self", {"geometry": "spheres"}, "geometry 'spheres' is not known; give one of hulls, meshes"),
])
def test_bad_settings_are_errors_even_for_a_robot_without_geometry(course_arm, bare, what, kwargs, message):
    for robot in (course_arm, manipkit.load(bare)):
        with pytest.raises(CollisionError) as caught:
            collision_view(robot, what, **kwargs)
        assert str(caught.value) == message


def test_srdf_pairs_are_not_checked(course_arm, tmp_path):
    srdf = tmp_path / "course_arm.srdf"
    srdf.write_text('<robot name="course_arm"><disable_collisions link1="base_link" link2="bicep" reason="User"/>'
                    '</robot>')
    state = ViewerState(course_arm, q=course_arm.q(FOLDED), collisions=collision_view(course_arm, "self", srdf=srdf))
    pairs = {(p["link1"], p["link2"]) for p in state.snapshot()["collisions"]["pairs"]}
    assert pairs == {("base_link", "bottom_wrist")}
    bad = tmp_path / "bad.srdf"
    bad.write_text('<robot name="x"><disable_collisions link1="base_link" link2="forearm"/></robot>')
    with pytest.raises(CollisionError, match="names link 'forearm'"):
        collision_view(course_arm, "self", srdf=bad)


# ----------------------------------------------------------------------
# The scene: tints and the floor reach meshcat
# ----------------------------------------------------------------------


def meshcat_commands(html: str) -> list[dict]:
    import umsgpack

    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(blob)) for blob in blobs]


def test_static_view_tints_the_links_in_contact_and_lays_the_floor_at_its_height(course_arm, tmp_path):
    view = collision_view(course_arm, "self,floor", floor=-0.05)
    html = write_static(course_arm, tmp_path / "c.html", q=course_arm.q(FOLDED), collisions=view).read_text()
    commands = meshcat_commands(html)
    colours = {c["path"]: c["value"] for c in commands if c["type"] == "set_property" and c["property"] == "color"}
    # in contact with -0.05: base_link - bicep, base_link - bottom_wrist, and the links below the floor
    links = ViewerState(course_arm, q=course_arm.q(FOLDED), collisions=view).collided_links()
    assert {"base_link", "bicep", "bottom_wrist"} <= links
    assert colours == {f"/meshcat/{VISUALS_ROOT}/{name}_0": [1.0, 0.0, 0.0, 1.0] for name in links}
    grid = next(c for c in commands if c["type"] == "set_object" and c["path"] == "/Grid")
    positions = grid["object"]["geometries"][0]["data"]["attributes"]["position"]
    z = np.frombuffer(positions["array"].data, dtype=np.float32).reshape(-1, 3)[:, 2]  # a msgpack ext: float32
    assert np.all(z == np.float32(-0.05))  # the grid is the floor checked


def test_static_view_without_checks_sends_no_colour(course_arm, tmp_path):
    html = write_static(course_arm, tmp_path / "n.html", q=course_arm.q(FOLDED)).read_text()
    assert not [c for c in meshcat_commands(html) if c["type"] == "set_property" and c["property"] == "color"]


def post(server, body: dict):
    connection = http.client.HTTPConnection("127.0.0.1", server.port, timeout=10)
    connection.request("POST", "/api/update", body=json.dumps(body),
                       headers={"Content-Type": "application/json", "X-Manipkit-Token": server.token})
    response = connection.getresponse()
    answer = json.loads(response.read())
    connection.close()
    return response.status, answer


def test_slider_moves_tint_and_untint_the_scene(course_arm):
    server = open_view(course_arm, port=0, collisions=collision_view(course_arm, "self"))
    try:
        tinted_paths = {f"{VISUALS_ROOT}/{name}_0" for name in ("base_link", "bicep", "bottom_wrist")}
        status, answer = post(server, {"q": FOLDED})
        assert status == 200 and answer["collisions"]["in_collision"] is True
        assert answer["collisions_text"].startswith("robot course_arm: IN COLLISION (2 pairs in contact")
        assert server.wait_for_scene()
        assert {path for path, on in server.scene.tinted.items() if on} == tinted_paths
        status, answer = post(server, {"q": {"shoulder_joint": 0.5}})
        assert status == 200 and answer["collisions"]["in_collision"] is False
        assert server.wait_for_scene()
        assert not any(server.scene.tinted.values())
    finally:
        server.close()


# ----------------------------------------------------------------------
# The command line
# ----------------------------------------------------------------------


@pytest.mark.parametrize("args, message", [
    (["--collisions", "walls"], "manipkit: error: collisions 'walls': give self, floor, self,floor or none\n"),
    (["--srdf", "x.srdf"], "manipkit: error: --srdf applies with --collisions self, floor or self,floor\n"),
])
def test_view_refuses_bad_collision_options_in_one_line(tmp_path, args, message):
    result = run_cli("manipkit", "view", "--static", tmp_path / "v.html", *args)
    assert result.returncode == 2 and result.stderr == message
    assert not (tmp_path / "v.html").exists()


def test_view_floor_option_takes_a_height_or_none(tmp_path):
    result = run_cli("manipkit", "view", "--static", tmp_path / "v.html", "--collisions", "floor", "--floor", "low")
    assert result.returncode == 2 and "--floor: low: give a height in metres (such as 0 or -0.05), or none" in result.stderr
    result = run_cli("manipkit", "view", "--static", tmp_path / "v.html", "--collisions", "self,floor", "--floor", "none")
    assert result.returncode == 2
    assert result.stderr == "manipkit: error: collisions 'self,floor' needs a floor height in metres, not None\n"


def test_view_static_with_collisions_prints_the_report(tmp_path):
    out = tmp_path / "v.html"
    result = run_cli("manipkit", "view", "--static", out, "--q", "shoulder_joint=3.0", "--collisions", "self", status=0)
    expected = _report_part(run_cli("manipkit", "collisions", "--q", "shoulder_joint=3.0", "--geometry", "hulls",
                                    status=0).stdout)
    assert result.stdout.endswith(expected) and f"wrote {out}" in result.stdout


def test_view_of_a_robot_without_collision_geometry_warns_once(tmp_path, bare):
    out = tmp_path / "v.html"
    result = run_cli("manipkit", "view", "--robot", bare, "--static", out, "--collisions", "self", status=0)
    assert result.stderr == f"warning: {UNAVAILABLE}\n"
    assert "collision-free" not in result.stdout


def test_notebook_view_tints_and_reads_out_collisions(course_arm):
    pytest.importorskip("ipywidgets")
    import html

    from manipkit.app.viewer import notebook_view

    view = notebook_view(course_arm, collisions="self")
    try:
        assert "collision-free" in view.collision_readout.value and not any(view.scene.tinted.values())
        view.sliders["shoulder_joint"].value = 3.0
        expected = _report_part(run_cli("manipkit", "collisions", "--q", "shoulder_joint=3.0", "--geometry", "hulls",
                                        status=0).stdout).rstrip("\n")
        assert html.escape(expected) in view.collision_readout.value
        assert {path for path, on in view.scene.tinted.items() if on} == {
            f"{VISUALS_ROOT}/{name}_0" for name in ("base_link", "bicep", "bottom_wrist")}
        view.sliders["shoulder_joint"].value = 0.5
        assert "collision-free" in view.collision_readout.value and not any(view.scene.tinted.values())
    finally:
        view.close()
    plain = notebook_view(course_arm)
    try:
        assert plain.collision_readout.value == "" and plain.scene.tinted == {}
    finally:
        plain.close()
