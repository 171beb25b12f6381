"""Lightning DDP with two CPU processes (gloo) through the real entry point."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]

TINY = [
    "data.name=tiny-ddp",
    "data.n_train_objects=2",
    "data.n_train_placements=3",
    "data.val_fraction=0.34",
    "data.n_test_objects=0",
    "data.n_test_placements=0",
    "data.image_size=32",
    "data.n_steps=30",
    "data.batch_size=2",
    "data.progress=false",
    "model.channels=[4,4,4,8]",
    "model.hidden=[16,16]",
]


def test_ddp_two_cpu_processes_train_and_save(tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]), "OMP_NUM_THREADS": "1"}
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
        *TINY,
    ]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-4000:]
    assert "Initializing distributed: GLOBAL_RANK: 1, MEMBER: 2/2" in log, log[-4000:]
    assert "distributed_backend=gloo" in log, log[-4000:]
    ckpts = list((tmp_path / "outputs" / "train").glob("*/checkpoints/last.ckpt"))
    assert len(ckpts) == 1, log[-4000:]
    ckpt = torch.load(ckpts[0], map_location="cpu", weights_only=False)
    assert ckpt["global_step"] >= 1 and ckpt["hyper_parameters"]["kind"] == "cnn_dmp"
