"""Front/back relabelling of MediaPipe landmarks: finding the frames whose left and right labels
were swapped, and undoing it."""

from __future__ import annotations

import numpy as np

from .landmarks import ALL_LEFT, ALL_RIGHT, TRUNK_LEFT, TRUNK_RIGHT, torso

__all__ = ["front_back_flips", "undo_flips"]


def front_back_flips(pixels: np.ndarray, detected: np.ndarray, switch: float = 0.5) -> np.ndarray:
    """(T,) bool: frames of ``pixels`` (T, 33, 2) px whose left/right labels MediaPipe swapped (front/back confusion).

    BlazePose sometimes decides in one frame that a person facing the camera has turned
    their back to it (or the reverse): every left landmark takes the right one's place in
    the image. A real turn moves the landmarks continuously, so the labelling of each
    detected frame (as given, or swapped) is chosen by dynamic programming to minimise the
    summed pixel distance of the trunk landmarks (shoulders, hips) from one detected frame to
    the next, plus ``switch`` torso lengths for every change of labelling (so ambiguous,
    side-on frames do not toggle it); of the two global labellings the one MediaPipe gave
    for most frames is kept. Returns the frames to swap (never one that is not ``detected`` (T,)).

    Raises:
        ValueError: ``switch`` < 0.
    """
    if switch < 0:
        raise ValueError(f"switch must be >= 0 (torso lengths per change of labelling), got {switch!r}")
    frames = np.nonzero(detected)[0]
    flips = np.zeros(len(detected), bool)
    if len(frames) == 0:
        return flips
    px = pixels[frames]
    length = np.median([torso(p)[1] for p in px])
    direct = (
        np.linalg.norm(px[1:, TRUNK_LEFT] - px[:-1, TRUNK_LEFT], axis=-1)
        + np.linalg.norm(px[1:, TRUNK_RIGHT] - px[:-1, TRUNK_RIGHT], axis=-1)
    ).sum(1)
    cross = (
        np.linalg.norm(px[1:, TRUNK_RIGHT] - px[:-1, TRUNK_LEFT], axis=-1)
        + np.linalg.norm(px[1:, TRUNK_LEFT] - px[:-1, TRUNK_RIGHT], axis=-1)
    ).sum(1)
    direct, cross = np.nan_to_num(direct, nan=0.0), np.nan_to_num(cross, nan=0.0)
    n = len(frames)
    cost = np.zeros(2)  # state 0: labels as given, 1: swapped
    back = np.zeros((n, 2), int)
    for i in range(1, n):
        stay = cost + direct[i - 1]  # same state as the previous frame
        move = cost[::-1] + cross[i - 1] + switch * length  # the other state
        back[i] = np.where(stay <= move, [0, 1], [1, 0])
        cost = np.minimum(stay, move)
    state = np.zeros(n, int)
    state[-1] = int(np.argmin(cost))
    for i in range(n - 1, 0, -1):
        state[i - 1] = back[i, state[i]]
    flips[frames] = state.astype(bool)
    if flips[frames].mean() > 0.5:
        flips[frames] = ~flips[frames]
    return flips


def undo_flips(
    pixels: np.ndarray, visibility: np.ndarray, world: np.ndarray, flips: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Copies of ``pixels`` (T, 33, 2), ``visibility`` (T, 33) and ``world`` (T, 33, 3) with the
    left/right landmarks of the ``flips`` (T,) frames swapped back and their world depth mirrored
    (``z -> -z`` about the hips: the relabelled estimate is the mirror image of the person
    through the image plane)."""
    out = pixels.copy(), visibility.copy(), world.copy()
    for arr in out:
        sub = arr[flips]
        sub[:, ALL_LEFT], sub[:, ALL_RIGHT] = arr[flips][:, ALL_RIGHT], arr[flips][:, ALL_LEFT]
        arr[flips] = sub
    out[2][flips, :, 2] *= -1.0
    return out
