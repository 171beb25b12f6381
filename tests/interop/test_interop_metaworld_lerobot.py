"""Meta-World demonstrations -> LeRobot v3.0: ``info.json`` (fps 80, camera, names, splits),
states / actions / frames read back by :class:`LeRobotFolder` equal the source, lerobot-doctor
finds no failure, and ``scripts/export_dataset.py data=metaworld`` exports with a progress bar."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("metaworld", reason="the [metaworld] extra is not installed")

# The script's data=metaworld imports the datamodule (Lightning, which loads triton); triton loaded
# after MuJoCo has rendered through Mesa's EGL crashes the process, so load it at collection first.
import lfd.visuomotor.metaworld.datamodule  # noqa: F401
from lfd.interop import LeRobotFolder, export_lerobot
from lfd.interop.lerobot.export import export_metaworld
from lfd.visuomotor.metaworld.demos import (
    MetaWorldDataConfig,
    generate_demonstrations,
    load_demonstrations,
)

ROOT = Path(__file__).resolve().parents[2]
#: reach-v3's expert solves within 60 steps; 32 px frames keep generation and encoding short.
TINY = dict(task="reach-v3", n_train=2, n_val=1, image_size=32, n_steps=60)
CAMERA = "observation.images.corner"


@pytest.fixture(scope="module")
def mw(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("mw") / "reach"
    generate_demonstrations(MetaWorldDataConfig(**TINY), path, progress=False)
    return path


@pytest.fixture(scope="module")
def mw_lerobot(mw, tmp_path_factory) -> Path:
    return export_metaworld(mw, tmp_path_factory.mktemp("mw_lerobot") / "reach", progress=False)


def _psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return float(10 * np.log10(255**2 / mse))


def test_info(mw_lerobot):
    info = json.loads((mw_lerobot / "meta" / "info.json").read_text())
    assert info["fps"] == 80 and info["robot_type"] == "sawyer_metaworld"
    assert info["splits"] == {"train": "0:2", "val": "2:3"}
    assert info["total_episodes"] == 3 and info["total_frames"] == 3 * TINY["n_steps"]
    features = info["features"]
    assert features[CAMERA]["shape"] == [32, 32, 3] and features[CAMERA]["info"]["video.codec"] == "av1"
    assert features["observation.state"]["names"] == ["hand.x", "hand.y", "hand.z", "gripper.command"]
    assert features["action"]["names"] == ["x", "y", "z", "gripper"]
    assert (mw_lerobot / ".lfd-export.json").is_file()


def test_read_back_equals_the_source(mw, mw_lerobot):
    data = load_demonstrations(mw)
    order = data.split("train") + data.split("val")
    folder = LeRobotFolder(mw_lerobot)
    assert folder.tasks == ["reach-v3"] and len(folder) == len(order)
    for e, ep in enumerate(order):
        sl = folder.episode_slice(e)
        np.testing.assert_array_equal(folder.data["observation.state"][sl], ep.states.astype(np.float32))
        np.testing.assert_array_equal(folder.data["action"][sl], ep.arrays["actions"])
        np.testing.assert_array_equal(folder.data["frame_index"][sl], np.arange(TINY["n_steps"]))
        np.testing.assert_allclose(
            folder.data["timestamp"][sl], np.arange(TINY["n_steps"]) * 0.0125, atol=1e-6
        )
        assert folder.episodes[e]["tasks"] == ["reach-v3"]
        dec = folder.frames(e, CAMERA)
        assert dec.shape == ep.frames.shape and dec.dtype == np.uint8
        # AV1 at crf 30 (lerobot's default): the brightness is kept closely; at 32 px colour loses
        # more to yuv420p's half-resolution chroma (a lossless yuv420p round trip is ~29 dB alone)
        assert _psnr(ep.frames.mean(-1), dec.mean(-1)) > 32
        assert _psnr(ep.frames, dec) > 25


def test_lerobot_export_dispatches_on_the_manifest(mw, mw_lerobot, tmp_path):
    out = export_lerobot(mw, tmp_path / "via_export_lerobot", progress=False, limit=1)
    folder = LeRobotFolder(out)
    assert len(folder) == 1 and folder.info["splits"] == {"train": "0:1"} and folder.tasks == ["reach-v3"]
    np.testing.assert_array_equal(
        folder.data["action"], LeRobotFolder(mw_lerobot).data["action"][: TINY["n_steps"]]
    )


def test_lerobot_doctor_passes(mw_lerobot):
    pytest.importorskip("lerobot_doctor", reason="lerobot-doctor is a [test] dependency")
    from lerobot_doctor.dataset_loader import load_dataset
    from lerobot_doctor.runner import Severity, run_checks

    report = run_checks(load_dataset(str(mw_lerobot)))
    failures = {
        r.name: [m.message for m in r.messages if m.severity == Severity.FAIL] for r in report.results
    }
    assert len(report.results) == 11  # every check ran
    assert not any(failures.values()), failures


def _overrides(mw: Path, content: list[str]) -> list[str]:
    return [
        "format=lerobot",
        "data=metaworld",
        f"task={TINY['task']}",
        "seed=0",
        f"paths.data_dir={mw.parent}",
        f"data.name={mw.name}",
        *content,
    ]


def test_export_script(mw, tmp_path, capsys):
    from hydra import compose, initialize_config_dir

    spec = importlib.util.spec_from_file_location("export_dataset", ROOT / "scripts" / "export_dataset.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    content = [f"data.{k}={v}" for k, v in TINY.items() if k != "task"]
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        cfg = compose("export_dataset", overrides=[*_overrides(mw, content), f"out={tmp_path}/script"])
        out = script.export(cfg)  # the dataset is verified, not generated again
        refused = compose("export_dataset", overrides=[*_overrides(mw, content), "format=robomimic"])
        with pytest.raises(ValueError, match="format=lerobot only"):
            script.export(refused)
    assert out == tmp_path / "script"
    assert LeRobotFolder(out).info["robot_type"] == "sawyer_metaworld"
    captured = capsys.readouterr()
    assert "LeRobot v3.0" in captured.err and "3/3" in captured.err  # the progress bar
    assert "written to" in captured.out
