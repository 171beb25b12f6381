"""The teach server serves only its own page: hostile and careless use, tried for real.

A real :class:`~lfd.teach.server.TeachServer` on 127.0.0.1 (a free port) and plain
``websockets`` / ``http.client`` clients speaking viser's protocol (msgpack messages, the
``viser-v<version>`` subprotocol): no browser, all traffic on loopback.
"""

from __future__ import annotations

import hashlib
import http.client
import math
import threading
import time
from pathlib import Path

import msgspec
import numpy as np
import pytest
import viser
import websockets.exceptions
from viser import _messages
from websockets.sync.client import connect

from lfd.teach import TeachSession
from lfd.teach.access import AccessGuard, start_guarded_viser, token_required
from lfd.teach.control import READ_ONLY
from lfd.teach.server import TeachServer

ROOT = Path(__file__).resolve().parents[1]
SUBPROTOCOL = f"viser-v{viser.__version__}"
EVIL = "http://evil.example.com"


def _wait(predicate, timeout: float = 10.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.02)
    return bool(predicate())


class Tab:
    """A scripted browser tab: a websocket that registers as a viser client (its first
    camera message), drains what the server sends, and sends drags and button clicks."""

    def __init__(self, served: TeachServer, origin: str | None = "own", path: str = "/", headers=None):
        origin = f"http://127.0.0.1:{served.port}" if origin == "own" else origin
        self.served = served
        before = set(served.server.get_clients())
        self.ws = connect(
            f"ws://127.0.0.1:{served.port}{path}",
            origin=origin,
            subprotocols=[SUBPROTOCOL],
            additional_headers=headers,
            open_timeout=10,
        )
        threading.Thread(target=self._drain, daemon=True).start()
        self.send(
            _messages.ViewerCameraMessage(
                wxyz=(1.0, 0.0, 0.0, 0.0),
                position=(1.3, -1.3, 1.0),
                fov=1.0,
                near=0.01,
                far=100.0,
                image_height=600,
                image_width=900,
                look_at=(0.35, 0.0, 0.2),
                up_direction=(0.0, 0.0, 1.0),
            )
        )
        assert _wait(lambda: set(served.server.get_clients()) - before)
        (self.id,) = set(served.server.get_clients()) - before
        assert _wait(
            lambda: self.id == served.clients.control.owner or self.id in served.clients.control.viewers
        )

    def _drain(self) -> None:
        try:
            while True:
                self.ws.recv()
        except websockets.exceptions.ConnectionClosed:
            pass

    def send(self, message) -> None:
        self.ws.send(msgspec.msgpack.encode(message.as_serializable_dict()))

    def drag(self, position) -> None:
        owner = self.served.server.scene._owner_id
        self.send(
            _messages.TransformControlsUpdateMessage(
                name="/gizmo", wxyz=(1.0, 0.0, 0.0, 0.0), position=tuple(position), owner=owner
            )
        )

    def click(self, label: str) -> None:
        if label == "Take control":  # each viewer has its own button
            uuid = self.served.clients.take_buttons[self.id]._impl.uuid
        else:
            uuid = self.served.buttons[label]._impl.uuid
        self.send(_messages.GuiUpdateMessage(uuid=uuid, updates={"value": True}))

    def close(self) -> None:
        self.ws.close()


def _refused(served: TeachServer, **kw) -> int:
    """HTTP status of a websocket upgrade that the server refuses (fails if it accepts)."""
    with pytest.raises(websockets.exceptions.InvalidStatus) as info:
        Tab(served, **kw)
    return info.value.response.status_code


def _http(port: int, path: str = "/", headers: dict | None = None) -> http.client.HTTPResponse:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    conn.request("GET", path, headers=headers or {})
    response = conn.getresponse()
    response.read()
    conn.close()
    return response


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    session = TeachSession(robot="wam4", scene=ROOT / "configs" / "teach" / "boxes.yaml")
    server = TeachServer(session, port=0, export_dir=tmp_path_factory.mktemp("teach") / "export")
    yield server
    server.close()
    session.close()


@pytest.fixture
def fresh(served):
    """The module's server with its session cleared and nobody connected."""
    served.server._websock_server.disconnect_all_clients()
    assert _wait(lambda: not served.server.get_clients())
    assert _wait(lambda: served.clients.control.owner is None and not served.clients.control.viewers)
    served._run(served._clear)
    served.guard.refused.clear()
    return served


