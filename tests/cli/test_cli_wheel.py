"""The wheel: built from a copy of the repository, installed (not editable) into a fresh virtual environment in a
temporary folder, its commands run from a folder outside the repository with the configs it ships: lfd-train --help,
lfd-samples (when the package has it) and lfd-imitate on the samples' joint CSV (else on one written here).

The environment sees this one's packages (``--system-site-packages``: torch, PyBullet, ... are not downloaded
again) but imports lfd from the wheel, which is checked (``lfd.__file__``)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
#: What a build of lfd reads from the repository.
SOURCES = ("pyproject.toml", "setup.py", "MANIFEST.in", "README.md", "src", "configs")


def _run(args: list, cwd: Path, env: dict[str, str], timeout: float = 600) -> subprocess.CompletedProcess:
    run = subprocess.run(
        [str(a) for a in args], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
    )
    assert run.returncode == 0, f"{args}: rc {run.returncode}\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}"
    return run


def _joint_csv(path: Path) -> Path:
    """A WAM joint CSV (with a comment line) of 2 s at 50 Hz: every joint moves smoothly."""
    t = np.linspace(0.0, 2.0, 101)
    s = 0.5 - 0.5 * np.cos(np.pi * t / 2.0)
    q = np.stack([0.2 * s, 0.3 + 0.4 * s, -0.1 * s, 1.2 - 0.5 * s], axis=1)
    rows = ["# a sample joint recording, rad", "time,j0,j1,j2,j3"]
    rows += [",".join(f"{v:.5f}" for v in (ti, *qi)) for ti, qi in zip(t, q)]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.slow
def test_the_wheel_runs_its_commands_from_any_folder(tmp_path):
    source = tmp_path / "source"
    source.mkdir()
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(
                ROOT / name, source / name, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info")
            )
        else:
            shutil.copy2(ROOT / name, source / name)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "LFD_ROOT", "VIRTUAL_ENV")}
    env["OMP_NUM_THREADS"] = "1"
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w", tmp_path / "dist", source],
         tmp_path, env)  # fmt: skip
    (wheel,) = (tmp_path / "dist").glob("lfd-*.whl")

    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--system-site-packages", venv], tmp_path, env)
    bin_dir = venv / "bin"
    env["PATH"] = f"{bin_dir}{os.pathsep}{env.get('PATH', '')}"
    install = ["install", "--no-deps", "--no-index", "--ignore-installed", wheel]
    _run([bin_dir / "python", "-m", "pip", *install], tmp_path, env)

    work = tmp_path / "elsewhere"  # outside the repository, no configs/ here
    work.mkdir()
    where = _run([bin_dir / "python", "-c", "import lfd, lfd.cli; print(lfd.__file__); print(lfd.cli.configs_dir())"],
                 work, env).stdout.split()  # fmt: skip
    assert Path(where[0]).is_relative_to(venv), f"the venv imports lfd from {where[0]}, not from the wheel"
    assert Path(where[1]) == Path(where[0]).parent / "configs"
    assert (Path(where[1]) / "experiment" / "quick.yaml").is_file()

    usage = _run([bin_dir / "lfd-train", "--help"], work, env).stdout
    assert usage.startswith("lfd-train (python train.py): train a model"), usage
    assert len(usage.splitlines()) <= 10

    if (source / "src" / "lfd" / "samples.py").is_file():  # the samples command: its joint CSV
        _run([bin_dir / "lfd-samples", "samples"], work, env)
        csv = Path("samples") / "arm.csv"
        assert (work / csv).is_file()
    else:
        csv = _joint_csv(work / "arm.csv").relative_to(work)
    run = _run([bin_dir / "lfd-imitate", f"source={csv}", "robot=wam4"], work, env)
    (summary,) = (work / "outputs" / "imitate").glob("*/summary.json")
    assert json.loads(summary.read_text()), run.stdout
    assert (summary.parent / "dmp.json").is_file() and (summary.parent / "robot_trajectory.csv").is_file()
