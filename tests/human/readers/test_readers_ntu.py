"""NTU RGB+D .skeleton: body selection (index, id, most frames); truncated files and short joint lines."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest

from lfd.human import SkeletonFormatError, read_skeleton

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "human"
NTU = FIXTURES / "ntu_S001C001P001R001A001_excerpt.skeleton.gz"


def test_ntu_body_selection():
    sk = read_skeleton(NTU, body=0)
    assert sk.n_frames == 40 and "body 72057594037931101" in sk.source
    with pytest.raises(ValueError, match="body=3 out of range"):
        read_skeleton(NTU, body=3)


def test_ntu_picks_body_with_most_frames(tmp_path):
    lines = gzip.decompress((NTU).read_bytes()).decode().splitlines()
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


def _write(tmp_path, name, lines):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_ntu_truncated_and_bad_joint_line(tmp_path):
    lines = gzip.decompress((NTU).read_bytes()).decode().splitlines()
    with pytest.raises(SkeletonFormatError, match=r"cut\.skeleton, line 100, field .*unexpected end of file"):
        read_skeleton(_write(tmp_path, "cut.skeleton", lines[:99]))
    bad = list(lines)
    bad[5] = " ".join(bad[5].split()[:-2])  # 2nd joint line of frame 1 (spine_mid): 10 values instead of 12
    with pytest.raises(SkeletonFormatError, match=r"line 6, field spine_mid: expected 12 values, got 10"):
        read_skeleton(_write(tmp_path, "short.skeleton", bad))
