"""Teach by dragging: serve the browser interface for one robot and scene.

Usage::

    python scripts/teach.py robot=wam4 scene=configs/teach/boxes.yaml
    python scripts/teach.py robot=sawyer scene=null port=0     # empty scene, free port

Prints the URL (``http://127.0.0.1:8080`` by default; with ``?token=<secret>`` whenever
``host`` is not loopback, or with ``token=true``); open it in any browser, drag the
gizmo on the tool (3-D mode) or use the 2-D panel, then Export / Send. Configuration:
``configs/teach/teach.yaml``, turned into :class:`lfd.teach.TeachSettings` (every value checked
once; a bad one is one line on stderr and exit status 2); the scene format is described in
``docs/teach.md``.
"""

from __future__ import annotations

import sys
import time

import hydra
from hydra.utils import to_absolute_path
from omegaconf import DictConfig, OmegaConf

from lfd.teach import TeachSession, TeachSettings
from lfd.teach.server import TeachServer


def settings_of(cfg: DictConfig) -> TeachSettings:
    """The composed config as :class:`TeachSettings`, with ``scene`` and ``export_dir`` made absolute
    (relative to where the command was started). Raises ``ValueError`` on a bad value."""
    values = OmegaConf.to_container(cfg, resolve=True)
    values.pop("hydra", None)
    if values.get("scene") not in (None, "", "null"):
        values["scene"] = to_absolute_path(str(values["scene"]))
    if isinstance(values.get("export_dir"), str) and values["export_dir"]:
        values["export_dir"] = to_absolute_path(values["export_dir"])
    return TeachSettings.from_mapping(values)


def build(settings: TeachSettings) -> TeachServer:
    """Session + server of ``settings`` (raises ValueError/FileNotFoundError on bad input)."""
    return TeachServer.from_settings(TeachSession.from_settings(settings), settings)


@hydra.main(version_base="1.3", config_path="../configs/teach", config_name="teach")
def main(cfg: DictConfig) -> None:
    try:
        settings = settings_of(cfg)
        server = build(settings)
    except (ValueError, FileNotFoundError, RuntimeError) as e:
        print(f"teach: {e}", file=sys.stderr)
        raise SystemExit(2) from None
    access = (
        "the token in this URL is required: share it only with whoever may drive the arm"
        if server.token
        else "this machine only, no token"
    )
    print(f"teach: {settings.robot} ready at {server.url}  ({access}; Ctrl-C to stop)", flush=True)
    try:
        end = None if settings.duration_s is None else time.monotonic() + settings.duration_s
        while end is None or time.monotonic() < end:
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        server.session.close()


if __name__ == "__main__":
    main()
