"""Slow accuracy test: a small CNN -> DMP training must reach *new* objects.

The quick experiment shrunk to a few minutes of CPU (64 px, 150 training objects x 2
placements, 1000 steps; the quick experiment's CNN -> DMP options, RGB-D input included),
trained with ``train.py`` and evaluated closed loop in PyBullet with ``evaluate.py
eval.split=val`` on the 8 held-out validation objects (2 placements each), exactly as a user
runs them. The thresholds were set from one measured run (numbers in the assertion messages
and in docs/evaluation.md) with a margin: CI notices when generalisation to new objects breaks, not a 1 cm fluctuation.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
DATA = [
    "experiment=quick",
    "data.name=accuracy",
    "data.image_size=64",
    "data.n_train_objects=150",
    "data.n_train_placements=2",
    "data.n_val_objects=8",
    "data.n_val_object_placements=2",
    "data.n_test_objects=0",
    "data.n_test_placements=0",
    "data.progress=false",
]
#: Measured once with this setting (2026-12-03, this machine, RGB-D input as experiment=quick
#: gives CNN -> DMP): 3.4 cm mean, 11 of 16 successes (0.69); with RGB (2026-12-02) 4.3 cm,
#: 0.50; with colour averaging, quick's default since 2026-12-04: 3.4 cm, 14 of 16 (0.88); with
#: the relief depth encoding as well (quick's CNN -> DMP since later on 2026-12-04): 4.1 cm, 11
#: of 16 (0.69); at 64 px the table is not quite 0 in relief (tests/visuomotor/eval/test_eval_depth.py).
#: Since 2026-12-07 experiment=quick trains in bfloat16 and its validation objects lie just outside
#: the training sizes (data.val_sizes=outside), so these are new objects of new sizes: 4.2 cm, 10 of
#: 16 (0.62) on that day, in 51 s. With the wide sizes and random lighting (later that day) 600 steps
#: gave 6.2 cm, 7 of 16 (0.44), at the thresholds' edge for a harder problem; 1000 steps give 5.1 cm,
#: 10 of 16 (0.62), in 77 s.
#: The thresholds leave a margin for run-to-run spread (~2 cm, docs/evaluation.md).
MAX_MEAN_DISTANCE_M = 0.065
MIN_SUCCESS = 0.40


@pytest.mark.slow
def test_small_training_reaches_new_objects(tmp_path):
    common = [f"paths.root_dir={tmp_path}", *DATA]
    train = subprocess.run(
        [
            sys.executable,
            str(ROOT / "train.py"),
            "model=cnn_dmp",
            "trainer.max_steps=1000",
            f"hydra.run.dir={tmp_path}/train",
            *common,
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=1500,
    )
    assert train.returncode == 0, train.stderr[-3000:]
    ckpt = tmp_path / "train" / "checkpoints" / "last.ckpt"
    ev = subprocess.run(
        # data.depth=true: the dataset quick's CNN -> DMP input made (evaluate.py has no model to pick it)
        [
            sys.executable,
            str(ROOT / "evaluate.py"),
            "eval.split=val",
            "eval.n_gifs=0",
            f"ckpt={ckpt}",
            f"hydra.run.dir={tmp_path}/eval",
            *common,
        ],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=900,
    )
    assert ev.returncode == 0, ev.stderr[-3000:]
    m = json.loads((tmp_path / "eval" / "metrics.json").read_text())["cnn_dmp"]
    assert m["episodes"] == 16 and "val split" in m["cases"]
    mean, success = m["final_distance_m"]["mean"], m["success_5cm"]
    print(f"new objects: mean final distance {mean:.3f} m, success {success:.2f}")
    assert mean < MAX_MEAN_DISTANCE_M, f"mean final distance on new objects {mean:.3f} m"
    assert success >= MIN_SUCCESS, f"success on new objects {success:.2f}"
