"""lfd.human.multiview.labels: each view's left/right labels reconciled before triangulating, on
synthetic views (exact projections) and on MediaPipe's landmarks of the Pose2Sim demo with labels
swapped on purpose in some views and frames."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.human.multiview import read_calibration, reconcile_left_right, triangulate
from lfd.human.video.landmarks import ALL_LEFT, ALL_RIGHT, LEFT_RIGHT_GROUPS

PAIRS = list(zip(ALL_LEFT, ALL_RIGHT))


def swap(pixels, conf, pattern, pairs):
    """Copies with the labels of ``pairs`` exchanged where ``pattern`` (C, T) is True."""
    px, cf = pixels.copy(), conf.copy()
    for a, b in pairs:
        px[:, :, [a, b]] = np.where(pattern[..., None, None], pixels[:, :, [b, a]], pixels[:, :, [a, b]])
        cf[:, :, [a, b]] = np.where(pattern[..., None], conf[:, :, [b, a]], conf[:, :, [a, b]])
    return px, cf


def test_synthetic_swaps_in_two_views_at_once_are_undone(pose2sim_demo):
    calib = read_calibration(pose2sim_demo / "calibration" / "Calib.qca.txt")
    rng = np.random.default_rng(3)
    T = 60
    trunk = rng.uniform([-0.4, -0.4, 0.8], [0.4, 0.4, 1.2], (T, 1, 3)) + np.linspace(0, 0.5, T)[:, None, None]
    # Two left/right pairs (shoulders 0/1, wrists 2/3) 0.35 m and 0.5 m apart.
    X = np.concatenate([trunk, trunk + [0.35, 0, 0], trunk + [0, 0.1, -0.4], trunk + [0.5, 0.1, -0.4]], 1)
    px = calib.project(X) + rng.normal(0, 2.0, (4, T, 4, 2))
    conf = np.full(px.shape[:3], 0.9)
    truth = np.zeros((4, T), bool)
    truth[1, 10:30] = truth[2, 20:25] = truth[3, 40:] = True  # views 1 and 2 together at frames 20-24
    bad = swap(px, conf, truth, [(0, 1), (2, 3)])[0]
    labels = reconcile_left_right(calib, bad, conf, [(0, 1), (2, 3)])
    for g in range(2):
        np.testing.assert_array_equal(labels.swapped[:, :, g], truth)
    np.testing.assert_array_equal(labels.pixels, px)
    assert labels.swapped_joints[1, 15].all() and not labels.swapped_joints[0].any()
    assert np.nanmax(labels.cost_px) < 10 < np.nanmin(labels.cost_as_given_px[truth.any(0)])
    # Pose2Sim's rule (fewer than half the views swapped) could not undo frames 20-24; the
    # rejection of disagreeing views alone leaves them wrong or drops views.
    fixed = triangulate(calib, labels.pixels, labels.confidence, max_error_px=1e9)
    np.testing.assert_allclose(fixed.points, triangulate(calib, px, conf, max_error_px=1e9).points, atol=1e-9)
    greedy = triangulate(calib, bad, conf)
    assert (
        np.nanmedian(greedy.error[20:25]) > 2 * np.nanmedian(fixed.error[20:25])
        or not greedy.used[:, 20:25].all()
    )


def test_mediapipe_views_with_labels_swapped_are_reconciled(pose2sim_views):
    calib, px, conf = pose2sim_views
    T = px.shape[1]
    as_given = reconcile_left_right(calib, px, conf, PAIRS, groups=[PAIRS])
    assert not as_given.swapped.any()  # MediaPipe labelled these 10 frames consistently in all views
    truth = np.zeros((4, T), bool)
    truth[1, 2:7] = truth[3, 4:9] = True  # frames 4-6: two of the four views swapped
    bad_px, bad_conf = swap(px, conf, truth, PAIRS)
    for groups in ([PAIRS], LEFT_RIGHT_GROUPS):  # the whole body together, or upper body and legs
        labels = reconcile_left_right(calib, bad_px, bad_conf, PAIRS, groups=groups)
        assert (labels.swapped == truth[..., None]).all()
        joints = [j for group in groups for pair in group for j in pair]
        np.testing.assert_array_equal(labels.pixels[:, :, joints], px[:, :, joints])
    # Every pair on its own (Pose2Sim's way): the arms and hips are found; pairs whose two points
    # nearly coincide in a view (eyes, the knees seen side-on) cannot be told apart by reprojection.
    labels = reconcile_left_right(calib, bad_px, bad_conf, PAIRS)
    strong = [i for i, (a, _) in enumerate(PAIRS) if a in (11, 13, 15, 23)]
    assert (labels.swapped[:, :, strong] == truth[..., None]).all()
    reference = triangulate(calib, px, conf, max_error_px=1e9)
    broken = triangulate(calib, bad_px, bad_conf, max_error_px=1e9)
    labels = reconcile_left_right(calib, bad_px, bad_conf, PAIRS, groups=LEFT_RIGHT_GROUPS)
    fixed = triangulate(calib, labels.pixels, labels.confidence, max_error_px=1e9)
    arm = [11, 12, 13, 14, 15, 16]
    ok, bad = np.nanmedian(reference.error[:, arm]), np.nanmedian(broken.error[2:9][:, arm])
    assert ok < 25 and bad > 2 * ok  # MediaPipe's views agree to ~10-15 px; a swapped view does not
    np.testing.assert_allclose(fixed.error[:, arm], reference.error[:, arm])
    assert (
        labels.swapped_joints[1, 3, 11]
        and labels.swapped_joints[3, 5, 15]
        and not labels.swapped_joints[0].any()
    )


def test_reconcile_refuses_bad_arguments(pose2sim_demo):
    calib = read_calibration(pose2sim_demo / "calibration" / "Calib.qca.txt")
    px, conf = np.zeros((4, 3, 4, 2)), np.ones((4, 3, 4))
    with pytest.raises(ValueError, match="pixels must have shape"):
        reconcile_left_right(calib, px[:2], conf[:2], [(0, 1)])
    with pytest.raises(ValueError, match="each in one pair"):
        reconcile_left_right(calib, px, conf, [(0, 1), (1, 2)])
    with pytest.raises(ValueError, match=r"in \[0, 4\)"):
        reconcile_left_right(calib, px, conf, [(0, 7)])
    with pytest.raises(ValueError, match="groups must be non-empty lists of pairs"):
        reconcile_left_right(calib, px, conf, [(0, 1)], groups=[[(2, 3)]])
    with pytest.raises(ValueError, match="switch_px must be >= 0"):
        reconcile_left_right(calib, px, conf, [(0, 1)], switch_px=-1)