# ---------------------------------------------------------------- origin, host, binding
def test_loopback_by_default_and_no_token_there(fresh):
    assert fresh.server.get_host() == "127.0.0.1" and fresh.token is None
    assert fresh.url == f"http://127.0.0.1:{fresh.port}"
    config = (ROOT / "configs" / "teach" / "teach.yaml").read_text()
    assert "\nhost: 127.0.0.1 " in config and "\ntoken: auto " in config
    assert TeachServer.__init__.__defaults__[0] == "127.0.0.1"


def test_websocket_from_a_foreign_origin_is_refused(fresh):
    n = fresh.session.counters["drag_updates"]
    for origin in (EVIL, f"{EVIL}:{fresh.port}", "null", f"http://127.0.0.1:{fresh.port + 1}"):
        assert _refused(fresh, origin=origin) == 403
    assert len(fresh.guard.refused) == 4 and "evil.example.com" in fresh.guard.refused[0]
    assert not fresh.server.get_clients() and fresh.clients.control.owner is None
    assert fresh.session.counters["drag_updates"] == n


def test_websocket_from_the_own_page_is_accepted(fresh):
    for origin in (f"http://127.0.0.1:{fresh.port}", f"http://localhost:{fresh.port}", None):
        tab = Tab(fresh, origin=origin)
        assert tab.ws.subprotocol == SUBPROTOCOL
        tab.close()
        assert _wait(lambda t=tab: t.id not in fresh.server.get_clients())
    assert not fresh.guard.refused


def test_dns_rebinding_host_is_refused(fresh):
    """evil.example.com resolved to 127.0.0.1: its Host header names it, and it is refused."""
    rebound = f"evil.example.com:{fresh.port}"
    assert _http(fresh.port, headers={"Host": rebound}).status == 403
    upgrade = {
        "Host": rebound,
        "Origin": f"http://{rebound}",
        "Upgrade": "websocket",
        "Connection": "Upgrade",
        "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==",
        "Sec-WebSocket-Version": "13",
        "Sec-WebSocket-Protocol": SUBPROTOCOL,
    }
    assert _http(fresh.port, headers=upgrade).status == 403
    assert _http(fresh.port).status == 200  # the own page is still served


def test_token_required_when_exposed(tmp_path):
    assert token_required("0.0.0.0") and token_required("192.168.1.20") and token_required("::")
    assert not any(token_required(h) for h in ("127.0.0.1", "localhost", "::1", "127.0.0.2"))
    assert token_required("127.0.0.1", True)
    with pytest.raises(ValueError, match="not loopback"):
        token_required("0.0.0.0", False)


def test_token_in_force_refuses_requests_without_it(tmp_path):
    """Bound to 127.0.0.1 but configured as exposed (token=True): what 0.0.0.0 would enforce."""
    session = TeachSession(robot="wam4", scene=None)
    server = TeachServer(session, port=0, export_dir=tmp_path, token=True)
    try:
        token, port = server.token, server.port
        assert token and len(token) >= 40 and server.url == f"http://127.0.0.1:{port}/?token={token}"
        assert _http(port).status == 403
        assert _http(port, f"/?token={token[:-1]}x").status == 403
        page = _http(port, f"/?token={token}")
        assert page.status == 200
        cookie = page.getheader("Set-Cookie")
        assert cookie.startswith(f"lfd_teach_token_{port}={token};") and "HttpOnly" in cookie
        assert "SameSite=Strict" in cookie
        # the websocket: the page opens it without the query string, so the cookie carries the token
        assert _refused(server) == 403
        assert _refused(server, origin=None) == 403  # non-browser clients need it too
        assert _refused(server, headers={"Cookie": f"lfd_teach_token_{port}=wrong"}) == 403
        assert _refused(server, origin=EVIL, path=f"/?token={token}") == 403  # token + foreign page
        Tab(server, headers={"Cookie": f"lfd_teach_token_{port}={token}"}).close()
        Tab(server, origin=None, path=f"/?token={token}").close()
    finally:
        server.close()
        session.close()


