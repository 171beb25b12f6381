"""ReachScene: world layout, frames, control, contacts, rendering."""

import numpy as np
import pybullet as p
import pytest
import torch

from lfd.robots import load_robot
from lfd.sim.approach import TABLE_Z
from lfd.sim.objects import ObjectSpec, Placement
from lfd.sim.scene import TABLE_X, ReachScene

BOX = ObjectSpec("box", (0.05, 0.06, 0.08), (0.9, 0.1, 0.1, 1.0), 0.3, "box")


@pytest.fixture(scope="module")
def robot():
    return load_robot("pr2_right_arm")


@pytest.fixture(scope="module")
def scene(robot):
    with ReachScene(robot, image_size=48) as s:
        yield s


def test_table_top_and_object_in_torso_frame(scene):
    scene.reset(BOX, Placement(0.6, -0.1, 0.4))
    lo, hi = p.getAABB(scene.table_id, physicsClientId=scene.client)
    assert hi[2] - scene.base_to_world[2, 3] == pytest.approx(TABLE_Z, abs=1e-3)
    assert lo[0] == pytest.approx(TABLE_X[0], abs=1e-3)
    pose = scene.object_pose()
    np.testing.assert_allclose(pose[:3, 3], [0.6, -0.1, TABLE_Z + 0.04], atol=1e-6)
    np.testing.assert_allclose(pose[:2, 0], [np.cos(0.4), np.sin(0.4)], atol=1e-6)
    for _ in range(20):  # the object rests on the table
        scene.step(scene.joint_state()[0])
    np.testing.assert_allclose(scene.object_pose()[:3, 3], [0.6, -0.1, TABLE_Z + 0.04], atol=2e-3)


def test_ee_pose_matches_robot_fk(scene, robot):
    q = robot.home.numpy() + np.array([0.2, 0.3, -0.1, -0.2, 0.4, -0.3, 0.5])
    scene.reset(q=q)
    np.testing.assert_allclose(scene.ee_pose(), robot.fk(torch.as_tensor(q)[None])[0].numpy(), atol=1e-6)
    np.testing.assert_allclose(scene.joint_state()[0], q, atol=1e-9)


def test_position_control_tracks_and_holds(scene, robot):
    scene.reset()
    home = robot.home.numpy()
    target = home + np.array([0.3, 0.2, 0.0, -0.3, 0.0, -0.2, 0.0])
    for _ in range(50):  # URDF torque limits (30 N m on the pan joint) need ~1.6 s, not 1 s
        scene.step(target)
    q, qd = scene.joint_state()
    np.testing.assert_allclose(q, target, atol=2e-3)
    assert np.abs(qd).max() < 0.05


def test_contacts(scene, robot):
    scene.reset(BOX, Placement(0.6, 0.0, 0.0))
    assert not scene.arm_touches("table") and not scene.arm_touches("object")
    # tool straight down into the table, through the box
    res = robot.ik(
        torch.tensor([[0.6, 0.0, TABLE_Z - 0.02]], dtype=torch.float64),
        q0=robot.home[None],
        position_only=True,
    )
    scene.set_joints(res.q[0])
    assert scene.arm_touches("table") or scene.arm_touches("object")
    with pytest.raises(ValueError, match="'table' or 'object'"):
        scene.arm_touches("floor")


def test_render_is_deterministic_and_shows_the_object(scene):
    scene.reset()
    empty = scene.render()
    scene.reset(BOX, Placement(0.58, 0.0, 0.0))
    a, b = scene.render(), scene.render()
    assert a.shape == (48, 48, 3) and a.dtype == np.uint8
    np.testing.assert_array_equal(a, b)
    changed = np.abs(a.astype(int) - empty.astype(int)).sum(-1) > 30
    rows, cols = np.nonzero(changed)
    assert changed.sum() > 4
    assert abs(cols.mean() - 24) < 4  # the object at y = 0 is in the middle column
    red = (a[..., 0] > 150) & (a[..., 1] < 80)
    assert red.sum() > 4


