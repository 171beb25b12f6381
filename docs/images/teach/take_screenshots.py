"""The screenshots of docs/teach.md's walkthrough, taken in headless Chromium.

Runs the walkthrough on a real teach server (wam4, configs/teach/boxes.yaml): the page on load, a
demonstration over the wall into the goal (the drag updates the server's worker would run for the
gizmo's arrows), the gripper closed at the end of the timeline, Send. Buttons are pressed in the page.
Writes ``1_start.png`` .. ``4_sent.png`` next to this file (palette PNGs, 1200x640).

    python docs/images/teach/take_screenshots.py

Chromium is ``$LFD_CHROMIUM`` or ``chromium-headless-shell`` / ``chromium`` on the PATH (Debian:
``apt-get install -y chromium-headless-shell``).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
VIEW = {"width": 1200, "height": 640}
CAMERA = ((1.65, -0.45, 0.75), (0.55, 0.3, 0.12))  # position, look-at (m): the wall edge-on, the goal beyond


def _wait(predicate, timeout: float = 30.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.1)
    return bool(predicate())


def _shot(page, name: str) -> None:
    """Save the page as a small palette PNG ``name`` next to this file."""
    from PIL import Image

    time.sleep(1.0)  # let the last frame render
    raw = HERE / f".{name}"
    page.screenshot(path=str(raw), timeout=60_000)
    Image.open(raw).convert("RGB").quantize(colors=96).save(HERE / name, optimize=True)
    raw.unlink()


def _line(server, a, b, n: int) -> None:
    """Drag the tool from ``a`` to ``b`` (m) in ``n`` updates, as the worker does for the gizmo."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    for s in np.linspace(0.0, 1.0, n + 1)[1:]:
        server.handle_drag(a + (b - a) * s)
        time.sleep(0.03)


def main() -> int:
    sys.path.insert(0, str(ROOT / "tests"))
    from conftest import find_chromium
    from playwright.sync_api import sync_playwright

    from lfd.teach import TeachSession
    from lfd.teach.server import TeachServer

    chromium = find_chromium()
    if chromium is None:
        print(
            "take_screenshots: Chromium is missing (apt-get install -y chromium-headless-shell, or set LFD_CHROMIUM)"
        )
        return 2
    session = TeachSession(robot="wam4", scene=ROOT / "configs" / "teach" / "boxes.yaml")
    export = Path(tempfile.mkdtemp(prefix="lfd-teach-docs-"))
    server = TeachServer(session, port=0, export_dir=export)
    profile = tempfile.mkdtemp(prefix="lfd-teach-chromium-")
    try:
        with sync_playwright() as pw:
            context = pw.chromium.launch_persistent_context(
                profile,
                executable_path=chromium,
                headless=True,
                viewport=VIEW,
                args=["--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking"],
            )
            page = context.new_page()
            page.goto(server.url)
            page.get_by_role("button", name="Clear").wait_for(timeout=60_000)
            assert _wait(lambda: server.server.get_clients())
            cam = next(iter(server.server.get_clients().values())).camera
            assert _wait(lambda: cam.image_width > 0)
            for _ in range(3):  # the page echoes its camera once it has applied it
                cam.position, cam.look_at = CAMERA
                if _wait(lambda: np.allclose(cam.position, CAMERA[0], atol=1e-2), timeout=5):
                    break
            for close in page.locator(".mantine-Notification-root button").all():
                close.click()  # the notice that WebGL runs in software (headless)
            _shot(page, "1_start.png")
            p = session.tool_position
            over = p + [0.0, 0.0, 0.30]
            across = over + [0.0, 0.70, 0.0]
            _line(server, p, over, 30)
            _line(server, over, across, 70)
            _line(server, across, across - [0.0, 0.0, 0.28], 30)
            assert _wait(lambda: session.recording_state == "done"), session.summary()
            _shot(page, "2_recorded.png")
            with server.lock:
                server.timeline.value = np.floor(session.motion_duration * 100) / 100  # the end
                server._run(server._scrub)
            page.get_by_role("button", name="Close gripper at t").scroll_into_view_if_needed()
            page.get_by_role("button", name="Close gripper at t").click()
            assert _wait(lambda: len(session.gripper_events) == 1)
            _shot(page, "3_gripper.png")
            page.get_by_role("button", name="Send", exact=True).scroll_into_view_if_needed()
            page.get_by_role("button", name="Send", exact=True).click()
            assert _wait(lambda: session.last_send is not None, timeout=60)
            _shot(page, "4_sent.png")
            context.close()
    finally:
        server.close()
        session.close()
        shutil.rmtree(profile, ignore_errors=True)
        shutil.rmtree(export, ignore_errors=True)
    for png in sorted(HERE.glob("*.png")):
        print(f"{png.relative_to(ROOT)}: {png.stat().st_size // 1024} KiB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
