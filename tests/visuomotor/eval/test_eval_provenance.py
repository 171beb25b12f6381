"""What a checkpoint records of its training run, and how ``evaluate.py`` follows it: plain values
only (a hostile record is refused in one line, nothing of it instantiated), one dataset per
evaluation, and the command line winning over the record."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
import torch
from hydra import compose, initialize_config_dir

import evaluate
from lfd.visuomotor.eval.provenance import same_dataset, shared_training_run, training_run
from lfd.visuomotor.policies.base import TRAINING_RUN_KEY

CONFIGS = Path(__file__).resolve().parents[3] / "configs"
DATA = {"name": "quick96o300d_s7", "seed": 7, "image_size": 96, "depth": True, "n_train_objects": 300}


def _checkpoint(path: Path, run: dict | None, kind: str = "velocity") -> Path:
    """A checkpoint file with a recorded run (``None``: an earlier release's, with none)."""
    content = {"state_dict": {}, "hyper_parameters": {"kind": kind}}
    if run is not None:
        content[TRAINING_RUN_KEY] = run
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(content, path)
    return path


def _run(**changes) -> dict:
    return {"experiment": "quick", "data_config": "quick", "seed": 7, "data": dict(DATA), **changes}


def test_a_recorded_run_is_read_back_plain(tmp_path):
    ckpt = _checkpoint(tmp_path / "a.ckpt", {**_run(), "data": {**DATA, "_target_": "x.Y"}})
    assert training_run(ckpt) == {**_run(), "data": DATA}  # keys starting with _ are dropped
    assert training_run(_checkpoint(tmp_path / "old.ckpt", None)) is None


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"experiment": "../data/original"}, "experiment must be a config name"),
        ({"data_config": "quick/../lerobot"}, "data_config must be a config name"),
        ({"seed": "7"}, "seed must be an integer"),
        (
            {"data": {**DATA, "batch_size": {"_target_": "os.mkdir", "path": "pwned"}}},
            "data.batch_size must be",
        ),
        ({"data": {**DATA, "root": "${oc.env:HOME}"}}, "data.root must be a plain value"),
        ({"data": {**DATA, "name": "../../elsewhere"}}, "data.name must be a dataset folder's name"),
        ({"data": ["name"]}, "data must be a mapping"),
    ],
)
def test_a_hostile_record_is_refused_in_one_line(tmp_path, change, field):
    ckpt = _checkpoint(tmp_path / "evil.ckpt", _run(**change))
    with pytest.raises(ValueError, match=field) as info:
        training_run(ckpt)
    assert str(ckpt) in str(info.value) and "\n" not in str(info.value)


def test_one_dataset_per_evaluation(tmp_path):
    """Loading settings may differ (batch size, input depth); another dataset is left out when found,
    refused when named; the newest checkpoint is the reference."""
    assert same_dataset({**DATA, "batch_size": 8, "input_depth": True}, {**DATA, "batch_size": 32})
    assert not same_dataset(DATA, {**DATA, "n_train_objects": 50})
    old = _checkpoint(tmp_path / "velocity.ckpt", _run(data={**DATA, "name": "other_s7"}))
    newer = _checkpoint(tmp_path / "dmp.ckpt", _run(), kind="cnn_dmp")
    os.utime(old, (time.time() - 60, time.time() - 60))
    unrecorded = _checkpoint(tmp_path / "act.ckpt", None, kind="act")
    found = {"cnn_dmp": newer, "velocity": old, "act": unrecorded}
    run, kept, notes = shared_training_run(found)
    assert run["data"]["name"] == DATA["name"] and kept == {"cnn_dmp": newer, "act": unrecorded}
    assert len(notes) == 1 and str(old) in notes[0] and "'other_s7'" in notes[0]
    with pytest.raises(ValueError, match="evaluate them apart"):
        shared_training_run(found, given={"velocity", "cnn_dmp"})


@pytest.fixture
def composed():
    with initialize_config_dir(str(CONFIGS), version_base="1.3"):
        yield lambda *overrides: compose(config_name="evaluate", overrides=list(overrides))


def test_the_record_fills_what_the_command_line_leaves_open(composed):
    cfg = evaluate.follow_training_run(composed(), _run(), overrides=[])
    assert list(cfg.eval.colour_tta) == ["cnn_dmp"]  # experiment=quick followed
    assert (cfg.data.name, cfg.data.image_size, cfg.seed) == ("quick96o300d_s7", 96, 7)
    # the command line wins: its experiment, or its data (then the data is composed, not recorded)
    cfg = evaluate.follow_training_run(composed("experiment=original"), _run(), ["experiment=original"])
    assert list(cfg.eval.colour_tta) == [] and cfg.data.name == "quick96o300d_s7"
    cfg = evaluate.follow_training_run(composed("data.name=mine"), _run(), ["data.name=mine"])
    assert cfg.data.name == "mine" and cfg.seed == 42 and list(cfg.eval.colour_tta) == ["cnn_dmp"]
    # nothing recorded, or a config composed by a caller: unchanged
    plain = composed()
    assert evaluate.follow_training_run(plain, None, []) is plain
    assert evaluate.follow_training_run(plain, _run(), None) is plain


@pytest.mark.parametrize(
    ("run", "message"),
    [
        (_run(experiment="gone"), "trained with experiment=gone, which is no config here"),
        (_run(data={**DATA, "image_size": "big"}), "recorded data.image_size='big' is not of the kind"),
        (
            _run(data_config="lerobot", data={}),
            "data.root: not set; the checkpoints were trained with data=lerobot",
        ),
    ],
)
def test_a_record_that_does_not_fit_these_configs_is_one_line(composed, run, message):
    with pytest.raises(ValueError, match=message) as info:
        evaluate.follow_training_run(composed(), run, overrides=[])
    assert "\n" not in str(info.value)
