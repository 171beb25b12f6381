"""Several people in view: choosing one, following everyone through a crossing in one image, and
the same person across calibrated views (lfd.human.video.people, lfd.human.multiview.people).
Synthetic people with known identities; no pose estimator is run."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.human.multiview import Calibration
from lfd.human.multiview.people import epipolar_distance, follow_person
from lfd.human.video.people import VideoPeople, choose_person, track_people

RNG = np.random.default_rng(7)


def _body(height: float = 1.7) -> np.ndarray:
    """(33, 3) m, a standing person centred on the origin, feet at z = 0 (z up)."""
    pts = np.zeros((33, 3))
    pts[:11] = [0.0, 0.0, 0.93 * height]  # face
    pts[:11, 0] += np.linspace(-0.06, 0.06, 11)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        x = sign * 0.2
        j = {"shoulder": 11, "elbow": 13, "wrist": 15, "pinky": 17, "index": 19, "thumb": 21,
             "hip": 23, "knee": 25, "ankle": 27, "heel": 29, "foot": 31}  # fmt: skip
        off = 0 if side == "left" else 1
        pts[j["shoulder"] + off] = [x, 0.0, 0.82 * height]
        pts[j["elbow"] + off] = [x * 1.2, 0.05, 0.63 * height]
        for name, z in (("wrist", 0.48), ("pinky", 0.44), ("index", 0.43), ("thumb", 0.45)):
            pts[j[name] + off] = [x * 1.25, 0.1, z * height]
        pts[j["hip"] + off] = [x * 0.55, 0.0, 0.53 * height]
        pts[j["knee"] + off] = [x * 0.55, 0.03, 0.28 * height]
        for name, z in (("ankle", 0.04), ("heel", 0.01), ("foot", 0.0)):
            pts[j[name] + off] = [x * 0.55, 0.08 if name == "foot" else 0.0, z * height]
    return pts


def _calibration(n: int = 4, radius: float = 5.0) -> Calibration:
    """n cameras on a circle at 1.5 m height looking at (0, 0, 1) m, 1000 x 1000 px, no distortion."""
    K, R, t = [], [], []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False) + 0.3:
        centre = np.array([radius * np.cos(a), radius * np.sin(a), 1.5])
        forward = np.array([0.0, 0.0, 1.0]) - centre
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        down = np.cross(forward, right)
        rot = np.stack([right, down, forward])
        K.append([[1000.0, 0, 500], [0, 1000.0, 500], [0, 0, 1]])
        R.append(rot)
        t.append(-rot @ centre)
    names = tuple(f"cam{i + 1:02d}" for i in range(n))
    return Calibration(
        names, np.array(K), np.zeros((n, 4)), np.array(R), np.array(t), np.full((n, 2), 1000.0)
    )


def test_choose_person_by_rule_point_and_box():
    small = np.stack([np.linspace(100, 140, 33), np.linspace(100, 200, 33)], 1)
    big = np.stack([np.linspace(500, 700, 33), np.linspace(300, 800, 33)], 1)
    pixels, vis = np.stack([small, big]), np.ones((2, 33))
    assert choose_person(pixels, vis, "largest", (1000, 1000)) == 1
    assert choose_person(pixels, vis, "central", (240, 300)) == 0
    assert choose_person(pixels, vis, [120, 150], (1000, 1000)) == 0
    assert choose_person(pixels, vis, (90, 90, 150, 210), (1000, 1000)) == 0
    with pytest.raises(
        ValueError,
        match=r"person point \[10.0, 10.0\] is inside nobody's box; people found at boxes \[100, 100, 140, 200\], ",
    ):
        choose_person(pixels, vis, [10, 10], (1000, 1000))
    with pytest.raises(ValueError, match="person must be one of largest, central, a point"):
        choose_person(pixels, vis, "tallest", (1000, 1000))
    with pytest.raises(ValueError, match="x1 > x0"):
        choose_person(pixels, vis, [5, 5, 1, 1], (1000, 1000))


def _image_person(centre_x: float, scale: float) -> np.ndarray:
    """(33, 2) px: the synthetic body seen from the front, torso centred at ``centre_x``."""
    body = _body()
    return np.stack([centre_x + scale * body[:, 0], 900 - scale * body[:, 2]], 1)


def test_two_people_crossing_in_one_image_keep_their_tracks():
    """A (near, large) walks right, B (far, small) walks left; they cross at frame 30, where the
    detector finds only one of them for two frames; the lists come in random order."""
    T = 60
    t = np.arange(T) / 30.0
    xa, xb = np.linspace(200, 800, T), np.linspace(800, 200, T)
    detections, truth = [], []
    for f in range(T):
        people = [(_image_person(xa[f], 300.0), "A"), (_image_person(xb[f], 200.0), "B")]
        if f in (30, 31):
            people = people[:1]
        order = RNG.permutation(len(people))
        detections.append(np.array([people[i][0] for i in order]))
        truth.append([people[i][1] for i in order])
    ids, n_tracks = track_people(detections, t)
    assert n_tracks == 2
    owner = {}
    for f in range(T):
        for track, who in zip(ids[f], truth[f]):
            assert owner.setdefault(int(track), who) == who, f"frame {f}: track {track} switched to {who}"


def test_video_people_marks_frames_without_the_person_and_round_trips(tmp_path):
    T, P = 5, 2
    pixels = RNG.normal(500, 50, (T, P, 33, 2))
    pixels[2, 0] = np.nan  # person 0 missing in frame 2, person 1 still there
    pixels[3] = np.nan  # nobody in frame 3
    vis = np.where(np.isfinite(pixels).all(-1), 0.9, 0.0)
    people = VideoPeople(
        np.arange(T) / 30.0, np.arange(T), pixels, vis, np.zeros((T, P, 33, 3)), (1000, 1000)
    )
    kp = people.person(0)
    assert kp.detected.tolist() == [True, True, False, False, True]
    assert kp.other_person.tolist() == [False, False, True, False, False]
    assert np.isnan(kp.pixels[2]).all()
    back = VideoPeople.load(people.save(tmp_path / "people.npz"))
    np.testing.assert_array_equal(back.pixels, pixels)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="bad.npz: not a people cache written by lfd"):
        VideoPeople.load(tmp_path / "bad.npz")
    with pytest.raises(ValueError, match=r"track must be in \[0, 2\)"):
        people.person(2)
    import dataclasses

    ragged = dataclasses.replace(people, visibility=vis[:, :1])
    with pytest.raises(
        ValueError, match=r"ragged.npz: visibility must have shape \(5, 2, 33\), got \(5, 1, 33\)"
    ):
        VideoPeople.load(ragged.save(tmp_path / "ragged.npz"))


def test_epipolar_distance_is_zero_for_one_point_and_grows_for_another():
    calib = _calibration()
    points = _body() + [0.3, -0.2, 0.0]
    px = calib.project(points)
    assert np.abs(epipolar_distance(calib, 0, 1, px[0], px[1])).max() < 1e-6
    other = calib.project(_body() + [-1.0, 1.0, 0.0])
    assert np.median(epipolar_distance(calib, 0, 1, px[0], other[1])) > 5.0


def test_the_chosen_person_is_followed_in_every_view_and_a_view_without_them_stays_empty():
    """Two people walk past each other 0.7 m apart (A along +x, B along -x), so in the cameras looking
    along y they cross in the image; camera 4 sees neither, only a bystander C standing aside (never
    on A's line of sight there). Track ids are shuffled per view; the answer must name A's track in
    views 1-3 in every frame and nobody in view 4."""
    calib = _calibration()
    T = 40
    t = np.arange(T) / 30.0
    a_path = np.stack([np.linspace(-1.0, 1.0, T), np.zeros(T), np.zeros(T)], 1)
    b_path = np.stack([np.linspace(1.0, -1.0, T), np.full(T, 0.7), np.zeros(T)], 1)
    pixels, visibility, a_track = [], [], []
    for v in range(4):
        projected = (
            [calib.project(_body() + a_path[f])[v] for f in range(T)],
            [calib.project(_body(1.6) + b_path[f])[v] for f in range(T)],
            [calib.project(_body(1.8) + [2.0, -1.0, 0.0])[v] for f in range(T)],
        )
        shown = (0, 1) if v < 3 else (2,)
        order = RNG.permutation(shown)
        px = np.stack([np.stack(projected[who]) for who in order], 1) + RNG.normal(
            0, 1.0, (T, len(order), 33, 2)
        )
        pixels.append(px)
        visibility.append(np.full(px.shape[:3], 0.9))
        a_track.append(int(np.flatnonzero(order == 0)[0]) if 0 in order else -1)
    chosen = follow_person(calib, pixels, visibility, t, reference=0, person=a_track[0]).tracks
    for v in range(3):
        assert (chosen[v] == a_track[v]).all(), f"view {v}: {chosen[v]}"
    assert (chosen[3] == -1).all()
    # the same call choosing B follows B
    b_track = [1 - a for a in a_track[:3]]
    chosen_b = follow_person(calib, pixels, visibility, t, reference=0, person=b_track[0]).tracks
    assert all((chosen_b[v] == b_track[v]).all() for v in range(3)) and (chosen_b[3] == -1).all()


def test_follow_person_refuses_bad_inputs_in_one_line():
    calib = _calibration()
    px = np.zeros((3, 1, 33, 2))
    with pytest.raises(ValueError, match=r"one entry per camera \(4\)"):
        follow_person(calib, [px], [np.zeros((3, 1, 33))], np.arange(3.0), 0, 0)
    with pytest.raises(ValueError, match=r"view 1: pixels must have shape \(T=3, P, 33, 2\)"):
        follow_person(calib, [px, px[:, :, :10], px, px], [np.zeros((3, 1, 33))] * 4, np.arange(3.0), 0, 0)
    with pytest.raises(ValueError, match=r"person must be a track of view 0 in \[0, 1\), got 5"):
        follow_person(calib, [px] * 4, [np.zeros((3, 1, 33))] * 4, np.arange(3.0), 0, 5)


def test_a_person_the_whole_frame_missed_is_taken_from_the_crop_search():
    """View 2's detector never finds A; the search callback, asked where A's skeleton projects,
    finds A there (and is told to hide B, who stands far from that projection)."""
    calib = _calibration(3)
    T = 10
    t = np.arange(T) / 30.0
    a = [calib.project(_body() + [0.1 * f / T, 0.0, 0.0]) for f in range(T)]  # (C, 33, 2) per frame
    b = [calib.project(_body(1.6) + [-1.5, 1.0, 0.0]) for _ in range(T)]
    pixels = [np.stack([np.stack([a[f][v], b[f][v]]) for f in range(T)]) for v in range(2)]
    pixels.append(np.stack([b[f][2][None] for f in range(T)]))  # view 3: only B
    visibility = [np.full(p.shape[:3], 0.9) for p in pixels]
    asked = []

    def search(view, frame, box, hide):
        asked.append((view, frame, len(hide)))
        if view != 2:
            return []
        assert box[0] <= a[frame][2][:, 0].min() and a[frame][2][:, 0].max() <= box[2]
        return [(a[frame][2], np.full(33, 0.9), np.zeros((33, 3)))]

    result = follow_person(calib, pixels, visibility, t, reference=0, person=0, search=search)
    assert (result.tracks[:2, :] == 0).all()
    assert (result.tracks[2, 1:] == 1).all() and result.tracks[2, 0] == -1  # found from frame 1 on
    assert sorted(result.found[2]) == list(range(1, T))
    assert all(hidden == 1 for view, _, hidden in asked if view == 2)  # B hidden from view 3's crops


def test_everyone_in_a_real_two_person_video_is_found_and_followed(pose2sim_multiperson, mediapipe_ok):
    """The first 20 frames of Pose2Sim's multi-person demo, cam04: both people (the man at the
    left, the woman at the right) are found in every frame and each keeps one track."""
    from lfd.human.video.people import estimate_people

    people = estimate_people(pose2sim_multiperson / "videos" / "cam04.mp4", max_frames=20)
    frames = people.present.sum(0)
    assert sorted(frames)[-2:] == [20, 20], frames
    two = np.argsort(frames)[-2:]
    x = [np.nanmean(people.pixels[:, k, 11, 0]) for k in two]  # left shoulder
    assert abs(x[0] - x[1]) > 200  # two people, not one found twice
    assert people.choose("largest") in two.tolist()


def test_estimate_keypoints_keeps_the_person_chosen_by_rule_or_point(pose2sim_multiperson, mediapipe_ok):
    """cam04 of the multi-person demo: the man (left, nearer: the largest) or the woman (right,
    chosen by a point on her torso) is kept in every one of 10 frames, never the other."""
    from lfd.human.video import estimate_keypoints

    video = pose2sim_multiperson / "videos" / "cam04.mp4"
    man = estimate_keypoints(video, max_frames=10, person="largest")
    woman = estimate_keypoints(video, max_frames=10, person=[756, 608])
    assert man.detected.all() and woman.detected.all()
    assert (man.pixels[:, 11, 0] < 550).all() and (woman.pixels[:, 11, 0] > 650).all()
    with pytest.raises(
        ValueError, match=r"cam04.mp4, frame 0: person point \[5.0, 5.0\] is inside nobody's box"
    ):
        estimate_keypoints(video, max_frames=2, person=[5, 5])