def test_server_refuses_to_start_unchecked(monkeypatch):
    class Unhooked:  # a viser that would not start through the hooked call
        def __init__(self, **kw):
            self.stopped = False

        def stop(self):
            self.stopped = True

    monkeypatch.setattr("lfd.teach.access.viser.ViserServer", Unhooked)
    with pytest.raises(RuntimeError, match="refusing to serve unchecked"):
        start_guarded_viser("127.0.0.1", 0, AccessGuard("127.0.0.1", None))


# ---------------------------------------------------------------- the drag worker
def test_nan_drag_keeps_the_worker_and_later_drags_move_the_arm(fresh):
    tab = Tab(fresh)
    try:
        q0 = fresh.session.q.copy()
        p0 = fresh.session.tool_position
        tab.drag((math.nan, math.nan, math.nan))
        assert _wait(lambda: fresh.drag_errors == 1)
        assert fresh._worker.is_alive() and "NaN" in fresh.status.content
        np.testing.assert_array_equal(fresh.session.q, q0)
        for n, bad in enumerate((np.array([np.inf, 0.0, 0.0]), np.zeros(2)), start=2):
            with fresh._cond:  # straight into the worker's slot (latest wins: one at a time)
                fresh._pending = (bad, None)
                fresh._cond.notify()
            assert _wait(lambda n=n: fresh.drag_errors == n) and fresh._worker.is_alive()
        assert "shape" in fresh.status.content
        tab.drag(p0 + [0.0, 0.0, 0.03])
        assert _wait(lambda: np.linalg.norm(fresh.session.tool_position - p0 - [0, 0, 0.03]) < 2e-3)
        assert fresh.session.recording_state == "recording" and "NaN" not in fresh.status.content
    finally:
        tab.close()


# ---------------------------------------------------------------- export and handler errors
def _digest(folder: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir())}


def test_export_twice_writes_two_folders_and_keeps_the_first(fresh):
    p0 = fresh.session.tool_position
    for k in range(1, 6):
        fresh.handle_drag(p0 + [0.0, 0.0, 0.01 * k])
    fresh._run(fresh._export)
    first = fresh.last_export["csv"].parent
    before = _digest(first)
    assert {"demo.csv", "demo.json", "demo.dmp.json", "episode.npz"} <= set(before)
    fresh.handle_drag(p0 + [0.0, 0.0, 0.06])
    fresh._run(fresh._export)
    second = fresh.last_export["csv"].parent
    assert second != first and second.parent == first.parent == fresh.export_dir
    assert _digest(first) == before
    assert len(second.joinpath("demo.csv").read_text().splitlines()) == len(fresh.session.recorded) + 1
    assert not [p for p in fresh.export_dir.iterdir() if p.name.startswith(".")]  # no partial left