def test_wrist_camera_and_lifecycle(robot):
    scene = ReachScene(robot, image_size=32, wrist_camera=True)
    scene.reset(BOX, Placement(0.55, 0.05, 0.0))
    assert scene.render_wrist().shape == (32, 32, 3)
    scene.close()
    scene.close()  # idempotent


def test_argument_validation(robot, scene):
    with pytest.raises(ValueError, match="image_size"):
        ReachScene(robot, image_size=0)
    with pytest.raises(ValueError, match="both object_spec and placement"):
        scene.reset(BOX)
    with pytest.raises(ValueError, match="q_target"):
        scene.step(np.zeros(3))
    scene.reset()
    with pytest.raises(ValueError, match="no object"):
        scene.object_pose()


@pytest.mark.parametrize("friction", [None, 0.0])
def test_upright_capsule_stands_through_a_demonstration_unless_pushed(robot, monkeypatch, friction):
    """A capsule stands on its hemispherical cap: with the objects' rolling friction it stays
    put through an expert demonstration and the hold after it (success needs the object to
    move < 2 cm); without it (friction 0.0) the same capsule falls over by itself. A push
    (the tool teleported into it) still moves it."""
    import lfd.sim.scene as scene_module
    from lfd.robots import solve_near
    from lfd.sim.approach import plan_approach
    from lfd.sim.expert import ScriptedExpert

    if friction is not None:
        monkeypatch.setattr(scene_module, "OBJECT_ROLLING_FRICTION", friction)
    cap = ObjectSpec("capsule", (0.031, 0.103), (0.2, 0.6, 0.9, 1.0), 0.3, "cap")
    expert = ScriptedExpert(robot)
    moved = []
    with ReachScene(robot, image_size=16) as s:
        for pl in (Placement(0.55, -0.2, 0.0), Placement(0.6, 0.0, 0.0), Placement(0.5, 0.1, 0.0)):
            demo = expert.run(s, cap, pl)
            for _ in range(50):
                s.step(demo.joints[-1])
            moved.append(float(np.linalg.norm(s.object_pose()[:3, 3] - demo.object_poses[0][:3, 3])))
        if friction is None:
            assert max(moved) < 2e-3, moved
            grasp = plan_approach(cap, Placement(0.6, 0.0, 0.0), table_z=TABLE_Z).grasp_pose
            q = solve_near(robot, grasp[None], robot.home.numpy(), n_seeds=16).q[0].numpy()
            s.reset(cap, Placement(0.6, 0.0, 0.0), q=q)
            start = s.object_pose()[:3, 3].copy()
            for _ in range(20):
                s.step(q)
            assert np.linalg.norm(s.object_pose()[:3, 3] - start) > 5e-3
        else:
            assert max(moved) > 0.05, moved


def test_lighting_changes_colours_not_depth_and_the_default_is_pybullets(scene, robot):
    """A default Lighting renders exactly what no Lighting does (PyBullet's own defaults); a random
    light recolours the table and the object (the backdrop too), leaves the depth alone, and lasts
    across resets until it is set back."""
    from lfd.sim.camera import LIGHTING_RANGES, Lighting, sample_lighting

    scene.set_lighting(None)
    scene.reset(BOX, Placement(0.58, 0.0, 0.0))
    rgb, depth = scene.render(with_depth=True)
    scene.set_lighting(Lighting())
    np.testing.assert_array_equal(scene.render(), rgb)
    rng = np.random.default_rng(0)
    lights = [sample_lighting(rng) for _ in range(4)]
    assert lights == [sample_lighting(r) for r in [np.random.default_rng(0)] * 1 for _ in range(4)]
    table = (slice(30, 34), slice(20, 28))  # a patch of table in front of the object
    changed = 0
    for light in lights:
        lo, hi = LIGHTING_RANGES["ambient"]
        assert lo <= light.ambient <= hi and light.direction[2] >= np.sin(np.radians(29.9))
        scene.set_lighting(light)
        scene.reset(BOX, Placement(0.58, 0.0, 0.0))
        lit, lit_depth = scene.render(with_depth=True)
        np.testing.assert_array_equal(lit_depth, depth)
        changed += np.abs(lit[table].astype(int) - rgb[table].astype(int)).mean() > 3
        np.testing.assert_array_equal(Lighting.from_array(light.as_array()).as_array(), light.as_array())
    assert changed >= 3  # the backdrop's table is relit, not pasted from the default light
    scene.set_lighting(None)
    np.testing.assert_array_equal(scene.render(), rgb)
    with pytest.raises(ValueError, match="Lighting.ambient: expected a value in"):
        Lighting(ambient=1.5)
    with pytest.raises(ValueError, match="Lighting.direction"):
        Lighting(direction=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="ReachScene.set_lighting"):
        scene.set_lighting("bright")


