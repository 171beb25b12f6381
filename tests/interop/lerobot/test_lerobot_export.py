"""lfd dataset -> LeRobot v3.0: states, actions and ``lfd/`` episode columns of every
episode, task strings and colour words, the H.264 option."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lfd.interop import LeRobotFolder, export_lerobot
from lfd.interop.lerobot.export import colour_name, task_string
from lfd.visuomotor.data import load_dataset
from lfd.visuomotor.data.episodes import SPLITS


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


def test_h264_option_and_psnr(tiny, tmp_path):
    out = export_lerobot(tiny, tmp_path / "h264", codec="h264", progress=False, limit=2)
    info = json.loads((out / "meta" / "info.json").read_text())
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
