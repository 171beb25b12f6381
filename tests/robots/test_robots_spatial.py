import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from lfd.robots.spatial import matrix_to_quaternion


def test_rotation_about_z():
    theta = 0.7
    R = np.array([[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]])
    half = [np.sin(theta / 2), np.cos(theta / 2)]
    np.testing.assert_allclose(matrix_to_quaternion(R, "xyzw"), [0, 0, *half], atol=1e-12)
    np.testing.assert_allclose(matrix_to_quaternion(R), [half[1], 0, 0, half[0]], atol=1e-12)


@pytest.mark.parametrize("order", ["wxyz", "xyzw"])
def test_matches_scipy_on_random_and_half_turn_rotations(order):
    R = np.concatenate(
        [
            Rotation.random(500, random_state=1).as_matrix(),
            [np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1])],
        ]
    )
    ref = Rotation.from_matrix(R).as_quat()  # x, y, z, w
    ref = np.where(ref[:, 3:] < 0, -ref, ref)
    if order == "wxyz":
        ref = ref[:, [3, 0, 1, 2]]
    got = matrix_to_quaternion(R.reshape(503, 1, 3, 3), order)
    assert got.shape == (503, 1, 4)
    # half turns have w = 0, where q and -q are both canonical
    np.testing.assert_allclose(np.abs(got[:, 0]), np.abs(ref), atol=1e-12)
    np.testing.assert_allclose(got[:500, 0], ref[:500], atol=1e-12)


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match=r"R: expected .*\(\.\.\., 3, 3\)"):
        matrix_to_quaternion(np.eye(4))
    with pytest.raises(ValueError, match="R: .*finite"):
        matrix_to_quaternion(np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match="order"):
        matrix_to_quaternion(np.eye(3), order="zyxw")
