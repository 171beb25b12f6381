"""Export (CSV, JSON, DMP, dataset episode) and Send (PyBullet execution)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from teach_helpers import BOXES, FakeClock, drag_line

from lfd.dmp import DMP
from lfd.model_reaching.demonstrations import load_demo_csv, make_demonstration
from lfd.sim.collision import CollisionWorld
from lfd.teach import TeachSession
from lfd.teach.export import dmp_options
from lfd.visuomotor.data.episodes import EpisodeRecord

LIFT = 0.42  # m, clears the wall of boxes.yaml


def mirror_session() -> TeachSession:
    """boxes.yaml with a small goal at the mirror image of the start: the demonstration lifts
    joints 2 and 4 over the wall and puts them back exactly where they started."""
    from lfd.teach.scene import load_scene

    scene = load_scene(BOXES).to_dict()
    s0 = TeachSession(robot="wam4", scene=scene)
    p0 = s0.tool_position
    s0.close()
    scene["goal"] = {"center": [p0[0], -p0[1], p0[2]], "radius": 0.005}
    return TeachSession(robot="wam4", scene=scene, clock=FakeClock(0.04))


def drag_over_wall(s: TeachSession) -> None:
    p0 = s.tool_position
    goal = s.scene.goal.center
    up, over = np.array([p0[0], p0[1], LIFT]), np.array([goal[0], goal[1], LIFT])
    for a, b in ((p0, up), (up, over), (over, goal)):
        assert all(r.accepted for r in drag_line(s, a, b, n=25))
    assert s.recording_state == "done"


@pytest.fixture(scope="module")
def mirror(tmp_path_factory):
    s = mirror_session()
    drag_over_wall(s)
    paths = s.export(tmp_path_factory.mktemp("export"))
    yield s, paths
    s.close()


def test_demo_returns_to_its_start_in_joint_space(mirror):
    s, _ = mirror
    rec = s.recorded
    assert abs(rec.q[-1, 1] - rec.q[0, 1]) < 1e-3 and abs(rec.q[-1, 3] - rec.q[0, 3]) < 1e-3
    assert np.ptp(rec.q[:, 1]) > 0.2 and np.ptp(rec.q[:, 3]) > 0.2  # ... after lifting them


def test_csv_loads_in_the_sawyer_power_tools(mirror):
    s, paths = mirror
    rec = s.recorded
    assert paths["csv"].read_text().splitlines()[0] == "time,j0,j1,j2,j3"
    demo = load_demo_csv(paths["csv"], n_joints=4, n_steps=len(rec))
    np.testing.assert_allclose(demo.duration, rec.t[-1])
    np.testing.assert_allclose(demo.q[0], rec.q[0])
    np.testing.assert_allclose(demo.q[-1], rec.q[-1])


def test_json_holds_robot_scene_collisions_timings(mirror):
    s, paths = mirror
    info = json.loads(paths["json"].read_text())
    assert info["robot"] == "wam4" and info["mode"] == "3d"
    assert info["scene"]["goal"]["radius"] == 0.005 and len(info["scene"]["obstacles"]) == 2
    assert info["collisions"] == s.collisions == 0
    assert info["timings"]["drag_updates"] == s.counters["drag_updates"]
    assert info["timings"]["duration_s"] == pytest.approx(s.recorded.t[-1])
    assert info["timings"]["drag_latency_p95_ms"] >= info["timings"]["drag_latency_median_ms"] > 0
    np.testing.assert_allclose(info["recording"]["q"], s.recorded.q)


def test_episode_loads_as_a_dataset_record(mirror):
    s, paths = mirror
    ep = EpisodeRecord.load(paths["episode"])
    assert ep.obj.shape == "sphere" and ep.split == "train"
    # the episode is the exported motion; its target point is where the demonstration ended
    np.testing.assert_allclose(ep.target_point, s.recorded.tool[-1], atol=1e-12)
    end = ep.arrays["ee_poses"][-1, :3, 3]
    assert float(ep.arrays["final_error"]) == pytest.approx(np.linalg.norm(end - ep.target_point), abs=1e-12)
    assert float(ep.arrays["final_error"]) < 0.01
    np.testing.assert_allclose(ep.arrays["joints"], DMP.load(paths["dmp"]).rollout())
    assert ep.arrays["joints"].shape[1] == 4


def _tool_errors(s, plan):
    """Final and largest time-aligned tool distance (m) of a DMP plan from the recording."""
    rec = s.recorded
    t = np.linspace(0.0, rec.t[-1], plan.shape[0])
    tool = np.array([s.kin.tool_position(q) for q in plan])
    demo_tool = np.stack([np.interp(t, rec.t, rec.tool[:, k]) for k in range(3)], axis=1)
    return np.linalg.norm(tool[-1] - rec.tool[-1]), np.linalg.norm(tool - demo_tool, axis=1).max()


def test_exported_dmp_reproduces_a_path_over_the_obstacle(mirror):
    s, paths = mirror
    dmp = DMP.load(paths["dmp"])
    assert dmp.formulation == dmp_options()["formulation"] == "pastor"
    plan = dmp.rollout()
    final, worst = _tool_errors(s, plan)
    assert final < 0.01  # within 1 cm of the recorded end
    assert worst < 0.02  # within 2 cm of the recorded tool path all along
    checker = CollisionWorld(s.robot, s.scene.obstacles, s.scene.table_z)
    assert not any(checker.check(q).in_collision for q in plan)
    checker.close()


def test_classic_dmp_fails_on_the_same_demonstration(mirror):
    """The check above can fail: Ijspeert's forcing term holds the returning joints still."""
    s, _ = mirror
    rec = s.recorded
    t = np.linspace(0.0, rec.t[-1], 200)
    q = np.stack([np.interp(t, rec.t, rec.q[:, j]) for j in range(4)], axis=1)
    with pytest.warns(RuntimeWarning):
        classic = DMP(n_basis=30, formulation="ijspeert").fit(t, q)
    _, worst = _tool_errors(s, classic.rollout())
    assert worst > 0.05