def test_oserror_in_a_handler_shows_in_the_status_line(fresh, tmp_path, monkeypatch):
    p0 = fresh.session.tool_position
    for k in range(1, 5):
        fresh.handle_drag(p0 + [0.0, 0.0, 0.01 * k])
    blocker = tmp_path / "export"
    blocker.write_text("not a folder")
    monkeypatch.setattr(fresh, "export_dir", blocker)
    fresh._run(fresh._export)
    status = fresh.status.content.splitlines()[-1]
    assert "NotADirectoryError" in status and "is a file" in status and blocker.read_text() == "not a folder"

    def broken(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(fresh.session, "playback", broken)
    fresh._run(fresh._playback)
    assert "OSError: \\[Errno 28\\] No space left on device" in fresh.status.content.splitlines()[-1]
    fresh.handle_drag(p0 + [0.0, 0.0, 0.05])  # the server still works
    assert len(fresh.session.recorded) == 6


# ---------------------------------------------------------------- two tabs
def test_second_tab_is_read_only_and_cannot_clear_the_first(fresh):
    first = Tab(fresh)
    second = None
    try:
        p0 = fresh.session.tool_position
        for k in range(1, 5):
            first.drag(p0 + [0.0, 0.0, 0.01 * k])
            assert _wait(lambda k=k: len(fresh.session.recorded) == k + 1)
        assert fresh.clients.control.owner == first.id
        second = Tab(fresh)
        assert _wait(lambda: "in use" in fresh.clients.notices.get(second.id, ""))
        recorded = fresh.session.recorded.q.copy()
        second.click("Clear")
        second.drag(p0 + [0.0, 0.1, 0.0])
        assert _wait(lambda: fresh.clients.notices.get(second.id) == READ_ONLY)
        time.sleep(0.3)  # let any wrongly accepted action land
        assert fresh.session.recording_state == "recording"
        np.testing.assert_array_equal(fresh.session.recorded.q, recorded)
        # an explicit take-over: the first tab is told, its recording ends untouched
        second.click("Take control")
        assert _wait(lambda: fresh.clients.control.owner == second.id)
        assert _wait(lambda: "took control" in fresh.clients.notices.get(first.id, ""))
        assert fresh.session.recording_state == "done"
        first.click("Clear")
        second.drag(fresh.session.tool_position + [0.0, 0.0, 0.01])
        assert _wait(lambda: fresh.clients.notices.get(first.id) == READ_ONLY)
        assert _wait(lambda: fresh.session.counters["drag_updates"] >= 5)
        np.testing.assert_array_equal(fresh.session.recorded.q, recorded)  # never merged
    finally:
        first.close()
        if second is not None:
            second.close()


# ---------------------------------------------------------------- no way out, malformed messages, busy port
def test_share_request_is_refused_and_nothing_connects_out(fresh, monkeypatch):
    """viser's Share button asks the server to open a public tunnel (share.viser.studio): the request is
    dropped before viser sees it; no tunnel is built and no socket connects anywhere."""
    import socket

    import viser._viser

    tunnels, connects = [], []

    class Tunnel:  # stands in for viser's tunnel: records the attempt, never connects
        def __init__(self, *args, **kwargs):
            tunnels.append(args)

    real_connect = socket.socket.connect

    def connect_spy(sock, address):
        connects.append(address)
        return real_connect(sock, address)

    monkeypatch.setattr(viser._viser, "ViserTunnel", Tunnel)
    tab = Tab(fresh)
    monkeypatch.setattr(socket.socket, "connect", connect_spy)
    try:
        tab.send(_messages.ShareUrlRequest())
        tab.send(_messages.ShareUrlDisconnect())
        assert _wait(lambda: len(fresh.guard.refused) == 2)
        assert "ShareUrlRequest" in fresh.guard.refused[0]
        time.sleep(0.5)  # let a wrongly dispatched request reach the thread pool
        assert tunnels == [] and connects == []
        with pytest.raises(RuntimeError, match="never opens a share tunnel"):
            fresh.server.request_share_url()
        assert tunnels == []
        # the tab still works
        p0 = fresh.session.tool_position
        tab.drag(p0 + [0.0, 0.0, 0.02])
        assert _wait(lambda: fresh.session.samples >= 2)
    finally:
        tab.close()


def test_malformed_messages_are_dropped_and_the_connection_stays_open(fresh, capfd):
    tab = Tab(fresh)
    try:
        for raw in (
            b"\x00garbage",
            msgspec.msgpack.encode({"type": "NoSuchMessage"}),
            msgspec.msgpack.encode([1, 2]),
        ):
            tab.ws.send(raw)
        tab.ws.send("a text frame")
        tab.send(
            _messages.TransformControlsUpdateMessage(
                name="/gizmo", wxyz=(1.0, 0.0, 0.0, 0.0), position=(0.4, 0.0, 0.5), owner=None
            )
        )  # a viser message with a bad field (owner None)
        assert _wait(lambda: len(fresh.guard.refused) >= 4)
        assert all(r.startswith("refused: a ") for r in list(fresh.guard.refused)[:4])
        p0 = fresh.session.tool_position
        tab.drag(p0 + [0.0, 0.0, 0.02])  # the same connection still drives the arm
        assert _wait(lambda: fresh.session.samples >= 2)
        assert tab.ws.close_code is None and tab.id in fresh.server.get_clients()
        assert "Traceback" not in capfd.readouterr().err
    finally:
        tab.close()


def test_busy_port_is_refused_not_moved(tmp_path):
    import socket

    session = TeachSession(robot="wam4", scene=None)
    with socket.socket() as blocker:
        blocker.bind(("0.0.0.0", 0))
        blocker.listen()
        port = blocker.getsockname()[1]
        try:
            with pytest.raises(ValueError, match=f"port {port} on 0.0.0.0 is in use"):
                TeachServer(session, host="0.0.0.0", port=port, export_dir=tmp_path)
        finally:
            session.close()