def test_camera_jitter_moves_the_view_within_its_ranges_and_the_scene_renders_through_it(scene, robot):
    """jitter_camera: eye and target within CAMERA_JITTER of the default, the roll about the viewing
    direction within its degrees, the same draws for the same stream, intrinsics unchanged; a pose
    array round-trips. The scene renders through a set camera (the backdrop too: no pixel of the old
    view's table is pasted) and back exactly to the default."""
    from dataclasses import replace

    from lfd.sim.camera import CAMERA_JITTER, jitter_camera

    base = scene.camera
    scene.set_camera(base)
    scene.reset(BOX, Placement(0.58, 0.0, 0.0))
    rgb = scene.render()
    cams = [jitter_camera(base, np.random.default_rng([3, k])) for k in range(6)]
    assert cams == [jitter_camera(base, np.random.default_rng([3, k])) for k in range(6)]
    assert len({c.pose_array().tobytes() for c in cams}) == 6
    e_max, t_max = np.zeros(3), np.zeros(3)
    for cam in cams:
        e_max = np.maximum(e_max, np.abs(np.subtract(cam.eye, base.eye)))
        t_max = np.maximum(t_max, np.abs(np.subtract(cam.target, base.target)))
        assert (cam.fov_deg, cam.width, cam.height, cam.near, cam.far) == (
            base.fov_deg,
            base.width,
            base.height,
            base.near,
            base.far,
        )
        # roll: the angle between the camera's x axis and the horizontal plane
        side = cam.view_matrix[0, :3]
        assert abs(np.degrees(np.arcsin(side[2]))) <= CAMERA_JITTER["roll_deg"] + 1e-6
        assert cam.with_pose(cam.pose_array()) == cam
    assert np.all(e_max <= CAMERA_JITTER["eye_m"]) and np.all(t_max <= CAMERA_JITTER["target_m"])
    assert e_max.max() > 0.5 * CAMERA_JITTER["eye_m"] and t_max.max() > 0.5 * CAMERA_JITTER["target_m"]
    rolls = [np.degrees(np.arcsin(c.view_matrix[0, 2])) for c in cams]
    assert max(np.abs(rolls)) > 0.3  # it does roll
    # a camera 3 cm to the side: the image is what a scene built with that camera renders (the
    # backdrop of table and floor re-rendered, not pasted from the old view), and back again
    shifted = replace(base, eye=(base.eye[0], base.eye[1] + 0.03, base.eye[2]))
    scene.set_camera(shifted)
    scene.reset(BOX, Placement(0.58, 0.0, 0.0))
    moved = scene.render()
    with ReachScene(robot, image_size=base.width, camera=shifted) as fresh:
        fresh.reset(BOX, Placement(0.58, 0.0, 0.0))
        np.testing.assert_array_equal(moved, fresh.render())
    assert (moved != rgb).any(-1).mean() > 0.02  # the view moved (the object, the table edge)
    scene.set_camera(base)
    scene.reset(BOX, Placement(0.58, 0.0, 0.0))
    np.testing.assert_array_equal(scene.render(), rgb)
    with pytest.raises(ValueError, match="ReachScene.set_camera: expected a Camera"):
        scene.set_camera("tripod")
    with pytest.raises(ValueError, match="ReachScene.set_camera: expected a .* camera"):
        scene.set_camera(replace(base, width=base.width + 8))
    with pytest.raises(ValueError, match="Camera.with_pose: expected 9 finite values"):
        base.with_pose(np.zeros(7))
