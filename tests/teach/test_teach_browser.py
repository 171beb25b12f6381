"""The teach page in a real browser: headless Chromium (Debian's ``chromium``) driven by
Playwright through ``executable_path`` (no browser download). The tests drag the gizmo
with mouse events, press the panel's buttons and check the server's state; screenshots
go to ``outputs/tests/teach/`` (or ``$LFD_TEACH_SCREENSHOTS``).

Chromium is ``$LFD_CHROMIUM`` or ``chromium`` / ``chromium-browser`` on the PATH (the ``chromium``
fixture of tests/conftest.py): without it the tests are skipped with the reason, and fail under
``LFD_REQUIRE_ALL_TESTS=1`` (``.ci/run``, whose test command installs it).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from teach_helpers import BOXES, ROOT

from lfd.teach import TeachSession
from lfd.teach.server import TeachServer
from lfd.teach.visuals import project_to_pixel

# A browser that stops answering must not hold CI for its whole time limit: after 300 s pytest-timeout
# prints every thread's stack (which Playwright call waited) and ends the run.
pytestmark = pytest.mark.timeout(300, method="thread")

FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
SHOTS = Path(os.environ.get("LFD_TEACH_SCREENSHOTS", ROOT / "outputs" / "tests" / "teach"))
VIEW = {"width": 900, "height": 600}


@pytest.fixture(scope="module")
def browser(chromium):
    from playwright.sync_api import sync_playwright

    profile = tempfile.mkdtemp(prefix="lfd-teach-chromium-")
    with sync_playwright() as pw:
        context = pw.chromium.launch_persistent_context(
            profile, executable_path=chromium, args=FLAGS, headless=True, viewport=VIEW
        )
        yield context
        context.close()
    shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    session = TeachSession(robot="wam4", scene=BOXES)
    server = TeachServer(session, port=0, export_dir=tmp_path_factory.mktemp("teach") / "export")
    yield server
    server.close()
    session.close()


@pytest.fixture(scope="module")
def page(browser, served):
    """One page for both tests (loading the page is the slow part in software WebGL)."""
    page, _ = _open(browser, served)
    yield page
    page.close()


def _open(browser, server):
    page = browser.new_page()
    page.goto(server.url)
    page.get_by_role("button", name="Clear").wait_for(timeout=45_000)
    # wait until the page reports its camera, then point it at the arm and wait for the echo
    assert _wait(page, lambda: server.server.get_clients() and _camera(server).image_width > 0, timeout=45)
    cam = _camera(server)
    for _ in range(3):
        cam.position, cam.look_at = (1.3, -1.3, 1.0), (0.35, 0.0, 0.2)
        if _wait(page, lambda: np.allclose(_camera(server).position, (1.3, -1.3, 1.0), atol=1e-2), timeout=5):
            break
    page.wait_for_timeout(1000)  # let the frame with the new camera render
    return page, _camera(server)


def _camera(server):
    return next(iter(server.server.get_clients().values())).camera


_project = project_to_pixel


def _drag_arrow(page, server, cam, axis: int, distance: float, steps: int = 15) -> None:
    """Grab the gizmo's arrow along ``axis`` and drag it by ``distance`` m along that axis."""
    tool = server.session.tool_position
    along = np.eye(3)[axis] * server.view.gizmo_scale * 0.7
    a = _project(cam, tool + along)
    b = _project(cam, tool + along + np.eye(3)[axis] * distance)
    page.mouse.move(*a)
    page.mouse.down()
    for k in range(1, steps + 1):
        page.mouse.move(*(a + (b - a) * k / steps))
        time.sleep(0.02)
    page.mouse.up()
    page.wait_for_timeout(300)


