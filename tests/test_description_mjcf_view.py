"""`manipkit view --static` on an MJCF arm, rendered in headless Chromium (as tests/test_app_viewer_browser.py does).

The Menagerie UR5e has no mesh files here, so its links are drawn by their
collision geoms (capsules as a cylinder and two spheres, the wrist's
cylinder); the screenshot is tests/artifacts/static_mjcf_ur5e.png.
"""

from cli_helper import run_cli
from test_app_viewer_browser import assert_robot_drawn, browser, visual_count, wait_for_scene  # noqa: F401
from test_description_mjcf import MENAGERIE, needs_menagerie

UR5E = MENAGERIE / "universal_robots_ur5e" / "ur5e.xml"


@needs_menagerie
def test_static_view_draws_an_mjcf_arm_without_its_meshes(browser, tmp_path):  # noqa: F811 - the fixture
    path = tmp_path / "ur5e.html"
    result = run_cli("manipkit", "view", "--robot", UR5E, "--q", "shoulder_lift_joint=-1.2", "elbow_joint=1.4",
                     "--static", path, status=0)
    assert "20 of 20 visual mesh files are missing" in result.stderr
    assert "drawn instead: 6 links by their collision shapes, 1 link as lines between joint origins" in result.stderr
    page = browser.new_page()
    try:
        page.goto(path.as_uri())
        frame = page.main_frame
        wait_for_scene(frame, visual_count(str(UR5E)))
        assert assert_robot_drawn(lambda shot: page.screenshot(path=shot), frame, "static_mjcf_ur5e") > 0.005  # 0.9 % measured
    finally:
        page.close()
