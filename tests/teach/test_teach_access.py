"""The teach server's request rules and its one-controller rule, without a server."""

from __future__ import annotations

import importlib.util

import pytest
from hydra import compose, initialize_config_dir
from teach_helpers import ROOT
from websockets.datastructures import Headers

from lfd.teach.access import AccessGuard, is_loopback
from lfd.teach.control import Control, error_line


def _upgrade(host: str, origin: str | None = None, **extra) -> Headers:
    h = Headers(Host=host, Upgrade="websocket", **extra)
    if origin is not None:
        h["Origin"] = origin
    return h


@pytest.mark.parametrize(
    ("host", "origin", "ok"),
    [
        ("127.0.0.1:8080", "http://127.0.0.1:8080", True),
        ("127.0.0.1:8080", "http://localhost:8080", True),  # loopback spellings are one name
        ("[::1]:8080", "http://127.0.0.1:8080", True),
        ("localhost:9000", "http://localhost:9000", True),  # an SSH-forwarded port
        ("127.0.0.1:8080", None, True),  # a non-browser client
        ("127.0.0.1:8080", "http://127.0.0.1:8081", False),
        ("127.0.0.1:8080", "http://127.0.0.1", False),
        ("127.0.0.1:8080", "http://evil.example.com:8080", False),
        ("127.0.0.1:8080", "null", False),
        ("127.0.0.1:8080", "file://", False),
        ("evil.example.com:8080", "http://evil.example.com:8080", False),  # DNS rebinding
    ],
)
def test_origin_and_host_rules_on_loopback(host, origin, ok):
    guard = AccessGuard("127.0.0.1", None, 8080)
    assert (guard.refusal("/", _upgrade(host, origin)) is None) == ok


def test_any_interface_accepts_any_name_but_only_its_own_page_and_token():
    guard = AccessGuard("0.0.0.0", "s3cret", 8080)
    assert guard.refusal("/?token=s3cret", _upgrade("lab-pc.local:8080", "http://lab-pc.local:8080")) is None
    assert guard.refusal("/", _upgrade("lab-pc.local:8080", "http://lab-pc.local:8080")) is not None
    assert (
        guard.refusal("/?token=s3cret", _upgrade("lab-pc.local:8080", "http://evil.example.com")) is not None
    )
    assert guard.refusal("/", _upgrade("lab-pc.local:8080", None, Authorization="token s3cret")) is None
    assert guard.refusal("/", Headers(Host="10.0.0.5:8080", Cookie="lfd_teach_token_8080=s3cret")) is None
    two_hosts = Headers([("Host", "127.0.0.1:8080"), ("Host", "evil.example.com")])
    assert "Host" in guard.refusal("/?token=s3cret", two_hosts)


def test_is_loopback():
    assert all(map(is_loopback, ["127.0.0.1", "localhost", "::1", "[::1]", "127.1.2.3"]))
    assert not any(map(is_loopback, ["0.0.0.0", "::", "192.168.0.2", "example.com", ""]))


def test_control_first_tab_drives_then_explicit_take_over_and_promotion():
    c = Control()
    assert c.connect(1) and not c.connect(2) and not c.connect(3)
    assert c.allows(1) and not c.allows(2) and c.allows(None)
    assert c.take(2) == 1 and c.owner == 2 and c.viewers == [3, 1]
    assert c.take(2) is None
    assert c.disconnect(3) is None and c.disconnect(2) == 1 and c.owner == 1
    assert c.disconnect(1) is None and c.owner is None and c.connect(4)


def test_error_line_is_one_escaped_line():
    assert error_line(ValueError("bad\nvalue")) == "**bad value**"
    line = error_line(OSError(2, "No such file", "/tmp/a_b*c"))
    assert line.startswith("**FileNotFoundError: ") and "a\\_b\\*c" in line and "\n" not in line
    assert len(error_line(RuntimeError("x" * 1000))) < 320


def test_entry_point_token_option():
    spec = importlib.util.spec_from_file_location("teach_script", ROOT / "scripts" / "teach.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    with initialize_config_dir(config_dir=str(ROOT / "configs" / "teach"), version_base="1.3"):
        policies = {
            value: script.settings_of(compose("teach", overrides=[f"token={value}"])).token_policy
            for value in ("auto", "null", "true", "false")
        }
        assert policies == {"auto": None, "null": None, "true": True, "false": False}
        with pytest.raises(ValueError, match="token must be auto, true or false, got 's3cret'"):
            script.settings_of(compose("teach", overrides=["token=s3cret"]))
