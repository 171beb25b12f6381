"""``lfd-teach`` / ``python scripts/teach.py``: the browser teach interface.

The entry point; the repository's ``scripts/teach.py`` documents the command and is a wrapper of
this module.
"""

from __future__ import annotations

import sys
import time

import hydra
from hydra.utils import to_absolute_path
from omegaconf import DictConfig, OmegaConf

from lfd.cli import config_file, configs_dir, run_app
from lfd.teach import TeachSession, TeachSettings
from lfd.teach.server import TeachServer

#: The configs composed (the checkout's configs/, else the packaged copy: :func:`lfd.cli.configs_dir`).
CONFIGS = configs_dir()


def settings_of(cfg: DictConfig) -> TeachSettings:
    """The composed config as :class:`TeachSettings`, with ``scene`` and ``export_dir`` made absolute
    (relative to where the command was started; a ``configs/...`` scene that is not there is the
    shipped one: :func:`lfd.cli.config_file`). Raises ``ValueError`` on a bad value."""
    values = OmegaConf.to_container(cfg, resolve=True)
    values.pop("hydra", None)
    if values.get("scene") not in (None, "", "null"):
        values["scene"] = to_absolute_path(str(config_file(str(values["scene"]))))
    if isinstance(values.get("export_dir"), str) and values["export_dir"]:
        values["export_dir"] = to_absolute_path(values["export_dir"])
    return TeachSettings.from_mapping(values)


def build(settings: TeachSettings) -> TeachServer:
    """Session + server of ``settings`` (raises ValueError/FileNotFoundError on bad input)."""
    return TeachServer.from_settings(TeachSession.from_settings(settings), settings)


@hydra.main(version_base="1.3", config_path=str(CONFIGS / "teach"), config_name="teach")
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


USAGE = """
lfd-teach (python scripts/teach.py): drag a robot in a browser, export demonstrations (configs/teach/)
  robot=wam4|sawyer|pr2_right_arm|panda|iiwa14   scene=configs/teach/boxes.yaml|null
  host=127.0.0.1   port=8080 (0: a free port; a busy port is refused)   token=auto|true   mode=3d|2d
  export_dir=outputs/teach/export   duration_s=N (stop after N s; default: Ctrl-C)
Prints the URL to open in a browser.
"""


def cli(argv: list[str] | None = None) -> None:
    """The ``lfd-teach`` command (``python scripts/teach.py``): ``--help`` prints :data:`USAGE`."""
    run_app(main, USAGE, argv)


if __name__ == "__main__":
    cli()
