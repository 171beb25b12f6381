"""Boundary validation shared by the public functions of :mod:`lfd.rl`.

Every helper raises :class:`ValueError` naming the offending argument and what was
expected, so that no NaN or shape error surfaces from deep inside a computation.
"""

from __future__ import annotations

import numbers

import numpy as np


def to_numpy(value) -> np.ndarray:
    """A numpy view of ``value`` (a torch tensor is detached and moved to the CPU first)."""
    if hasattr(value, "detach"):
        value = value.detach().cpu().numpy()
    return np.asarray(value)


def as_finite_array(
    value, name: str, *, shape: tuple | None = None, ndim: int | None = None, copy: bool = True
) -> np.ndarray:
    """Return ``value`` as a float64 array after checking finiteness and shape.

    Args:
        value: array-like (numpy, torch or nested sequences).
        name: argument name used in error messages.
        shape: required shape; ``None`` entries match any length.
        ndim: required number of dimensions (checked when ``shape`` is ``None``).

        copy: return a new array the caller may modify freely; ``False`` avoids the copy
            when ``value`` already is a float64 array (read-only use).
    """
    try:
        array = np.array(to_numpy(value), dtype=np.float64, copy=copy or None)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array, got {type(value).__name__}") from exc
    if shape is not None:
        if array.ndim != len(shape) or any(
            want is not None and got != want for got, want in zip(array.shape, shape)
        ):
            wanted = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name} must have shape {wanted}, got {array.shape}")
    elif ndim is not None and array.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-dimensional, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return array


def check_int(value, name: str, *, minimum: int) -> int:
    """Return ``value`` as an ``int`` after checking it is an integer ``>= minimum``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}, got {value}")
    return int(value)


def check_float(
    value, name: str, *, low: float | None = None, high: float | None = None, strict_low: bool = False
) -> float:
    """Return ``value`` as a finite ``float`` inside ``[low, high]`` (``(low, high]`` if ``strict_low``)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value):
        raise ValueError(f"{name} must be a finite real number, got {value!r}")
    value = float(value)
    if low is not None and (value < low or (strict_low and value == low)):
        bound = f"> {low}" if strict_low else f">= {low}"
        raise ValueError(f"{name} must be {bound}, got {value}")
    if high is not None and value > high:
        raise ValueError(f"{name} must be <= {high}, got {value}")
    return value


def check_trajectories(trajectories, name: str = "trajectories", *, n_dof: int | None = None) -> np.ndarray:
    """Check a batch of trajectories ``(B, T, D)`` with ``B >= 1``, ``T >= 2``; return it as float64 (no copy)."""
    array = as_finite_array(trajectories, name, shape=(None, None, n_dof), copy=False)
    if array.shape[0] < 1 or array.shape[1] < 2:
        raise ValueError(f"{name} must have shape (B >= 1, T >= 2, D), got {array.shape}")
    return array
