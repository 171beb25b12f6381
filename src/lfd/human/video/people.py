"""Several people in a video: everyone found in each frame, followed over time, and the one chosen.

:func:`estimate_people` runs MediaPipe's pose landmarker with up to ``max_people`` people per
frame (:func:`~lfd.human.video.estimator.load_people_estimator`) and links the detections of
consecutive frames into *tracks* (:func:`track_people`): each frame's people are assigned to the
tracks by the Hungarian method on the distance from each track's predicted torso centre
(constant velocity), in torso lengths, plus the change of torso length (log ratio), so two people
who cross keep their identities when one is nearer the camera or they keep their headings. A
track may move ``max_jump + max_speed * dt`` torso lengths in the ``dt`` seconds since it was last
seen; a detection farther from every track starts a new one. The result is a
:class:`VideoPeople` (``(T, P, 33, ...)`` arrays, NaN where a track is absent).

:meth:`VideoPeople.person` gives one track as :class:`~lfd.human.video.VideoKeypoints`: frames
where that person is not found are marked (``detected`` False, NaN landmarks; ``other_person``
True when someone else is in view), never filled with someone else. Which track:
:func:`choose_person` in the first frame with anyone in it, by a rule (:data:`CHOICES`):

* ``"largest"``: the largest box around the landmarks seen (visibility >= 0.5);
* ``"central"``: the torso centre nearest the image centre;
* ``(x, y)``: a click point, px of the original frame: the person whose box contains it (the
  nearest torso centre among them);
* ``(x0, y0, x1, y1)``: a box, px: the person whose box overlaps it most (intersection over union).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lfd.io.video import frame_bar, increasing_times, iter_frames, video_info

from .keypoints import VideoKeypoints, read_cache, write_cache
from .landmarks import torso

__all__ = [
    "CHOICES",
    "CropSearch",
    "PeopleTracker",
    "VideoPeople",
    "check_person",
    "choose_person",
    "estimate_people",
    "track_people",
]

#: The named rules of :func:`choose_person` (a point or a box is given as numbers).
CHOICES = ("largest", "central")
#: Landmarks painted over when a person is hidden from a crop search: face, arms, shoulders, hips.
_HIDDEN = [0, 2, 5, 7, 8, 11, 12, 13, 14, 15, 16, 23, 24]
#: Landmarks at or above this visibility count towards a person's box.
_SEEN = 0.5


def _box(px: np.ndarray, vis: np.ndarray) -> np.ndarray:
    """(4,) x0, y0, x1, y1 px around the landmarks seen (all of them when fewer than 4 are)."""
    seen = px[(vis >= _SEEN) & np.isfinite(px).all(-1)]
    if len(seen) < 4:
        seen = px[np.isfinite(px).all(-1)]
    return np.concatenate([seen.min(0), seen.max(0)])


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    w = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    h = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = w * h
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def check_person(choice) -> str | tuple[float, ...]:
    """``choice`` as a rule name of :data:`CHOICES` or a tuple of 2 (point) or 4 (box) px numbers;
    ``ValueError`` naming ``person`` and the accepted forms otherwise."""
    if isinstance(choice, str):
        if choice not in CHOICES:
            raise ValueError(
                f"person must be one of {', '.join(CHOICES)}, a point [x, y] or a box [x0, y0, x1, y1] in px, "
                f"got {choice!r}"
            )
        return choice
    try:
        values = tuple(float(v) for v in choice)
    except (TypeError, ValueError):
        values = ()
    if len(values) not in (2, 4) or not np.isfinite(values).all():
        shown = list(choice) if isinstance(choice, list | tuple) else choice
        raise ValueError(
            f"person must be one of {', '.join(CHOICES)}, a point [x, y] or a box [x0, y0, x1, y1] in px, "
            f"got {shown!r}"
        )
    if len(values) == 4 and not (values[2] > values[0] and values[3] > values[1]):
        raise ValueError(f"person box [x0, y0, x1, y1] must have x1 > x0 and y1 > y0, got {list(values)}")
    return values


def choose_person(pixels: np.ndarray, visibility: np.ndarray, choice, image_size: tuple[int, int]) -> int:
    """Index of the chosen person among one frame's people.

    Args:
        pixels: (P, 33, 2) px of the P people found (P >= 1). visibility: (P, 33).
        choice: ``"largest"``, ``"central"``, a point ``(x, y)`` or a box ``(x0, y0, x1, y1)`` in px.
        image_size: (width, height) px.

    Raises:
        ValueError: a bad ``choice``; no person; a point inside nobody's box (the boxes are listed).
    """
    choice = check_person(choice)
    pixels = np.asarray(pixels, float)
    if pixels.ndim != 3 or pixels.shape[0] == 0:
        raise ValueError("choose_person needs at least one person, pixels of shape (P, 33, 2)")
    boxes = np.array([_box(p, v) for p, v in zip(pixels, visibility)])
    centres = np.array([torso(p)[0] for p in pixels])
    if choice == "largest":
        return int(np.argmax((boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])))
    if choice == "central":
        middle = np.asarray(image_size, float) / 2.0
        return int(np.argmin(np.linalg.norm(centres - middle, axis=1)))
    if len(choice) == 4:
        overlap = [_iou(np.asarray(choice), b) for b in boxes]
        if max(overlap) <= 0.0:
            raise ValueError(
                f"person box {list(choice)} overlaps nobody; people found at boxes {_listed(boxes)}"
            )
        return int(np.argmax(overlap))
    point = np.asarray(choice)
    inside = (boxes[:, :2] <= point).all(1) & (point <= boxes[:, 2:]).all(1)
    if not inside.any():
        raise ValueError(
            f"person point {list(choice)} is inside nobody's box; people found at boxes {_listed(boxes)}"
        )
    distance = np.where(inside, np.linalg.norm(centres - point, axis=1), np.inf)
    return int(np.argmin(distance))


def _listed(boxes: np.ndarray) -> str:
    return ", ".join("[" + ", ".join(f"{v:.0f}" for v in b) + "]" for b in boxes)


def _distinct(people: list) -> list:
    """``people`` without duplicates: of two detections whose torso centres lie within half a torso
    length of each other (the detector may return one person twice, or one person's shoulders with
    a neighbour's hips), the one with more landmarks seen is kept."""
    order = sorted(range(len(people)), key=lambda j: -float(people[j][1].sum()))
    kept: list = []
    for j in order:
        centre, length = torso(people[j][0])
        if all(np.linalg.norm(torso(k[0])[0] - centre) >= 0.5 * min(length, torso(k[0])[1]) for k in kept):
            kept.append(people[j])
    return kept


class PeopleTracker:
    """Online linking of each frame's people into tracks (see the module docstring).

    Args:
        max_jump, max_speed: torso lengths, torso lengths/s: the gate ``max_jump + max_speed * dt``.
    """

    def __init__(self, max_jump: float = 0.5, max_speed: float = 3.0):
        if not (max_jump > 0 and max_speed >= 0):
            raise ValueError(f"max_jump must be > 0 and max_speed >= 0, got {max_jump!r}, {max_speed!r}")
        self.max_jump, self.max_speed = float(max_jump), float(max_speed)
        self.tracks: list[dict] = []  # last seen time, torso centre, velocity, torso length, box

    def costs(self, people: np.ndarray, t: float) -> np.ndarray:
        """(n_tracks, N) cost of each track taking each person (inf outside the gate)."""
        cost = np.full((len(self.tracks), len(people)), np.inf)
        torsos = [torso(p) for p in people]
        for i, track in enumerate(self.tracks):
            dt = t - track["t"]
            predicted = track["centre"] + track["velocity"] * dt
            gate = self.max_jump + self.max_speed * dt
            for j, (centre, length) in enumerate(torsos):
                jump = np.linalg.norm(centre - predicted) / track["length"]
                if jump <= gate:
                    cost[i, j] = jump + abs(np.log(length / track["length"]))
        return cost

    def update(self, people: np.ndarray, t: float) -> np.ndarray:
        """Assign ``people`` (N, 33, 2) px found at time ``t`` s to tracks; new tracks for the rest.

        Returns:
            (N,) int track ids.
        """
        from scipy.optimize import linear_sum_assignment

        people = np.asarray(people, float).reshape(-1, 33, 2)
        ids = np.full(len(people), -1)
        if self.tracks and len(people):
            cost = self.costs(people, t)
            rows, cols = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e9))
            for i, j in zip(rows, cols):
                if np.isfinite(cost[i, j]):
                    ids[j] = i
        for j, p in enumerate(people):
            centre, length = torso(p)
            finite = p[np.isfinite(p).all(-1)]
            box = np.concatenate([finite.min(0), finite.max(0)])
            if ids[j] < 0:
                ids[j] = len(self.tracks)
                self.tracks.append(
                    {"t": t, "centre": centre, "velocity": np.zeros(2), "length": length, "box": box}
                )
                continue
            track = self.tracks[ids[j]]
            dt = t - track["t"]
            if dt > 0:
                track["velocity"] = 0.5 * track["velocity"] + 0.5 * (centre - track["centre"]) / dt
            track.update(t=t, centre=centre, length=length, box=box)
        return ids

    def claim(self, track: int, person: np.ndarray, t: float) -> int:
        """Give ``person`` (33, 2) px, found at ``t`` by a targeted search, to ``track``; returns ``track``."""
        centre, length = torso(person)
        finite = person[np.isfinite(person).all(-1)]
        entry = self.tracks[track]
        dt = t - entry["t"]
        if dt > 0:
            entry["velocity"] = 0.5 * entry["velocity"] + 0.5 * (centre - entry["centre"]) / dt
        entry.update(t=t, centre=centre, length=length, box=np.concatenate([finite.min(0), finite.max(0)]))
        return track

    def missing(self, seen: np.ndarray, t: float, within: float) -> list[tuple[int, np.ndarray]]:
        """Tracks not in ``seen`` (ids) last seen at most ``within`` s ago, with their predicted box
        (x0, y0, x1, y1) px: where to look for them again."""
        out = []
        for i, track in enumerate(self.tracks):
            dt = t - track["t"]
            if i in set(seen.tolist()) or dt > within:
                continue
            out.append((i, track["box"] + np.tile(track["velocity"] * dt, 2)))
        return out


