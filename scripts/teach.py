"""Teach by dragging: serve the browser interface for one robot and scene.

Usage::

    python scripts/teach.py robot=wam4 scene=configs/teach/boxes.yaml
    python scripts/teach.py robot=sawyer scene=null port=0     # empty scene, free port

Prints the URL (``http://127.0.0.1:8080`` by default; with ``?token=<secret>`` whenever
``host`` is not loopback, or with ``token=true``); open it in any browser, drag the
gizmo on the tool (3-D mode) or use the 2-D panel, then Export / Send. Configuration:
``configs/teach/teach.yaml``; the scene format is described in ``docs/teach.md``.
"""

from __future__ import annotations

import sys
import time

import hydra
from hydra.utils import to_absolute_path
from omegaconf import DictConfig

from lfd.teach import TeachSession
from lfd.teach.server import TeachServer


def build(cfg: DictConfig) -> TeachServer:
    """Session + server from the config (raises ValueError/FileNotFoundError on bad input)."""
    scene = None if cfg.scene in (None, "", "null") else to_absolute_path(str(cfg.scene))
    session = TeachSession(
        robot=str(cfg.robot),
        scene=scene,
        mode=str(cfg.mode),
        ik_time_budget=float(cfg.ik.time_budget),
        max_joint_step=float(cfg.ik.max_joint_step),
        wam_q3=str(cfg.ik.wam_q3),
        margin=float(cfg.margin),
    )
    return TeachServer(
        session,
        host=str(cfg.host),
        port=int(cfg.port),
        export_dir=to_absolute_path(str(cfg.export_dir)),
        token=token_option(cfg.get("token", "auto")),
    )


def token_option(value) -> bool | None:
    """The ``token`` config value as ``TeachServer``'s ``token``: auto/null -> None (a token
    exactly when host is not loopback), true -> True, false -> False."""
    if value is None or (isinstance(value, str) and value.lower() == "auto"):
        return None
    if isinstance(value, bool):
        return value
    raise ValueError(f"token must be auto, true or false, got {value!r}")


@hydra.main(version_base="1.3", config_path="../configs/teach", config_name="teach")
def main(cfg: DictConfig) -> None:
    try:
        server = build(cfg)
    except (ValueError, FileNotFoundError, RuntimeError) as e:
        print(f"teach: {e}", file=sys.stderr)
        raise SystemExit(2) from None
    access = (
        "the token in this URL is required: share it only with whoever may drive the arm"
        if server.token
        else "this machine only, no token"
    )
    print(f"teach: {cfg.robot} ready at {server.url}  ({access}; Ctrl-C to stop)", flush=True)
    try:
        end = None if cfg.duration_s is None else time.monotonic() + float(cfg.duration_s)
        while end is None or time.monotonic() < end:
            time.sleep(0.2)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        server.session.close()


if __name__ == "__main__":
    main()
