import os

import pytest
import torch

import lfd.training
from lfd.training import ACTIVATIONS, checkpoint_kind, find_checkpoints, make_activation, resolve_precision


def _checkpoint(path, kind, mtime):
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save({"hyper_parameters": {} if kind is None else {"kind": kind}, "global_step": 1}, path)
    os.utime(path, (mtime, mtime))
    return path


def test_find_checkpoints_takes_the_newest_of_each_kind(tmp_path):
    old = _checkpoint(tmp_path / "train/a/checkpoints/last.ckpt", "cnn_dmp", 1000)
    new = _checkpoint(tmp_path / "train/b/checkpoints/last.ckpt", "cnn_dmp", 2000)
    vel = _checkpoint(tmp_path / "train/multirun/x/0/checkpoints/last.ckpt", "velocity", 1500)
    _checkpoint(tmp_path / "train/c/checkpoints/last.ckpt", None, 3000)
    _checkpoint(tmp_path / "train/d/checkpoints/epoch001.ckpt", "cnn_dmp", 4000)  # not a last.ckpt
    assert checkpoint_kind(old) == "cnn_dmp"
    assert checkpoint_kind(tmp_path / "train/c/checkpoints/last.ckpt") is None
    found = find_checkpoints(tmp_path, ("cnn_dmp", "velocity", "sawyer_models"))
    assert found == {"cnn_dmp": new, "velocity": vel}


def test_make_activation_by_name():
    assert all(isinstance(make_activation(name), cls) for name, cls in ACTIVATIONS.items())
    with pytest.raises(ValueError, match="activation: expected one of"):
        make_activation("swish")


@pytest.mark.parametrize("native", [True, False])
def test_bf16_on_a_cpu_without_it_trains_in_float32(monkeypatch, native):
    monkeypatch.setattr(lfd.training, "cpu_bf16_supported", lambda: native)
    if native:
        assert resolve_precision("bf16-mixed", "cpu") == "bf16-mixed"
    else:
        with pytest.warns(UserWarning, match="trainer.precision=bf16-mixed: this CPU has no native bfloat16"):
            assert resolve_precision("bf16-mixed", "cpu") == "32-true"
    # float32 and float16 stay as asked; a GPU decides its own bf16 support
    assert resolve_precision("32-true", "cpu") == "32-true"
    assert resolve_precision(None, "cpu") is None  # no precision key: Lightning's default
    assert resolve_precision("16-mixed", "gpu") == "16-mixed"
    assert resolve_precision("bf16-mixed", "gpu") == "bf16-mixed"
