"""Drag -> arm update of the teach page as the user sees it, in headless Chromium.

A real :class:`~lfd.teach.server.TeachServer` (wam4, configs/teach/boxes.yaml) is opened in headless
Chromium (Playwright, ``$LFD_CHROMIUM`` or ``chromium`` on the PATH, software WebGL). The script grabs the
gizmo's vertical arrow with the mouse and moves it up and down in small steps, one mouse move every
``--interval`` ms so that each move's answer is told apart from the next. For each move the page measures,
on its own clock:

* **move**: the ``pointermove`` event the browser dispatches for the mouse move;
* **seen**: the first animation frame after the page received (from viser's websocket worker) a message
  that moves the arm's links, i.e. the first frame drawn with the arm where the drag put it.

``seen - move`` is the latency the user sees (pointer event -> gizmo message -> server IK, collision
check and scene update -> websocket -> the page's next frame). Moves whose answer never came (the update was
refused or dropped by the server's latest-wins slot) are counted apart. The rows between split it: when
viser handed the update to the server's callbacks, when the server finished it (scene messages queued)
and when the page's main thread received the arm's message (epoch clocks of one machine). Beside it:
the server-side part, the session's IK + collision check per update (``TeachSession.latencies``), and the
page's frame interval (software WebGL draws a frame at a time: a message waits for the frame in progress).

    python benchmarks/teach_browser_latency.py [--moves 60] [--interval 120]

Prints a markdown table (median / p95 in ms, and the share of moves answered).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

#: Runs in the page before viser's code: wraps ``Worker`` (viser's websocket lives in one) to time the
#: messages that move the arm, and records the time of each pointer move with a button held.
PAGE_PROBE = """
window.__lfd = {moves: [], seen: [], received: [], origin: performance.timeOrigin};
const NativeWorker = window.Worker;
window.Worker = function (...args) {
  const worker = new NativeWorker(...args);
  worker.addEventListener("message", (ev) => {
    let text = "";
    try { text = JSON.stringify(ev.data); } catch (e) { return; }
    if (text && text.includes("/robot/link")) {
      window.__lfd.received.push(performance.now());
      requestAnimationFrame(() => window.__lfd.seen.push(performance.now()));
    }
  });
  return worker;
};
window.Worker.prototype = NativeWorker.prototype;
window.__lfd.frames = [];
const tick = () => { window.__lfd.frames.push(performance.now()); requestAnimationFrame(tick); };
requestAnimationFrame(tick);
window.addEventListener("pointermove", (e) => { if (e.buttons) window.__lfd.moves.push(performance.now()); }, true);
"""


def percentiles(values) -> tuple[float, float]:
    """(median, p95) of ``values`` (NaN, NaN when empty)."""
    if len(values) == 0:
        return float("nan"), float("nan")
    return float(np.median(values)), float(np.percentile(values, 95))


def match(moves, seen, window_ms: float) -> list[float]:
    """For each move time, the delay to the first ``seen`` time after it within ``window_ms`` (ms); moves
    without one are left out."""
    seen = np.sort(np.asarray(seen, dtype=float))
    out = []
    for t in moves:
        k = int(np.searchsorted(seen, t, side="right"))
        if k < len(seen) and seen[k] - t <= window_ms:
            out.append(float(seen[k] - t))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--moves", type=int, default=60, help="mouse moves while the gizmo is held")
    ap.add_argument("--interval", type=float, default=120.0, help="ms between mouse moves")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "tests"))
    from conftest import find_chromium  # the one place that finds Chromium
    from playwright.sync_api import sync_playwright

    from lfd.teach import TeachSession
    from lfd.teach.server import TeachServer
    from lfd.teach.visuals import project_to_pixel

    chromium = find_chromium()
    if chromium is None:
        print(
            "teach_browser_latency: Chromium is missing "
            "(apt-get install -y chromium-headless-shell, or set LFD_CHROMIUM)"
        )
        return 2
    session = TeachSession(robot="wam4", scene=ROOT / "configs" / "teach" / "boxes.yaml")
    export = Path(tempfile.mkdtemp(prefix="lfd-teach-bench-"))
    server = TeachServer(session, port=0, export_dir=export)
    arrived: list[float] = []  # epoch ms at which viser handed each gizmo update to the server's callbacks
    server.view.gizmo.on_update(lambda event: arrived.append(time.time() * 1000.0))
    handled: list[float] = []  # epoch ms at which the server finished each update (scene messages queued)
    handle = server.handle_drag

    def timed_handle(*a, **k):
        out = handle(*a, **k)
        handled.append(time.time() * 1000.0)
        return out

    server.handle_drag = timed_handle
    profile = tempfile.mkdtemp(prefix="lfd-teach-chromium-")
    try:
        with sync_playwright() as pw:
            context = pw.chromium.launch_persistent_context(
                profile,
                executable_path=chromium,
                headless=True,
                viewport={"width": 900, "height": 600},
                args=["--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking"],
            )
            page = context.new_page()
            page.add_init_script(PAGE_PROBE)
            page.goto(server.url)
            page.get_by_role("button", name="Clear").wait_for(timeout=60_000)
            end = time.monotonic() + 60
            while time.monotonic() < end and not (
                server.server.get_clients()
                and next(iter(server.server.get_clients().values())).camera.image_width > 0
            ):
                time.sleep(0.1)
            cam = next(iter(server.server.get_clients().values())).camera
            cam.position, cam.look_at = (1.3, -1.3, 1.0), (0.35, 0.0, 0.2)
            time.sleep(2.0)
            cam = next(iter(server.server.get_clients().values())).camera
            tool = session.tool_position
            up = np.array([0.0, 0.0, 1.0])
            a = project_to_pixel(cam, tool + up * server.view.gizmo_scale * 0.7)
            b = project_to_pixel(cam, tool + up * (server.view.gizmo_scale * 0.7 + 0.004))
            step = b - a  # one move: 4 mm up the arrow
            page.mouse.move(*a)
            page.mouse.down()
            pos = a.copy()
            for k in range(args.moves):
                pos = pos + (step if (k // 15) % 2 == 0 else -step)  # 15 moves up, 15 down, ...
                page.mouse.move(*pos)
                time.sleep(args.interval / 1000.0)
            page.mouse.up()
            time.sleep(0.5)
            probe = page.evaluate("window.__lfd")
            context.close()
    finally:
        server.close()
        session.close()
        shutil.rmtree(profile, ignore_errors=True)
        shutil.rmtree(export, ignore_errors=True)
    seen = match(probe["moves"], probe["seen"], window_ms=args.interval)
    received = match(probe["moves"], probe["received"], window_ms=args.interval)
    med, p95 = percentiles(seen)
    rmed, rp95 = percentiles(received)
    moves_epoch = np.asarray(probe["moves"]) + probe["origin"]
    reached = match(moves_epoch, arrived, window_ms=args.interval)
    amed, ap95 = percentiles(reached)
    done = match(moves_epoch, handled, window_ms=args.interval)
    dmed, dp95 = percentiles(done)
    smed, sp95 = percentiles(np.asarray(session.latencies) * 1000.0)
    frames = np.diff(np.asarray(probe["frames"])[-300:])
    print(f"frame interval median {np.median(frames):.1f} ms p95 {np.percentile(frames, 95):.1f} ms")
    print("| part | median ms | p95 ms | n |")
    print("|---|---|---|---|")
    print(
        f"| drag -> arm drawn in the browser | {med:.1f} | {p95:.1f} | {len(seen)} of {len(probe['moves'])} moves |"
    )
    print(f"| drag -> gizmo update in the server's callback | {amed:.1f} | {ap95:.1f} | {len(reached)} |")
    print(f"| drag -> server update done | {dmed:.1f} | {dp95:.1f} | {len(done)} |")
    print(f"| drag -> arm message received by the page | {rmed:.1f} | {rp95:.1f} | {len(received)} |")
    print(f"| server: IK + collision check | {smed:.1f} | {sp95:.1f} | {len(session.latencies)} updates |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
