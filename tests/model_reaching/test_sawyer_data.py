"""Sawyer model datamodules (lfd.model_reaching.data): forward-model samples, no simulator."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from lfd.model_reaching.data import SawyerFKDataModule
from lfd.robots import load_robot

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def robot():
    return load_robot("sawyer")


# ---------------------------------------------------------------------------- forward-model samples
def test_fk_datamodule_fresh_training_samples_fixed_test_set(robot):
    dm = SawyerFKDataModule(batch_size=64, batches_per_epoch=3, n_val=10, n_test=20, seed=5)
    first, second = list(dm.train_dataloader()), list(dm.train_dataloader())
    assert len(first) == 3 and first[0][0].shape == (64, 7) and first[0][1].shape == (64, 3)
    assert not torch.equal(first[0][0], second[0][0])  # a new epoch draws new configurations
    q, x = dm.fixed_set("test").tensors
    assert torch.equal(q, SawyerFKDataModule(n_test=20, seed=5).fixed_set("test").tensors[0])
    assert bool(robot.within_limits(q.double()).all())
    assert torch.allclose(x.double(), robot.fk(q.double())[:, :3, 3], atol=1e-5)
    with pytest.raises(ValueError, match="batch_size"):
        SawyerFKDataModule(batch_size=0)


def test_sawyer_data_imports_without_pybullet():
    """The numeric data pipeline (lfd.model_reaching.data, lfd.sim.trajectory) needs no simulator."""
    code = (
        "import sys; sys.modules['pybullet'] = None\n"  # any `import pybullet` now raises ImportError
        "import lfd.model_reaching.data, lfd.model_reaching.demonstrations, lfd.sim.trajectory, lfd.robots\n"
        "print(sorted(m for m in sys.modules if m.startswith('lfd.sim')))"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    result = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip() == "['lfd.sim', 'lfd.sim.trajectory']"
