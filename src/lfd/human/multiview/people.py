"""The same person in every calibrated view, frame by frame, when several people are in view.

:func:`follow_person` takes, per view, everyone found in each frame (the tracks of
:class:`lfd.human.video.people.VideoPeople`: ``(T, P_v, 33, 2)`` px, NaN where absent) and the
person chosen in a reference view, and returns which track shows that person in each view and
frame (``-1``: nobody there is that person; the frame is then left out of that view, never
filled with someone else).

* **Start** (the first frame where the chosen person is found in the reference view): in each
  other view, among the people whose joints lie within ``max_epipolar`` torso lengths of the
  epipolar lines of the chosen person's joints (symmetric epipolar distance, median over the
  joints seen in both views; as Pose2Sim's multi-person mode associates people), the one whose
  pair with the reference, triangulated, lands on someone in the most other views (then the
  smallest epipolar distance): cameras at one height have nearly parallel epipolar lines, which
  anyone of a similar height fits.
* **Every later frame**, per view: the person's skeleton as the *other* views saw it last (all
  views when fewer than two others did) is projected into the view; if ``search`` is given, a
  crop around that projection is searched again, with the people clearly elsewhere painted
  over. The person (whole-frame or found in the crop, labels as given or left/right swapped)
  whose joints lie closest to the projection is taken if within ``max_jump + max_speed * dt``
  torso lengths (median over the joints seen; the shoulders and hips alone must fit as well, so
  a detection mixing two people's parts is not taken). Of three or more views, those that the
  pair of views most others agree with does not fit are dropped (``agree_within``); a frame whose
  triangulated torso would jump farther than a person moves keeps no view. Two people who cross
  in one image are told apart by where they stand in 3-D, which the other views see.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence

import numpy as np

from .calibration import Calibration
from .triangulation import triangulate

__all__ = ["PersonInViews", "epipolar_distance", "follow_person", "follow_person_in_videos"]

#: Shoulders and hips (MediaPipe indices): the torso length of a projection or a detection.
_SHOULDERS, _HIPS = (11, 12), (23, 24)
#: MediaPipe's landmark order with every left/right pair swapped.
_SWAP = np.arange(33)
_SWAP[[1, 2, 3, 4, 5, 6]] = [4, 5, 6, 1, 2, 3]  # eyes
_SWAP[7:33] = np.arange(7, 33) + np.where(np.arange(7, 33) % 2, 1, -1)  # ears ... feet: odd left, even right
#: Landmarks at or above this visibility take part in the association.
_SEEN = 0.5


def _torso_length(px: np.ndarray) -> float:
    length = np.linalg.norm(px[list(_SHOULDERS)].mean(0) - px[list(_HIPS)].mean(0))
    return float(length) if np.isfinite(length) and length >= 1.0 else np.nan


@dataclasses.dataclass
class PersonInViews:
    """Result of :func:`follow_person`.

    Attributes:
        tracks: (C, T) int, the track showing the chosen person per view and frame; -1 where none does.
        points: (T, 33, 3) m, the person's skeleton as followed (triangulated from the chosen views;
            the last one carried over where fewer than two views have them); NaN before the start.
        found: per view, ``{frame: (px, visibility, world)}`` taken from ``search`` (their track
            index in ``tracks`` is one past the view's tracks).
        swapped: (C, T) bool, the person's left/right labels were swapped to fit the skeleton (the
            entries of ``found`` are stored with the labels as taken).
    """

    tracks: np.ndarray
    points: np.ndarray
    found: list = dataclasses.field(default_factory=list)
    swapped: np.ndarray | None = None


def epipolar_distance(calib: Calibration, a: int, b: int, px_a: np.ndarray, px_b: np.ndarray) -> np.ndarray:
    """Symmetric epipolar distance (px) of corresponding points seen by cameras ``a`` and ``b``.

    Args:
        px_a, px_b: (..., 2) px in views ``a`` and ``b`` (the same points).

    Returns:
        (...) px: the mean of each point's distance from the epipolar line of its partner, each in
        its own view's pixels (normalised distance times that camera's focal length).
    """
    both = np.stack([np.asarray(px_a, float), np.asarray(px_b, float)])
    cams = Calibration(
        tuple(calib.names[i] for i in (a, b)),
        calib.K[[a, b]],
        calib.dist[[a, b]],
        calib.R[[a, b]],
        calib.t[[a, b]],
        calib.size[[a, b]],
    )
    norm = cams.undistort(both)
    xa = np.concatenate([norm[0], np.ones(norm[0].shape[:-1] + (1,))], -1)
    xb = np.concatenate([norm[1], np.ones(norm[1].shape[:-1] + (1,))], -1)
    R = calib.R[b] @ calib.R[a].T
    t = calib.t[b] - R @ calib.t[a]
    E = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]]) @ R
    line_b = xa @ E.T  # epipolar lines in view b of the points of view a
    line_a = xb @ E
    with np.errstate(invalid="ignore", divide="ignore"):
        d_b = np.abs((xb * line_b).sum(-1)) / np.linalg.norm(line_b[..., :2], axis=-1) * calib.K[b, 0, 0]
        d_a = np.abs((xa * line_a).sum(-1)) / np.linalg.norm(line_a[..., :2], axis=-1) * calib.K[a, 0, 0]
    return 0.5 * (d_a + d_b)


def follow_person(
    calib: Calibration,
    pixels: Sequence[np.ndarray],
    visibility: Sequence[np.ndarray],
    t: np.ndarray,
    reference: int,
    person: int,
    *,
    max_epipolar: float = 0.25,
    max_jump: float = 0.5,
    max_speed: float = 3.0,
    max_error_px: float = 20.0,
    search=None,
    hide_beyond: float = 0.25,
    max_step_m: float = 0.2,
    max_speed_m: float = 2.0,
    agree_within: float = 0.5,
) -> PersonInViews:
    """Which track shows the chosen person in each view and frame (see the module docstring).

    Args:
        calib: C cameras.
        pixels: per view, (T, P_v, 33, 2) px of its P_v tracks (NaN where absent).
        visibility: per view, (T, P_v, 33).
        t: (T,) s, frame times (the views are synchronised).
        reference: the view in which the person was chosen. person: their track there.
        max_epipolar: torso lengths; the start's association gate.
        max_jump, max_speed: torso lengths, torso lengths/s; the gate of later frames.
        max_error_px: px, :func:`~lfd.human.multiview.triangulate`'s view rejection.
        agree_within: torso lengths; with three or more views taken, a view whose person lies
            farther than this from the projection of the pair of views most others agree with is
            dropped for that frame.
        max_step_m, max_speed_m: m, m/s; a frame whose triangulated torso centre lies farther than
            ``max_step_m + max_speed_m * dt`` from the last one keeps no view (the views taken
            cannot all show the person).
        search: optional ``search(view, frame, box, hide) -> [(px (33, 2), visibility (33,), world (33, 3)), ...]``,
            the people a pose estimator finds in the crop ``box`` (x0, y0, x1, y1 px) around where the
            person's skeleton projects in that view and frame, with the people ``hide`` ((33, 2) px
            each: those of the frame farther than ``hide_beyond`` torso lengths from the projection)
            painted over; they join that frame's people (the detector of a whole frame misses people
            next to or behind someone else). Called once
            per view and frame after the start, in increasing frame order. What is taken from it
            is in :attr:`PersonInViews.found` (track index ``P_v``, one past the view's tracks).

    Returns:
        :class:`PersonInViews` (``tracks`` (C, T): the chosen person's track per view and frame, -1
        where none is).

    Raises:
        ValueError: a view count other than C, shapes that disagree, a bad ``reference``/``person``,
        or the chosen person never found in the reference view.
    """
    C = calib.n_cameras
    if len(pixels) != C or len(visibility) != C:
        raise ValueError(
            f"pixels and visibility must have one entry per camera ({C}), got {len(pixels)}, {len(visibility)}"
        )
    T = len(t)
    for v, (px, vis) in enumerate(zip(pixels, visibility)):
        if px.ndim != 4 or px.shape[0] != T or px.shape[2:] != (33, 2) or vis.shape != px.shape[:3]:
            raise ValueError(
                f"view {v}: pixels must have shape (T={T}, P, 33, 2) and visibility (T, P, 33), "
                f"got {px.shape} and {vis.shape}"
            )
    if not 0 <= reference < C:
        raise ValueError(f"reference must be a view in [0, {C}), got {reference!r}")
    if not 0 <= person < pixels[reference].shape[1]:
        raise ValueError(
            f"person must be a track of view {reference} in [0, {pixels[reference].shape[1]}), got {person!r}"
        )
    # one more column per view for what ``search`` finds
    pixels = [np.concatenate([px, np.full((T, 1, 33, 2), np.nan)], 1) for px in pixels]
    visibility = [np.concatenate([vis, np.zeros((T, 1, 33))], 1) for vis in visibility]
    searched: list[dict] = [{} for _ in range(C)]
    swapped = np.zeros((C, T), bool)
    present = [np.isfinite(px).all(-1).any(-1) for px in pixels]  # (T, P_v + 1) per view
    found = np.flatnonzero(present[reference][:, person])
    if not len(found):
        raise ValueError(f"track {person} of view {reference} is never found")
    chosen = np.full((C, T), -1)
    points = np.full((T, 33, 3), np.nan)
    f0 = int(found[0])
    chosen[reference, f0] = person
    ref_px, ref_vis = pixels[reference][f0, person], visibility[reference][f0, person]
    for v in range(C):
        if v == reference:
            continue
        best, best_key = -1, (np.inf, np.inf)
        for k in np.flatnonzero(present[v][f0]):
            seen = (ref_vis >= _SEEN) & (visibility[v][f0, k] >= _SEEN)
            if seen.sum() < 4:
                continue
            d = np.nanmedian(epipolar_distance(calib, reference, v, ref_px[seen], pixels[v][f0, k][seen]))
            d /= _torso_length(pixels[v][f0, k])
            if not d <= max_epipolar:
                continue
            # Cameras at one height have nearly parallel epipolar lines, which anyone of a similar
            # height fits: prefer the pair that lands on someone in more of the other views.
            pair = np.full(C, -1)
            pair[reference], pair[v] = person, k
            pair_points = _triangulate(calib, pixels, visibility, pair, f0, np.inf)
            if pair_points is None:
                continue
            projected = calib.project(pair_points)
            support = sum(
                _nearest(projected[w], pixels[w][f0], visibility[w][f0]) <= max_jump
                for w in range(C)
                if w not in (reference, v)
            )
            if (-support, d) < best_key:
                best, best_key = k, (-support, d)
        chosen[v, f0] = best
    _consensus(calib, pixels, visibility, chosen[:, f0], f0, agree_within)
    skeleton = _triangulate(calib, pixels, visibility, chosen[:, f0], f0, max_error_px)
    if skeleton is not None:
        points[f0] = skeleton
    last_t = t[f0]
    for f in range(f0 + 1, T):
        if skeleton is None:
            break
        projected = calib.project(skeleton)  # (C, 33, 2)
        # Each view is judged against the skeleton the *other* views saw last (when at least two
        # did): a view that took someone standing close to the person cannot drag the skeleton,
        # and so its own yardstick, towards them.
        previous = chosen[:, f - 1] if f > f0 else chosen[:, f0]
        for v in range(C):
            others = previous.copy()
            others[v] = -1
            if (others >= 0).sum() >= 2:
                alone = _triangulate(calib, pixels, visibility, others, f - 1, max_error_px)
                if alone is not None:
                    by_others = calib.project(alone)[v]
                    projected[v] = np.where(np.isfinite(by_others), by_others, projected[v])
        gate = max_jump + max_speed * (t[f] - last_t)
        for v in range(C):
            if search is not None:
                box = _crop_box(projected[v], calib.size[v])
                if box is not None:
                    # people of the whole frame who are clearly someone else are painted over in
                    # the crop: the detector, drawn to faces, finds a neighbour facing the camera
                    # before a person seen from behind
                    hide = [
                        pixels[v][f, k]
                        for k in np.flatnonzero(present[v][f][:-1])
                        if _nearest(projected[v], pixels[v][f, k][None], visibility[v][f, k][None])
                        > hide_beyond
                    ]
                    extra = search(v, f, box, hide)
                    if extra:
                        options = [(e[0][o], e[1][o], e[2][o]) for e in extra for o in (slice(None), _SWAP)]
                        pick = int(
                            np.argmin([_nearest(projected[v], e[0][None], e[1][None]) for e in options])
                        )
                        extra = options
                        searched[v][f] = extra[pick]
                        pixels[v][f, -1], visibility[v][f, -1] = extra[pick][0], extra[pick][1]
                        present[v][f, -1] = True
            best, best_d = -1, np.inf
            best_swap = False
            for k in np.flatnonzero(present[v][f]):
                for swap in (False, True):  # the estimator may have swapped the left/right labels
                    order = _SWAP if swap else slice(None)
                    d = _nearest(projected[v], pixels[v][f, k][order][None], visibility[v][f, k][order][None])
                    if d < best_d:
                        best, best_d, best_swap = k, d, swap
            if best_d <= gate:
                chosen[v, f] = best
                if best_swap:
                    pixels[v][f, best] = pixels[v][f, best][_SWAP]
                    visibility[v][f, best] = visibility[v][f, best][_SWAP]
                    swapped[v, f] = True
        _consensus(calib, pixels, visibility, chosen[:, f], f, agree_within)
        update = _triangulate(calib, pixels, visibility, chosen[:, f], f, max_error_px)
        if update is not None:
            step = np.linalg.norm(_centre(update) - _centre(skeleton))
            if step > max_step_m + max_speed_m * (t[f] - last_t):
                chosen[:, f] = -1  # the views taken disagree with where the person can be: none kept
            else:
                skeleton = np.where(np.isfinite(update), update, skeleton)
                last_t = t[f]
        points[f] = skeleton
    for v in range(C):
        last = pixels[v].shape[1] - 1
        taken = {}
        for f in np.flatnonzero(chosen[v] == last):  # as taken: with the labels the person was given
            world = searched[v][f][2][_SWAP] if swapped[v, f] else searched[v][f][2]
            taken[int(f)] = (pixels[v][f, -1].copy(), visibility[v][f, -1].copy(), world)
            swapped[v, f] = False
        searched[v] = taken
    return PersonInViews(chosen, points, searched, swapped)


def _crop_box(projected: np.ndarray, size: np.ndarray, pad: float = 0.2):
    """(x0, y0, x1, y1) px around the projected joints (33, 2), grown by ``pad`` of the larger side;
    None when fewer than 4 joints project or the centre is outside the image."""
    px = projected[np.isfinite(projected).all(-1)]
    if len(px) < 4:
        return None
    centre = px.mean(0)
    if not (0 <= centre[0] < size[0] and 0 <= centre[1] < size[1]):
        return None
    lo, hi = px.min(0), px.max(0)
    grow = pad * (hi - lo).max()
    return np.concatenate([lo - grow, hi + grow])


def _consensus(calib, pixels, visibility, tracks: np.ndarray, f: int, tolerance: float) -> None:
    """Drop (set to -1 in place) the views of ``tracks`` at frame ``f`` that disagree with the rest:
    with three or more views, every pair is triangulated and the pair that the most views' people
    land on (within ``tolerance`` torso lengths of its projection) decides. Two views that fit
    each other (a wrong person on the epipolar lines) cannot outvote the others."""
    views = np.flatnonzero(tracks >= 0)
    if len(views) < 3:
        return
    best, best_key = None, (0, np.inf)
    for a, b in itertools.combinations(views, 2):
        pair = np.full(len(tracks), -1)
        pair[[a, b]] = tracks[[a, b]]
        pair_points = _triangulate(calib, pixels, visibility, pair, f, np.inf)
        if pair_points is None:
            continue
        projected = calib.project(pair_points)
        gaps = {
            w: _nearest(projected[w], pixels[w][f, tracks[w]][None], visibility[w][f, tracks[w]][None])
            for w in views
        }
        agree = [w for w in views if gaps[w] <= tolerance]
        key = (-len(agree), float(np.mean([gaps[w] for w in agree])) if agree else np.inf)
        if key < best_key:
            best, best_key = agree, key
    if best is not None and len(best) >= 2:
        for w in views:
            if w not in best:
                tracks[w] = -1


def _centre(points: np.ndarray) -> np.ndarray:
    """(3,) the mean of the shoulders and hips (whichever are known) of a (33, 3) skeleton."""
    torso = points[list(_SHOULDERS + _HIPS)]
    torso = torso[np.isfinite(torso).all(-1)]
    return torso.mean(0) if len(torso) else np.full(3, np.nan)


def _nearest(projected: np.ndarray, people: np.ndarray, visibility: np.ndarray) -> float:
    """Torso lengths from ``projected`` (33, 2) px to the closest of ``people`` (P, 33, 2) (median
    over the joints seen), inf when nobody is close to comparable."""
    length = _torso_length(projected)
    best = np.inf
    for px, vis in zip(people, visibility):
        seen = (vis >= _SEEN) & np.isfinite(px).all(-1) & np.isfinite(projected).all(-1)
        if seen.sum() >= 4 and np.isfinite(length):
            gap = np.linalg.norm(px - projected, axis=-1)
            d = float(np.median(gap[seen]))
            trunk = [j for j in _SHOULDERS + _HIPS if seen[j]]
            if len(trunk) >= 2:  # a detection mixing two people fits one's limbs only
                d = max(d, float(np.median(gap[trunk])))
            best = min(best, d / length)
    return best


def _triangulate(calib, pixels, visibility, tracks, f, max_error_px):
    """(33, 3) m of the chosen tracks at frame ``f`` (NaN joints), or None with fewer than 2 views."""
    if (tracks >= 0).sum() < 2:
        return None
    px = np.full((calib.n_cameras, 1, 33, 2), np.nan)
    conf = np.zeros((calib.n_cameras, 1, 33))
    for v, k in enumerate(tracks):
        if k >= 0:
            px[v, 0], conf[v, 0] = pixels[v][f, k], visibility[v][f, k]
    points = triangulate(calib, px, conf, max_error_px=max_error_px).points[0]
    return points if np.isfinite(points).any() else None


def follow_person_in_videos(
    calib: Calibration,
    people: Sequence,
    choice,
    reference: int = 0,
    *,
    videos: Sequence | None = None,
    width: int | None = 640,
    model: str = "full",
    heavy_model=None,
    **follow_options,
):
    """The chosen person in every view of a synchronised recording.

    Args:
        calib: C cameras. people: per view, the :class:`~lfd.human.video.people.VideoPeople` of
            its video (:func:`~lfd.human.video.people.estimate_people`, same ``width``, every frame).
        choice: who, in ``reference``'s first frame with anyone (:func:`~lfd.human.video.people.choose_person`).
        videos: per view, the video file; when given, every frame of every view is also searched
            in a crop around where the person's skeleton projects (``search`` of :func:`follow_person`).
        follow_options: further arguments of :func:`follow_person`.

    Returns:
        (per view :class:`~lfd.human.video.VideoKeypoints` of the chosen person (frames without
        them NaN, ``other_person`` where someone else was found), :class:`PersonInViews`).
    """
    from lfd.human.video.people import CropSearch

    people = list(people)
    if len(people) != calib.n_cameras:
        raise ValueError(f"people must have one entry per camera ({calib.n_cameras}), got {len(people)}")
    T = min(len(p.t) for p in people)
    person = people[reference].choose(choice)
    search = None
    if videos is not None:
        search = CropSearch(videos, width=width, model=model, heavy_model=heavy_model)
    try:
        result = follow_person(
            calib,
            [p.pixels[:T] for p in people],
            [p.visibility[:T] for p in people],
            people[reference].t[:T],
            reference,
            person,
            search=search,
            **follow_options,
        )
    finally:
        if search is not None:
            search.close()
    keypoints = []
    rows = np.arange(T)
    for v, p in enumerate(people):
        full = p.with_found(result.found[v]) if result.found else p.with_found({})
        pick = result.tracks[v]
        ok = pick >= 0
        pixels, vis, world = np.full((T, 33, 2), np.nan), np.zeros((T, 33)), np.full((T, 33, 3), np.nan)
        pixels[ok] = full.pixels[rows[ok], pick[ok]]
        vis[ok] = full.visibility[rows[ok], pick[ok]]
        world[ok] = full.world[rows[ok], pick[ok]]
        swap = result.swapped[v] & ok
        for f in np.flatnonzero(swap):  # found ones are stored as taken: never marked swapped
            pixels[f], vis[f], world[f] = pixels[f][_SWAP], vis[f][_SWAP], world[f][_SWAP]
        kp = full.person(0)
        keypoints.append(
            dataclasses.replace(
                kp,
                t=kp.t[:T],
                frame_index=kp.frame_index[:T],
                pixels=pixels,
                visibility=vis,
                world=world,
                detected=ok,
                other_person=~ok & p.present[:T].any(1),
            )
        )
    return keypoints, result
