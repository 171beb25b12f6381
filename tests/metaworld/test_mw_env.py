"""lfd.metaworld: the task wrapper against MuJoCo's own camera model and Meta-World's experts."""

import numpy as np
import pytest

from lfd.metaworld import MT10, MetaWorldTask, check_task, placement_seed, record_expert, task_names


@pytest.fixture(scope="module")
def push():
    with MetaWorldTask("push-v3", image_size=96) as task:
        yield task


def test_fifty_tasks_and_mt10_by_name():
    names = task_names()
    assert len(names) == 50 and set(MT10) <= set(names)
    assert check_task("push-v3") == "push-v3"
    with pytest.raises(ValueError, match="task: expected a Meta-World task name such as push-v3"):
        check_task("push-v2")


def test_bad_settings_one_line():
    with pytest.raises(ValueError, match="camera: expected one of"):
        MetaWorldTask("reach-v3", camera="front")
    with pytest.raises(ValueError, match="image_size: expected an int in 16..1024"):
        MetaWorldTask("reach-v3", image_size=8)
    for bad in (2.0, 180, True, "30"):
        with pytest.raises(ValueError, match="fovy: expected degrees in 5..120"):
            MetaWorldTask("reach-v3", fovy=bad)


def test_reset_is_seeded_and_splits_are_independent(push):
    push.reset(placement_seed(0, "train", 3))
    a = push.placement.copy()
    push.step(np.array([1.0, 0.0, 0.0, 1.0]))
    push.reset(placement_seed(0, "train", 3))
    assert np.array_equal(push.placement, a)  # same seed, same placement (also after steps)
    others = set()
    for split in ("train", "val", "test"):
        for i in range(5):
            push.reset(placement_seed(0, split, i))
            others.add(tuple(push.placement.round(9)))
    assert len(others) == 15  # no placement shared between episodes or splits
    assert np.all(push.placement >= push.placement_low - 1e-9) and np.all(
        push.placement <= push.placement_high + 1e-9
    )
    with pytest.raises(ValueError, match="seed: expected an int >= 0"):
        push.reset(-1)
    with pytest.raises(ValueError, match="split: expected one of"):
        placement_seed(0, "validation", 0)


def test_state_and_action_units(push):
    state = push.reset(placement_seed(0, "val", 0))
    assert state.shape == (4,) and state[3] == -1.0  # gripper open at reset
    far = state + np.array([0.5, 0.0, 0.0, 0.0])
    action = push.action_for(far)
    assert action[0] == 1.0 and abs(action[1]) < 0.05  # clipped to 1 cm per step
    for _ in range(20):
        push.step_to(np.array([*(state[:3] + [0.05, 0.0, 0.0]), 0.5]))
    moved = push.state()
    assert moved[3] == 0.5
    np.testing.assert_allclose(
        moved[:3], state[:3] + [0.05, 0.0, 0.0], atol=0.01
    )  # the hand reached the target
    with pytest.raises(ValueError, match="target: expected 4 finite values"):
        push.action_for(np.array([0.0, np.nan, 0.0, 0.0]))


def _project(task, point):
    """Pixel (column, row from the top) of a world point in MuJoCo's camera model."""
    import mujoco

    env = task.env
    cam = mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_CAMERA, task.camera)
    pos, rot = env.data.cam_xpos[cam], env.data.cam_xmat[cam].reshape(3, 3)
    x, y, z = rot.T @ (np.asarray(point) - pos)  # camera frame: looks along -z, y up
    f = (task.image_size / 2) / np.tan(np.deg2rad(env.model.cam_fovy[cam]) / 2)
    return task.image_size / 2 + f * x / -z, task.image_size / 2 - f * y / -z


