"""Training helpers shared by the LightningModules of :mod:`lfd.visuomotor.policies` and
:mod:`lfd.model_reaching`: activations by name, AdamW with a per-step learning-rate schedule,
hyper-parameters saved per module, reading checkpoint files without running code from them
(:func:`read_checkpoint`) and finding them by kind; and the protocols the entry points rely on:
:class:`Adaptable` / :class:`AdaptationSource` (``train.py``: a model that takes plain data from
its datamodule before fitting) and :class:`Evaluator` (``evaluate.py``).

Example::

    >>> from lfd.training import make_activation
    >>> make_activation("silu")
    SiLU()
"""

from __future__ import annotations

import math
import pickle
import re
import warnings
import zipfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import lightning as L
import torch
from torch import nn

__all__ = [
    "ACTIVATIONS",
    "CHECKPOINT_GLOB",
    "EXPECTED_CHECKPOINT",
    "SCHEDULERS",
    "Adaptable",
    "AdaptationSource",
    "CheckpointError",
    "Evaluator",
    "checkpoint_kind",
    "find_checkpoints",
    "make_activation",
    "make_optimizer",
    "read_checkpoint",
    "save_own_hyperparameters",
]

#: Hidden activations by name (``activation`` in the model configs).
ACTIVATIONS = {"silu": nn.SiLU, "gelu": nn.GELU, "relu": nn.ReLU, "tanh": nn.Tanh, "sigmoid": nn.Sigmoid}
#: Learning-rate schedules of :func:`make_optimizer` (all per optimiser step).
SCHEDULERS = ("onecycle", "cosine", "none")


def make_activation(name: str) -> nn.Module:
    """A new activation module by name (one of :data:`ACTIVATIONS`)."""
    if name not in ACTIVATIONS:
        raise ValueError(f"activation: expected one of {sorted(ACTIVATIONS)}, got {name!r}")
    return ACTIVATIONS[name]()


def save_own_hyperparameters(module: L.LightningModule, init_locals: dict[str, Any]) -> None:
    """``module.save_hyperparameters`` of exactly its own ``__init__`` arguments (pass
    ``locals()``); without an explicit dict Lightning would also collect the arguments of
    an enclosing module's ``__init__`` when the module is built inside another one."""
    module.save_hyperparameters({k: v for k, v in init_locals.items() if k not in ("self", "__class__")})


def make_optimizer(
    module: L.LightningModule, groups: list[dict[str, Any]], scheduler: str, pct_start: float = 0.15
) -> dict[str, Any]:
    """AdamW over parameter ``groups`` (each with ``params``, ``lr``, ``weight_decay``) and a
    per-step schedule over the trainer's total steps: ``"onecycle"`` (peak at each group's
    ``lr``, warming up for the fraction ``pct_start``), ``"cosine"`` (to 0) or ``"none"``.
    The return value is what ``configure_optimizers`` returns."""
    if scheduler not in SCHEDULERS:
        raise ValueError(f"scheduler: expected one of {SCHEDULERS}, got {scheduler!r}")
    opt = torch.optim.AdamW(groups)
    if scheduler == "none":
        return {"optimizer": opt}
    steps = module.trainer.estimated_stepping_batches
    total = max(1, int(steps)) if math.isfinite(steps) else 1
    if scheduler == "cosine":
        sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=total)
    else:
        sched = torch.optim.lr_scheduler.OneCycleLR(
            opt, max_lr=[g["lr"] for g in groups], total_steps=total + 1, pct_start=pct_start
        )
    return {"optimizer": opt, "lr_scheduler": {"scheduler": sched, "interval": "step"}}


# ---------------------------------------------------------------------------- checkpoints
#: Where training runs leave their checkpoints, relative to ``paths.output_root``.
CHECKPOINT_GLOB = "train/**/checkpoints/last.ckpt"
#: What every :class:`CheckpointError` message says was expected.
EXPECTED_CHECKPOINT = "expected a .ckpt written by train.py"


class CheckpointError(ValueError):
    """A file that is not a readable Lightning checkpoint, or one that holds pickled Python
    objects beyond tensors and plain data; the message is one line naming the file."""


def _refused_global(message: str) -> str:
    """The global a ``weights_only`` unpickler refused (from torch's message), printable and short."""
    found = re.search(r"Unsupported global: GLOBAL (\S+)", message)
    name = found.group(1) if found else ""
    return "".join(c for c in name if c.isprintable())[:80] or "an object"


