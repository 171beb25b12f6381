"""Plausible ranges of a person's recording, and the checks that refuse a file outside them.

A file in the wrong unit is well-formed and analyses without a complaint into nonsense (a file
in millimetres read as metres gives a 300 m upper arm and mega-newton-metre torques), so the
entry points check the physical scale once: :func:`lfd.human.read_skeleton` checks the upper
arm and the frame rate of every file it reads, :func:`lfd.human.analyze_arm` checks the body
mass. Each check raises ``ValueError`` with one line naming the file or option, the measured
value, the range, and the unit that would bring it into range when one does.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .skeleton import Skeleton

__all__ = [
    "BODY_MASS_RANGE_KG",
    "FRAME_RATE_RANGE_HZ",
    "MAX_JOINT_SPEED_MPS",
    "SCALE_JUMP_FACTOR",
    "UPPER_ARM_RANGE_M",
    "ImplausibleFrames",
    "check_body_mass",
    "check_frame_rate",
    "check_frames",
    "check_upper_arm",
    "implausible_frames",
]

#: Shoulder-elbow median length (m) accepted for an adult or a child.
UPPER_ARM_RANGE_M = (0.15, 0.6)
#: Frame rates (Hz) accepted: from a slow tracker to a high-speed marker system.
FRAME_RATE_RANGE_HZ = (1.0, 1000.0)
#: Body masses (kg) accepted by the torque model.
BODY_MASS_RANGE_KG = (20.0, 250.0)

#: A frame whose upper arm is more than this factor longer or shorter than the recording's median
#: is in another length unit (a row in millimetres among metres) or a corrupt sample.
SCALE_JUMP_FACTOR = 8.0
#: A joint that leaves both its neighbouring frames faster than this (m/s) is a single-frame spike.
MAX_JOINT_SPEED_MPS = 50.0

_LENGTH_UNITS = (("m", "metres", 1.0), ("cm", "centimetres", 0.01), ("mm", "millimetres", 0.001))
_TIME_UNITS = (("milliseconds", 1e-3), ("microseconds", 1e-6), ("100 ns ticks", 1e-7))


def _inside(value: float, bounds: tuple[float, float]) -> bool:
    return bounds[0] <= value <= bounds[1]


def upper_arm_length(skeleton: Skeleton) -> float | None:
    """Median shoulder-elbow distance (m) over the frames and both sides where both joints were
    tracked (else, when no side ever was, where both are finite); ``None`` when the skeleton has
    no such pair."""
    tracked, finite = [], []
    for side in ("left", "right"):
        a, b = f"shoulder_{side}", f"elbow_{side}"
        if not skeleton.has(a, b):
            continue
        ia, ib = skeleton.index(a), skeleton.index(b)
        d = np.linalg.norm(skeleton.positions[:, ib] - skeleton.positions[:, ia], axis=1)
        tracked.append(d[skeleton.tracked[:, ia] & skeleton.tracked[:, ib]])
        finite.append(d[np.isfinite(d)])
    for lengths in (tracked, finite):
        pooled = np.concatenate(lengths) if lengths else np.empty(0)
        if pooled.size:
            return float(np.median(pooled))
    return None


def check_upper_arm(skeleton: Skeleton, where: str, scale: float | Callable[[], float]) -> None:
    """``ValueError`` when the upper arm (:func:`upper_arm_length`) is outside :data:`UPPER_ARM_RANGE_M`.

    ``scale`` is the metres per file unit the reader applied (or a function returning it, called
    only for an implausible arm); the message suggests the ``units=`` value under which the
    file's numbers would give a plausible arm. A skeleton without a shoulder-elbow pair passes
    (the analysis names the missing joints).
    """
    length = upper_arm_length(skeleton)
    if length is None or _inside(length, UPPER_ARM_RANGE_M):
        return
    scale = scale() if callable(scale) else scale
    low, high = UPPER_ARM_RANGE_M
    problem = f"{where}: upper arm {length:.4g} m: outside {low:g}-{high:g} m"
    raw = length / scale  # the file's own numbers
    fits = [(u, name) for u, name, s in _LENGTH_UNITS if s != scale and _inside(raw * s, UPPER_ARM_RANGE_M)]
    if fits:
        unit, name = fits[0]
        raise ValueError(f"{problem}; is the file in {name}? pass units={unit}")
    raise ValueError(f"{problem}; check the file's length unit (units= m, cm or mm) and its joint labels")


def check_frame_rate(skeleton: Skeleton, where: str, time_source: str) -> None:
    """``ValueError`` when the median frame rate of ``skeleton`` is outside :data:`FRAME_RATE_RANGE_HZ`.

    ``time_source`` names where the times came from, e.g. ``"time column"`` or ``"rate=30"``;
    a time column whose steps read in milliseconds (or microseconds, 100 ns ticks) would give
    a plausible rate is named as such. One frame has no rate and passes.
    """
    if skeleton.n_frames < 2:
        return
    step = float(np.median(np.diff(skeleton.t)))
    rate = 1.0 / step
    if _inside(rate, FRAME_RATE_RANGE_HZ):
        return
    low, high = FRAME_RATE_RANGE_HZ
    problem = f"{where}: {time_source} gives {rate:.4g} frames/s (median step {step:.4g} s)"
    problem += f": outside {low:g}-{high:g} Hz"
    if time_source.startswith("rate"):
        raise ValueError(f"{problem}; pass rate= in Hz (frames per second)")
    rates = {name: 1.0 / (step * s) for name, s in _TIME_UNITS}
    fits = [f"{name} ({r:.3g} Hz)" for name, r in rates.items() if _inside(r, FRAME_RATE_RANGE_HZ)]
    hint = f"is it in {' or '.join(fits)}? " if fits else ""
    raise ValueError(f"{problem}; {hint}the {time_source} must be in seconds")


def check_body_mass(body_mass: float) -> None:
    """``ValueError`` when ``body_mass`` (kg) is outside :data:`BODY_MASS_RANGE_KG`; a mass that
    fits when read as grams is suggested."""
    if isinstance(body_mass, bool) or not isinstance(body_mass, (int, float)) or not np.isfinite(body_mass):
        raise ValueError(f"body_mass must be a number of kg, got {body_mass!r}")
    if _inside(body_mass, BODY_MASS_RANGE_KG):
        return
    low, high = BODY_MASS_RANGE_KG
    hint = ""
    if _inside(body_mass / 1000.0, BODY_MASS_RANGE_KG):
        hint = f" (is it in grams? {body_mass / 1000.0:g} kg)"
    raise ValueError(f"body_mass {body_mass:g} is outside {low:g}-{high:g} kg; give body_mass in kg{hint}")


class ImplausibleFrames(ValueError):
    """Frames of a recording that cannot be a person's motion (mixed length units, spikes); the
    message names the file, the frames and the expectation. ``frames``: their indices."""

    def __init__(self, message: str, frames: np.ndarray) -> None:
        super().__init__(message)
        self.frames = frames


def implausible_frames(skeleton: Skeleton) -> tuple[np.ndarray, np.ndarray]:
    """Frames that cannot be a person's motion, as two boolean (T,) masks ``(scale, spike)``.

    ``scale``: the frame's tracked upper arm (shoulder-elbow) is more than :data:`SCALE_JUMP_FACTOR`
    times longer or shorter than the recording's median (rows in another length unit, e.g.
    millimetres among metres). ``spike``: a tracked joint leaves both its neighbouring frames
    faster than :data:`MAX_JOINT_SPEED_MPS` (a single corrupt frame).
    """
    t, pos, tracked = skeleton.t, skeleton.positions, skeleton.tracked
    n = skeleton.n_frames
    scale = np.zeros(n, bool)
    spike = np.zeros(n, bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        for side in ("left", "right"):
            a, b = f"shoulder_{side}", f"elbow_{side}"
            if not skeleton.has(a, b):
                continue
            ia, ib = skeleton.index(a), skeleton.index(b)
            d = np.linalg.norm(pos[:, ib] - pos[:, ia], axis=1)
            d[~(tracked[:, ia] & tracked[:, ib])] = np.nan
            if not np.isfinite(d).any():
                continue
            ratio = d / np.nanmedian(d)
            scale |= np.isfinite(ratio) & ((ratio > SCALE_JUMP_FACTOR) | (ratio < 1.0 / SCALE_JUMP_FACTOR))
        if n >= 3:
            step = np.linalg.norm(np.diff(pos, axis=0), axis=2)  # (T-1, J) m
            both = tracked[1:] & tracked[:-1]
            speed = np.where(both, step / np.diff(t)[:, None], np.nan)
            inner = np.fmin(speed[:-1], speed[1:])  # frames 1..T-2: the slower of leaving to either side
            spike[1:-1] = (inner > MAX_JOINT_SPEED_MPS).any(1)
    return scale, spike


def _runs(mask: np.ndarray, t: np.ndarray, limit: int = 3) -> str:
    """``"12-15 (t 0.4-0.5 s), 40"``: the first ``limit`` runs of True in ``mask``, then how many more."""
    idx = np.flatnonzero(mask)
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    stops = np.concatenate([idx[breaks], [idx[-1]]])
    parts = [
        f"{a}" + (f"-{b}" if b > a else "") + f" (t {t[a]:.3g}" + (f"-{t[b]:.3g}" if b > a else "") + " s)"
        for a, b in zip(starts[:limit], stops[:limit])
    ]
    more = len(starts) - limit
    return ", ".join(parts) + (f" and {more} more run(s)" if more > 0 else "")


def check_frames(skeleton: Skeleton, where: str) -> None:
    """:class:`ImplausibleFrames` (a ``ValueError``) when :func:`implausible_frames` finds any: one
    line naming ``where`` (the file), the frames (0-based, with their times) and the expectation,
    and that :func:`lfd.human.analyze_arm`'s ``repair_frames`` drops them."""
    scale, spike = implausible_frames(skeleton)
    bad = scale | spike
    if not bad.any():
        return
    reasons = []
    if scale.any():
        reasons.append(
            f"{int(scale.sum())} with an upper arm over {SCALE_JUMP_FACTOR:g}x longer or shorter than the "
            "median (another length unit?)"
        )
    if spike.any():
        reasons.append(
            f"{int(spike.sum())} jumping away and back faster than {MAX_JOINT_SPEED_MPS:g} m/s (spikes?)"
        )
    raise ImplausibleFrames(
        f"{where}: {int(bad.sum())} frame(s) {_runs(bad, skeleton.t)} cannot be a person's motion: "
        f"{', '.join(reasons)}; expected one length unit and no jumps: fix the file, or pass "
        "repair_frames=true (analyze_arm.py: gaps.repair_frames=true) to drop them and interpolate short gaps",
        bad,
    )
