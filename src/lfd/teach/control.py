"""Which browser tab drives the teach session.

One session has one arm and one recording, so one client (a viser connection, a browser
tab) controls it at a time: the first to connect. Every later client is a read-only
viewer (it sees the scene; its drags and buttons are ignored with a message) until it
takes over explicitly (the "Take control" button) or the controller leaves, when the
longest-connected viewer is promoted. Whenever control changes hands, a recording in
progress is stopped, so one recording never holds two clients' drags. The "Take control" button
is a per-tab button that only viewers see (:attr:`ClientControl.take_buttons`).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable

from lfd.checks import one_line

__all__ = ["READ_ONLY", "ClientControl", "Control", "error_line", "escape_markdown"]

#: What a viewer is told when its action is ignored.
READ_ONLY = "read-only: another tab controls this teach session (press Take control to take it over)"


class Control:
    """The controlling client id and the waiting viewers, in connection order."""

    def __init__(self) -> None:
        self.owner: int | None = None
        self.viewers: list[int] = []

    def connect(self, client_id: int) -> bool:
        """Register a client; True when it gets control (nobody had it)."""
        if self.owner is None:
            self.owner = client_id
            return True
        if client_id != self.owner and client_id not in self.viewers:
            self.viewers.append(client_id)
        return False

    def disconnect(self, client_id: int) -> int | None:
        """Forget a client; when it was the controller, the promoted viewer (or None)."""
        if client_id in self.viewers:
            self.viewers.remove(client_id)
            return None
        if client_id != self.owner:
            return None
        self.owner = self.viewers.pop(0) if self.viewers else None
        return self.owner

    def take(self, client_id: int) -> int | None:
        """Give control to ``client_id``; the previous controller (now a viewer), or None."""
        previous = self.owner
        if previous == client_id:
            return None
        if client_id in self.viewers:
            self.viewers.remove(client_id)
        if previous is not None:
            self.viewers.append(previous)
        self.owner = client_id
        return previous

    def allows(self, client_id: int | None) -> bool:
        """Whether an action of ``client_id`` may change the session (None: the server itself)."""
        return client_id is None or client_id == self.owner


_MARKDOWN = str.maketrans({c: "\\" + c for c in "\\`*_[]<>#|"})


def error_line(e: BaseException) -> str:
    """``e`` as one bold status line: its message (a ``ValueError``'s alone, other types
    prefixed with their name), newlines folded, at most 300 characters, Markdown escaped."""
    text = one_line(str(e)) or "(no message)"
    if not isinstance(e, ValueError):
        text = one_line(f"{type(e).__name__}: {text}")
    return f"**{escape_markdown(text)}**"


def escape_markdown(text: str) -> str:
    """``text`` with Markdown's special characters backslash-escaped (shown literally)."""
    return text.translate(_MARKDOWN)


class ClientControl:
    """The client side of :class:`~lfd.teach.server.TeachServer`: registers tabs with a
    :class:`Control` (``control``), tells each one its role, and lets only the controller act.

    Args:
        viser_server: the running viser server (its clients, their notifications).
        lock: the server's lock; every change of the session holds it.
        on_handover: called under ``lock`` when control changes hands (the server ends a recording in
            progress there).
        on_refresh: called under ``lock`` after an explicit take-over (the server redraws).

    Attributes:
        control: the :class:`Control`. notices: the last message shown to each client id.
        take_buttons: client id -> its "Take control" button (viewers only; the controller has none).
    """

    def __init__(
        self, viser_server, lock, on_handover: Callable[[], None], on_refresh: Callable[[], None]
    ) -> None:
        self.server, self.lock = viser_server, lock
        self.on_handover, self.on_refresh = on_handover, on_refresh
        self.control = Control()
        self.notices: dict[int, str] = {}
        self._noticed_at: dict[int, float] = {}
        self.take_buttons: dict[int, object] = {}

    def _show_take(self, client_id: int | None, show: bool) -> None:
        """Give ``client_id``'s tab its own "Take control" button (``show``) or remove it."""
        if client_id is None:
            return
        button = self.take_buttons.pop(client_id, None)
        if button is not None:
            with contextlib.suppress(Exception):  # a client that just left
                button.remove()
        client = self.client(client_id)
        if show and client is not None:
            with contextlib.suppress(Exception):
                button = client.gui.add_button("Take control", color="orange", order=-100.0)
                button.on_click(self.on_take)
                self.take_buttons[client_id] = button

    def notify(self, client, text: str, persistent: bool = False) -> None:
        """Tell one client ``text`` (a notification in its page, the same one at most every
        5 s: a read-only tab's drag sends dozens of updates; kept in ``notices``)."""
        if client is None:
            return
        cid, now = client.client_id, time.monotonic()
        if self.notices.get(cid) == text and now - self._noticed_at.get(cid, -1e9) < 5.0:
            return
        self.notices[cid], self._noticed_at[cid] = text, now
        with contextlib.suppress(Exception):  # a client that just left
            client.add_notification(
                "lfd teach", text, auto_close_seconds=None if persistent else 6.0, color="red"
            )

    def client(self, client_id: int | None):
        """The viser client handle of ``client_id`` (None when gone or None)."""
        return None if client_id is None else self.server.get_clients().get(client_id)

    def may_act(self, event) -> bool:
        """Whether ``event``'s client controls the session (None: the server itself); tells it otherwise."""
        client_id = None if event is None else getattr(event, "client_id", None)
        with self.lock:
            if self.control.owner is None and client_id in self.server.get_clients():
                self.control.connect(client_id)  # its connect callback has not run yet
            if self.control.allows(client_id):
                return True
        self.notify(getattr(event, "client", None), READ_ONLY)
        return False

    def on_connect(self, client) -> None:
        """A tab connected: it controls the session if nobody does, else it is told it is read-only."""
        with self.lock:
            if client.client_id not in self.server.get_clients():
                return  # it left before this callback ran (they run on a thread pool)
            if not self.control.connect(client.client_id) and client.client_id != self.control.owner:
                self._show_take(client.client_id, True)
                self.notify(client, "this teach session is in use by another tab: " + READ_ONLY, True)

    def on_disconnect(self, client) -> None:
        """A tab left: when it controlled the session, the longest-connected viewer takes over."""
        with self.lock:
            promoted = self.control.disconnect(client.client_id)
            self.take_buttons.pop(client.client_id, None)
            self.notices.pop(client.client_id, None)
            self._noticed_at.pop(client.client_id, None)
            if promoted is not None:
                self._show_take(promoted, False)
                self.on_handover()
                self.notify(self.client(promoted), "the controlling tab left: you now control this session")

    def on_take(self, event) -> None:
        """The "Take control" button: ``event``'s client takes over; the previous controller is told."""
        client_id = getattr(event, "client_id", None)
        if client_id is None:
            return
        with self.lock:
            previous = self.control.take(client_id)
            if previous is None:
                self.notify(event.client, "you control this session")
                return
            self._show_take(client_id, False)
            self._show_take(previous, True)
            self.on_handover()
            self.notify(event.client, "you took control of this session")
            self.notify(self.client(previous), "another tab took control: this view is now read-only")
            self.on_refresh()