def track_people(
    detections: Sequence[np.ndarray], t: np.ndarray, *, max_jump: float = 0.5, max_speed: float = 3.0
) -> tuple[list[np.ndarray], int]:
    """Link each frame's people into tracks (:class:`PeopleTracker`, see the module docstring).

    Args:
        detections: per frame, (N_f, 33, 2) px of the people found (N_f may be 0).
        t: (T,) s, increasing frame times.
        max_jump, max_speed: torso lengths, torso lengths/s: the gate ``max_jump + max_speed * dt``.

    Returns:
        (per frame an (N_f,) int array of track ids, the number of tracks).
    """
    if len(detections) != len(t):
        raise ValueError(f"detections has {len(detections)} frames but t has {len(t)}")
    tracker = PeopleTracker(max_jump, max_speed)
    out = [
        tracker.update(people, float(time_now)) for time_now, people in zip(np.asarray(t, float), detections)
    ]
    return out, len(tracker.tracks)


@dataclasses.dataclass(eq=False)
class VideoPeople:
    """Every person followed through a video (:func:`estimate_people`).

    Attributes:
        t: (T,) s. frame_index: (T,) int, as in :class:`VideoKeypoints`.
        pixels: (T, P, 33, 2) px of P tracks; NaN where a track is absent.
        visibility: (T, P, 33); 0 where absent. world: (T, P, 33, 3) m; NaN where absent.
        image_size: (width, height) px. source: the video. seconds: wall time, s. model: landmark model.
    """

    t: np.ndarray
    frame_index: np.ndarray
    pixels: np.ndarray
    visibility: np.ndarray
    world: np.ndarray
    image_size: tuple[int, int]
    source: str = ""
    seconds: float = float("nan")
    model: str = "full"

    @property
    def n_people(self) -> int:
        """P, the number of tracks."""
        return int(self.pixels.shape[1])

    @property
    def present(self) -> np.ndarray:
        """(T, P) bool, track p was found in frame t."""
        return np.isfinite(self.pixels).all(-1).any(-1)

    def choose(self, choice) -> int:
        """The track chosen by ``choice`` (:func:`choose_person`) in the first frame with anyone in it.

        Raises:
            ValueError: nobody in the video, or as :func:`choose_person`.
        """
        frames = np.flatnonzero(self.present.any(1))
        if not len(frames):
            raise ValueError(f"{self.source or 'video'}: nobody was found in any frame")
        f = frames[0]
        tracks = np.flatnonzero(self.present[f])
        try:
            k = choose_person(self.pixels[f, tracks], self.visibility[f, tracks], choice, self.image_size)
        except ValueError as exc:
            raise ValueError(f"{self.source or 'video'}, frame {int(self.frame_index[f])}: {exc}") from None
        return int(tracks[k])

    def person(self, track: int) -> VideoKeypoints:
        """Track ``track`` as :class:`VideoKeypoints`; frames without it are NaN (``detected`` False),
        ``other_person`` where someone else was found."""
        if not 0 <= track < self.n_people:
            raise ValueError(f"track must be in [0, {self.n_people}), got {track!r}")
        present = self.present
        return VideoKeypoints(
            t=self.t.copy(),
            frame_index=self.frame_index.copy(),
            pixels=self.pixels[:, track].copy(),
            visibility=self.visibility[:, track].copy(),
            world=self.world[:, track].copy(),
            detected=present[:, track].copy(),
            other_person=~present[:, track] & present.any(1),
            image_size=self.image_size,
            source=self.source,
            seconds=self.seconds,
            model=self.model,
        )

    def with_found(self, found: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]) -> VideoPeople:
        """A copy with one more track holding ``found``: ``{frame: (px (33, 2), visibility (33,),
        world (33, 3))}``, people found by a targeted search (:func:`search_people`)."""
        T = len(self.t)
        pixels = np.concatenate([self.pixels, np.full((T, 1, 33, 2), np.nan)], 1)
        visibility = np.concatenate([self.visibility, np.zeros((T, 1, 33))], 1)
        world = np.concatenate([self.world, np.full((T, 1, 33, 3), np.nan)], 1)
        for f, (px, vis, wl) in found.items():
            pixels[f, -1], visibility[f, -1], world[f, -1] = px, vis, wl
        return dataclasses.replace(self, pixels=pixels, visibility=visibility, world=world)

    def save(self, path: str | os.PathLike) -> Path:
        """Write all arrays to an ``.npz`` cache (read back with :meth:`load`)."""
        return write_cache(path, self, dataclasses.fields(self))

    @classmethod
    def load(cls, path: str | os.PathLike) -> VideoPeople:
        """Read a cache written by :meth:`save` (no pickled objects are loaded).

        Raises:
            FileNotFoundError: no file. ValueError: not such a cache.
        """
        p = Path(path)
        people = read_cache(p, cls, "people cache")
        T = len(people.t)
        if people.pixels.ndim != 4 or people.pixels.shape[0] != T or people.pixels.shape[2:] != (33, 2):
            raise ValueError(f"{p}: pixels must have shape (T={T}, P, 33, 2), got {people.pixels.shape}")
        P = people.pixels.shape[1]
        for name, shape in (("visibility", (T, P, 33)), ("world", (T, P, 33, 3)), ("frame_index", (T,))):
            if getattr(people, name).shape != shape:
                raise ValueError(f"{p}: {name} must have shape {shape}, got {getattr(people, name).shape}")
        return people


