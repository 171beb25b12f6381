"""The pose landmarks of one person in a video (:class:`VideoKeypoints`): conversion to a
:class:`~lfd.human.Skeleton`, a per-frame table/CSV and an ``.npz`` cache."""

from __future__ import annotations

import dataclasses
import io
import os
import zipfile
from pathlib import Path

import numpy as np

from lfd.io.files import write_bytes_atomic, write_text_atomic

from ..skeleton import Skeleton
from .flips import front_back_flips, undo_flips
from .landmarks import CANONICAL_NAMES, MEDIAPIPE_LANDMARKS
from .lifting import lift_arm_depth

__all__ = ["VideoKeypoints", "read_cache", "write_cache"]

#: Fields of a keypoint cache that are not arrays, and how each is read back.
_SCALARS = {"image_size": lambda v: tuple(int(x) for x in v), "source": str, "seconds": float, "model": str}


def write_cache(path: str | os.PathLike, record, fields) -> Path:
    """Write the ``fields`` (dataclass fields) of ``record`` to a compressed ``.npz``, atomically
    (:func:`read_cache` reads it back); the landmark names are not written."""
    buffer = io.BytesIO()
    np.savez_compressed(
        buffer, **{f.name: np.asarray(getattr(record, f.name)) for f in fields if f.name != "names"}
    )
    write_bytes_atomic(Path(path), buffer.getvalue())
    return Path(path)


