"""Readers: real excerpts give plausible bones and in-limit angles; malformed files give clear errors."""

from __future__ import annotations

import gzip
import shutil

import numpy as np
import pytest
from conftest import FIXTURES, REAL_FILES

from lfd.human import SkeletonFormatError, analyze_arm, canonical_joint_name, read_skeleton
from lfd.human.arm_ik import LIMITS


def _bone(sk, a, b):
    """Median bone length over frames where the camera tracked both joints (None if < 10 such frames)."""
    both = sk.tracked[:, sk.index(a)] & sk.tracked[:, sk.index(b)]
    return np.median(np.linalg.norm(sk.joint(b) - sk.joint(a), axis=1)[both]) if both.sum() >= 10 else None


@pytest.mark.parametrize("fmt", sorted(REAL_FILES))
def test_real_excerpt_plausible(fmt):
    sk = read_skeleton(FIXTURES / REAL_FILES[fmt])  # format inferred from the name
    assert f"({fmt}" in sk.source
    assert sk.positions.shape[1:] in {(25, 3), (22, 3)} and sk.rate == pytest.approx(30.0)
    tested = 0
    for side in ("left", "right"):
        upper, fore = (
            _bone(sk, f"shoulder_{side}", f"elbow_{side}"),
            _bone(sk, f"elbow_{side}", f"wrist_{side}"),
        )
        if upper is None or fore is None:
            continue  # e.g. NTU "drink water": the left arm is occluded (only inferred) in most frames
        tested += 1
        assert 0.2 <= upper <= 0.4  # upper arm, m
        assert 0.15 <= fore <= 0.35  # forearm, m
        result = analyze_arm(sk, side=side)
        q = result.q[np.isfinite(result.q).all(1)]
        assert len(q) > 20
        assert np.all(q >= LIMITS[0] - 1e-9) and np.all(q <= LIMITS[1] + 1e-9)
        assert 0.2 <= result.segment_lengths["upper_arm"] <= 0.4
        # Most frames need no clamping: the model covers these poses.
        assert result.quality["clamped_frames"] <= 0.5 * len(result.t)
    assert tested >= 1
    # Kinect labels: the person's left shoulder is on the trunk's +y side, i.e. facing the sensor
    # the trunk x axis points towards the camera (negative z for Kinect, the origin for UI-PRMD).
    from lfd.human.trunk import trunk_frames

    rot, origin = trunk_frames(sk)
    forward = np.nanmedian(rot[:, :, 0], axis=0)
    towards_camera = -np.nanmedian(origin, axis=0)
    assert forward @ towards_camera / np.linalg.norm(towards_camera) > 0.7


def test_kimore_blank_rows_and_tracking_state():
    sk = read_skeleton(FIXTURES / REAL_FILES["kinect_csv"])
    assert sk.n_frames == 120
    assert np.isnan(sk.positions[:24]).all() and not sk.tracked[:24].any()  # blank rows = no body
    assert np.isfinite(sk.positions[24:]).all()
    inferred = ~sk.tracked[24:]
    assert 0 < inferred.mean() < 0.5  # state 1 (inferred) is kept as position but not as tracked


def test_ntu_body_selection():
    sk = read_skeleton(FIXTURES / REAL_FILES["ntu"], body=0)
    assert sk.n_frames == 40 and "body 72057594037931101" in sk.source
    with pytest.raises(ValueError, match="body=3 out of range"):
        read_skeleton(FIXTURES / REAL_FILES["ntu"], body=3)


def test_ntu_picks_body_with_most_frames(tmp_path):
    lines = gzip.decompress((FIXTURES / REAL_FILES["ntu"]).read_bytes()).decode().splitlines()
    out, i = ["3"], 1
    for frame in range(3):  # body A in frame 0 only, body B (a copy shifted 1 m) in all 3
        body = lines[i + 1 : i + 1 + 27]
        i += 28
        shifted = [body[0].replace("72057594037931101", "99"), body[1]]
        shifted += [
            " ".join([str(float(v) + (1.0 if k == 0 else 0.0)) for k, v in enumerate(line.split())])
            for line in body[2:]
        ]
        out += ["2", *body, *shifted] if frame == 0 else ["1", *shifted]
    path = tmp_path / "two.skeleton"
    path.write_text("\n".join(out) + "\n")
    assert "body 99" in read_skeleton(path).source
    assert "body 72057594037931101" in read_skeleton(path, body="72057594037931101").source


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


