"""Argument checks shared by every package of lfd: the ground floor (numpy and the standard library only).

Every helper takes the value first and the argument's name second, returns the value converted
(a float64 array, an ``int``, a ``float``, a ``str``) and otherwise raises one ``ValueError`` whose
message is a single line naming the argument and what was expected:

* ``"<name> must be <expectation>, got <what came>"``: wrong type, bounds, shape, choice, keys;
* ``"<name> contains NaN or inf"``: a non-finite entry.

Helpers taking ``optional=True`` also accept None (returned as is) and then say so in the message
(``"<name> must be <expectation> (or None), got <what came>"``).

Arrays: :func:`finite_array` (any numeric array-like, torch tensors included: they are detached
and moved to the CPU), :func:`check_vector` (a ``(length,)`` vector a user typed), :func:`time_grid`
(sample times in seconds). Scalars: :func:`check_int`, :func:`positive_int`, :func:`check_float`,
:func:`positive_float`, :func:`unit_interval`, :func:`check_flag`. Names: :func:`check_choice`,
:func:`check_text`. Settings mappings: :func:`check_keys`, :data:`ENTRY_POINT_KEYS`. A third-party error quoted in a
message: :func:`one_line`.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = [
    "ENTRY_POINT_KEYS",
    "check_choice",
    "check_flag",
    "check_float",
    "check_int",
    "check_keys",
    "check_text",
    "check_vector",
    "finite_array",
    "one_line",
    "positive_float",
    "positive_int",
    "time_grid",
    "to_numpy",
    "unit_interval",
]


#: Keys of an entry point's composed Hydra config that belong to the entry point, never to the settings
#: it builds (Hydra's own node, the shared ``configs/paths`` and the run's ``task_name``): settings
#: readers drop them before :func:`check_keys`.
ENTRY_POINT_KEYS = ("hydra", "paths", "task_name")


def one_line(error: BaseException | str, limit: int | None = 300) -> str:
    """``error`` (an exception, shown as ``<type>: <message>``, or a text) as one printable line:
    whitespace runs, newlines included, folded to one space, cut to ``limit`` characters with "..."
    (``None``: not cut).
    For quoting another library's multi-line message inside lfd's one-line errors."""
    text = error if isinstance(error, str) else f"{type(error).__name__}: {error}".rstrip(": ")
    text = " ".join("".join(c if c.isprintable() else " " for c in text).split())
    return text if limit is None or len(text) <= limit else text[: limit - 3] + "..."


def _or_none(optional: bool) -> str:
    """The message's note that None is accepted too."""
    return " (or None)" if optional else ""


def _shown(value: Any) -> str:
    """``value`` as a message shows it: a sequence (a tuple, a config's list) as a list."""
    if isinstance(value, Sequence) and not isinstance(value, str | bytes):
        return repr(list(value))
    return repr(value)


def to_numpy(value) -> np.ndarray:
    """A numpy view of ``value`` (a torch tensor is detached and moved to the CPU first)."""
    if hasattr(value, "detach"):
        value = value.detach().cpu().numpy()
    return np.asarray(value)


def _shape_text(shape: Sequence[int | None]) -> str:
    """``(3,)``, ``(*, *, 7)``: a required shape as the message shows it (``*`` for any length)."""
    parts = ["*" if s is None else str(s) for s in shape]
    return "(" + ", ".join(parts) + ("," if len(parts) == 1 else "") + ")"


def finite_array(
    value,
    name: str,
    *,
    ndim: int | tuple[int, ...] | None = None,
    shape: Sequence[int | None] | None = None,
    copy: bool = True,
) -> np.ndarray:
    """``value`` as a float64 array without NaN/inf, of the required dimensions or shape.

    Args:
        value: array-like (numpy, torch, nested sequences).
        name: the argument's name, for the message.
        ndim: accepted number(s) of dimensions (``2`` or ``(1, 2)``), checked when ``shape`` is None.
        shape: required shape; ``None`` entries match any length.
        copy: return a new array the caller may modify; ``False`` returns ``value`` itself when
            it already is a writeable float64 array (for callers that only read it).

    Raises:
        ValueError: not numeric (``"<name> must be a numeric array, got <type>"``), wrong
            dimensions or shape, NaN or inf.
    """
    try:
        data = to_numpy(value)
        array = np.array(data, dtype=np.float64) if copy else np.asarray(data, dtype=np.float64)
        if not array.flags.writeable:  # torch.from_numpy warns on read-only memory
            array = array.copy()
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array, got {type(value).__name__}") from exc
    if shape is not None:
        if array.ndim != len(shape) or any(
            want is not None and got != want for got, want in zip(array.shape, shape)
        ):
            raise ValueError(f"{name} must have shape {_shape_text(shape)}, got {array.shape}")
    elif ndim is not None:
        ndims = (ndim,) if isinstance(ndim, int) else tuple(ndim)
        if array.ndim not in ndims:
            expected = " or ".join(f"{n}-D" for n in ndims)
            raise ValueError(f"{name} must be {expected}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contains NaN or inf")
    return array