def _wait(page, predicate, timeout: float = 20.0) -> bool:
    """Poll the server-side ``predicate`` until it holds or ``timeout`` s pass. Waits are
    ``page.wait_for_timeout``, not ``time.sleep``: Playwright's sync API handles the browser's
    messages only inside its own calls, and a test that sleeps for seconds lets them pile up (only the
    mouse moves' pacing, a user's hand speed, uses short sleeps)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        page.wait_for_timeout(100)
    return predicate()


def test_drag_gizmo_records_collides_exports_and_sends(page, served):
    s = served.session
    cam = _camera(served)
    _shot(page, "3d_0_loaded.png")
    # no way out (viser's Share button), one controller without a "Take control", the hint, whole numbers
    assert page.locator("svg.tabler-icon-share").count() == 0
    assert page.get_by_role("button", name="Take control").count() == 0
    assert page.get_by_text("Drag the arrows").count() == 1
    for label in ("Playback", "Send"):
        assert page.get_by_role("button", name=label, exact=True).count() == 1
    z0 = s.tool_position[2]
    _drag_arrow(page, served, cam, axis=2, distance=0.12)  # lift the tool
    assert _wait(page, lambda: s.recording_state == "recording" and len(s.recorded) >= 5)
    assert s.tool_position[2] > z0 + 0.05 and s.collisions == 0
    _shot(page, "3d_1_lifted.png")
    _drag_arrow(page, served, cam, axis=1, distance=0.45)  # sideways into the wall
    assert _wait(page, lambda: s.collisions >= 1)
    assert s.counters["refused_collision"] >= 1
    assert abs(s.tool_position[1]) > 0.03  # the arm stopped short of the wall (y = 0, 4 cm thick)
    _shot(page, "3d_2_collision.png")
    n = len(s.recorded)
    page.get_by_role("button", name="Stop").click()
    assert _wait(page, lambda: s.recording_state == "done")
    page.get_by_role("button", name="Export").click()
    assert _wait(page, lambda: served.last_export is not None)
    assert all(Path(p).is_file() for p in served.last_export.values())
    assert Path(served.last_export["csv"]).read_text().count("\n") == n + 1
    page.get_by_role("button", name="Send", exact=True).first.click()
    assert _wait(page, lambda: s.last_send is not None, timeout=30)
    assert s.last_send.final_error < 0.01
    assert _wait(page, lambda: "final error" in served.status.content)
    page.wait_for_timeout(500)
    _shot(page, "3d_3_sent.png")
    # Clear puts the arm back at the start and the gizmo with it: the next drag starts there
    page.get_by_role("button", name="Clear").click()
    assert _wait(page, lambda: s.recording_state == "idle" and np.allclose(s.q, s.start))
    page.wait_for_timeout(500)  # let the page draw the gizmo where the server put it
    jumps, z0 = s.counters["refused_jump"], s.tool_position[2]
    _drag_arrow(page, served, cam, axis=2, distance=0.08)
    assert _wait(page, lambda: s.recording_state == "recording" and len(s.recorded) >= 5)
    assert s.counters["refused_jump"] == jumps and s.tool_position[2] > z0 + 0.04
    assert _wait(page, lambda: np.allclose(served.view.gizmo.position, s.tool_position, atol=1e-6))


def test_two_d_panel_buttons(page, served):
    s = served.session
    page.get_by_role("button", name="Clear").click()
    assert _wait(page, lambda: s.recording_state == "idle" and np.allclose(s.q, s.start))
    page.get_by_role("button", name="2-D panel").click()
    assert _wait(page, lambda: s.mode == "2d")
    page.get_by_text("2-D panel", exact=True).last.click()  # open the folder
    # joint slider: drag the first joint's slider thumb to the right with the mouse
    q0 = page.get_by_role("slider").nth(2)  # after the timeline's and the speed's
    q0.wait_for(state="visible")
    page.wait_for_timeout(500)  # let the panel finish its layout before reading the thumb's position
    # every number box shows its whole value
    widths = page.locator("input.mantine-NumberInput-input").evaluate_all(
        "(els) => els.filter(e => e.clientWidth > 0).map(e => [e.value, e.scrollWidth, e.clientWidth])"
    )
    assert widths and all(sw <= cw for _, sw, cw in widths), widths
    thumb = q0.bounding_box()
    x, y = thumb["x"] + thumb["width"] / 2, thumb["y"] + thumb["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for k in range(1, 6):
        page.mouse.move(x + k, y)  # ~0.04 rad per pixel
        time.sleep(0.05)
    page.mouse.up()
    if not _wait(page, lambda: s.counters["panel_moves"] >= 1, timeout=5):
        # a drag that started beside the thumb moves nothing: move it as a keyboard user would
        q0.focus()
        for _ in range(5):
            page.keyboard.press("ArrowRight")  # one step (0.01 rad) each
            time.sleep(0.05)
    assert _wait(page, lambda: s.counters["panel_moves"] >= 1)
    assert s.q[0] > s.start[0] + 0.02
    # x/y/z entry + Move (IK), then Store
    p = s.tool_position + [0.0, 0.0, 0.1]
    inputs = page.locator("input.mantine-NumberInput-input")
    first = inputs.evaluate_all(f"(els) => els.findIndex(e => e.id === '{served.xyz_uuid}')")
    for k in range(3):
        box = inputs.nth(first + k)
        box.fill(f"{p[k]:.3f}")
        box.press("Tab")
    assert _wait(page, lambda: np.allclose(served.xyz.value, np.round(p, 3), atol=1e-6))
    page.get_by_role("button", name="Move (IK)").click()
    assert _wait(page, lambda: np.linalg.norm(s.tool_position - np.round(p, 3)) < 2e-3)
    page.get_by_role("button", name="Store").click()
    assert _wait(page, lambda: len(s.waypoints) == 2)
    _shot(page, "2d_1_stored.png")
    page.get_by_role("button", name="Go Home").click()
    assert _wait(page, lambda: np.allclose(s.q, s.start))
    page.get_by_role("button", name="Store").click()
    assert _wait(page, lambda: len(s.waypoints) == 3)
    page.get_by_role("button", name="Playback", exact=True).click()
    assert _wait(page, lambda: served.playbacks == 1, timeout=30)
    _shot(page, "2d_2_playback.png")
    assert s.counters["stores"] == 2 and s.counters["refused_stores"] == 0


def _shot(page, name: str) -> None:
    SHOTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(SHOTS / name), timeout=60_000)


def test_rotation_ring_turns_the_sawyer_tool(browser, tmp_path):
    """Drag the gizmo's ring about its z axis with the mouse: the Sawyer's tool follows the orientation the
    gizmo commanded within 2 degrees, and the tool stays where it was."""
    from lfd.teach.drag_ik import as_rotation, rotation_angle

    session = TeachSession(robot="sawyer", scene=None)
    server = TeachServer(session, port=0, export_dir=tmp_path)
    page = None
    try:
        page, cam = _open(browser, server)
        pos, quat = session.tool_pose()
        rot = as_rotation(quat, order="xyzw")
        radius = server.view.gizmo_scale * 0.65  # the ring between the gizmo's x and y arrows
        arc = [pos + radius * rot @ [np.cos(a), np.sin(a), 0.0] for a in np.radians(np.linspace(45, 65, 21))]
        pixels = [_project(cam, p) for p in arc]
        page.mouse.move(*pixels[0])
        page.mouse.down()
        for p in pixels[1:]:
            page.mouse.move(*p)
            time.sleep(0.03)
        page.wait_for_timeout(300)
        page.mouse.up()
        assert _wait(page, lambda: server.last_target is not None and server.last_target[1] is not None)
        assert _wait(page, lambda: not server._dragging)
        commanded = as_rotation(server.last_target[1], order="xyzw")
        frame = session.kin.frames(session.q)[-1]
        turned = np.degrees(rotation_angle(commanded, rot))
        assert turned > 5.0, turned  # the ring turned the gizmo
        assert np.degrees(rotation_angle(commanded, frame[:3, :3])) < 2.0
        assert np.linalg.norm(frame[:3, 3] - pos) < 0.01
        _shot(page, "3d_4_sawyer_turned.png")
    finally:
        if page is not None:
            page.close()
        server.close()
        session.close()


def test_keyframes_added_dragged_and_deleted_in_the_page(page, served):
    """Keyframes from the panel, one dragged by its own gizmo with the mouse, one deleted: the exported skill
    passes the edited keyframes within 1 mm."""
    from lfd.dmp import DMP

    s = served.session
    cam = _camera(served)
    page.get_by_role("button", name="Clear").click()
    assert _wait(page, lambda: s.recording_state == "idle")
    page.get_by_role("button", name="3-D drag").click()
    assert _wait(page, lambda: s.mode == "3d")
    page.get_by_role("button", name="Add keyframe").click()
    assert _wait(page, lambda: len(s.keyframes) == 1)
    _drag_arrow(page, served, cam, axis=2, distance=0.10)
    assert _wait(page, lambda: s.recording_state == "recording" and len(s.recorded) >= 5)
    page.get_by_role("button", name="Add keyframe").click()
    assert _wait(page, lambda: len(s.keyframes) == 2)
    page.get_by_role("button", name="Stop").click()
    assert _wait(page, lambda: s.recording_state == "done" and served.view.motion_line is not None)
    # drag keyframe 1's gizmo (at the start, below the arm's) along its y arrow, away from the wall
    before = s.keyframe_poses()[0][0]
    line = np.array(served.view.motion_line.points).copy()
    y = np.eye(3)[1]
    a = _project(cam, before + y * 0.08 * 0.7)
    b = _project(cam, before + y * (0.08 * 0.7 - 0.04))
    page.mouse.move(*a)
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(*(a + (b - a) * k / 10))
        time.sleep(0.05)
    page.mouse.up()
    assert _wait(page, lambda: np.linalg.norm(s.keyframe_poses()[0][0] - before) > 0.01)
    assert not np.allclose(served.view.motion_line.points, line)  # the motion was refitted
    page.get_by_role("button", name="Add keyframe").click()  # a third one, then delete it (selected)
    assert _wait(page, lambda: len(s.keyframes) == 3)
    page.get_by_role("button", name="Delete keyframe").click()
    assert _wait(page, lambda: len(s.keyframes) == 2 and len(served.view.keyframe_handles) == 2)
    served.last_export = None
    page.get_by_role("button", name="Export").click()
    assert _wait(page, lambda: served.last_export is not None)
    tool = np.array([s.kin.tool_position(q) for q in DMP.load(served.last_export["dmp"]).rollout()])
    for p, _ in s.keyframe_poses():
        assert np.linalg.norm(tool - p, axis=1).min() < 1e-3
    _shot(page, "3d_5_keyframes.png")


def test_gripper_event_round_trips_through_export_and_reopen_in_the_page(page, served):
    """Close the gripper at the motion's end from the Timeline, Export, Reopen: the reopened session (now the
    page's) has the event, the keyframes and the speed."""
    s = served.session
    assert s.recording_state == "done" and len(s.keyframes) == 2  # left by the keyframes test
    with served.lock:  # the time slider at the end (dragging its thumb is the slider test's job)
        served.timeline.value = float(np.floor(s.motion_duration * 100) / 100)
    page.get_by_role("button", name="Close gripper at t").click()
    assert _wait(page, lambda: len(s.gripper_events) == 1 and s.gripper_events[0].closed)
    served.last_export = None
    page.get_by_role("button", name="Export").click()
    assert _wait(page, lambda: served.last_export is not None)
    page.get_by_text("Reopen an export", exact=True).click()  # open the folder
    page.get_by_role("button", name="Reopen").click()
    assert _wait(page, lambda: served.session is not s and "reopened" in served.status.content)
    r = served.session
    assert [e.closed for e in r.gripper_events] == [True] and len(r.keyframes) == 2 and r.speed == s.speed
    assert abs(r.gripper_events[0].t - s.gripper_events[0].t) < 1e-6
    page.get_by_role("button", name="Clear").wait_for(timeout=20_000)  # the rebuilt panel is there
    _shot(page, "3d_6_reopened.png")


