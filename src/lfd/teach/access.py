"""Who may talk to the teach server: the Origin check, the Host check and the launch token.

viser serves its page and its websocket on one port and checks neither where a websocket
comes from nor who asks. :class:`AccessGuard` decides for every HTTP request and websocket
upgrade, before viser sees it; :func:`start_guarded_viser` starts a ``viser.ViserServer``
with the guard in front of viser's own request hook (the ``process_request`` of
``websockets.asyncio.server.serve``) and refuses to serve when it cannot install it.

Rules (a refusal is an HTTP 403 whose body is the one-line reason):

* **Host**: the ``Host`` header must name this server (a loopback name, or the configured
  host); when bound to every interface (``0.0.0.0``, ``::``) any name is accepted and the
  token does the work. This stops DNS rebinding (a foreign name resolved to 127.0.0.1).
* **Origin** (websocket upgrades only): when present it must be the page's own origin,
  ``http(s)://<Host header>``, the loopback spellings ``127.0.0.1`` / ``localhost`` /
  ``[::1]`` being one name for the same port. Browsers always send ``Origin`` on a
  websocket upgrade, so a page from another site (``http://evil.example.com``) is refused.
  A missing ``Origin`` is accepted: only non-browser clients omit it, and they are not the
  cross-site threat (any local process can open a loopback port anyway); when a token is
  in force they must present it like everyone else.
* **Token** (:func:`token_required`: whenever the host is not loopback, or on request):
  every request must carry the per-launch secret, as ``?token=`` in the URL, as the cookie
  the page receives with it (``HttpOnly; SameSite=Strict``: the viser page opens its
  websocket without the query string), or as ``Authorization: token <secret>``.

Messages (every websocket message, before viser decodes it; :meth:`AccessGuard.message_refusal`):

* **No way out**: viser's share request (``ShareUrlRequest``, its Share button) would make the server
  open a public tunnel to ``share.viser.studio``; it is dropped and counted in ``refused``, viser's
  share handlers are removed and :meth:`viser.ViserServer.request_share_url` refuses. lfd never opens a
  connection out of the machine.
* A message that is not one of viser's (not msgpack, an unknown type, wrong fields, a text frame) is
  dropped with a one-line reason in ``refused``; the connection stays open (viser alone would close
  it with code 1011 and print a traceback).
* **Port**: an explicit port that is busy is refused (``ValueError``) instead of viser's silent move
  to the next free port, whose address nobody printed.
"""

from __future__ import annotations

import contextlib
import hmac
import http
import io
import ipaddress
import secrets
import sys
import threading
from collections import deque
from http.cookies import CookieError, SimpleCookie
from urllib.parse import parse_qs, urlsplit

import viser
from viser import _messages

from lfd.checks import one_line

__all__ = ["AccessGuard", "is_loopback", "new_token", "start_guarded_viser", "token_required"]

