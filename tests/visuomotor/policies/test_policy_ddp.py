"""Lightning DDP with two CPU processes (gloo) through the real entry point."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[3]


def test_ddp_two_cpu_processes_train_and_save(tmp_path, tiny_reaching):
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
        "OMP_NUM_THREADS": "1",
    }
    cmd = [
        sys.executable,
        str(ROOT / "train.py"),
        "model=cnn_dmp",
        "trainer=ddp",
        "trainer.accelerator=cpu",
        "trainer.devices=2",
        "++trainer.max_steps=2",
        "++trainer.limit_val_batches=1",
        f"paths.root_dir={tmp_path}",
        f"hydra.run.dir={tmp_path / 'outputs' / 'train' / 'ddp'}",
        "data.name=tiny-ddp",
        *tiny_reaching,
    ]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-4000:]
    assert "Initializing distributed: GLOBAL_RANK: 1, MEMBER: 2/2" in log, log[-4000:]
    assert "distributed_backend=gloo" in log, log[-4000:]
    ckpts = list((tmp_path / "outputs" / "train").glob("*/checkpoints/last.ckpt"))
    assert len(ckpts) == 1, log[-4000:]
    ckpt = torch.load(ckpts[0], map_location="cpu", weights_only=True)  # what evaluation loads
    assert ckpt["global_step"] >= 1 and ckpt["hyper_parameters"]["kind"] == "cnn_dmp"
