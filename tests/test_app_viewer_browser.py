"""`manipkit view` end to end in a real headless Chromium.

Debian's /usr/bin/chromium is driven by Playwright (Python); nothing here
downloads a browser. The viewer runs as the user runs it, a subprocess of the
installed `manipkit` entry point (a server stopped by a signal), and every
number the page shows is checked against `tf-between ... --format json`, run
in process (tests/cli_helper.py).

Screenshots go to tests/artifacts/ (git-ignored): viewer_control.png (the
control page), viewer_scene.png (the meshcat scene after a slider move),
static_<robot>.png (the --static export), framing_<robot>_shown.png (the opening view), static_without_meshes.png (a description
without its mesh files), viewer_ellipsoid.png (the manipulability
ellipsoid overlay), viewer_collision_free.png and viewer_collision.png (the
course arm before and after its shoulder folds into the base, links in
contact red), path_view_start.png and path_view_end.png (`path --view-html`: the arm at the start and the end
of its animation along the tool path), path_view_live.png (`path --view`); viewer_round_trip.json holds the
measured slider-to-readout round trips.
"""

import json
import math
import queue
import signal
import socket
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from cli_helper import run_cli

from manipkit.text import short_text

CHROMIUM = Path("/usr/bin/chromium")
BIN = Path(sys.executable).parent
ARTIFACTS = Path(__file__).parent / "artifacts"
# Headless Chromium on a machine without a GPU: software WebGL (SwiftShader) so meshcat's canvas renders.
CHROMIUM_ARGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--no-first-run",
    "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
]
# Each page is drawn in software (SwiftShader), at a CPU cost that grows with its pixels: the pages are 800 x 500
# (the browser file's Chromium CPU: 67 s at 1280 x 800, 45 s at this size), except the opening view's, judged in a
# window of the size users open, 1280 x 800, where its fill bound was set (the Panda fills 45 % of 500 rows).
VIEWPORT = {"width": 800, "height": 500}
USERS_WINDOW = {"width": 1280, "height": 800}
COURSE_ARM_JOINTS = ("arm_base_joint", "shoulder_joint", "bottom_wrist_joint", "elbow_joint", "top_wrist_joint")
COURSE_ARM_FRAMES = ("base_link", "arm_base", "bicep", "bottom_wrist", "elbow", "top_wrist", "ee_link")


# ----------------------------------------------------------------------
# Fixtures: the browser, the viewer process
# ----------------------------------------------------------------------


MISSING_CHROMIUM = (f"{CHROMIUM} is missing: the viewer tests need Debian's chromium; `make test` installs it "
                    "(apt-get install chromium chromium-driver)")