def test_send_runs_the_dmp_in_pybullet(boxes_session):
    s = boxes_session
    p0, goal = s.tool_position, s.scene.goal.center
    up, over = np.array([p0[0], p0[1], LIFT]), np.array([goal[0], goal[1], LIFT])
    for a, b in ((p0, up), (up, over), (over, goal)):
        drag_line(s, a, b, n=20)
    assert s.recording_state == "done"
    res = s.send()
    lower, upper = s.robot.spec.lower, s.robot.spec.upper
    assert np.all(res.executed.q >= lower - 1e-3) and np.all(res.executed.q <= upper + 1e-3)
    assert res.final_error < 0.01
    assert res.max_path_deviation < 0.02
    assert res.executed.tool.shape == (res.plan_q.shape[0], 3)
    assert s.last_send is res


def test_export_needs_a_recording(boxes_session, tmp_path):
    with pytest.raises(ValueError, match="at least 3"):
        boxes_session.export(tmp_path)


def test_two_d_export_and_sawyer_csv(tmp_path):
    s = TeachSession(robot="sawyer", scene=None, mode="2d", clock=FakeClock())
    p0 = s.tool_position
    for d in ([0.1, 0.0, 0.0], [0.1, 0.1, 0.0], [0.0, 0.1, 0.1]):
        assert s.move_to(p0 + d).accepted and s.store()
    paths = s.export(tmp_path)
    demo = load_demo_csv(paths["csv"])  # the Sawyer tools' default: time, j0..j6
    np.testing.assert_allclose(demo.q[-1], s.waypoints[-1])
    task_demo = make_demonstration(s.robot, demo_csv=paths["csv"])  # what the Sawyer/PoWER protocol reads
    np.testing.assert_allclose(task_demo.q[0], s.start, atol=1e-12)
    info = json.loads(paths["json"].read_text())
    assert info["mode"] == "2d" and len(info["waypoints"]) == 4
    s.close()


def test_export_into_a_folder_that_holds_a_demo_overwrites_nothing(mirror, tmp_path):
    s, paths = mirror
    before = {p.name: p.read_bytes() for p in paths["csv"].parent.iterdir()}
    with pytest.raises(FileExistsError, match="lfd does not overwrite files"):
        s.export(paths["csv"].parent)
    assert {p.name: p.read_bytes() for p in paths["csv"].parent.iterdir()} == before
    (tmp_path / "demo.json").write_text("the user's own notes")
    with pytest.raises(FileExistsError, match="demo.json"):
        s.export(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.json"]


def test_send_and_episode_final_error_mean_the_same(boxes_session, tmp_path):
    """Both are the distance of the final tool position to target_point, the tool position of the skill's
    goal: with the last keyframe moved 2 cm that is the moved keyframe, not the recorded end."""
    s = boxes_session
    p0, goal = s.tool_position, s.scene.goal.center
    up, over = np.array([p0[0], p0[1], LIFT]), np.array([goal[0], goal[1], LIFT])
    for a, b in ((p0, up), (up, over), (over, goal)):
        drag_line(s, a, b, n=20)
    s.add_keyframe()
    end = s.keyframe_poses()[0][0] + [0.0, 0.02, 0.0]
    assert s.move_keyframe(0, end).accepted
    res = s.send()
    paths = s.export(tmp_path)
    info = json.loads(paths["json"].read_text())
    ep = EpisodeRecord.load(paths["episode"])
    np.testing.assert_allclose(ep.target_point, info["target_point"])
    np.testing.assert_allclose(ep.target_point, end, atol=1e-3)
    assert res.final_error == pytest.approx(np.linalg.norm(res.executed.tool_final - ep.target_point))
    assert info["send"]["final_error_m"] == res.final_error < 0.01
    ep_final = np.linalg.norm(ep.arrays["ee_poses"][-1, :3, 3] - ep.target_point)
    assert float(ep.arrays["final_error"]) == pytest.approx(ep_final) and ep_final < 0.01