#: viser messages refused whoever sends them: the share tunnel's (a connection out of the machine).
REFUSED_MESSAGES = ("ShareUrlRequest", "ShareUrlDisconnect")
LOOPBACK_NAMES = frozenset({"127.0.0.1", "localhost", "::1"})
_WILDCARDS = frozenset({"", "0.0.0.0", "::"})
_START_LOCK = threading.Lock()


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or an address, IPv6 with or without brackets) is this machine only."""
    name = host.strip().strip("[]").lower()
    if name == "localhost":
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def token_required(host: str, token: bool | None = None) -> bool:
    """Whether a server on ``host`` needs the launch token: ``token=None`` (auto) means exactly
    when ``host`` is not loopback; ``True`` always.

    Raises:
        ValueError: ``token=False`` with a host that is not loopback.
    """
    if token is False and not is_loopback(host):
        raise ValueError(
            f"host {host!r} is not loopback: the teach server needs its token there (token=false)"
        )
    return bool(token) or not is_loopback(host)


def new_token() -> str:
    """A fresh per-launch secret (``secrets.token_urlsafe``, 32 bytes)."""
    return secrets.token_urlsafe(32)


def _netloc(value: str) -> tuple[str, int | None] | None:
    """``(hostname, port)`` of ``host[:port]`` (lower case, IPv6 without brackets), None if malformed."""
    try:
        parts = urlsplit(f"//{value}")
        return (parts.hostname or "", parts.port)
    except ValueError:
        return None


class AccessGuard:
    """The request checks of the module docstring for a server bound to ``host``.

    Args:
        host: the interface the server binds.
        token: the secret every request must carry, or None for no token.
        port: the bound port (names the cookie; set again once the server runs).
    """

    def __init__(self, host: str, token: str | None, port: int = 0) -> None:
        self.host, self.token, self.port = host, token, int(port)
        name = host.strip().strip("[]").lower()
        self._any_name = name in _WILDCARDS
        self._names = LOOPBACK_NAMES | ({name} if not self._any_name else set())
        self.refused: deque[str] = deque(maxlen=100)  # the latest refusal reasons
        self.installed = False

    @property
    def cookie_name(self) -> str:
        return f"lfd_teach_token_{self.port}"

    def refusal(self, path: str, headers) -> str | None:
        """The one-line reason to refuse a request for ``path`` with ``headers`` (a
        ``websockets`` ``Headers``), or None to let it through."""
        hosts = headers.get_all("Host")
        where = _netloc(hosts[0]) if len(hosts) == 1 else None
        if where is None:
            return "refused: one well-formed Host header expected"
        hostname, port = where
        if not self._any_name and hostname not in self._names:
            return f"refused: Host {hosts[0]!r} is not this server"
        if headers.get("Upgrade", "").lower() == "websocket":
            origins = headers.get_all("Origin")
            if len(origins) > 1 or (origins and not self._same_origin(origins[0], hostname, port)):
                return f"refused: websocket from Origin {origins[0]!r}, not this server's page ({hosts[0]})"
        if self.token is not None and not self._has_token(path, headers):
            return "refused: this server needs the token of the URL it printed"
        return None

    @staticmethod
    def _same_origin(origin: str, hostname: str, port: int | None) -> bool:
        try:
            parts = urlsplit(origin.strip())
            o_port = parts.port
        except ValueError:
            return False
        if parts.scheme not in ("http", "https") or parts.path not in ("", "/") or not parts.hostname:
            return False
        o_port = o_port if o_port is not None else (443 if parts.scheme == "https" else 80)
        if o_port != (port if port is not None else 80):
            return False
        same = parts.hostname == hostname
        return same or (parts.hostname in LOOPBACK_NAMES and hostname in LOOPBACK_NAMES)

    def _has_token(self, path: str, headers) -> bool:
        offered = parse_qs(urlsplit(path).query).get("token", [])
        auth = headers.get("Authorization", "")
        if auth.lower().startswith("token "):
            offered.append(auth[6:].strip())
        for raw in headers.get_all("Cookie"):
            try:
                morsel = SimpleCookie(raw).get(self.cookie_name)
            except CookieError:
                continue
            if morsel is not None:
                offered.append(morsel.value)
        want = self.token.encode()
        return any(hmac.compare_digest(x.encode(), want) for x in offered)

    def message_refusal(self, raw) -> str | None:
        """The one-line reason to drop the websocket message ``raw`` (bytes as received), or None to
        hand it to viser: a text frame, bytes viser cannot decode, or a :data:`REFUSED_MESSAGES` type."""
        if not isinstance(raw, (bytes, bytearray)):
            return "refused: a text websocket message (viser speaks binary msgpack)"
        try:
            message = _messages.Message.deserialize(bytes(raw))
        except Exception as e:  # any decoding failure is the sender's, not the server's
            return f"refused: a malformed websocket message ({one_line(e, 160)})"
        if type(message).__name__ in REFUSED_MESSAGES:
            return f"refused: {type(message).__name__} (a public share tunnel out of this machine)"
        return None

    def wrap_handler(self, handler):
        """viser's websocket connection handler, receiving through :meth:`message_refusal`: refused
        messages are dropped (reason in ``refused``) and the connection stays open."""

        async def guarded(connection):
            receive = connection.recv

            async def recv(*args, **kwargs):
                while True:
                    raw = await receive(*args, **kwargs)
                    reason = self.message_refusal(raw)
                    if reason is None:
                        return raw
                    self.refused.append(reason)

            connection.recv = recv
            return await handler(connection)

        return guarded

    def wrap(self, inner):
        """A ``process_request`` hook: refuse (403) what :meth:`refusal` names, otherwise ask
        ``inner`` (viser's page server) and hand the page its token cookie."""

        async def process_request(connection, request):
            reason = self.refusal(request.path, request.headers)
            if reason is not None:
                self.refused.append(reason)
                return connection.respond(http.HTTPStatus.FORBIDDEN, reason + "\n")
            response = None if inner is None else inner(connection, request)
            if hasattr(response, "__await__"):
                response = await response
            if response is not None and self.token is not None:
                response.headers["Set-Cookie"] = (
                    f"{self.cookie_name}={self.token}; Path=/; HttpOnly; SameSite=Strict"
                )
            return response

        self.installed = True
        return process_request


def start_guarded_viser(host: str, port: int, guard: AccessGuard, verbose: bool = False) -> viser.ViserServer:
    """A started ``viser.ViserServer`` on ``host:port`` whose every request passes ``guard``.

    viser 1.1.1 builds its server with ``websockets.asyncio.server.serve(handler, host, port,
    process_request=<its page server>, ...)`` on a background thread while its constructor
    waits; for that call only (matched by ``host``, under a lock) the hook is wrapped by
    :meth:`AccessGuard.wrap`. The port is set on ``guard`` once bound.

    Raises:
        RuntimeError: viser did not start through that call (another viser version): the
            server is stopped rather than left running unchecked.
    """
    import websockets.asyncio.server as ws_server

    with _START_LOCK:
        original = ws_server.serve

        def serve(handler, *args, **kwargs):
            if args[:1] == (host,) and "process_request" in kwargs:
                kwargs["process_request"] = guard.wrap(kwargs["process_request"])
                handler = guard.wrap_handler(handler)
            return original(handler, *args, **kwargs)

        ws_server.serve = serve
        try:
            # viser prints a banner (``localhost:<port>``, without the token) unless asked to talk
            with contextlib.redirect_stdout(sys.stdout if verbose else io.StringIO()):
                server = viser.ViserServer(host=host, port=port, verbose=verbose)
        finally:
            ws_server.serve = original
    if not guard.installed:
        server.stop()
        raise RuntimeError(
            f"viser {viser.__version__} started its web server without the request hook lfd.teach "
            "checks Origin and token with; refusing to serve unchecked"
        )
    if port and server.get_port() != port:
        server.stop()
        raise ValueError(f"port {port} on {host} is in use: choose another port (port=0 picks a free one)")
    _no_share(server)
    guard.port = server.get_port()
    return server


def _no_share(server: viser.ViserServer) -> None:
    """Remove viser's share-tunnel handlers and make ``request_share_url`` refuse (the messages are
    also dropped before viser sees them: :meth:`AccessGuard.message_refusal`)."""
    ws = server._websock_server
    for name in REFUSED_MESSAGES:
        with contextlib.suppress(AssertionError, KeyError):
            ws.unregister_handler(getattr(_messages, name))

    def refuse(*args, **kwargs):
        raise RuntimeError("lfd.teach never opens a share tunnel (a connection out of this machine)")

    server.request_share_url = refuse
