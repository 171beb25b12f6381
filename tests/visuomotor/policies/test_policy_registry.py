"""The policy registry: a new policy kind is its module and its model config, nothing else.

A toy policy is written outside the repository (its module on ``PYTHONPATH``, its
``model/toy.yaml`` on ``hydra.searchpath``) and trained and evaluated through ``train.py`` and
``evaluate.py``; and ``python train.py model=velocity`` then ``python evaluate.py`` with no
other override scores that checkpoint, on the data it was trained on."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from lfd.visuomotor.policies import POLICIES, VisuomotorPolicy, get_policy_class

ROOT = Path(__file__).resolve().parents[3]

TOY_MODULE = '''
"""A toy velocity policy: the image's mean colour and the joints -> joint velocity (one linear layer)."""
import numpy as np
import torch
from torch import nn

from lfd.visuomotor.policies import VisuomotorPolicy
from lfd.visuomotor.policies.control import VelocityController


class ToyPolicy(VisuomotorPolicy):
    kind = "toy"
    item_mode = "velocity"
    label = "toy linear policy"

    def __init__(self, *, gain: float = 1.0, **common):
        super().__init__(**common)
        n = self.hparams.n_joints
        self.net = nn.Linear(self.input_channels + n, n)
        self.register_statistics({"joints": (n,)})

    def forward(self, image, joints):
        colour = image.mean(dim=(2, 3))
        return self.hparams.gain * self.net(torch.cat([colour, self.normalise("joints", joints)], dim=1))

    def losses(self, batch):
        error = self(batch["image"], batch["joints"]) - batch["command"]
        return {"loss": (error**2).mean()}

    def sample_figure(self, batch):
        return None

    def controller(self, dt):
        return VelocityController(self, dt)

    @torch.inference_mode()
    def act(self, image, joints, time=None):
        img, q, batched = self._observation(image, joints)
        qd = self(img, q).double().cpu().numpy()
        return qd if batched else qd[0]
'''
TOY_CONFIG = """# A toy policy outside the repository (tests/visuomotor/policies/test_policy_registry.py).
_target_: toy_policy.ToyPolicy
_convert_: all
gain: 0.5
lr: 1.0e-3
plot_every_n_val: 0
"""
#: A few optimiser steps (on tests/conftest.py's tiny dataset).
STEPS = ["++trainer.max_steps=3", "++trainer.limit_val_batches=1"]


def _run(script: str, *overrides: str, cwd: Path, pythonpath: Path | None = None) -> str:
    paths = [str(ROOT / "src"), *([str(pythonpath)] if pythonpath else []), os.environ.get("PYTHONPATH", "")]
    proc = subprocess.run(
        [sys.executable, str(ROOT / script), *overrides],
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(paths), "OMP_NUM_THREADS": "1"},
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc.stdout


def _metrics(cwd: Path) -> dict:
    (found,) = (cwd / "outputs" / "evaluate").glob("*/metrics.json")
    return json.loads(found.read_text())


def test_a_fifth_policy_is_its_module_and_its_config(tmp_path, tiny_data):
    """The toy kind trains and is scored through the entry points; no file of the repository
    names it. ``evaluate.py`` gets nothing but the config search path: the checkpoint's kind
    comes from the file, its data from the run it recorded."""
    code = tmp_path / "code"
    (code / "model").mkdir(parents=True)
    (code / "toy_policy.py").write_text(TOY_MODULE)
    (code / "model" / "toy.yaml").write_text(TOY_CONFIG)
    search = f"hydra.searchpath=[file://{code}]"
    work = tmp_path / "work"
    work.mkdir()
    out = _run("train.py", "model=toy", search, *tiny_data, *STEPS, cwd=work, pythonpath=code)
    assert "[lfd] checkpoint:" in out
    out = _run("evaluate.py", search, "eval.n_gifs=0", cwd=work, pythonpath=code)
    metrics = _metrics(work)
    assert set(metrics) == {"toy"}, metrics.keys()
    assert metrics["toy"]["episodes"] == 2 and "tiny" in metrics["toy"]["cases"]
    assert _table_row(out, "toy")[1:3] == ["2", f"{100 * metrics['toy']['final_distance_m']['mean']:.2f}"]
    assert "toy" not in POLICIES  # registered in the entry points only, from the files above


@pytest.mark.slow
def test_train_then_evaluate_with_no_other_override(tmp_path, tiny_data):
    """``python train.py model=velocity`` (here on the tiny data) then a bare ``python evaluate.py``
    in the same folder: the checkpoint is found and scored on the test split of its own dataset."""
    _run(
        "train.py",
        "model=velocity",
        "model.channels=[4,4]",
        "model.hidden=[8]",
        *tiny_data,
        *STEPS,
        cwd=tmp_path,
    )
    out = _run("evaluate.py", cwd=tmp_path)
    metrics = _metrics(tmp_path)
    assert set(metrics) == {"velocity"} and "tiny" in metrics["velocity"]["cases"]
    assert metrics["velocity"]["episodes"] == 2 and _table_row(out, "velocity")[1] == "2"


def _table_row(out: str, kind: str) -> list[str]:
    """The cells of ``kind``'s row in the results table that evaluate.py ends with (under its header)."""
    lines = out.splitlines()
    header = next(i for i, line in enumerate(lines) if line.split()[:2] == ["policy", "episodes"])
    return next(line.split() for line in lines[header + 2 :] if line.split()[:1] == [kind])


def test_registry_names_each_kind_once_with_its_item_layout():
    assert list(POLICIES)[:4] == ["cnn_dmp", "velocity", "act", "diffusion"]
    assert get_policy_class("act").item_mode == "velocity" and POLICIES["cnn_dmp"].label == "CNN -> DMP"
    with pytest.raises(KeyError, match="no policy kind 'nope'"):
        get_policy_class("nope")
    with pytest.raises(ValueError, match="policy kind 'velocity' is already registered by"):
        type("Impostor", (VisuomotorPolicy,), {"kind": "velocity", "item_mode": "velocity"})
    with pytest.raises(ValueError, match="item_mode: expected one of"):
        type("Odd", (VisuomotorPolicy,), {"kind": "odd", "item_mode": "frames"})
    assert "odd" not in POLICIES


def test_a_misspelt_model_setting_is_one_line(compose, tmp_path, capsys):
    """The policy's constructor is its schema: train.py reports a setting it refuses in one line."""
    import train

    cfg = compose("train", "model=velocity", "+model.hiden=[8]", f"paths.root_dir={tmp_path}")
    with pytest.raises(SystemExit) as info:
        train.main(cfg)
    assert info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == "train: model=velocity: VelocityPolicy: unexpected arguments ['hiden']"
    assert not (tmp_path / "data").exists()