def test_a_drag_with_a_long_pause_exports_the_motion_time(page, served):
    """Two drags of about 2.5 s with 10 s of holding still between them, all with the mouse: the exported
    DMP lasts the time the arm moved (within 10 %), not the 15 s the clock saw; the raw recording keeps them."""
    from lfd.dmp import DMP

    page.get_by_role("button", name="Clear").click()
    s = served.session  # the reopened session of the test before, or the first one
    assert _wait(page, lambda: s.recording_state == "idle" and np.allclose(s.q, s.start))
    page.get_by_role("button", name="3-D drag").click()
    assert _wait(page, lambda: s.mode == "3d")
    page.wait_for_timeout(500)
    cam = _camera(served)
    moving = 0.0
    for axis, distance in ((2, 0.06), (0, -0.05)):  # up, then towards the robot
        tool = s.tool_position
        along = np.eye(3)[axis] * served.view.gizmo_scale * 0.7
        a, b = _project(cam, tool + along), _project(cam, tool + along + np.eye(3)[axis] * distance)
        page.mouse.move(*a)
        page.mouse.down()
        start = time.monotonic()
        for k in range(1, 26):  # one small move every 0.1 s
            page.mouse.move(*(a + (b - a) * k / 25))
            time.sleep(0.1)
        moving += time.monotonic() - start
        page.mouse.up()
        if axis == 2:
            assert _wait(page, lambda: s.recording_state == "recording" and len(s.recorded) >= 10)
            page.wait_for_timeout(10000)  # the user holds still
    page.wait_for_timeout(500)
    page.get_by_role("button", name="Stop").click()
    assert _wait(page, lambda: s.recording_state == "done")
    assert s.recorded_raw.t[-1] > moving + 9.0 and s.collisions == 0
    served.last_export = None
    page.get_by_role("button", name="Export").click()
    assert _wait(page, lambda: served.last_export is not None)
    tau = DMP.load(served.last_export["dmp"]).tau_
    assert abs(tau - moving) < 0.1 * moving, (tau, moving)
