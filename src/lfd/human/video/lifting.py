"""Monocular arm depth from bone lengths (Taylor 2000, weak perspective): the image gives each
arm segment's projected length, the clip gives its true length, and MediaPipe's world landmarks
give only the sign of its depth difference, which they get right more often than its size."""

from __future__ import annotations

import warnings

import numpy as np

from .landmarks import MEDIAPIPE_LANDMARKS

__all__ = [
    "ARM_CHAINS",
    "LENGTH_PERCENTILE",
    "MIN_LENGTH_RATIO",
    "SIGN_MARGIN",
    "TORSO_FRACTION",
    "lift_arm_depth",
]


def _i(name: str) -> int:
    return MEDIAPIPE_LANDMARKS.index(name)


#: Per arm: shoulder -> elbow -> wrist, then the hand landmarks moved rigidly with the wrist.
ARM_CHAINS = tuple(
    (
        tuple(_i(f"{side}_{j}") for j in ("shoulder", "elbow", "wrist")),
        tuple(_i(f"{side}_{j}") for j in ("pinky", "index", "thumb")),
    )
    for side in ("left", "right")
)
#: Percentile of a segment's projected length over the clip taken as its true length. Chosen on
#: frames 0-49 of the Pose2Sim 4-view demo (grid 60-98; docs/video.md), reported on frames 50-99.
LENGTH_PERCENTILE = 85.0
#: m: a world depth difference smaller than this gives a proportionally smaller share of the
#: lifted depth (``clip(world dz / SIGN_MARGIN, -1, 1)`` instead of its sign), so a segment
#: whose world depth wavers around zero does not jump between +dz and -dz. Chosen on the same
#: validation frames (grid 0-0.08 m: worst median 8.83 deg at 0, 8.81 at 0.02, 9.6 at 0.04).
SIGN_MARGIN = 0.02
#: Segment lengths as fractions of the torso (shoulders' to hips' midpoint), from Winter's
#: anthropometric table (upper arm 0.186 H, forearm 0.146 H, torso 0.288 H).
TORSO_FRACTION = (0.186 / 0.288, 0.146 / 0.288)
#: A segment whose percentile length is below this fraction of its anthropometric length was
#: never seen parallel to the image (an arm reaching at the camera throughout): it keeps the
#: world landmarks' depth difference. On the Pose2Sim demos (16 clips x 4 segments) the ratio is
#: 0.75-1.17, so the guard leaves every validated clip as it was.
MIN_LENGTH_RATIO = 0.6
_SHOULDERS = [_i("left_shoulder"), _i("right_shoulder")]
_HIPS = [_i("left_hip"), _i("right_hip")]


def lift_arm_depth(
    pixels: np.ndarray,
    world: np.ndarray,
    length_percentile: float = LENGTH_PERCENTILE,
    sign_margin: float = SIGN_MARGIN,
) -> np.ndarray:
    """World landmarks with the arms' geometry taken from the image and bone lengths.

    Weak perspective, per frame ``t``: the scale ``s_t`` (m/px) is the clip's median world torso
    length (shoulders' midpoint to hips' midpoint) over the torso's image length in that frame
    (the torso is assumed roughly parallel to the image plane: an upright person, a level
    camera). Every landmark's x, y become ``s_t * (pixel - hips' midpoint pixel)`` plus the
    world hips' midpoint (x right, y down, as MediaPipe's world frame); z stays the world z.
    Then along each arm (shoulder -> elbow -> wrist) a segment with image length ``d`` (m) and
    true length ``L`` (its ``length_percentile`` of ``d`` over the clip: the segment is seen
    parallel to the image in some frames) gets the depth difference
    ``dz = clip(world dz / sign_margin, -1, 1) * sqrt(max(L**2 - d**2, 0))`` (the sign of the
    world depth difference, softened within ``sign_margin``; 0 = the plain sign); the hand
    landmarks move with the wrist.
    A segment whose ``L`` is below :data:`MIN_LENGTH_RATIO` of its anthropometric length
    (:data:`TORSO_FRACTION` of the world torso) keeps the world depth difference (the
    percentile cannot be its true length), with a warning.

    Args:
        pixels: (T, 33, 2) px, MediaPipe landmark pixels (NaN where not detected).
        world: (T, 33, 3) m, MediaPipe world landmarks (NaN where not detected).
        length_percentile: in (0, 100].
        sign_margin: m, >= 0.

    Returns:
        (T, 33, 3) m, a new array; NaN where a needed landmark is missing.

    Raises:
        ValueError: shapes other than (T, 33, 2) / (T, 33, 3) with the same T, a
            percentile outside (0, 100] or a negative or non-finite ``sign_margin``.
    """
    pixels, world = np.asarray(pixels, float), np.asarray(world, float)
    n = len(MEDIAPIPE_LANDMARKS)
    if pixels.ndim != 3 or pixels.shape[1:] != (n, 2):
        raise ValueError(f"pixels must have shape (T, {n}, 2), got {pixels.shape}")
    if world.shape != (len(pixels), n, 3):
        raise ValueError(f"world must have shape ({len(pixels)}, {n}, 3), got {world.shape}")
    if not 0.0 < length_percentile <= 100.0:
        raise ValueError(f"length_percentile must be in (0, 100], got {length_percentile!r}")
    if not (np.isfinite(sign_margin) and sign_margin >= 0.0):
        raise ValueError(f"sign_margin must be a finite distance >= 0 m, got {sign_margin!r}")
    out = world.copy()
    hips_px, hips_w = pixels[:, _HIPS].mean(1), world[:, _HIPS].mean(1)
    torso_px = np.linalg.norm(pixels[:, _SHOULDERS].mean(1) - hips_px, axis=1)
    torso_w = np.linalg.norm(world[:, _SHOULDERS].mean(1) - hips_w, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(torso_px > 0, _nanmedian(torso_w) / torso_px, np.nan)
    out[..., :2] = scale[:, None, None] * (pixels - hips_px[:, None]) + hips_w[:, None, :2]
    torso = _nanmedian(torso_w)
    for chain, hand in ARM_CHAINS:
        for (a, b), fraction in zip(zip(chain[:-1], chain[1:]), TORSO_FRACTION):
            d = np.linalg.norm(out[:, b, :2] - out[:, a, :2], axis=1)
            length = np.nanpercentile(d, length_percentile) if np.isfinite(d).any() else np.nan
            world_dz = world[:, b, 2] - world[:, a, 2]
            expected = fraction * torso
            if length < MIN_LENGTH_RATIO * expected:
                warnings.warn(
                    f"lift_arm_depth: {MEDIAPIPE_LANDMARKS[a]}-{MEDIAPIPE_LANDMARKS[b]} never lies "
                    f"parallel to the image (seen at most ~{length:.3f} m long, expected ~{expected:.3f} m "
                    "from the torso); its depth stays the world landmarks'",
                    stacklevel=2,
                )
                out[:, b, 2] = out[:, a, 2] + world_dz
                continue
            sign = np.sign(world_dz) if sign_margin <= 0 else np.clip(world_dz / sign_margin, -1, 1)
            dz = sign * np.sqrt(np.clip(length**2 - d**2, 0, None))
            out[:, b, 2] = out[:, a, 2] + dz
        shift = out[:, chain[-1], 2] - world[:, chain[-1], 2]
        out[:, list(hand), 2] = world[:, list(hand), 2] + shift[:, None]
    return out


def _nanmedian(x: np.ndarray) -> float:
    return float(np.nanmedian(x)) if np.isfinite(x).any() else float("nan")