def test_debian_chromium_is_installed():
    assert CHROMIUM.is_file(), MISSING_CHROMIUM


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """A headless Chromium context with a fresh profile; requests off this machine are refused and recorded."""
    if not CHROMIUM.is_file():
        pytest.fail(MISSING_CHROMIUM)
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.fail("the Python package playwright is missing; `make test` installs it with the dev extras")
    ARTIFACTS.mkdir(exist_ok=True)
    with sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            str(tmp_path_factory.mktemp("chromium-profile")), executable_path=str(CHROMIUM), headless=True,
            args=CHROMIUM_ARGS, viewport=VIEWPORT,
        )
        context.external_requests = []

        def offline_only(route):
            url = route.request.url
            if url.startswith(("http://127.0.0.1", "ws://127.0.0.1", "file://", "data:", "blob:")):
                route.continue_()
            else:
                context.external_requests.append(url)
                route.abort()

        context.route("**/*", offline_only)
        yield context
        context.close()


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def start_viewer(*args, timeout=60):
    """Start `manipkit view --no-browser ...`; returns (process, control URL, meshcat URL).

    A subprocess: the viewer serves until a signal stops it, and the tests send SIGTERM and Ctrl-C.
    """
    proc = subprocess.Popen([str(BIN / "manipkit"), "view", "--no-browser", *map(str, args)],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = queue.Queue()

    def read_stdout():
        for line in proc.stdout:
            lines.put(line)

    threading.Thread(target=read_stdout, daemon=True).start()
    urls, deadline = {}, time.monotonic() + timeout
    while len(urls) < 2:
        try:
            line = lines.get(timeout=max(deadline - time.monotonic(), 0.01))
        except queue.Empty:
            proc.kill()
            pytest.fail(f"manipkit view printed no URLs within {timeout} s; stderr: {proc.stderr.read()}")
        for label in ("control page", "meshcat scene"):
            if line.startswith(label + ": "):
                urls[label] = line.split(": ", 1)[1].strip()
        if proc.poll() is not None:
            pytest.fail(f"manipkit view exited with {proc.returncode}: {proc.stderr.read()}")
    return proc, urls["control page"], urls["meshcat scene"]


def stop(proc, sig=signal.SIGTERM):
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(timeout=45)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


@pytest.fixture(scope="module")
def viewer():
    proc, url, scene_url = start_viewer("--port", free_port())
    yield {"proc": proc, "url": url, "scene_url": scene_url}
    stop(proc)


@pytest.fixture(scope="module")
def page(browser, viewer):
    page = browser.new_page()
    page.goto(viewer["url"])
    page.wait_for_function("document.querySelector('pre#readout-json').textContent.length > 0")
    yield page
    page.close()


# ----------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------


def tf_between(source, target, q: dict) -> dict:
    args = [f"{name}={value!r}" for name, value in q.items()]
    return json.loads(run_cli("tf-between", source, target, "--q", *args, "--format", "json", status=0).stdout)


def readout(page) -> dict:
    return json.loads(page.text_content("pre#readout-json"))


def after_change(page, action) -> dict:
    """Run ``action()`` and wait until the JSON readout changes; returns the new readout."""
    before = page.text_content("pre#readout-json")
    action()
    page.wait_for_function("before => document.querySelector('pre#readout-json').textContent !== before",
                           arg=before, timeout=10_000)
    return readout(page)


def move_slider(page, joint: str, value: float):
    """Set the range input like a user dragging it: new value, then input and change events."""
    page.eval_on_selector(
        f'input[type=range][data-joint="{joint}"]',
        """(el, value) => { el.value = String(value);
                            el.dispatchEvent(new Event('input', {bubbles: true}));
                            el.dispatchEvent(new Event('change', {bubbles: true})); }""",
        value,
    )


def assert_agrees_with_tf_between(shown: dict):
    expected = tf_between(shown["source"], shown["target"], shown["q"])
    assert list(shown) == list(expected) == ["source", "target", "robot", "q", "translation", "quaternion_xyzw", "rpy", "matrix"]
    assert shown["q"] == expected["q"]
    for key in ("translation", "quaternion_xyzw", "rpy", "matrix"):
        assert np.abs(np.array(shown[key]) - np.array(expected[key])).max() < 1e-6, key


def scene_frame(page):
    return page.wait_for_selector("iframe#scene").content_frame()


def visual_count(robot: str) -> int:
    import manipkit
    from manipkit.app.viewer import visual_model

    return len(visual_model(manipkit.load(robot)).geometryObjects)


def wait_for_scene(frame, n_visuals: int):
    """Until meshcat's page holds a drawable object for each of the robot's visuals (and both triads)."""
    frame.wait_for_function(
        """n => {
            if (typeof viewer === 'undefined') return false;
            const drawn = node => node.children['<object>'] !== undefined &&
                (node.children['<object>'].object.isMesh || node.children['<object>'].object.children.length > 0);
            const visuals = Object.values(viewer.scene_tree.find(['meshcat', 'pinocchio', 'visuals']).children);
            const triads = ['frame_a', 'frame_b'].map(f => viewer.scene_tree.find(['meshcat', 'manipkit', f, 'z']));
            return visuals.filter(drawn).length >= n && triads.every(drawn);
        }""", arg=n_visuals, timeout=20_000)
    frame.wait_for_timeout(300)  # a few animation frames


def set_robot_visible(frame, visible: bool):
    frame.evaluate("visible => viewer.handle_command({type: 'set_property', path: '/meshcat/pinocchio/visuals', "
                   "property: 'visible', value: visible})", visible)
    frame.wait_for_timeout(300)


def image(path: Path) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB"), dtype=float)


def assert_robot_drawn(shoot, frame, name: str):
    """Screenshot the scene, hide the robot, screenshot again: the robot must cover enough pixels.

    ``shoot(path)`` takes a screenshot. A blank canvas (no WebGL) fails the first
    check; a scene without the robot (meshes not loaded) fails the second.
    """
    shown, hidden = ARTIFACTS / f"{name}.png", ARTIFACTS / f"{name}_without_robot.png"
    shoot(shown)
    pixels = image(shown)
    assert pixels.std() > 10, f"{shown} looks blank (pixel std {pixels.std():.1f})"
    set_robot_visible(frame, False)
    shoot(hidden)
    set_robot_visible(frame, True)
    robot_pixels = (np.abs(pixels - image(hidden)).max(axis=-1) > 30).mean()
    assert robot_pixels > 0.002, f"the robot covers {robot_pixels:.2%} of {shown}"
    hidden.unlink()
    return robot_pixels


# ----------------------------------------------------------------------
# The live viewer
# ----------------------------------------------------------------------


def test_control_page_has_a_slider_and_a_number_per_joint_frame_pickers_and_the_scene(page, viewer):
    for joint in COURSE_ARM_JOINTS:
        assert page.locator(f'input[type=range][data-joint="{joint}"]').count() == 1
        assert page.locator(f'input[type=number][data-joint="{joint}"]').count() == 1
    assert page.locator("input[type=range]").count() == len(COURSE_ARM_JOINTS)
    for picker in ("select#frame-a", "select#frame-b"):
        options = page.eval_on_selector_all(f"{picker} option", "options => options.map(o => o.value)")
        assert options == list(COURSE_ARM_FRAMES)
    assert page.input_value("select#frame-a") == "base_link" and page.input_value("select#frame-b") == "ee_link"
    assert page.locator("button#reset").count() == 1
    assert page.get_attribute("iframe#scene", "src") == viewer["scene_url"]
    # continuous joints (the course arm's) slide over (-pi, pi]: from one step (2 pi / 1000) above -pi to pi
    limits = page.eval_on_selector('input[type=range][data-joint="shoulder_joint"]', "el => [el.min, el.max]")
    assert np.allclose([float(v) for v in limits], [-np.pi + 2 * np.pi / 1000, np.pi])


def test_moving_a_slider_shows_tf_between_for_that_joint_value(page):
    shown = after_change(page, lambda: move_slider(page, "shoulder_joint", 0.7))
    assert shown["q"]["shoulder_joint"] == 0.7
    assert_agrees_with_tf_between(shown)
    assert float(page.input_value('input[type=number][data-joint="shoulder_joint"]')) == 0.7
    text = page.text_content("#readout")
    assert "Translation (m)" in text and "Quaternion (x, y, z, w)" in text and "RPY (degree)" in text
    page.screenshot(path=ARTIFACTS / "viewer_control.png")


def test_a_slider_move_moves_the_robot_in_the_scene(page):
    frame = scene_frame(page)
    wait_for_scene(frame, visual_count("course_arm"))
    iframe = page.locator("iframe#scene")
    before = ARTIFACTS / "viewer_scene_before.png"
    iframe.screenshot(path=before)
    shown = after_change(page, lambda: move_slider(page, "shoulder_joint", -0.9))
    # meshcat's node for triad B now holds T_base_link_B (course_arm's root is base_link), as tf-between says
    T_root_b = np.array(tf_between("base_link", shown["target"], shown["q"])["matrix"])
    frame.wait_for_function(
        """expected => {
            const m = viewer.scene_tree.find(['meshcat', 'manipkit', 'frame_b']).object.matrix.elements;
            return expected.every((v, i) => Math.abs(v - m[i]) < 1e-6);
        }""", arg=T_root_b.T.ravel().tolist(), timeout=10_000)  # three.js matrices are column-major
    frame.wait_for_timeout(300)
    assert_robot_drawn(lambda path: iframe.screenshot(path=path), frame, "viewer_scene")
    moved = (np.abs(image(ARTIFACTS / "viewer_scene.png") - image(before)).max(axis=-1) > 30).mean()
    assert moved > 0.002, f"the scene barely changed after the slider move ({moved:.2%} of the pixels)"
    before.unlink()


def test_ellipsoid_checkbox_draws_it_at_b_and_a_slider_moves_it(page):
    """Toggle the overlay: meshcat shows the ellipsoid at ViewerState's placement, the readout shows Yoshikawa's
    index of robot.jacobian; a slider move changes both; toggling off hides it."""
    import manipkit
    from manipkit.analysis.manipulability import manipulability
    from manipkit.app.viewer import Overlay, ViewerState

    robot = manipkit.load("course_arm")
    frame = scene_frame(page)
    assert page.is_checked("input#ellipsoid") is False and page.text_content("pre#ellipsoid-readout") == ""

    def shown_and_drawn(q: dict):
        """Wait until the page's index and meshcat's node agree with the state at q; returns the index shown."""
        vector = robot.q(q)
        index = manipulability(robot.jacobian(vector, tip="ee_link", base="base_link"), axes="trans")
        page.wait_for_function(
            "text => document.querySelector('pre#ellipsoid-readout').textContent.includes(text)",
            arg=f"Yoshikawa index (translation rows): {short_text(index, 6, zero=1e-15)}", timeout=10_000)
        expected = ViewerState(robot, q=vector, overlay=Overlay(True)).ellipsoid_placement()
        frame.wait_for_function(
            """expected => {
                const node = viewer.scene_tree.find(['meshcat', 'manipkit', 'ellipsoid']);
                const sphere = node.children['<object>'];
                if (!sphere || !sphere.object.isMesh || !node.object.visible) return false;
                node.object.updateMatrix();
                return expected.every((v, i) => Math.abs(v - node.object.matrix.elements[i]) < 1e-6);
            }""", arg=expected.T.ravel().tolist(), timeout=10_000)  # column-major
        return index

    page.check("input#ellipsoid")
    first = shown_and_drawn(readout(page)["q"])
    assert "condition number (translation rows)" in page.text_content("pre#ellipsoid-readout")
    shown = after_change(page, lambda: move_slider(page, "elbow_joint", 1.1))
    second = shown_and_drawn(shown["q"])
    assert abs(second - first) > 1e-6, "the elbow move left the index unchanged"
    frame.wait_for_timeout(300)
    page.locator("iframe#scene").screenshot(path=ARTIFACTS / "viewer_ellipsoid.png")
    page.uncheck("input#ellipsoid")
    frame.wait_for_function("() => !viewer.scene_tree.find(['meshcat', 'manipkit', 'ellipsoid']).object.visible",
                            timeout=10_000)
    page.wait_for_function("() => document.querySelector('pre#ellipsoid-readout').textContent === ''")


def test_number_entry_sets_the_joint(page):
    def type_value():
        page.fill('input[type=number][data-joint="top_wrist_joint"]', "-0.25")
        page.press('input[type=number][data-joint="top_wrist_joint"]', "Enter")

    shown = after_change(page, type_value)
    assert shown["q"]["top_wrist_joint"] == -0.25
    assert float(page.input_value('input[type=range][data-joint="top_wrist_joint"]')) == -0.25
    assert_agrees_with_tf_between(shown)


def test_frame_pickers_change_the_readout(page):
    shown = after_change(page, lambda: page.select_option("select#frame-a", "bicep"))
    assert (shown["source"], shown["target"]) == ("bicep", "ee_link")
    shown = after_change(page, lambda: page.select_option("select#frame-b", "top_wrist"))
    assert (shown["source"], shown["target"]) == ("bicep", "top_wrist")
    assert_agrees_with_tf_between(shown)


def test_reset_returns_to_the_start_pose(page):
    after_change(page, lambda: move_slider(page, "arm_base_joint", 1.2))
    shown = after_change(page, lambda: page.click("button#reset"))
    assert set(shown["q"].values()) == {0.0}
    assert float(page.input_value('input[type=range][data-joint="arm_base_joint"]')) == 0.0
    assert_agrees_with_tf_between(shown)


def test_slider_to_readout_round_trip(page):
    """30 slider moves, one at a time; the page's own timings are reported (no timed assertion)."""
    for i in range(30):
        after_change(page, lambda i=i: move_slider(page, "bottom_wrist_joint", round(0.05 * (i + 1), 6)))
    timings = page.evaluate("window.manipkitTimings.slice(-30)")
    assert len(timings) == 30 and all(t > 0 for t in timings)
    median, p95 = statistics.median(timings), float(np.percentile(timings, 95))
    (ARTIFACTS / "viewer_round_trip.json").write_text(json.dumps(
        {"moves": 30, "median_ms": median, "p95_ms": p95, "timings_ms": timings}, indent=2))
    print(f"slider-to-readout round trip over 30 moves: median {median:.1f} ms, p95 {p95:.1f} ms")
    assert_agrees_with_tf_between(readout(page))


def test_the_pages_fetch_nothing_from_the_internet(page, browser):
    assert browser.external_requests == []


def test_ctrl_c_stops_both_servers_cleanly():
    """Ctrl-C ends the viewer with status 0 and no traceback, and its meshcat server goes with it: no process of
    the viewer's (it and every descendant, listed before the signal) is left, and none of them listens on the scene's
    port. (Another test's meshcat server may take the freed port at once: the port alone proves nothing.)"""
    import psutil  # a dependency of dask.distributed

    proc, url, scene_url = start_viewer("--port", 0)
    meshcat_port = int(scene_url.split(":")[2].split("/")[0])
    viewer = psutil.Process(proc.pid)
    ours = [viewer, *viewer.children(recursive=True)]
    assert len(ours) > 1  # the meshcat server is a process of its own
    assert stop(proc, signal.SIGINT) == 0
    stderr = proc.stderr.read()
    assert "Traceback" not in stderr, stderr
    _, alive = psutil.wait_procs(ours[1:], timeout=10)
    assert not alive, f"left running after Ctrl-C: {[p.cmdline() for p in alive]}"
    listening = {c.pid for c in psutil.net_connections("tcp") if c.laddr and c.laddr.port == meshcat_port
                 and c.status == psutil.CONN_LISTEN}
    assert not listening & {p.pid for p in ours}


# ----------------------------------------------------------------------
# --static
# ----------------------------------------------------------------------


@pytest.mark.parametrize("robot, q", [("course_arm", "shoulder_joint=0.6"), ("panda", "panda_joint4=-1.8")])
def test_static_export_renders_the_robot_without_a_server(browser, tmp_path, robot, q):
    path = tmp_path / f"{robot}.html"
    result = run_cli("manipkit", "view", "--robot", robot, "--q", q, "--static", path)
    assert result.returncode == 0, result.stderr
    assert str(path) in result.stdout
    page = browser.new_page()
    try:
        page.goto(path.as_uri())
        frame = page.main_frame
        wait_for_scene(frame, visual_count(robot))
        assert_robot_drawn(lambda shot: page.screenshot(path=shot), frame, f"static_{robot}")
    finally:
        page.close()


def set_visible(frame, path: str, visible: bool):
    frame.evaluate("([path, visible]) => viewer.handle_command({type: 'set_property', path, property: 'visible', "
                   "value: visible})", [path, visible])
    frame.wait_for_timeout(300)


def changed_pixels(shown: np.ndarray, hidden: np.ndarray) -> np.ndarray:
    """Where two screenshots differ (boolean image): what was hidden between them."""
    return np.abs(shown - hidden).max(axis=-1) > 30


@pytest.mark.parametrize("robot", ["iiwa14", "panda"])
def test_static_view_frames_the_whole_arm_from_above_with_the_floor_under_its_base(browser, tmp_path, robot):
    """Issue 25: the opening view shows the whole arm, looking down about 30 deg, the floor grid under its base.

    Judged on the picture: the robot's pixels (shown minus hidden) lie inside the frame with a margin and fill a
    good part of its height; the floor's pixels (grid shown minus hidden) lie under and around the base, both
    sides of it and in front of it, and the floor recedes behind it (it starts above the base's row, below the
    arm's top). The camera's angle is read from the page too.
    """
    path = tmp_path / f"{robot}.html"
    run_cli("manipkit", "view", "--robot", robot, "--static", path, status=0)
    page = browser.new_page()
    page.set_viewport_size(USERS_WINDOW)
    try:
        page.goto(path.as_uri())
        frame = page.main_frame
        wait_for_scene(frame, visual_count(robot))
        shots = {name: ARTIFACTS / f"framing_{robot}_{name}.png" for name in ("shown", "no_robot", "no_floor")}
        page.screenshot(path=shots["shown"])
        set_visible(frame, "/meshcat", False)  # the robot and its triads
        page.screenshot(path=shots["no_robot"])
        set_visible(frame, "/meshcat", True)
        set_visible(frame, "/Grid", False)
        page.screenshot(path=shots["no_floor"])
        camera = frame.evaluate("() => { const p = viewer.camera.position; "
                                "return [p.x, p.y, p.z, ...viewer.controls.target.toArray()]; }")
    finally:
        page.close()
    shown = image(shots["shown"])
    height, width = shown.shape[:2]
    robot_rows, robot_cols = np.nonzero(changed_pixels(shown, image(shots["no_robot"])))
    floor_rows, floor_cols = np.nonzero(changed_pixels(shown, image(shots["no_floor"])))
    assert robot_rows.size and floor_rows.size, "the robot or the floor is not drawn"
    top, bottom, left, right = robot_rows.min(), robot_rows.max(), robot_cols.min(), robot_cols.max()
    # the whole robot (triads included) inside the picture, 2 % clear of every edge, and not lost in it
    assert top > 0.02 * height and bottom < 0.98 * height, (top, bottom, height)
    assert left > 0.02 * width and right < 0.98 * width, (left, right, width)
    assert bottom - top > 0.45 * height, f"the robot fills only {(bottom - top) / height:.0%} of the height"
    # the floor under the base: floor pixels below the robot's lowest row, on both sides of it and in front
    base_col = int(np.median(robot_cols[robot_rows > bottom - 0.02 * height]))
    below = floor_rows > bottom
    assert np.any(below & (floor_cols < base_col - 0.05 * width)) and np.any(below & (floor_cols > base_col + 0.05 * width))
    assert np.any(below & (abs(floor_cols - base_col) < 0.05 * width)), "no floor in front of the base"
    # and it recedes behind the base (seen from above), but not above the arm's top (seen from below or level)
    assert top < floor_rows.min() < bottom - 0.1 * height, (top, floor_rows.min(), bottom)
    # the camera looks down 30 deg at the robot's centre (three.js is y-up)
    offset = np.subtract(camera[:3], camera[3:])
    assert np.degrees(np.arcsin(offset[1] / np.linalg.norm(offset))) == pytest.approx(30.0, abs=1e-6)
    for shot in ("no_robot", "no_floor"):
        shots[shot].unlink()


def test_path_view_draws_the_tool_path_and_moves_the_arm_along_it(browser, tmp_path):
    """`manipkit path --view-html`: the page draws the path (its pixels go when the path folder is hidden) and
    the animation moves the arm (the picture at the start and at the end of the clip differ where the arm is)."""
    path = tmp_path / "path.html"
    run_cli("manipkit", "path", "--robot", "ur5", "--tip", "tool0", "--line", "0.4", "0.25", "0.4", "3.14159", "0",
            "0", "0.5", "-0.25", "0.25", "3.14159", "0", "0", "--step", "0.02", "--speed", "0.1", "--view-html", path,
            status=0)
    page = browser.new_page()
    try:
        page.goto(path.as_uri())
        frame = page.main_frame
        wait_for_scene(frame, visual_count("ur5"))
        frame.wait_for_function("() => viewer.animator.actions.length > 0", timeout=20_000)
        duration = frame.evaluate("() => { viewer.animator.pause(); viewer.animator.seek(0); "
                                  "return viewer.animator.duration; }")
        frame.wait_for_timeout(300)
        shots = {name: ARTIFACTS / f"path_view_{name}.png" for name in ("start", "no_path", "end")}
        page.screenshot(path=shots["start"])
        set_visible(frame, "/meshcat/path", False)
        page.screenshot(path=shots["no_path"])
        set_visible(frame, "/meshcat/path", True)
        frame.evaluate("t => viewer.animator.seek(t)", duration)
        frame.wait_for_timeout(300)
        page.screenshot(path=shots["end"])
    finally:
        page.close()
    # 0.5 m at 0.1 m/s along x and z: the clip lasts as long as the planned motion
    assert duration == pytest.approx(math.sqrt(0.1 ** 2 + 0.5 ** 2 + 0.15 ** 2) / 0.1, rel=1e-6)
    start = image(shots["start"])
    assert start.std() > 10, "the page looks blank"
    path_pixels = changed_pixels(start, image(shots["no_path"])).mean()
    moved = changed_pixels(start, image(shots["end"])).mean()
    assert path_pixels > 0.0003, f"the path covers {path_pixels:.3%} of the picture"
    assert moved > 0.002, f"start and end differ on {moved:.3%} of the picture: the arm did not move"
    shots["no_path"].unlink()


def test_path_view_live_shows_the_same_scene_until_stopped(browser):
    """`manipkit path --view`: the scene served by its own meshcat server, the arm animated; SIGTERM stops it."""
    proc = subprocess.Popen([str(BIN / "manipkit"), "path", "--robot", "ur5", "--tip", "tool0", "--line", "0.4", "0.1",
                             "0.4", "3.14159", "0", "0", "0.5", "0.1", "0.4", "3.14159", "0", "0", "--step", "0.02",
                             "--speed", "0.1", "--view"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        lines = []
        for line in proc.stdout:
            lines.append(line)
            if line.startswith("meshcat scene: "):
                break
        assert lines and lines[-1].startswith("meshcat scene: http://127.0.0.1:"), "".join(lines) + proc.stderr.read()
        assert proc.stdout.readline() == ("the arm along the joint path, at the waypoint times, in a loop (meshcat's "
                                          "controls: Animations); Ctrl-C stops\n")
        page = browser.new_page()
        try:
            page.goto(lines[-1].split(": ", 1)[1].strip())
            frame = page.main_frame
            wait_for_scene(frame, visual_count("ur5"))
            frame.wait_for_function("() => viewer.animator.actions.length > 0", timeout=20_000)
            duration = frame.evaluate("() => viewer.animator.duration")
            page.screenshot(path=ARTIFACTS / "path_view_live.png")
        finally:
            page.close()
        assert duration == pytest.approx(0.1 / 0.1, rel=1e-6)  # 0.1 m at 0.1 m/s
    finally:
        status = stop(proc)
    assert status == 0 and proc.stdout.read().strip().endswith("viewer stopped")


REALWORLD_ABB = next((base / "shared" / "realworld" / "ws_ros1" / "src" / "abb" for base in Path(__file__).resolve().parents[2:4]
                      if (base / "shared" / "realworld").is_dir()), Path("/nonexistent"))


@pytest.mark.skipif(not REALWORLD_ABB.is_dir(), reason=f"the shared real-world descriptions are not here ({REALWORLD_ABB})")
def test_static_view_of_a_description_without_its_meshes_draws_the_arm_as_lines(browser, tmp_path):
    """Issue 25: ABB IRB 2400 copied without its meshes (mesh visuals and collisions only) shows as a line skeleton."""
    import shutil

    shutil.copytree(REALWORLD_ABB, tmp_path / "ws" / "src" / "abb", ignore=shutil.ignore_patterns("meshes"))
    description = tmp_path / "ws" / "src" / "abb" / "abb_irb2400_support" / "urdf" / "irb2400.xacro"
    path = tmp_path / "abb.html"
    result = run_cli("manipkit", "view", "--robot", description, "--static", path, "--q", "joint_2=0.5", "joint_3=-0.3",
                     status=0)
    assert "drawn instead: 7 links as lines between joint origins" in result.stderr
    page = browser.new_page()
    try:
        page.goto(path.as_uri())
        frame = page.main_frame
        wait_for_scene(frame, 7)
        assert_robot_drawn(lambda shot: page.screenshot(path=shot), frame, "static_without_meshes")
    finally:
        page.close()


# ----------------------------------------------------------------------
# Collisions while the sliders move (issue 23)
# ----------------------------------------------------------------------

# The course arm's shoulder turned to 3.0 rad folds the upper arm back into the base: found with the Python API
# (manipkit.collisions over each joint from -pi to pi; the contact starts near 2.7 rad), checked below by coal alone.
FOLDED, UNFOLDED = 3.0, 0.5


def red_fraction(path: Path) -> float:
    """Fraction of the picture in the collision colour, pure red lit by meshcat's lights: red above 120, green
    and blue below a quarter of it. The course arm's own colours are not (orange: green 0.47 of red; greys)."""
    pixels = image(path)
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    return float(((r > 120) & (g < 0.25 * r) & (b < 0.25 * r)).mean())


def coal_contact(robot, link_a: str, link_b: str, q) -> float:
    """Signed distance (m) of the two links' collision shapes at q by Pinocchio and coal alone (negative: contact)."""
    import coal
    import pinocchio as pin

    model = pin.buildGeomFromUrdfString(robot.model, robot.urdf, pin.GeometryType.COLLISION)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.pinocchio_configuration(q))
    geom_data = model.createData()
    pin.updateGeometryPlacements(robot.model, data, model, geom_data)
    names = [robot.model.frames[o.parentFrame].name for o in model.geometryObjects]
    a, b = names.index(link_a), names.index(link_b)
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    coal.distance(model.geometryObjects[a].geometry, geom_data.oMg[a], model.geometryObjects[b].geometry,
                  geom_data.oMg[b], request, result)
    return float(result.min_distance)


@pytest.fixture(scope="module")
def collision_page(browser):
    proc, url, _ = start_viewer("--port", free_port(), "--collisions", "self")
    page = browser.new_page()
    page.goto(url)
    page.wait_for_function("document.querySelector('pre#collision-readout').textContent.length > 0")
    yield page
    page.close()
    stop(proc)


def visual_colour(frame, name: str) -> list:
    return frame.evaluate("name => { const c = viewer.scene_tree.find(['meshcat', 'pinocchio', 'visuals', name])"
                          ".children['<object>'].object.material.color; return [c.r, c.g, c.b]; }", name)


def test_links_in_self_collision_turn_red_while_the_slider_moves_and_back_when_free(collision_page):
    """Drive the shoulder into the base: the links in contact are drawn red (and only they: hiding them hides the
    red), the readout names the pairs as `manipkit collisions` does; back out, the red is gone."""
    import manipkit

    robot = manipkit.load("course_arm")
    page = collision_page
    frame = scene_frame(page)
    wait_for_scene(frame, visual_count("course_arm"))
    # the triads' x axes (0xE41A1C), meshcat's axes at the root and the red sphere at ee_link (0.85, 0.1, 0.1)
    # are red too: hidden here
    set_visible(frame, "/meshcat/manipkit", False)
    set_visible(frame, "/Axes", False)
    set_visible(frame, "/meshcat/pinocchio/visuals/ee_link_0", False)
    iframe = page.locator("iframe#scene")
    free_text = page.text_content("pre#collision-readout")
    assert free_text.startswith("robot course_arm: collision-free (10 link pairs checked, hulls geometry)")
    iframe.screenshot(path=ARTIFACTS / "viewer_collision_free.png")
    assert red_fraction(ARTIFACTS / "viewer_collision_free.png") < 1e-4

    before = page.text_content("pre#collision-readout")
    move_slider(page, "shoulder_joint", FOLDED)
    page.wait_for_function("b => document.querySelector('pre#collision-readout').textContent !== b", arg=before,
                           timeout=10_000)
    text = page.text_content("pre#collision-readout")
    expected = run_cli("manipkit", "collisions", "--q", f"shoulder_joint={FOLDED}", "--geometry", "hulls", status=0).stdout
    # the viewer shows the command's report; the command adds what it left out (SRDF, home contacts) and the
    # other geometry's verdict after it
    report = [line for line in expected.splitlines() if not line.startswith(("no SRDF", "SRDF ", "geometry: "))]
    assert text == "\n".join(report)
    lines = text.splitlines()
    assert lines[0].startswith("robot course_arm: IN COLLISION (2 pairs in contact; 10 link pairs checked")
    pairs = [tuple(line.strip().split(":")[0].split(" - ")) for line in lines[1:3]]
    assert sorted(pairs) == [("base_link", "bicep"), ("base_link", "bottom_wrist")]
    q = robot.q({"shoulder_joint": FOLDED})
    for a, b in pairs:  # in contact by coal alone: a penetration, as the readout says
        depth = float(lines[1 + pairs.index((a, b))].split("penetration ")[1].split(" m")[0])
        assert coal_contact(robot, a, b, q) == pytest.approx(-depth, abs=1e-4)
    assert lines[3].startswith("closest pair: base_link - bicep, distance -0.06")
    assert "colliding" in page.get_attribute("pre#collision-readout", "class")

    for name in ("base_link_0", "bicep_0", "bottom_wrist_0"):
        frame.wait_for_function("name => { const c = viewer.scene_tree.find(['meshcat', 'pinocchio', 'visuals', name])"
                                ".children['<object>'].object.material.color; return c.r === 1 && c.g === 0 && c.b === 0; }",
                                arg=name, timeout=10_000)
    assert visual_colour(frame, "elbow_0") == pytest.approx([242 / 255, 114 / 255, 25 / 255], abs=0.01)  # orange
    frame.wait_for_timeout(300)
    iframe.screenshot(path=ARTIFACTS / "viewer_collision.png")
    red = red_fraction(ARTIFACTS / "viewer_collision.png")
    assert red > 0.001, f"only {red:.3%} of the scene is red with three links in contact"  # 10x the free bound
    for name in ("base_link_0", "bicep_0", "bottom_wrist_0"):
        set_visible(frame, f"/meshcat/pinocchio/visuals/{name}", False)
    iframe.screenshot(path=ARTIFACTS / "viewer_collision_links_hidden.png")
    assert red_fraction(ARTIFACTS / "viewer_collision_links_hidden.png") < 1e-4  # the red was those links
    for name in ("base_link_0", "bicep_0", "bottom_wrist_0"):
        set_visible(frame, f"/meshcat/pinocchio/visuals/{name}", True)
    (ARTIFACTS / "viewer_collision_links_hidden.png").unlink()

    before = page.text_content("pre#collision-readout")
    move_slider(page, "shoulder_joint", UNFOLDED)
    page.wait_for_function("b => document.querySelector('pre#collision-readout').textContent !== b", arg=before,
                           timeout=10_000)
    assert page.text_content("pre#collision-readout").startswith("robot course_arm: collision-free")
    frame.wait_for_function("() => viewer.scene_tree.find(['meshcat', 'pinocchio', 'visuals', 'bicep_0'])"
                            ".children['<object>'].object.material.color.r < 1", timeout=10_000)
    # each visual has its URDF colour back (8 bits a channel, as Pinocchio's visualizer sets it)
    assert visual_colour(frame, "base_link_0") == pytest.approx([25 / 255] * 3, abs=1e-6)
    assert visual_colour(frame, "bicep_0") == pytest.approx([242 / 255, 114 / 255, 25 / 255], abs=1e-6)
    assert visual_colour(frame, "bottom_wrist_0") == pytest.approx([191 / 255, 191 / 255, 198 / 255], abs=1e-6)
    frame.wait_for_timeout(300)
    iframe.screenshot(path=ARTIFACTS / "viewer_collision_free_again.png")
    assert red_fraction(ARTIFACTS / "viewer_collision_free_again.png") < 1e-4
    (ARTIFACTS / "viewer_collision_free_again.png").unlink()


def test_a_robot_without_collision_geometry_gets_one_line_and_never_collision_free(browser, tmp_path):
    urdf = tmp_path / "no_collisions.urdf"
    urdf.write_text(
        '<robot name="bare"><link name="base_link"><visual><geometry><box size="0.1 0.1 0.1"/></geometry></visual>'
        '</link><link name="ee_link"><visual><geometry><sphere radius="0.05"/></geometry></visual></link>'
        '<joint name="j1" type="revolute"><parent link="base_link"/><child link="ee_link"/><origin xyz="0 0 0.3"/>'
        '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>')
    proc, url, _ = start_viewer("--robot", urdf, "--port", free_port(), "--collisions", "self,floor")
    page = browser.new_page()
    line = ("collisions unavailable: robot 'bare' has no <collision> elements, so collisions cannot be checked for "
            "it; add <collision> geometry (box, cylinder, sphere or mesh) to its links")
    try:
        page.goto(url)
        page.wait_for_function("document.querySelector('pre#collision-readout').textContent.length > 0")
        assert page.text_content("pre#collision-readout") == line
        after_change(page, lambda: move_slider(page, "j1", 0.8))
        assert page.text_content("pre#collision-readout") == line
        assert "collision-free" not in page.text_content("body")
    finally:
        page.close()
        stop(proc)
    assert proc.stderr.read() == f"warning: {line}\n"  # said once


# ----------------------------------------------------------------------
# Names that mean something in HTML and JavaScript (issue 15)
# ----------------------------------------------------------------------

# names holding line breaks are refused at load (issue 26): the loadable copy of hostile_names.urdf
HOSTILE = Path(__file__).parent / "bad_inputs" / "outputs" / "hostile_names_one_line.urdf"


def test_control_page_shows_hostile_names_as_text(browser):
    import xml.etree.ElementTree as ET

    root = ET.parse(HOSTILE).getroot()
    robot_name = root.get("name")
    joints = [e.get("name") for e in root.findall("joint") if e.get("type") != "fixed"]
    links = [e.get("name") for e in root.findall("link")]
    proc, url, _ = start_viewer("--robot", HOSTILE, "--port", free_port())
    page = browser.new_page()
    errors = []
    page.on("pageerror", lambda error: errors.append(str(error)))
    page.on("dialog", lambda dialog: (errors.append(f"dialog: {dialog.message}"), dialog.dismiss()))
    try:
        page.goto(url)
        page.wait_for_function("document.querySelector('pre#readout-json').textContent.length > 0", timeout=20_000)
        assert page.text_content("#robot-name") == robot_name
        assert page.title() == f"manipkit view: {robot_name}"
        shown = page.eval_on_selector_all("input[type=range]", "inputs => inputs.map(i => i.dataset.joint)")
        assert shown == joints
        options = page.eval_on_selector_all("select#frame-a option", "options => options.map(o => o.value)")
        assert [o for o in options if o not in ("base_link", "ee_link")] == [n for n in links if n not in ("base_link", "ee_link")]
        # nothing the names spell was made into markup: the page's own two scripts, no <b> or <i>
        assert page.eval_on_selector_all("script", "s => s.length") == 2
        assert page.eval_on_selector_all("b, i", "e => e.length") == 0
        assert readout(page)["robot"] == robot_name
        assert errors == []
    finally:
        page.close()
        stop(proc)