@pytest.mark.parametrize(
    ("camera", "fovy"), [("corner", None), ("corner2", None), ("corner3", None), ("corner", 30)]
)
def test_render_is_upright(camera, fovy):
    """The green goal marker appears where MuJoCo's camera model projects the goal, in the image
    orientation where a point above the goal appears above it (upright), not mirrored; with a
    narrower field of view (zoomed in) too."""
    with MetaWorldTask("push-v3", image_size=96, camera=camera, fovy=fovy) as task:  # goal marker: green
        for index in range(3):  # the first image after each reset, also after earlier episodes
            task.reset(placement_seed(0, "test", index))
            image = task.render()
            assert image.shape == (96, 96, 3) and image.dtype == np.uint8
            goal = task.env._target_pos
            (u, v), (_, v_above) = _project(task, goal), _project(task, goal + [0.0, 0.0, 0.2])
            if v_above > v:  # the camera's own image has the world upside down: upright = turned 180 degrees
                u, v = 96 - u, 96 - v
            r, g, b = (image[..., i].astype(int) for i in range(3))
            rows, cols = np.nonzero((g > 120) & (r < 90) & (b < 90))
            assert rows.size >= 3, "no goal marker in the image"
            assert abs(cols.mean() - u) < 1.5 and abs(rows.mean() - v) < 1.5, (
                index,
                cols.mean(),
                rows.mean(),
                u,
                v,
            )


@pytest.mark.parametrize(("camera", "fovy"), [("corner", 25), ("corner2", None), ("corner3", None)])
def test_project_gives_where_a_point_appears_in_the_upright_image(camera, fovy):
    """``project`` of the goal lands on the green marker's pixels (their centroid, found by colour
    in the rendered image, upright or turned), and of pick-place's object position on the red
    puck; points behind the camera get NaN; bad points and a task never reset get one line."""
    with MetaWorldTask("push-v3", image_size=96, camera=camera, fovy=fovy) as task:
        with pytest.raises(RuntimeError, match="call reset"):
            task.project([0.0, 0.6, 0.0])
        for index in range(3):
            task.reset(placement_seed(1, "val", index))
            r, g, b = (task.render()[..., i].astype(int) for i in range(3))
            rows, cols = np.nonzero((g > 120) & (r < 90) & (b < 90))
            u, v = task.project(task.env._target_pos)
            assert rows.size >= 3 and abs(cols.mean() + 0.5 - u) < 1.0 and abs(rows.mean() + 0.5 - v) < 1.0
        position, rotation, _ = task._camera()
        behind = position + rotation[:, 2]  # one metre along the camera's +z: behind it
        assert np.isnan(task.project(np.stack([behind, task.env._target_pos]))[0]).all()
        assert task.project(np.zeros((2, 5, 3))).shape == (2, 5, 2)
        for bad in ([0.0, 0.6], [0.0, np.nan, 0.1]):
            with pytest.raises(ValueError, match=r"points: expected finite \(\.\.\., 3\) m"):
                task.project(bad)
    with MetaWorldTask("pick-place-v3", image_size=96, fovy=25) as task:
        for index in range(3):
            task.reset(placement_seed(1, "val", index))
            image = task.render().astype(int)
            u, v = task.project(task.placement[:3])  # the puck's centre
            r, g, b = image[int(v), int(u)]
            assert r > 70 and g < 30 and b < 30, (index, u, v, (r, g, b))


def test_narrower_field_of_view_magnifies_the_marker():
    """fovy=30 instead of the corner camera's 45 degrees: the goal marker covers about
    (tan 22.5 / tan 15)^2 = 2.4 times the pixels."""
    areas = []
    for fovy in (None, 30):
        with MetaWorldTask("push-v3", image_size=96, fovy=fovy) as task:
            task.reset(placement_seed(0, "test", 0))
            r, g, b = (task.render()[..., i].astype(int) for i in range(3))
            areas.append(int(((g > 120) & (r < 90) & (b < 90)).sum()))
    ratio = (np.tan(np.deg2rad(22.5)) / np.tan(np.deg2rad(15))) ** 2
    assert areas[0] >= 3 and 0.6 * ratio < areas[1] / areas[0] < 1.5 * ratio, areas


def test_expert_solves_and_success_is_the_tasks_flag(push):
    episode = record_expert(push, placement_seed(0, "train", 0), n_steps=120, render=False)
    assert episode.success and 0 < episode.first_success < 120
    assert episode.states.shape == (120, 4) and episode.frames.shape == (0, 96, 96, 3)
    # the flag is Meta-World's: the puck within its threshold of the goal at the first solved step
    push.reset(episode.reset_seed)
    for t in range(episode.first_success + 1):
        solved = push.step(episode.actions[t])
    assert solved and push.success
    obj = push.env._get_pos_objects()
    assert np.linalg.norm(obj[:2] - push.env._target_pos[:2]) < 0.05
