"""LeRobot v3.0 writer: layout against a dataset written by lerobot 0.4.4 itself, exact
timestamps and indices, file and chunk rollover, input checks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from lfd.interop import LeRobotEpisode, LeRobotFolder, LeRobotWriter
from lfd.interop.lerobot.stats import STAT_KEYS

REFERENCE = Path(__file__).resolve().parents[2] / "fixtures" / "lerobot_v3_reference"

DATA = "data/chunk-000/file-000.parquet"
EPISODES = "meta/episodes/chunk-000/file-000.parquet"
TASKS = "meta/tasks.parquet"


def _info(root):
    return json.loads((root / "meta" / "info.json").read_text())


def test_info_json_matches_reference(tiny_lerobot):
    ref, ours = _info(REFERENCE), _info(tiny_lerobot)
    assert list(ours) == list(ref)  # same keys, same order
    assert ours["codebase_version"] == "v3.0"
    for key in ("chunks_size", "data_files_size_in_mb", "video_files_size_in_mb", "data_path", "video_path"):
        assert ours[key] == ref[key], key
    assert list(ours["features"]) == list(ref["features"])  # images first, then state, action, defaults
    for name, feat in ref["features"].items():
        mine = ours["features"][name]
        assert list(mine) == list(feat), name
        assert mine["dtype"] == feat["dtype"] and len(mine["shape"]) == len(feat["shape"]), name
        if feat["dtype"] == "video":
            assert list(mine["info"]) == list(feat["info"])
            assert mine["info"]["video.codec"] == "av1" and mine["info"]["video.pix_fmt"] == "yuv420p"
            assert mine["names"] == feat["names"]
        elif feat["names"] is None:
            assert mine["names"] is None
    assert ours["features"]["observation.state"]["shape"] == [14] and ours["features"]["action"]["shape"] == [
        7
    ]
    assert ours["total_episodes"] == 7 and ours["total_frames"] == 7 * 30
    assert ours["splits"] == {"train": "0:4", "val": "4:6", "test": "6:7"}
    assert ours["fps"] == pytest.approx(29 / 4.0)  # (n_steps - 1) / duration


@pytest.mark.parametrize("rel", [DATA, EPISODES, TASKS])
def test_parquet_schemas_match_reference(tiny_lerobot, rel):
    ref, ours = pq.read_schema(REFERENCE / rel), pq.read_schema(tiny_lerobot / rel)
    shared = [n for n in ours.names if n in ref.names]
    assert shared == ref.names, f"{rel}: reference columns missing or reordered"
    for field in ref:
        assert ours.field(field.name).type == field.type, f"{rel}: {field.name}"
    extra = [n for n in ours.names if n not in ref.names]
    assert all(n.startswith("lfd/") for n in extra), extra
    if rel == DATA:
        assert extra == []
        ref_hf = json.loads(ref.metadata[b"huggingface"])["info"]["features"]
        our_hf = json.loads(ours.metadata[b"huggingface"])["info"]["features"]
        assert our_hf.keys() == ref_hf.keys()
        assert our_hf["timestamp"] == ref_hf["timestamp"] and our_hf["index"] == ref_hf["index"]
        assert our_hf["observation.state"]["_type"] == "List" and our_hf["observation.state"]["length"] == 14
    if rel == TASKS:
        assert json.loads(ours.metadata[b"pandas"])["index_columns"] == ["__index_level_0__"]


def test_one_row_group_per_episode_and_stats_layout(tiny_lerobot):
    assert pq.ParquetFile(tiny_lerobot / DATA).metadata.num_row_groups == 7
    ref, ours = (
        json.loads((REFERENCE / "meta/stats.json").read_text()),
        json.loads((tiny_lerobot / "meta/stats.json").read_text()),
    )
    assert set(ours) == set(ref)
    for feat in ref:
        assert list(ours[feat]) == list(ref[feat]) == list(STAT_KEYS)
        for k in STAT_KEYS:
            assert np.shape(ours[feat][k]) == np.shape(ref[feat][k]), (feat, k)


def test_frames_timestamps_indices_exact(tiny_lerobot):
    folder = LeRobotFolder(tiny_lerobot)
    d = folder.data
    np.testing.assert_array_equal(d["timestamp"], (d["frame_index"] / folder.fps).astype(np.float32))
    np.testing.assert_array_equal(d["index"], np.arange(7 * 30))
    key = "observation.images.front"
    to = 0.0
    for e, row in enumerate(folder.episodes):
        assert (row["dataset_from_index"], row["dataset_to_index"], row["length"]) == (
            30 * e,
            30 * e + 30,
            30,
        )
        np.testing.assert_array_equal(d["episode_index"][folder.episode_slice(e)], e)
        assert row[f"videos/{key}/from_timestamp"] == pytest.approx(to)
        to = row[f"videos/{key}/to_timestamp"]
        assert to - row[f"videos/{key}/from_timestamp"] == pytest.approx(30 / folder.fps)
        assert row["tasks"] == [folder.tasks[d["task_index"][30 * e]]]


def _episode(rng, T, cams=("front",)):
    return LeRobotEpisode(
        state=rng.normal(size=(T, 4)),
        action=rng.normal(size=(T, 2)),
        frames={c: rng.integers(0, 255, (T, 64, 64, 3), dtype=np.uint8) for c in cams},
        task=f"task {T % 2}",
        extra={"lfd/x": float(T), "lfd/v": [1.0, 2.0]},
    )


def test_file_size_and_chunk_rollover(tmp_path):
    """Tiny size limits: every episode opens a new data, episodes-metadata and video file,
    and the file index runs past chunks_size=2 into the next chunks, as lerobot's writer does."""
    rng = np.random.default_rng(0)
    w = LeRobotWriter(
        tmp_path / "ds",
        fps=10,
        robot_type="test",
        state_names=list("abcd"),
        action_names=["u", "v"],
        cameras={"front": (64, 64)},
        chunks_size=2,
        data_files_size_in_mb=1e-4,
        video_files_size_in_mb=1e-4,
        codec="h264",
    )
    eps = [_episode(rng, T) for T in (5, 6, 7, 8, 9)]
    for ep in eps:
        w.add_episode(ep)
    root = w.finalize()
    folder = LeRobotFolder(root)
    key = "observation.images.front"
    expected = [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0)]
    for e, row in enumerate(folder.episodes):
        assert (row["data/chunk_index"], row["data/file_index"]) == expected[e]
        assert (row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"]) == expected[e]
        assert (row["meta/episodes/chunk_index"], row["meta/episodes/file_index"]) == expected[e]
        assert row[f"videos/{key}/from_timestamp"] == 0.0  # each video file starts with its episode
        assert (root / f"data/chunk-{expected[e][0]:03d}/file-{expected[e][1]:03d}.parquet").is_file()
        assert (root / f"videos/{key}/chunk-{expected[e][0]:03d}/file-{expected[e][1]:03d}.mp4").is_file()
        np.testing.assert_array_equal(
            folder.data["observation.state"][folder.episode_slice(e)], eps[e].state.astype(np.float32)
        )
        assert folder.frames(e, key).shape == (len(eps[e].state), 64, 64, 3)
    assert folder.tasks == ["task 1", "task 0"]


def test_default_limits_keep_one_file(tmp_path):
    rng = np.random.default_rng(1)
    w = LeRobotWriter(
        tmp_path / "ds",
        fps=10,
        robot_type="t",
        state_names=list("abcd"),
        action_names=["u", "v"],
        cameras={"front": (64, 64)},
        codec="h264",
    )
    for T in (5, 6, 7):
        w.add_episode(_episode(rng, T))
    folder = LeRobotFolder(w.finalize())
    assert {
        (r["data/file_index"], r["videos/observation.images.front/file_index"]) for r in folder.episodes
    } == {(0, 0)}
    assert [r["videos/observation.images.front/from_timestamp"] for r in folder.episodes] == pytest.approx(
        [0.0, 0.5, 1.1]
    )


def test_writer_rejects_bad_input(tmp_path):
    rng = np.random.default_rng(2)
    w = LeRobotWriter(
        tmp_path / "ds",
        fps=10,
        robot_type="t",
        state_names=list("abcd"),
        action_names=["u", "v"],
        cameras={"front": (64, 64)},
    )
    ep = _episode(rng, 5)
    with pytest.raises(ValueError, match="state"):
        w.add_episode(LeRobotEpisode(ep.state[:, :3], ep.action, ep.frames, "t"))
    bad = ep.state.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        w.add_episode(LeRobotEpisode(bad, ep.action, ep.frames, "t"))
    with pytest.raises(ValueError, match="cameras"):
        w.add_episode(LeRobotEpisode(ep.state, ep.action, {"wrist": ep.frames["front"]}, "t"))
    with pytest.raises(ValueError, match="frames"):
        w.add_episode(LeRobotEpisode(ep.state, ep.action, {"front": ep.frames["front"][:, :32]}, "t"))
    with pytest.raises(ValueError, match="no episodes"):
        w.finalize()
    with pytest.raises(FileExistsError):
        (tmp_path / "full").mkdir()
        (tmp_path / "full" / "x").write_text("x")
        LeRobotWriter(
            tmp_path / "full", fps=10, robot_type="t", state_names=["a"], action_names=["a"], cameras={}
        )
    with pytest.raises(ValueError, match="fps"):
        LeRobotWriter(
            tmp_path / "f", fps=0, robot_type="t", state_names=["a"], action_names=["a"], cameras={}
        )