def estimate_people(
    video: str | os.PathLike,
    *,
    width: int | None = 640,
    stride: int = 1,
    max_frames: int | None = None,
    max_people: int = 4,
    min_detection_confidence: float = 0.5,
    min_tracking_confidence: float = 0.5,
    max_jump: float = 0.5,
    max_speed: float = 3.0,
    reacquire_s: float = 1.0,
    progress: bool = False,
    model: str = "full",
    heavy_model: str | os.PathLike | None = None,
) -> VideoPeople:
    """Find up to ``max_people`` people per frame and follow each (see the module docstring).

    Arguments as :func:`~lfd.human.video.estimate_keypoints`; ``max_people``: people per frame;
    ``reacquire_s``: s, how long a person not found is looked for in a crop around where they were.

    Raises:
        FileNotFoundError, ValueError, ImportError: as :func:`~lfd.human.video.estimate_keypoints`.
    """
    from .estimator import load_people_estimator, people_of

    info = video_info(video)
    landmarker = load_people_estimator(
        max_people, min_detection_confidence, min_tracking_confidence, model=model, heavy_model=heavy_model
    )
    import mediapipe as mp

    ts, idxs, found, ids = [], [], [], []
    tracker = PeopleTracker(max_jump, max_speed)
    bar = frame_bar(f"people {Path(video).name}", info, stride, max_frames) if progress else None
    start = time.perf_counter()

    def detect(rgb, offset=(0.0, 0.0)):
        image = mp.Image(image_format=mp.ImageFormat.SRGB, data=np.ascontiguousarray(rgb))
        return people_of(landmarker.detect(image), (rgb.shape[1], rgb.shape[0]), offset, scale)

    try:
        for index, t, rgb in iter_frames(video, width, stride, max_frames):
            scale = info.width / rgb.shape[1]
            people = _distinct(detect(rgb))
            frame_ids = tracker.update(np.array([p[0] for p in people]).reshape(-1, 33, 2), t)
            # A second pass on crops: each recently seen person not found in the whole frame is
            # looked for around where they were (the detector misses people who are small or
            # overlap someone else); what is found must pass that person's gate and be no one
            # already found.
            for track, box in tracker.missing(frame_ids, t, reacquire_s):
                pad = 0.25 * (box[2:] - box[:2]).max()
                x0, y0 = np.maximum((box[:2] - pad) / scale, 0).astype(int)
                x1, y1 = ((box[2:] + pad) / scale).astype(int)
                crop = rgb[y0 : max(y1, 0), x0 : max(x1, 0)]
                if crop.shape[0] < 32 or crop.shape[1] < 32:
                    continue
                again = detect(crop, (x0 * scale, y0 * scale))
                if not again:
                    continue
                cost = tracker.costs(np.array([p[0] for p in again]), t)[track]
                best = int(np.argmin(cost))
                centre, length = torso(again[best][0])
                taken = any(np.linalg.norm(torso(p[0])[0] - centre) < 0.5 * length for p in people)
                if np.isfinite(cost[best]) and not taken:
                    people.append(again[best])
                    frame_ids = np.append(frame_ids, tracker.claim(track, again[best][0], t))
            found.append(people)
            ids.append(frame_ids)
            ts.append(t)
            idxs.append(index)
            if bar is not None:
                bar.update(1)
    finally:
        landmarker.close()
        if bar is not None:
            bar.close()
    t = increasing_times(ts)
    T, P = len(t), len(tracker.tracks)
    pixels, world = np.full((T, P, 33, 2), np.nan), np.full((T, P, 33, 3), np.nan)
    visibility = np.zeros((T, P, 33))
    for f, (people, track_ids) in enumerate(zip(found, ids)):
        for (px, vis, wl), k in zip(people, track_ids):
            pixels[f, k], visibility[f, k], world[f, k] = px, vis, wl
    return VideoPeople(
        t=t,
        frame_index=np.array(idxs, int),
        pixels=pixels,
        visibility=visibility,
        world=world,
        image_size=(info.width, info.height),
        source=str(video),
        seconds=time.perf_counter() - start,
        model=model,
    )


