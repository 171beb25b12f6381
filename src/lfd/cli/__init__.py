"""The command-line entry points: thin Hydra apps that compose a config, instantiate objects and call
the package (the only place under ``src/lfd`` where Hydra and OmegaConf are imported).

Installed as console commands (``[project.scripts]`` in ``pyproject.toml``) and run by the
repository's top-level ``train.py``, ``evaluate.py`` and ``scripts/*.py``, which are wrappers::

    lfd-train          python train.py                   train a model
    lfd-evaluate       python evaluate.py                evaluate policy checkpoints, print a table
    lfd-imitate        python scripts/imitate.py         a demonstration -> a robot skill
    lfd-teach          python scripts/teach.py           the browser teach interface
    lfd-analyze-arm    python scripts/analyze_arm.py     a person's arm motion and joint torques
    lfd-export         python scripts/export_dataset.py  a dataset as LeRobot v3.0 or robomimic HDF5
    lfd-samples        python -m lfd.samples             one small sample of every input kind

The configs are the repository's ``configs/`` folder when lfd runs from a checkout (editable
install), else the copy shipped inside the package (``lfd/configs``, copied there when the wheel is
built): :func:`configs_dir`. ``--help`` (``-h``) prints a short usage of each command
(:func:`run_app`); Hydra's own long help stays available as ``--hydra-help``. A user's error (a bad
file or setting) ends a command with one line on stderr and exit status 2 (:func:`user_errors`).
"""

from __future__ import annotations

import logging
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from lfd.checks import one_line

#: The package folder (``src/lfd`` in a checkout, ``site-packages/lfd`` when installed).
PACKAGE = Path(__file__).resolve().parents[1]
#: The file every configs folder has (the check that a folder is lfd's configs).
ROOT_CONFIG = "train.yaml"


def _checkout_configs() -> Path | None:
    """``<checkout>/configs`` when this package is ``<checkout>/src/lfd`` of a checkout of lfd."""
    root = PACKAGE.parents[1]
    configs = root / "configs"
    if (
        PACKAGE.parent.name == "src"
        and (root / "pyproject.toml").is_file()
        and (configs / ROOT_CONFIG).is_file()
    ):
        return configs
    return None


def configs_dir() -> Path:
    """The configs the commands compose: the checkout's ``configs/`` (the source of truth) when lfd
    runs from a checkout, else the copy inside the installed package (``lfd/configs``).

    Raises:
        FileNotFoundError: neither exists (a package built without its configs).
    """
    checkout = _checkout_configs()
    if checkout is not None:
        return checkout
    packaged = PACKAGE / "configs"
    if (packaged / ROOT_CONFIG).is_file():
        return packaged
    raise FileNotFoundError(
        f"lfd configs: no {ROOT_CONFIG} in {packaged} (a package built without its configs) nor in a checkout's "
        "configs/; reinstall lfd with pip install ."
    )


def config_file(path: str | Path) -> Path:
    """``path`` as given when it exists (relative to the working folder); a relative
    ``configs/...`` path that does not exist there is the file of the configs the commands use
    (:func:`configs_dir`), so that e.g. ``scene=configs/teach/boxes.yaml`` runs from any folder."""
    given = Path(path)
    if given.exists() or given.is_absolute() or not given.parts or given.parts[0] != "configs":
        return given
    shipped = configs_dir().joinpath(*given.parts[1:])
    return shipped if shipped.exists() else given


class _NoTips(logging.Filter):
    """Drops Lightning's advertisements ("💡 Tip: ... try installing litlogger / litmodels")."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith("💡")


#: Warnings that Lightning's own code raises from the versions of torch lfd uses, which no user can act on:
#: (category, message pattern).
LIBRARY_WARNINGS = ((FutureWarning, r"`isinstance\(treespec, LeafSpec\)` is deprecated"),)


def quiet() -> None:
    """Lightning's advertisement tips off (its other messages stay), and the library-internal warnings of
    :data:`LIBRARY_WARNINGS` ignored."""
    for name in ("lightning.pytorch.utilities.rank_zero", "lightning.fabric.utilities.rank_zero"):
        logger = logging.getLogger(name)
        if not any(isinstance(f, _NoTips) for f in logger.filters):
            logger.addFilter(_NoTips())
    for category, message in LIBRARY_WARNINGS:
        warnings.filterwarnings("ignore", message=message, category=category)


def run_app(main: Callable[[], object], usage: str, argv: Sequence[str] | None = None) -> None:
    """Run the Hydra app ``main`` with the command-line ``argv`` (default: ``sys.argv[1:]``); with
    ``-h`` or ``--help`` print ``usage`` (the command's short help) instead."""
    args = list(sys.argv[1:] if argv is None else argv)
    if "-h" in args or "--help" in args:
        print(usage.strip())
        return
    sys.argv = [sys.argv[0], *args]
    main()


#: Errors that are the user's input (a bad file, checkpoint or setting; a missing file): a command
#: prints their message as one line, without a traceback, and exits with status 2 (:func:`user_errors`).
USER_ERRORS: tuple[type[BaseException], ...] = (ValueError, FileNotFoundError)


@contextmanager
def user_errors(command: str, errors: tuple[type[BaseException], ...] = USER_ERRORS) -> Iterator[None]:
    """Within the block, an error of ``errors`` (default :data:`USER_ERRORS`) ends the command: its
    message, on one line, as ``<command>: <message>`` on stderr, no traceback, exit status 2
    (``SystemExit(2)``)."""
    try:
        yield
    except errors as e:
        message = one_line(str(e), limit=None) or type(e).__name__
        print(f"{command}: {message}", file=sys.stderr)
        raise SystemExit(2) from None
