"""``scripts/export_dataset.py`` (Hydra entry point): both formats, progress bar, bad format."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
from hydra import compose, initialize_config_dir

ROOT = Path(__file__).resolve().parents[2]


def _overrides(params: dict, tiny_root: Path, *extra: str) -> list[str]:
    data = [f"data.{k}={v}" for k, v in params.items() if k != "seed"]
    return [
        f"seed={params['seed']}",
        f"paths.data_dir={tiny_root}",
        "data.name=tiny",
        "data.num_gen_workers=1",
        *data,
        *extra,
    ]


def _script():
    spec = importlib.util.spec_from_file_location("export_dataset", ROOT / "scripts" / "export_dataset.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_export_both_formats(tiny_root, tiny_params, tmp_path, capsys):
    script = _script()
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        cfg = compose(
            "export_dataset",
            overrides=_overrides(
                tiny_params,
                tiny_root,
                "format=lerobot",
                f"out={tmp_path}/ds",
                "lerobot.codec=h264",
                "limit=3",
            ),
        )
        out = script.export(cfg)
        info = json.loads((out / "meta" / "info.json").read_text())
        assert (
            info["total_episodes"] == 3
            and info["features"]["observation.images.front"]["info"]["video.codec"] == "h264"
        )
        cfg = compose("export_dataset", overrides=_overrides(tiny_params, tiny_root, "format=robomimic"))
        out = script.export(cfg)
        assert out == tiny_root / "tiny.hdf5"
        with h5py.File(out, "r") as f:
            assert len(f["data"]) == 7
        cfg = compose("export_dataset", overrides=_overrides(tiny_params, tiny_root, "format=zarr"))
        with pytest.raises(ValueError, match="format"):
            script.export(cfg)
    err = capsys.readouterr().err
    assert "LeRobot v3.0" in err and "robomimic" in err and "7/7" in err  # the progress bars


@pytest.mark.slow
def test_command_line(tiny_root, tiny_params, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    cmd = [
        sys.executable,
        str(ROOT / "scripts" / "export_dataset.py"),
        *_overrides(
            tiny_params, tiny_root, "format=lerobot", f"out={tmp_path}/cli", f"hydra.run.dir={tmp_path}/run"
        ),
    ]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    assert "written to" in res.stdout and "LeRobot v3.0" in res.stderr
    assert json.loads((tmp_path / "cli" / "meta" / "info.json").read_text())["total_episodes"] == 7
