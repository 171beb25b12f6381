"""LeRobot v3.0 writer: layout against a dataset written by lerobot 0.4.4 itself, exact
timestamps and stats, extra columns, task strings, AV1 / H.264, file and chunk rollover."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from lfd.interop import (
    LeRobotEpisode,
    LeRobotFolder,
    LeRobotWriter,
    export_lerobot,
    update_chunk_file_indices,
)
from lfd.interop.lerobot.writer import STAT_KEYS, colour_name, task_string
from lfd.io.video import decode_video_frames
from lfd.visuomotor.data import load_dataset
from lfd.visuomotor.data.episodes import SPLITS

REFERENCE = Path(__file__).resolve().parents[1] / "fixtures" / "lerobot_v3_reference"

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


def test_states_actions_extra_columns_and_tasks(tiny, tiny_lerobot):
    data = load_dataset(tiny)
    order = [r for s in SPLITS for r in data.split(s)]
    folder = LeRobotFolder(tiny_lerobot)
    for e, rec in enumerate(order):
        sl = folder.episode_slice(e)
        a = rec.arrays
        np.testing.assert_array_equal(
            folder.data["observation.state"][sl],
            np.concatenate([a["joints"], a["velocities"]], 1).astype(np.float32),
        )
        np.testing.assert_array_equal(folder.data["action"][sl][:-1], a["joints"][1:].astype(np.float32))
        row = folder.episodes[e]
        assert row["lfd/index"] == rec.index and row["lfd/split"] == rec.split
        assert row["lfd/object_name"] == rec.obj.name and row["lfd/object_shape"] == rec.obj.shape
        np.testing.assert_array_equal(
            np.reshape(row["lfd/dmp_weights"], a["dmp_weights"].shape), a["dmp_weights"]
        )
        np.testing.assert_array_equal(row["lfd/dmp_goal"], a["dmp_goal"])
        np.testing.assert_array_equal(row["lfd/placement"], a["placement"])
        np.testing.assert_array_equal(np.reshape(row["lfd/ee_path"], (-1, 3)), a["ee_poses"][:, :3, 3])
        task = row["tasks"][0]
        assert task == task_string(rec.obj, str(a["approach_mode"]))
        assert task.startswith("reach the ") and rec.obj.shape in task
        assert task.endswith("from the side" if str(a["approach_mode"]) == "side" else "from above")


def test_colour_names():
    assert colour_name((0.9, 0.1, 0.1, 1)) == "red"
    assert colour_name((0.1, 0.8, 0.2)) == "green"
    assert colour_name((0.1, 0.2, 0.9)) == "blue"
    assert colour_name((0.95, 0.9, 0.1)) == "yellow"
    assert colour_name((0.5, 0.5, 0.5)) == "grey"
    with pytest.raises(ValueError, match="approach_mode"):
        task_string(type("O", (), {"rgba": (1, 0, 0, 1), "shape": "box"})(), "diagonal")


def test_stats_are_exact(tiny, tiny_lerobot):
    stats = json.loads((tiny_lerobot / "meta/stats.json").read_text())
    folder = LeRobotFolder(tiny_lerobot)
    state = folder.data["observation.state"].astype(np.float64)
    np.testing.assert_allclose(
        stats["observation.state"]["q50"], np.quantile(state, 0.5, axis=0), rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(
        stats["observation.state"]["q99"], np.quantile(state, 0.99, axis=0), rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(
        stats["action"]["std"], folder.data["action"].astype(np.float64).std(axis=0), atol=1e-12
    )
    assert stats["index"]["count"] == [210] and stats["index"]["max"] == [209]
    # images: per channel in [0, 1], against a brute-force pass over every source pixel
    frames = np.concatenate([r.frames() for r in load_dataset(tiny).episodes]).astype(np.float64) / 255
    img = stats["observation.images.front"]
    for c in range(3):
        px = frames[..., c].ravel()
        assert img["mean"][c][0][0] == pytest.approx(px.mean(), abs=1e-12)
        assert img["std"][c][0][0] == pytest.approx(px.std(), abs=1e-9)
        for q, key in zip((0.01, 0.1, 0.5, 0.9, 0.99), ("q01", "q10", "q50", "q90", "q99"), strict=True):
            assert img[key][c][0][0] == pytest.approx(np.quantile(px, q), abs=1e-12), key
    assert img["count"] == [210] and img["std"][0][0][0] > 0  # lerobot's own uint8 std overflows to 0
    # per-episode stats of episode 0 (the episodes parquet)
    row = folder.episodes[0]
    np.testing.assert_allclose(row["stats/observation.state/mean"], state[:30].mean(axis=0), atol=1e-12)
    assert row["stats/observation.state/count"] == [30]


def test_h264_option_and_psnr(tiny, tmp_path):
    out = export_lerobot(tiny, tmp_path / "h264", codec="h264", progress=False, limit=2)
    info = _info(out)
    assert info["features"]["observation.images.front"]["info"]["video.codec"] == "h264"
    folder = LeRobotFolder(out)
    data = load_dataset(tiny)
    src = data.split("train")[1].frames()
    dec = folder.frames(1, "observation.images.front")
    mse = np.mean((src.astype(np.float64) - dec) ** 2)
    assert 10 * np.log10(255**2 / mse) > 35
    with pytest.raises(FileExistsError):
        export_lerobot(tiny, out, progress=False, limit=1)
    with pytest.raises(ValueError, match="codec"):
        export_lerobot(tiny, tmp_path / "bad", codec="vp9", progress=False)


def test_chunk_indices():
    assert update_chunk_file_indices(0, 0, 1000) == (0, 1)
    assert update_chunk_file_indices(0, 998, 1000) == (0, 999)
    assert update_chunk_file_indices(0, 999, 1000) == (1, 0)
    assert update_chunk_file_indices(3, 1, 2) == (4, 0)


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


def test_decode_tolerance(tiny_lerobot):
    path = LeRobotFolder(tiny_lerobot).video_path(0, "observation.images.front")
    with pytest.raises(ValueError, match="no frame within"):
        decode_video_frames(path, [0.5 / 7.25])  # half-way between two frames
    with pytest.raises(FileNotFoundError):
        decode_video_frames(path.with_name("missing.mp4"), [0.0])
