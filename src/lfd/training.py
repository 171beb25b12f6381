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

import inspect
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
from torch.overrides import TorchFunctionMode

from lfd.checks import one_line

__all__ = [
    "ACTIVATIONS",
    "CHECKPOINT_GLOB",
    "EXPECTED_CHECKPOINT",
    "MAX_CHECKPOINT_MODEL_BYTES",
    "SCHEDULERS",
    "Adaptable",
    "AdaptationSource",
    "CheckpointError",
    "Evaluator",
    "check_state_dict",
    "checkpoint_kind",
    "cpu_bf16_supported",
    "find_checkpoints",
    "init_arguments",
    "load_checkpoint_module",
    "make_activation",
    "make_optimizer",
    "read_checkpoint",
    "resolve_precision",
    "save_own_hyperparameters",
]

#: Hidden activations by name (``activation`` in the model configs).
ACTIVATIONS = {"silu": nn.SiLU, "gelu": nn.GELU, "relu": nn.ReLU, "tanh": nn.Tanh, "sigmoid": nn.Sigmoid}
#: Learning-rate schedules of :func:`make_optimizer` (all per optimiser step).
SCHEDULERS = ("onecycle", "cosine", "none")


def cpu_bf16_supported() -> bool:
    """Whether this CPU runs bfloat16 matrix products and convolutions natively (oneDNN with
    AVX512-BF16 or AMX). Elsewhere bf16 autocast is emulated, slower than float32."""
    try:
        return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):
        return False


def resolve_precision(precision: Any, accelerator: Any) -> Any:
    """The Lightning ``precision`` to train with: ``precision`` itself, except bfloat16 mixed
    precision (``"bf16-mixed"``) on a CPU without native bfloat16 (:func:`cpu_bf16_supported`),
    which becomes ``"32-true"`` with a warning (there it would be slower, not faster); ``None``
    (Lightning's default) stays ``None``.
    ``accelerator``: the trainer's (``"cpu"``, ``"gpu"``, ``"auto"``; ``"auto"`` means the CPU
    when CUDA is absent)."""
    on_cpu = str(accelerator) == "cpu" or (str(accelerator) == "auto" and not torch.cuda.is_available())
    if on_cpu and str(precision).startswith("bf16") and not cpu_bf16_supported():
        warnings.warn(
            f"trainer.precision={precision}: this CPU has no native bfloat16 (AVX512-BF16 or AMX), "
            "training in float32 instead",
            stacklevel=2,
        )
        return "32-true"
    return precision


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
            ``torch.save`` file, a zip archive with compressed members (torch maps the stored
            bytes, so a re-zipped checkpoint's tensors would be garbage), a pickled payload, not a
            dictionary, or a missing key (one line: ``<path>: not a PyTorch Lightning checkpoint
            (<why>); expected ...``).
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
            members = archive.infolist()
    except (zipfile.BadZipFile, OSError) as e:
        raise error(f"unreadable zip archive: {e}") from e
    if not any(m.filename.endswith("/data.pkl") for m in members):
        raise error("a zip archive without data.pkl")
    compressed = [m.filename for m in members if m.compress_type != zipfile.ZIP_STORED]
    if compressed:  # torch maps stored bytes: a compressed tensor would be read as garbage
        raise error(
            f"{len(compressed)} compressed zip member(s), e.g. {compressed[0]!r}: torch.save stores them "
            "uncompressed (re-zipped with compression?)"
        )
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


#: The most memory (bytes) the tensors of a model built from a checkpoint's hyper-parameters may
#: take (:func:`load_checkpoint_module`): 1 GiB, about 50 times lfd's largest policy (ACT with a
#: ResNet-18, 18 MiB). A checkpoint asking for more is refused before the tensor that would pass
#: the limit is allocated.
MAX_CHECKPOINT_MODEL_BYTES = 1 << 30

#: Factory functions whose result's size is checked before it is made (torch's own list: those a
#: ``torch.device`` context directs).
_CONSTRUCTORS = None


class _OverBudget(Exception):
    """A model being built asked for more than :data:`MAX_CHECKPOINT_MODEL_BYTES`."""


class _TensorBudget(TorchFunctionMode):
    """While active, every tensor factory call (``torch.empty``, ``zeros``, ``tensor``, ...) is
    first run on the ``meta`` device (no memory) to learn its size, and refused with
    :class:`_OverBudget` once the sizes made so far would pass ``limit`` bytes."""

    def __init__(self, limit: int) -> None:
        super().__init__()
        global _CONSTRUCTORS
        if _CONSTRUCTORS is None:
            from torch.utils._device import _device_constructors

            _CONSTRUCTORS = _device_constructors()
        self.limit, self.used = limit, 0

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        if func in _CONSTRUCTORS:
            probe = func(*args, **{**kwargs, "device": "meta"})
            size = probe.numel() * probe.element_size() if isinstance(probe, torch.Tensor) else 0
            if self.used + size > self.limit:
                raise _OverBudget(f"a tensor of shape {tuple(probe.shape)} after {self.used / 2**20:.0f} MiB")
            self.used += size
        return func(*args, **kwargs)


def _names(keys: Sequence[str], at_most: int = 5) -> str:
    shown = [str(k)[:80] for k in keys[:at_most]]
    return f"{shown}" + (f" (+{len(keys) - at_most} more)" if len(keys) > at_most else "")


def init_arguments(cls: type) -> set[str]:
    """The keyword arguments the constructor of a LightningModule class ``cls`` takes by name,
    along its class hierarchy (a subclass passing ``**common`` to its base takes the base's too),
    and the names in its ``RETIRED_HYPERPARAMETERS`` (earlier releases' settings it still accepts)."""
    names: set[str] = set(getattr(cls, "RETIRED_HYPERPARAMETERS", ()))
    for klass in cls.__mro__:
        if klass is L.LightningModule or not issubclass(klass, L.LightningModule):
            break
        init = klass.__dict__.get("__init__")
        if init is None:
            continue
        for p in list(inspect.signature(init).parameters.values())[1:]:
            if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL):
                names.add(p.name)
    return names


