"""UI-PRMD: units, the sibling angles file, the forward kinematics of the file layout, and the
Euler order of the angle files (undocumented; our choice, intrinsic ZXY, must be stable).

The order was chosen on every third UI-PRMD file (starting with the first) as the one with the
least motion of joints that should stay still during a right-arm exercise (left wrist, feet);
these tests use two files that were not part of that choice.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from lfd.human import analyze_arm, read_skeleton
from lfd.human.readers import uiprmd_global_positions

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "human"
HELD_OUT = ("m10_s05_e02", "m08_s03_e02")
ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")


def _path(name):
    return FIXTURES / f"ui_prmd/Kinect/Positions/{name}_positions.txt.gz"


def _static_motion(sk):
    return np.mean([np.linalg.norm(sk.joint(j).std(0)) for j in ("wrist_left", "foot_left", "foot_right")])


@pytest.mark.parametrize("name", HELD_OUT)
def test_chosen_order_is_stable_and_best_on_held_out_files(name):
    # one fixed filter for every order (the automatic cut-off follows each file's noise)
    results = {
        o: analyze_arm(read_skeleton(_path(name), euler_order=o), side="right", cutoff=6.0) for o in ORDERS
    }
    ref = results["ZXY"]
    for order, other in results.items():
        # the arm geometry changes little between orders: median elbow/wrist difference < 3 cm ...
        assert np.nanmedian(np.linalg.norm(other.positions - ref.positions, axis=-1)) < 0.03
        # ... and so do the well-conditioned angles (elbow < 6 deg RMS; elevation < 8.5 deg, the
        # thesis's bound of 6 deg on each of abduction and flexion, combined; the plane of
        # elevation of a nearly hanging arm and the rotation about a nearly straight arm are
        # ill-conditioned and differ more; the axial rotation there absorbs the plane's ambiguity)
        rms = np.rad2deg(np.sqrt(np.nanmean((other.q - ref.q) ** 2, axis=0)))
        assert rms[1] < 8.5 and rms[3] < 6.0, (order, rms)
        assert np.all(rms[[0, 2]] < 30.0), (order, rms)
        # raw bone lengths do not depend on the order; after filtering they differ by < 0.1 %
        assert other.segment_lengths == pytest.approx(ref.segment_lengths, rel=1e-3)
    motion = {o: _static_motion(read_skeleton(_path(name), euler_order=o)) for o in ORDERS}
    assert min(motion, key=motion.get) == "ZXY"


def test_forward_kinematics_of_the_file_layout():
    # Hand-made two-joint check of the stated rule: global = parent + parent_rot @ offset.
    offsets = np.zeros((1, 22, 3))
    angles = np.zeros((1, 22, 3))
    offsets[0, 0] = [1.0, 2.0, 3.0]  # waist absolute
    offsets[0, 1] = [0.0, 10.0, 0.0]  # spine 10 up from the waist
    angles[0, 0] = [0.0, 0.0, 90.0]  # waist turned 90 deg about z: the spine offset points along -x
    pos = uiprmd_global_positions(offsets, angles, "ZXY")
    np.testing.assert_allclose(pos[0, 1], [1.0 - 10.0, 2.0, 3.0], atol=1e-12)
    with pytest.raises(ValueError, match="euler_order"):
        read_skeleton(_path(HELD_OUT[0]), euler_order="XXY")


def test_uiprmd_units_and_sibling_angles(tmp_path):
    sk = read_skeleton(FIXTURES / "ui_prmd/Kinect/Positions/m07_s02_e01_positions.txt.gz", format="uiprmd")
    assert sk.n_frames == 76
    # waist row of frame 0 is (-12.35, 91.34, -254.14) cm
    np.testing.assert_allclose(sk.joint("spine_base")[0], [-0.1234805, 0.9134453, -2.5414243])
    # bone length = norm of the constant offset row (28.87635 cm upper arm), whatever the rotation
    np.testing.assert_allclose(
        np.linalg.norm(sk.joint("elbow_left")[0] - sk.joint("shoulder_left")[0]), 0.2887635, atol=1e-6
    )
    lonely = tmp_path / "Positions"
    lonely.mkdir()
    shutil.copy(FIXTURES / "ui_prmd/Kinect/Positions/m07_s02_e01_positions.txt.gz", lonely)
    with pytest.raises(FileNotFoundError, match="angles file not found"):
        read_skeleton(lonely / "m07_s02_e01_positions.txt.gz")
