"""Keyframes and the motion: add / insert / delete / move / reorder, and the exported skill passing through them."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from teach_helpers import BOXES, FakeClock, drag_line

from lfd.dmp import DMP
from lfd.teach import TeachSession

LIFT = 0.42  # m, clears the wall of boxes.yaml


def _record_with_keyframes(s: TeachSession) -> None:
    """Over the wall into the goal, a keyframe at each corner (up, over, goal)."""
    p0, goal = s.tool_position, s.scene.goal.center
    up, over = np.array([p0[0], p0[1], LIFT]), np.array([goal[0], goal[1], LIFT])
    for a, b in ((p0, up), (up, over), (over, goal)):
        assert all(r.accepted for r in drag_line(s, a, b, n=20))
        s.add_keyframe()
    assert s.recording_state == "done" and len(s.keyframes) == 3


def _passes(s: TeachSession, dmp: DMP, times) -> np.ndarray:
    """Distance (m) of the DMP's tool at ``times`` to each keyframe's tool position."""
    q = dmp.rollout(t=np.concatenate([[0.0], times]) if times[0] > 0 else np.asarray(times))
    q = q[-len(times) :]
    return np.array(
        [np.linalg.norm(s.kin.tool_position(x) - p) for x, (p, _) in zip(q, s.keyframe_poses(), strict=True)]
    )


def test_edited_keyframes_are_passed_by_the_exported_skill(tmp_path):
    s = TeachSession(robot="wam4", scene=BOXES, clock=FakeClock())
    _record_with_keyframes(s)
    # move: the "over" corner 6 cm higher and 3 cm along
    over_pose = s.keyframe_poses()[1][0]
    r = s.move_keyframe(1, over_pose + [0.0, 0.03, 0.06])
    assert r.accepted and np.linalg.norm(s.keyframe_poses()[1][0] - (over_pose + [0.0, 0.03, 0.06])) < 1e-3
    # insert: the arm dragged (not recorded: the recording is done) to a pose between "up" and "over"
    up_pose = s.keyframe_poses()[0][0]
    mid = 0.5 * (up_pose + over_pose) + [0.0, 0.0, 0.04]
    assert all(r.accepted for r in drag_line(s, s.tool_position, np.array([*mid[:2], LIFT]), n=30))
    assert all(r.accepted for r in drag_line(s, s.tool_position, mid, n=5))
    assert s.add_keyframe(index=1) == 1 and len(s.keyframes) == 4
    np.testing.assert_array_equal(s.keyframes[1], s.q)
    # add and delete one
    s.add_keyframe()
    s.delete_keyframe(4)
    assert len(s.keyframes) == 4
    skill = s.skill()
    assert np.all(np.diff(skill.via_t) > 0)  # visited in list order
    paths = s.export(tmp_path)
    dmp = DMP.load(paths["dmp"])
    info = json.loads(paths["json"].read_text())
    times = np.array(info["keyframes"]["t"])
    np.testing.assert_allclose(info["keyframes"]["q"], s.keyframes)
    assert _passes(s, dmp, times).max() < 1e-3  # within 1 mm at the keyframes' times
    # and the default rollout (the exported skill as DMP.load users run it) passes each within 1 mm
    tool = np.array([s.kin.tool_position(q) for q in dmp.rollout()])
    for p, _ in s.keyframe_poses():
        assert np.linalg.norm(tool - p, axis=1).min() < 1e-3
    # the motion() the panel draws is that skill
    m = s.motion()
    np.testing.assert_allclose(m.q, dmp.rollout(), atol=1e-9)
    s.close()


def test_a_keyframe_moved_into_the_wall_is_refused():
    s = TeachSession(robot="wam4", scene=BOXES, clock=FakeClock())
    _record_with_keyframes(s)
    before = s.keyframes.copy()
    wall_top = np.array([0.5, 0.0, 0.28])  # inside the wall of boxes.yaml
    results = [s.move_keyframe(1, p) for p in np.linspace(s.keyframe_poses()[1][0], wall_top, 15)[1:]]
    refused = [r for r in results if not r.accepted]
    assert refused and refused[0].reason == "collision" and s.collisions == 1
    assert not s.checker.check(s.keyframes[1]).in_collision
    np.testing.assert_array_equal(s.keyframes[[0, 2]], before[[0, 2]])
    np.testing.assert_array_equal(refused[0].q, s.keyframes[1])
    s.close()


def test_keyframes_alone_and_reorder():
    s = TeachSession(robot="sawyer", scene=None, clock=FakeClock(), mode="2d")
    p0 = s.tool_position
    s.add_keyframe()
    for d in ([0.1, 0.0, 0.0], [0.1, 0.1, 0.0], [0.0, 0.1, 0.1]):
        assert s.move_to(p0 + d).accepted
        s.add_keyframe()
    assert len(s.recorded) < 3  # no waypoint stored: the keyframes alone make the motion
    kf = s.keyframes
    skill = s.skill()
    assert skill.source == "keyframes"
    assert _passes(s, skill.dmp, skill.via_t).max() < 1e-3
    s.reorder_keyframes([0, 2, 1, 3])
    np.testing.assert_array_equal(s.keyframes, kf[[0, 2, 1, 3]])
    skill = s.skill()
    assert _passes(s, skill.dmp, skill.via_t).max() < 1e-3
    np.testing.assert_allclose(s.motion().q[[0, -1]], kf[[0, 3]], atol=1e-9)
    s.close()


def test_reorder_keeps_the_time_slots_of_a_recording():
    s = TeachSession(robot="wam4", scene=BOXES, clock=FakeClock())
    _record_with_keyframes(s)
    t = s.skill().via_t
    s.reorder_keyframes([1, 0, 2])
    np.testing.assert_allclose(s.skill().via_t, t)
    assert _passes(s, s.skill().dmp, t).max() < 1e-3
    s.close()


def test_bad_keyframe_edits_are_one_line():
    s = TeachSession(robot="wam4", scene=None, clock=FakeClock())
    with pytest.raises(ValueError, match="nothing to plan"):
        s.motion()
    assert s.motion_duration == 0.0
    s.add_keyframe()
    with pytest.raises(ValueError, match=r"keyframe index must be an integer in 0..0, got 3"):
        s.delete_keyframe(3)
    with pytest.raises(ValueError, match=r"keyframe index must be an integer in 0..1, got -1"):
        s.add_keyframe(index=-1)
    with pytest.raises(ValueError, match="permutation"):
        s.reorder_keyframes([0, 0])
    with pytest.raises(ValueError, match="position"):
        s.move_keyframe(0, [0.1, np.nan, 0.2])
    with pytest.raises(ValueError, match="n must be an integer >= 2"):
        s.motion(1)
    s.close()


def test_motion_is_cheap_enough_for_a_waypoint_drag():
    """motion() after each keyframe move (the fitted motion redrawn while a waypoint is dragged)."""
    s = TeachSession(robot="wam4", scene=BOXES, clock=FakeClock())
    _record_with_keyframes(s)
    p = s.keyframe_poses()[1][0]
    s.motion()  # warm the per-grid caches
    times = []
    for k in range(1, 21):
        assert s.move_keyframe(1, p + [0.0, 0.0, 0.002 * k]).accepted
        tic = time.perf_counter()
        s.motion()
        times.append(time.perf_counter() - tic)
    assert np.median(times) < 0.03
    s.close()