def check_state_dict(
    path: str | Path, kind: Any, expected: Mapping[str, torch.Tensor], given: Any, built: str = "the model"
) -> None:
    """Refuse a checkpoint's ``state_dict`` (``given``) that does not fit the model it is loaded
    into (``expected``: the model's ``state_dict()``): a missing or an unexpected key, a value
    that is no tensor, or a tensor of another shape. Only shapes are read (a memory-mapped tensor
    stays unread).

    Args:
        path: the checkpoint file (named in the message); ``kind``: the model kind it is for.
        built: what ``expected`` is, in the message (e.g. ``"a 'velocity' policy with its
            hyper-parameters"``).

    Raises:
        CheckpointError: one line naming the file, its kind and the first key that does not fit.
    """
    what = f"{path}: a {kind!r} checkpoint"
    if not isinstance(given, Mapping):
        raise CheckpointError(f"{what} whose state_dict is a {type(given).__name__}, not a mapping")
    missing = [k for k in expected if k not in given]
    if missing:
        raise CheckpointError(f"{what} whose state_dict misses key(s) {_names(missing)} of {built}")
    extra = [str(k) for k in given if k not in expected]
    if extra:
        raise CheckpointError(
            f"{what} whose state_dict has key(s) {_names(extra)} that {built} does not have"
        )
    for key, tensor in expected.items():
        value = given[key]
        if not isinstance(value, torch.Tensor):
            raise CheckpointError(
                f"{what} whose state_dict[{key!r}] is a {type(value).__name__}, not a tensor"
            )
        if value.shape != tensor.shape:
            raise CheckpointError(
                f"{what} whose state_dict[{key!r}] has shape {tuple(value.shape)}, "
                f"where {built} has {tuple(tensor.shape)}"
            )


def load_checkpoint_module(
    cls: type[L.LightningModule],
    path: str | Path,
    map_location: str | torch.device = "cpu",
    others: Mapping[str, type] | None = None,
) -> L.LightningModule:
    """The LightningModule ``cls`` built from the checkpoint file ``path`` (its
    ``hyper_parameters``) and loaded with its ``state_dict``, in eval mode on ``map_location``:
    the file is read by :func:`read_checkpoint` (no code from it runs), and everything is checked
    before the model's tensors are filled: the hyper-parameter names (those ``cls`` takes:
    :func:`init_arguments`), their values (``cls``'s own checks), the memory the model takes
    (at most :data:`MAX_CHECKPOINT_MODEL_BYTES`, refused before allocating past it) and the
    state_dict's keys and shapes (:func:`check_state_dict`). The caller checks the kind.

    Args:
        others: ``{kind: class}`` of other model kinds, to say whose hyper-parameters a
            checkpoint with foreign ones carries (e.g. :data:`lfd.visuomotor.policies.POLICIES`).

    Raises:
        FileNotFoundError: nothing at ``path``.
        CheckpointError: a file :func:`read_checkpoint` refuses, or one whose hyper-parameters or
            state_dict do not fit ``cls`` (one line naming the file, its kind and the key, field
            or shape).
    """
    ckpt = read_checkpoint(path, keys=("state_dict", "hyper_parameters"))
    hparams = {str(k): v for k, v in ckpt["hyper_parameters"].items()}
    kind = hparams.get("kind")
    what = f"{path}: a {kind!r} checkpoint"
    unknown = sorted(set(hparams) - init_arguments(cls))
    if unknown:
        owners = sorted(
            k for k, c in (others or {}).items() if c is not cls and set(unknown) <= init_arguments(c)
        )
        whose = f" (taken by kind {', '.join(map(repr, owners))})" if owners else ""
        raise CheckpointError(
            f"{what} with hyper-parameter(s) {_names(unknown)}{whose} that {cls.__name__} does not take"
        )
    budget = _TensorBudget(MAX_CHECKPOINT_MODEL_BYTES)
    try:
        with budget:
            model = cls(**hparams)
    except _OverBudget as e:
        raise CheckpointError(
            f"{what} whose hyper-parameters ask for a model of more than {MAX_CHECKPOINT_MODEL_BYTES >> 20} MiB "
            f"({e}; the limit is lfd.training.MAX_CHECKPOINT_MODEL_BYTES); refused before allocating it"
        ) from None
    except Exception as e:  # a value the model's own checks (or torch) refuse: TypeError, ValueError, ...
        raise CheckpointError(
            f"{what} whose hyper-parameters {cls.__name__} refuses: {one_line(str(e) or type(e).__name__)}"
        ) from None
    try:
        model.on_load_checkpoint(ckpt)  # e.g. drops an earlier release's retired entries
    except Exception as e:
        raise CheckpointError(
            f"{what} that {cls.__name__} cannot read: {one_line(str(e) or type(e).__name__)}"
        ) from None
    given = ckpt["state_dict"]
    check_state_dict(path, kind, model.state_dict(), given, f"{cls.__name__} built from its hyper-parameters")
    try:
        model.load_state_dict(given, strict=True)
    except Exception as e:  # e.g. a tensor of a dtype that cannot be copied
        raise CheckpointError(
            f"{what} whose state_dict cannot be loaded: {one_line(str(e) or type(e).__name__)}"
        ) from None
    return model.to(map_location).eval()


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