def test_trc_and_generic_csv_agree():
    truth = np.load(FIXTURES / "synthetic_truth.npz")
    trc = read_skeleton(FIXTURES / "synthetic.trc")
    long = read_skeleton(FIXTURES / "synthetic_long.csv")
    wide = read_skeleton(FIXTURES / "synthetic_wide.csv")
    assert trc.names == long.names == wide.names
    assert "wrist_right" in trc.names and "spine_shoulder" in trc.names
    np.testing.assert_allclose(trc.t, truth["t"], atol=1e-5)
    np.testing.assert_allclose(long.positions, wide.positions, atol=1e-9)
    finite = np.isfinite(trc.positions)
    assert not finite[10, trc.index("wrist_right")].any()  # blank marker cells -> NaN
    np.testing.assert_allclose(
        trc.positions[finite], long.positions[finite], atol=6e-6
    )  # mm -> m (both rounded to 5 µm)
    for sk in (trc, long, wide):
        q = analyze_arm(sk, side="right").q
        assert np.rad2deg(np.sqrt(np.nanmean((q - truth["q_right"]) ** 2))) < 4.0


@pytest.mark.parametrize(
    ("name", "canonical"),
    [("ShoulderRight", "shoulder_right"), ("right_shoulder", "shoulder_right"), ("RShoulder", "shoulder_right"),
     ("L.Elbow", "elbow_left"), ("HandTipLeft", "hand_tip_left"), ("SpineShoulder", "spine_shoulder"),
     ("wrist_l", "wrist_left"), ("Neck", "neck")],
)  # fmt: skip
def test_canonical_names(name, canonical):
    assert canonical_joint_name(name) == canonical


# ------------------------------------------------------------------ malformed files
def _kimore_lines():
    return gzip.decompress((FIXTURES / REAL_FILES["kinect_csv"]).read_bytes()).decode().splitlines()


def _write(tmp_path, name, lines):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_kimore_wrong_column_count(tmp_path):
    lines = _kimore_lines()
    lines[30] = ",".join(lines[30].split(",")[:-5])
    with pytest.raises(SkeletonFormatError, match=r"bad\.csv, line 31, field columns: expected 100 values"):
        read_skeleton(_write(tmp_path, "bad.csv", lines), format="kinect_csv")


def test_kimore_bad_number_names_joint_field(tmp_path):
    lines = _kimore_lines()
    fields = lines[40].split(",")
    fields[4 * 9 + 1] = "abc"  # ElbowRight y
    lines[40] = ",".join(fields)
    with pytest.raises(
        SkeletonFormatError, match=r"line 41, field elbow_right\.y: expected a number, got 'abc'"
    ):
        read_skeleton(_write(tmp_path, "bad.csv", lines), format="kinect_csv")


def test_kimore_bad_tracking_state(tmp_path):
    lines = _kimore_lines()
    fields = lines[50].split(",")
    fields[4 * 2 + 3] = "7"
    lines[50] = ",".join(fields)
    with pytest.raises(SkeletonFormatError, match=r"line 51, field neck\.tracking_state"):
        read_skeleton(_write(tmp_path, "bad.csv", lines), format="kinect_csv")


def test_ntu_truncated_and_bad_joint_line(tmp_path):
    lines = gzip.decompress((FIXTURES / REAL_FILES["ntu"]).read_bytes()).decode().splitlines()
    with pytest.raises(SkeletonFormatError, match=r"cut\.skeleton, line 100, field .*unexpected end of file"):
        read_skeleton(_write(tmp_path, "cut.skeleton", lines[:99]))
    bad = list(lines)
    bad[5] = " ".join(bad[5].split()[:-2])  # 2nd joint line of frame 1 (spine_mid): 10 values instead of 12
    with pytest.raises(SkeletonFormatError, match=r"line 6, field spine_mid: expected 12 values, got 10"):
        read_skeleton(_write(tmp_path, "short.skeleton", bad))


