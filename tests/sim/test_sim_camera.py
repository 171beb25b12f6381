"""Camera matrices, projection and rendering."""

import numpy as np
import pybullet as p
import pytest

from lfd.sim.camera import Camera, look_at, perspective, project_points, to_pybullet


def test_matrices_match_pybullet():
    eye, target, up = np.array([0.1, 0.2, 0.5]), np.array([0.6, 0.0, -0.3]), np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(
        to_pybullet(look_at(eye, target, up)), p.computeViewMatrix(eye, target, up), atol=1e-6
    )
    np.testing.assert_allclose(
        to_pybullet(perspective(45.0, 1.25, 0.05, 4.0)),
        p.computeProjectionMatrixFOV(45.0, 1.25, 0.05, 4.0),
        atol=1e-6,
    )


def test_projection_of_target_is_image_centre_and_behind_is_nan():
    cam = Camera(width=64, height=48)
    np.testing.assert_allclose(cam.project(np.array(cam.target)), [32.0, 24.0], atol=1e-9)
    behind = 2 * np.array(cam.eye) - np.array(cam.target)
    assert np.isnan(cam.project(behind)).all()
    # the robot's right (-y) is on the image's right
    left, right = cam.project(np.array([[0.58, 0.2, -0.33], [0.58, -0.2, -0.33]]))
    assert left[0] < 32 < right[0]


def test_rendered_sphere_appears_where_projected():
    client = p.connect(p.DIRECT)
    try:
        base = np.eye(4)
        base[2, 3] = 1.0
        cam = Camera(width=96, height=96)
        centre = np.array([0.6, -0.15, -0.2])  # torso frame
        vis = p.createVisualShape(p.GEOM_SPHERE, radius=0.03, rgbaColor=(1, 0, 0, 1), physicsClientId=client)
        p.createMultiBody(0, -1, vis, basePosition=(centre + base[:3, 3]).tolist(), physicsClientId=client)
        img = cam.render(client, base)
        assert img.shape == (96, 96, 3) and img.dtype == np.uint8
        red = (img[..., 0] > 150) & (img[..., 1] < 80)
        rows, cols = np.nonzero(red)
        u, v = cam.project(centre)
        assert abs(cols.mean() + 0.5 - u) < 1.5 and abs(rows.mean() + 0.5 - v) < 1.5
        backdrop = np.zeros_like(img)
        composite = cam.render(client, base, backdrop)
        np.testing.assert_array_equal(composite[red], img[red])
        assert (composite[~red] == 0).mean() > 0.95
    finally:
        p.disconnect(physicsClientId=client)


def test_camera_validation():
    with pytest.raises(ValueError, match="width and height"):
        Camera(width=0)
    with pytest.raises(ValueError, match="fov_deg"):
        Camera(fov_deg=180)
    with pytest.raises(ValueError, match="'up'"):
        look_at(np.zeros(3), np.array([0, 0, -1.0]), np.array([0, 0, 1.0]))
    assert project_points(np.zeros((0, 3)), np.eye(4), perspective(45, 1, 0.1, 2), 8, 8).shape == (0, 2)