class CropSearch:
    """``search(view, frame, box)`` for :func:`lfd.human.multiview.people.follow_person`: the people
    MediaPipe finds in a crop of a frame of one of several videos (frames asked in increasing
    order per view, numbered as :func:`estimate_people` with the same ``width`` numbers them).
    Close it (or use it as a context manager) to release the estimator."""

    def __init__(
        self,
        videos: Sequence,
        *,
        width: int | None = 640,
        max_people: int = 2,
        min_detection_confidence: float = 0.3,
        model: str = "full",
        heavy_model: str | os.PathLike | None = None,
    ):
        from .estimator import load_people_estimator

        self.videos = [Path(v) for v in videos]
        self.width = width
        self._info = [video_info(v) for v in self.videos]
        self._frames = [iter_frames(v, width, 1, None) for v in self.videos]
        self._current: list = [(-1, None)] * len(self.videos)
        self._landmarker = load_people_estimator(
            max_people, min_detection_confidence, min_detection_confidence, model, heavy_model
        )

    def _frame(self, view: int, frame: int):
        f, rgb = self._current[view]
        while f < frame:
            try:
                _index, _t, rgb = next(self._frames[view])
            except StopIteration:
                return None
            f += 1
        self._current[view] = (f, rgb)
        return rgb if f == frame else None

    def __call__(self, view: int, frame: int, box, hide=()) -> list:
        """People found in ``box`` (x0, y0, x1, y1 px) of ``frame`` of video ``view``, with the
        people ``hide`` ((33, 2) px each) painted grey first (the hull of their face, arms and
        torso, grown by 15 %)."""
        import cv2
        import mediapipe as mp

        from .estimator import people_of

        rgb = self._frame(view, frame)
        if rgb is None:
            return []
        scale = self._info[view].width / rgb.shape[1]
        box = np.asarray(box, float)
        x0, y0 = np.maximum(box[:2] / scale, 0).astype(int)
        x1, y1 = np.minimum(box[2:] / scale, (rgb.shape[1], rgb.shape[0])).astype(int)
        if x1 - x0 < 32 or y1 - y0 < 32:
            return []
        crop = np.ascontiguousarray(rgb[y0:y1, x0:x1])
        for px in hide:
            pts = px[_HIDDEN] / scale - (x0, y0)
            pts = pts[np.isfinite(pts).all(-1)]
            if len(pts) >= 3:
                hull = cv2.convexHull(pts.astype(np.float32)).reshape(-1, 2)
                centre = hull.mean(0)
                cv2.fillPoly(crop, [(centre + 1.15 * (hull - centre)).astype(np.int32)], (128, 128, 128))
        image = mp.Image(image_format=mp.ImageFormat.SRGB, data=crop)
        return people_of(
            self._landmarker.detect(image), (crop.shape[1], crop.shape[0]), (x0 * scale, y0 * scale), scale
        )

    def close(self) -> None:
        self._landmarker.close()
        for frames in self._frames:
            frames.close()

    def __enter__(self) -> CropSearch:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