def test_gzip_corrupt(tmp_path):
    path = tmp_path / "x.csv.gz"
    path.write_bytes(b"\x1f\x8b\x08\x00garbage")
    with pytest.raises(SkeletonFormatError, match="x.csv.gz, field gzip"):
        read_skeleton(path, format="kinect_csv")


def test_missing_file_and_unknown_format(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.csv"):
        read_skeleton(tmp_path / "nowhere.csv")
    path = _write(tmp_path, "a.xyz", ["1"])
    with pytest.raises(ValueError, match="cannot infer"):
        read_skeleton(path)
    with pytest.raises(ValueError, match="unknown skeleton format 'bvh'"):
        read_skeleton(path, format="bvh")
    with pytest.raises(ValueError, match=r"has no option\(s\) \['body'\]"):
        read_skeleton(FIXTURES / "synthetic.trc", body=1)
    assert read_skeleton(FIXTURES / "synthetic.trc", up=(0, 0, 2)).up.tolist() == [0.0, 0.0, 1.0]


def test_csv_non_monotonic_time_and_missing_column(tmp_path):
    lines = (FIXTURES / "synthetic_wide.csv").read_text().splitlines()
    lines[5], lines[6] = lines[6], lines[5]
    with pytest.raises(SkeletonFormatError, match=r"line 7, field time: time must increase strictly"):
        read_skeleton(_write(tmp_path, "w.csv", lines))
    long = (FIXTURES / "synthetic_long.csv").read_text().splitlines()
    long = long[:1] + long[20:] + long[1:20]
    with pytest.raises(SkeletonFormatError, match=r"field t: time must not decrease"):
        read_skeleton(_write(tmp_path, "l.csv", long))
    wide = (FIXTURES / "synthetic_wide.csv").read_text().splitlines()
    header = wide[0].split(",")
    cut = [",".join(line.split(",")[:-1]) for line in wide]  # drops neck_z
    assert header[-1] == "neck_z"
    with pytest.raises(SkeletonFormatError, match=r"line 1, field neck_z: missing column"):
        read_skeleton(_write(tmp_path, "c.csv", cut))
    wide[3] = wide[3] + ",1.0"
    with pytest.raises(SkeletonFormatError, match=r"line 4, field columns"):
        read_skeleton(_write(tmp_path, "n.csv", wide))


def test_trc_errors(tmp_path):
    lines = (FIXTURES / "synthetic.trc").read_text().splitlines()
    bad = list(lines)
    bad[2] = bad[2].replace("\tmm\t", "\tinch\t")
    with pytest.raises(SkeletonFormatError, match=r"line 3, field Units"):
        read_skeleton(_write(tmp_path, "u.trc", bad))
    bad = list(lines)
    bad[12] = "\t".join(bad[12].split("\t")[:-3])
    with pytest.raises(SkeletonFormatError, match=r"line 13, field columns"):
        read_skeleton(_write(tmp_path, "c.trc", bad))
    bad = list(lines)
    bad[10], bad[11] = bad[11], bad[10]
    with pytest.raises(SkeletonFormatError, match=r"line 12, field Time: time must increase"):
        read_skeleton(_write(tmp_path, "t.trc", bad))


def test_missing_joints_for_the_arm(tmp_path):
    wide = (FIXTURES / "synthetic_wide.csv").read_text().splitlines()
    header = wide[0].split(",")
    keep = [i for i, h in enumerate(header) if not h.startswith("elbow_right")]
    path = _write(tmp_path, "noelbow.csv", [",".join(line.split(",")[i] for i in keep) for line in wide])
    sk = read_skeleton(path)
    with pytest.raises(ValueError, match=r"noelbow.csv.*missing joint\(s\) \['elbow_right'\]"):
        analyze_arm(sk, side="right")
    analyze_arm(sk, side="left")  # the other arm is still fine