def read_checkpoint(path: str | Path, keys: tuple[str, ...] = ()) -> dict[str, Any]:
    """The content of the checkpoint file ``path``: ``torch.load(weights_only=True, mmap=True)``
    on CPU, so no code from the file runs (a pickled object other than tensors and plain data is
    refused) and no tensor is read until used. The one place lfd opens a checkpoint file.

    Args:
        path: a ``.ckpt`` file (torch's zip format, as Lightning writes it).
        keys: top-level keys the checkpoint must hold (e.g. ``("state_dict", "hyper_parameters")``).

    Raises:
        FileNotFoundError: nothing at ``path``.
        CheckpointError: a folder, an empty, truncated or foreign file, a legacy (non-zip)
            ``torch.save`` file, a pickled payload, not a dictionary, or a missing key
            (one line: ``<path>: not a PyTorch Lightning checkpoint (<why>); expected ...``).
    """
    path = Path(path)

    def error(why: str) -> CheckpointError:
        return CheckpointError(f"{path}: not a PyTorch Lightning checkpoint ({why}); {EXPECTED_CHECKPOINT}")

    if not path.exists():
        raise FileNotFoundError(f"{path}: no such checkpoint file")
    if not path.is_file():
        raise error("not a regular file")
    if path.stat().st_size == 0:
        raise error("empty file")
    if not zipfile.is_zipfile(path):
        raise error("not a zip archive: truncated, or not written by torch.save")
    try:
        with zipfile.ZipFile(path) as archive:
            names = archive.namelist()
    except (zipfile.BadZipFile, OSError) as e:
        raise error(f"unreadable zip archive: {e}") from e
    if not any(n.endswith("/data.pkl") for n in names):
        raise error("a zip archive without data.pkl")
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True, mmap=True)
    except pickle.UnpicklingError as e:
        raise error(
            f"it holds a pickled Python object ({_refused_global(str(e))}) that a weights-only load "
            "refuses to build; nothing in it was run"
        ) from e
    except Exception as e:  # torch's reader: RuntimeError, OSError, EOFError, KeyError, ...
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise error(f"unreadable: {first[:200]}") from e
    if not isinstance(ckpt, dict):
        raise error(f"it holds a {type(ckpt).__name__}, not a dictionary")
    hparams = ckpt.get("hyper_parameters", {})
    if not isinstance(hparams, Mapping):
        raise error(f"'hyper_parameters' is a {type(hparams).__name__}, not a mapping")
    missing = [k for k in keys if k not in ckpt]
    if missing:
        raise error(f"no {missing} in it")
    return ckpt


def checkpoint_kind(path: str | Path) -> str | None:
    """The model kind stored in a Lightning checkpoint's hyper-parameters (``kind``; None if it
    has none), read by :func:`read_checkpoint` (no code from the file runs, no tensor is read).

    Raises:
        FileNotFoundError, CheckpointError: see :func:`read_checkpoint`.
    """
    kind = read_checkpoint(path).get("hyper_parameters", {}).get("kind")
    return kind if isinstance(kind, str) else None


def find_checkpoints(output_root: str | Path, kinds: tuple[str, ...]) -> dict[str, Path]:
    """The newest (by modification time) ``last.ckpt`` of each model kind (:func:`checkpoint_kind`)
    under ``<output_root>/train/**/checkpoints/``; kinds without one are left out. A file that
    is no readable checkpoint (:class:`CheckpointError`) is skipped with a printed warning
    naming it; none of its code runs."""
    found: dict[str, Path] = {}
    candidates = sorted(
        Path(output_root).glob(CHECKPOINT_GLOB), key=lambda p: p.stat().st_mtime, reverse=True
    )
    for path in candidates:
        try:
            kind = checkpoint_kind(path)
        except (CheckpointError, OSError) as e:
            warnings.warn(f"skipped: {e}", RuntimeWarning, stacklevel=2)
            print(f"[lfd] warning: skipped: {e}")
            continue
        if kind in kinds and kind not in found:
            found[kind] = path
        if len(found) == len(kinds):
            break
    return found


# ---------------------------------------------------------------------------- protocols
@runtime_checkable
class AdaptationSource(Protocol):
    """A datamodule that hands its model plain data before fitting (normalisation statistics,
    demonstrations), e.g. :class:`lfd.model_reaching.SawyerModelsDataModule`."""

    def adaptation_data(self) -> Any:
        """The data :meth:`Adaptable.adapt` takes (built on first call)."""
        ...


@runtime_checkable
class Adaptable(Protocol):
    """A model that takes plain data from its datamodule before fitting (``train.py`` calls
    ``model.adapt(datamodule.adaptation_data())`` when the datamodule is an
    :class:`AdaptationSource`), e.g. :class:`lfd.model_reaching.SawyerModels`."""

    def adapt(self, data: Any) -> None:
        """Take ``data`` (:meth:`AdaptationSource.adaptation_data`); the model never reaches
        into the datamodule itself."""
        ...


@runtime_checkable
class Evaluator(Protocol):
    """What ``evaluate.py`` needs of the object ``eval._target_`` names
    (:class:`lfd.visuomotor.eval.ReachEvaluator`, :class:`lfd.model_reaching.protocol.SawyerProtocol`).

    Attributes:
        needs_datamodule: :meth:`run` reads the ``data`` config's datamodule (else it gets None).
    """

    needs_datamodule: bool

    def resolve_checkpoints(
        self, output_root: str | Path, given: Sequence[str | Path] | str | Path | None = None
    ) -> dict[str, Path]:
        """``{kind: path}`` of the checkpoints to evaluate: the files ``given`` (``evaluate.py
        ckpt=...``; each one's kind is read from it), else the newest under ``output_root``.
        Raises ``FileNotFoundError`` when none can be found."""
        ...

    def run(
        self, datamodule: Any, checkpoints: Mapping[str, str | Path], out_dir: str | Path
    ) -> dict[str, Any]:
        """Evaluate the ``checkpoints``, write the outputs into ``out_dir`` and return the metrics."""
        ...