def check_vector(
    value: Any, length: int, name: str, *, what: str | None = None, optional: bool = False
) -> np.ndarray | None:
    """``value`` (a vector a user gave: a position, joint angles) as a finite float ``(length,)`` array.

    Args:
        what: the expectation the message states (``"a tool position [x, y, z] in metres"``) for
            a value that is not ``length`` numbers; None: ``"<length> numbers"`` and, for a wrong
            length, the shape (``"<name> must have shape (3,), got (2,)"``).
        optional: accept None (returned as is).

    Raises:
        ValueError: not numbers (``"<name> must be <length> numbers, got ..."``), wrong shape,
            NaN or inf.
    """
    if value is None and optional:
        return None
    expectation = (what or f"{length} numbers") + _or_none(optional)
    try:
        if isinstance(value, str | bytes):
            raise TypeError
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {expectation}, got {_shown(value)}") from None
    if what is not None and array.shape != (length,):
        raise ValueError(f"{name} must be {expectation}, got {_shown(value)}")
    return finite_array(array, name, shape=(length,), copy=False)


def check_int(value, name: str, *, minimum: int | None = None, optional: bool = False) -> int | None:
    """``value`` as an ``int`` (not a bool), at least ``minimum`` when given; None too when ``optional``."""
    if value is None and optional:
        return None
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Integral)
        or (minimum is not None and value < minimum)
    ):
        bound = "" if minimum is None else f" >= {minimum}"
        raise ValueError(f"{name} must be an integer{bound}{_or_none(optional)}, got {value!r}")
    return int(value)


def positive_int(value, name: str) -> int:
    """``value`` as an ``int >= 1``."""
    return check_int(value, name, minimum=1)


def _bounds_text(low, high, strict_low: bool, strict_high: bool) -> str:
    if low is not None and high is not None:
        return f" in {'(' if strict_low else '['}{low:g}, {high:g}{')' if strict_high else ']'}"
    if low is not None:
        return f" {'>' if strict_low else '>='} {low:g}"
    if high is not None:
        return f" {'<' if strict_high else '<='} {high:g}"
    return ""


def check_float(
    value,
    name: str,
    *,
    low: float | None = None,
    high: float | None = None,
    strict_low: bool = False,
    strict_high: bool = False,
    optional: bool = False,
) -> float | None:
    """``value`` (a real number, not a bool) as a finite ``float`` within ``[low, high]``; the
    ``strict_*`` flags exclude the bound itself; None too when ``optional``. The message states the
    bounds, e.g. ``"tau must be a finite number > 0, got -1.0"``."""
    if value is None and optional:
        return None
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
    if ok and low is not None:
        ok = value > low if strict_low else value >= low
    if ok and high is not None:
        ok = value < high if strict_high else value <= high
    if not ok:
        bounds = _bounds_text(low, high, strict_low, strict_high)
        raise ValueError(f"{name} must be a finite number{bounds}{_or_none(optional)}, got {value!r}")
    return float(value)


def positive_float(value, name: str) -> float:
    """``value`` as a finite ``float > 0``."""
    return check_float(value, name, low=0.0, strict_low=True)


def unit_interval(value, name: str) -> float:
    """``value`` as a ``float`` strictly between 0 and 1."""
    return check_float(value, name, low=0.0, high=1.0, strict_low=True, strict_high=True)


def check_flag(value, name: str) -> bool:
    """``value`` if it is a ``bool``: ``"<name> must be true or false, got <value>"`` otherwise (1, "yes")."""
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be true or false, got {value!r}")
    return value


def check_choice(value, name: str, choices: Sequence, *, optional: bool = False):
    """``value`` if it is one of ``choices`` (or None when ``optional``):
    ``"<name> must be one of a, b, c, got <value>"`` otherwise."""
    if (value is None and optional) or value in choices:
        return value
    listed = ", ".join(map(str, choices))
    raise ValueError(f"{name} must be one of {listed}{_or_none(optional)}, got {value!r}")


def check_text(value, name: str, *, optional: bool = False) -> str | None:
    """``value`` (a ``str`` or a path) as a non-empty ``str``; None too when ``optional``."""
    if value is None and optional:
        return None
    if not isinstance(value, str | os.PathLike) or not str(value):
        raise ValueError(f"{name} must be a non-empty string{_or_none(optional)}, got {value!r}")
    return str(value)


def check_keys(values: Mapping, name: str, allowed: Iterable[str]) -> Mapping:
    """``values`` (a mapping of settings, e.g. a config section) if every key is one of ``allowed``:
    ``"<name> must have keys among a, b, c, got unknown x, y"`` otherwise, the unknown keys and the
    allowed ones each sorted."""
    known = {str(k) for k in allowed}
    unknown = sorted(str(k) for k in values if str(k) not in known)
    if unknown:
        raise ValueError(
            f"{name} must have keys among {', '.join(sorted(known))}, got unknown {', '.join(unknown)}"
        )
    return values


def time_grid(t, name: str = "t", *, min_samples: int) -> np.ndarray:
    """Sample times in seconds: 1-D float64, finite, strictly increasing, at least ``min_samples`` long."""
    times = finite_array(t, name, ndim=1)
    if times.shape[0] < min_samples:
        raise ValueError(f"{name} needs at least {min_samples} samples, got {times.shape[0]}")
    if np.any(np.diff(times) <= 0):
        raise ValueError(f"{name} must be strictly increasing")
    return times