def read_cache(path: str | os.PathLike, cls, what: str, defaults: dict | None = None):
    """``cls(**arrays)`` of a cache written by :func:`write_cache` (no pickled objects are loaded);
    a field missing from the file takes its value in ``defaults``.

    Raises:
        FileNotFoundError: no file. ValueError: not such a cache (``"<path>: not a <what> written by lfd"``).
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{what} not found: {p}")
    names = [f.name for f in dataclasses.fields(cls) if f.name != "names"]
    try:
        with np.load(p, allow_pickle=False) as z:
            values = {n: z[n] if n in z.files or n not in (defaults or {}) else defaults[n] for n in names}
        for name, convert in _SCALARS.items():
            if name in values and isinstance(values[name], np.ndarray):
                values[name] = convert(values[name])
        return cls(**values)
    except (OSError, ValueError, KeyError, EOFError, TypeError, zipfile.BadZipFile) as exc:
        raise ValueError(f"{p}: not a {what} written by lfd ({type(exc).__name__}: {exc})") from None


@dataclasses.dataclass(eq=False)
class VideoKeypoints:
    """Pose landmarks of one person in a video.

    Attributes:
        t: (T,) s, presentation time of each processed frame (first frame = 0).
        frame_index: (T,) int, index of the frame in the video stream.
        pixels: (T, 33, 2) px in the original frame (x right, y down); NaN where not detected.
        visibility: (T, 33) in [0, 1] (MediaPipe's visibility); 0 where not detected.
        world: (T, 33, 3) m, MediaPipe world landmarks (origin between the hips; x right,
            y down, z away from the camera); NaN where not detected.
        detected: (T,) bool, the followed person was found.
        other_person: (T,) bool, a different person was found and left out.
        image_size: (width, height) px of the original frames.
        source: the video path. seconds: wall time of the estimation, s.
        names: the 33 landmark names (:data:`MEDIAPIPE_LANDMARKS`).
        model: the landmark model (``"full"`` or ``"heavy"``).
    """

    t: np.ndarray
    frame_index: np.ndarray
    pixels: np.ndarray
    visibility: np.ndarray
    world: np.ndarray
    detected: np.ndarray
    other_person: np.ndarray
    image_size: tuple[int, int]
    source: str = ""
    seconds: float = float("nan")
    names: tuple[str, ...] = MEDIAPIPE_LANDMARKS
    model: str = "full"

    @property
    def n_frames(self) -> int:
        """T, the number of processed frames."""
        return len(self.t)

    @property
    def fps(self) -> float:
        """Frames processed per second of wall time (estimation speed)."""
        return self.n_frames / self.seconds if self.seconds > 0 else float("nan")

    def front_back_flips(self, switch: float = 0.5) -> np.ndarray:
        """(T,) bool: frames whose left/right labels MediaPipe swapped (front/back confusion);
        see :func:`lfd.human.video.flips.front_back_flips`."""
        return front_back_flips(self.pixels, self.detected, switch)

    def repaired(self, switch: float = 0.5) -> VideoKeypoints:
        """A copy with the :meth:`front_back_flips` undone (:func:`lfd.human.video.flips.undo_flips`:
        left/right landmarks swapped back, world depth mirrored)."""
        pixels, visibility, world = undo_flips(
            self.pixels, self.visibility, self.world, self.front_back_flips(switch)
        )
        return dataclasses.replace(self, pixels=pixels, visibility=visibility, world=world)

    def to_skeleton(
        self, min_visibility: float = 0.5, repair_flips: bool = False, lift_depth: bool = True
    ) -> Skeleton:
        """A :class:`Skeleton` of the world landmarks with canonical joint names.

        Landmarks with visibility below ``min_visibility`` are marked untracked (treated as
        missing by :func:`~lfd.human.analyze_arm`); ``up`` is ``(0, -1, 0)`` (MediaPipe's y
        points down). With ``repair_flips`` the frames MediaPipe labelled back to front are
        repaired first (:meth:`repaired`; reliable for a person facing the camera, not for a
        side view of a walk, where the global labelling is ambiguous). With ``lift_depth`` (the
        default, chosen on a validation split: docs/video.md) the arms' x, y come from the pixels
        and their depth from bone lengths, the world landmarks giving only its sign
        (:func:`~lfd.human.video.lifting.lift_arm_depth`; weak perspective, an upright torso
        roughly parallel to the image; a segment never seen parallel to the image keeps its
        world depth, with a warning); ``lift_depth=False`` gives MediaPipe's world landmarks
        as they are. Raises ``ValueError`` when no frame has a person.
        """
        if not 0.0 <= min_visibility <= 1.0:
            raise ValueError(f"min_visibility must be in [0, 1], got {min_visibility!r}")
        if not self.detected.any():
            raise ValueError(
                f"no person found in any of the {self.n_frames} frames of {self.source or 'the video'}"
            )
        kp = self.repaired() if repair_flips else self
        tracked = (kp.visibility >= min_visibility) & kp.detected[:, None]
        world = kp.world
        if lift_depth:  # as validated in benchmarks/video_multiview.py: every landmark given
            world = lift_arm_depth(kp.pixels, kp.world)
            tracked &= np.isfinite(world).all(-1)
        return Skeleton(
            kp.t,
            CANONICAL_NAMES,
            world,
            tracked,
            source=f"{kp.source} (mediapipe)",
            up=np.array([0.0, -1.0, 0.0]),
        )

    def points(self, names) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (T, K, 2) and visibility (T, K) of landmarks by MediaPipe or canonical name."""
        idx = [self.names.index(n) if n in self.names else CANONICAL_NAMES.index(n) for n in names]
        return self.pixels[:, idx], self.visibility[:, idx]

    def table(self) -> dict[str, np.ndarray]:
        """Per-frame columns: time, frame, flags, and per landmark px, py, visibility, X, Y, Z (m)."""
        cols = {
            "time_s": self.t,
            "frame": self.frame_index.astype(float),
            "detected": self.detected.astype(float),
            "other_person": self.other_person.astype(float),
        }
        for j, name in enumerate(CANONICAL_NAMES):
            cols[f"{name}_px"], cols[f"{name}_py"] = self.pixels[:, j, 0], self.pixels[:, j, 1]
            cols[f"{name}_visibility"] = self.visibility[:, j]
            for k, axis in enumerate("xyz"):
                cols[f"{name}_{axis}_m"] = self.world[:, j, k]
        return cols

    def to_csv(self, path: str | os.PathLike) -> Path:
        """Write :meth:`table` as CSV (NaN as empty). Returns the path."""
        cols = self.table()
        data = np.column_stack(list(cols.values()))
        lines = [",".join(cols)] + [
            ",".join("" if not np.isfinite(v) else f"{v:.6g}" for v in row) for row in data
        ]
        return write_text_atomic(Path(path), "\n".join(lines) + "\n")

    def save(self, path: str | os.PathLike) -> Path:
        """Write all arrays to an ``.npz`` cache (read back with :meth:`load`)."""
        return write_cache(path, self, dataclasses.fields(self))

    @classmethod
    def load(cls, path: str | os.PathLike) -> VideoKeypoints:
        """Read a cache written by :meth:`save` (no pickled objects are loaded).

        Raises:
            FileNotFoundError: no file at ``path``.
            ValueError: the file is not such a cache (corrupt, truncated, or missing arrays).
        """
        return read_cache(path, cls, "keypoint cache", defaults={"model": "full"})
