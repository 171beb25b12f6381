"""Hostile and careless checkpoint and scenario files, through the public entry points.

A checkpoint carrying a pickle payload (given on the command line, or planted where
discovery looks) never runs: the payload would create a marker file, and the marker must not
exist afterwards. Truncated, empty and foreign checkpoints, and binary or bad scenario files,
end in one line naming the file; a scenario file is refused before any checkpoint is loaded or
any dataset is touched. Checkpoints written by ``train.py`` still load, and resume, under
``weights_only=True``.
"""

from __future__ import annotations

import os
import pathlib
import pickle
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
import torch

import evaluate  # the repository's entry points (pytest's pythonpath holds the root)
import train
from lfd.model_reaching import load_sawyer_models
from lfd.training import CheckpointError, checkpoint_kind, find_checkpoints, read_checkpoint
from lfd.visuomotor.eval import ReachEvaluator
from lfd.visuomotor.eval.scenario import ScenarioError
from lfd.visuomotor.policies import load_policy

ROOT = Path(__file__).resolve().parent.parent
GOOD_SCENARIO = (ROOT / "configs" / "scenarios" / "mixed.yaml").read_text()


class Payload:
    """Unpickling this creates ``marker``: what an attacker's checkpoint would run."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (pathlib.Path.touch, (pathlib.Path(self.marker),))


def evil_checkpoint(path: Path, marker: Path, kind: str = "cnn_dmp") -> Path:
    """A torch.save'd Lightning-looking checkpoint whose unpickling would create ``marker``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save({"state_dict": {}, "hyper_parameters": {"kind": kind}, "x": Payload(marker)}, path)
    assert not marker.exists()
    return path


def run_entry_point(script: str, *overrides: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run(
        [sys.executable, str(ROOT / script), *overrides],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def assert_one_line_error(proc: subprocess.CompletedProcess, prefix: str, *fragments: str) -> str:
    """Exit status 2, no traceback, and a last stderr line ``<prefix>: ...`` holding ``fragments``."""
    assert proc.returncode == 2, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    line = proc.stderr.strip().splitlines()[-1]
    assert line.startswith(f"{prefix}: "), proc.stderr[-2000:]
    for fragment in fragments:
        assert fragment in line, line
    return line


def reaching_overrides(root: Path) -> list[str]:
    """Everything under ``root``: outputs, data, Hydra's run directory."""
    return [f"paths.root_dir={root}", f"hydra.run.dir={root}/run"]


# ---------------------------------------------------------------------------- pickle payloads
def test_evaluate_ckpt_with_a_payload_runs_nothing(tmp_path):
    """``evaluate.py ckpt=evil.ckpt`` beside a planted ``last.ckpt`` for the velocity policy:
    the given one gets one line naming it; searching the outputs, the planted one is named and
    skipped; neither payload runs, and no dataset is generated for them."""
    marker = tmp_path / "pwned"
    evil = evil_checkpoint(tmp_path / "evil.ckpt", marker)
    planted = evil_checkpoint(
        tmp_path / "outputs" / "train" / "planted" / "checkpoints" / "last.ckpt", marker, "velocity"
    )
    proc = run_entry_point("evaluate.py", f"ckpt={evil}", *reaching_overrides(tmp_path), cwd=tmp_path)
    assert_one_line_error(
        proc, "evaluate", str(evil), "not a PyTorch Lightning checkpoint", "nothing in it was run"
    )
    proc = run_entry_point("evaluate.py", *reaching_overrides(tmp_path), cwd=tmp_path)
    assert_one_line_error(proc, "evaluate", "no 'cnn_dmp' checkpoint")
    assert f"skipped: {planted}: not a PyTorch Lightning checkpoint" in proc.stdout
    assert not marker.exists()
    assert not (tmp_path / "data").exists()


def test_evaluate_sawyer_discovery_skips_a_planted_payload(tmp_path):
    """``evaluate.py eval=sawyer`` searches ``outputs/train/**/last.ckpt``: a planted payload is
    named and skipped, never unpickled; with nothing else there, the usual one line says so."""
    marker = tmp_path / "pwned"
    planted = evil_checkpoint(
        tmp_path / "outputs" / "train" / "planted" / "checkpoints" / "last.ckpt", marker, "sawyer_models"
    )
    proc = run_entry_point("evaluate.py", "eval=sawyer", *reaching_overrides(tmp_path), cwd=tmp_path)
    assert_one_line_error(proc, "evaluate", "no Sawyer models checkpoint")
    assert f"skipped: {planted}: not a PyTorch Lightning checkpoint" in proc.stdout
    assert not marker.exists()


def test_discovery_and_loaders_never_run_a_payload(tmp_path):
    """Every loader of a user's or a discovered checkpoint refuses the payload with one line."""
    marker = tmp_path / "pwned"
    evil = evil_checkpoint(tmp_path / "train" / "a" / "checkpoints" / "last.ckpt", marker)
    for load in (read_checkpoint, checkpoint_kind, load_policy, load_sawyer_models):
        with pytest.raises(CheckpointError) as info:
            load(evil)
        message = str(info.value)
        assert (
            "\n" not in message and str(evil) in message and "expected a .ckpt written by train.py" in message
        )
    with pytest.warns(RuntimeWarning, match="skipped: .*last.ckpt: not a PyTorch Lightning checkpoint"):
        assert find_checkpoints(tmp_path, ("cnn_dmp",)) == {}
    # a raw pickle (no zip): refused unread
    raw = tmp_path / "raw.ckpt"
    raw.write_bytes(pickle.dumps({"hyper_parameters": Payload(marker)}))
    with pytest.raises(CheckpointError, match="not a zip archive"):
        read_checkpoint(raw)
    assert not marker.exists()


# ---------------------------------------------------------------------------- broken files
def broken_files(tmp_path: Path, good: Path) -> dict[str, tuple[Path, str]]:
    """``{name: (file, expected fragment of the message)}``."""
    files = {}

    def put(name: str, data: bytes, why: str) -> None:
        path = tmp_path / f"{name}.ckpt"
        path.write_bytes(data)
        files[name] = (path, why)

    put("empty", b"", "empty file")
    put("truncated", good.read_bytes()[: good.stat().st_size // 2], "not a zip archive")
    put("text", b"hello, I am a text file\n", "not a zip archive")
    with zipfile.ZipFile(tmp_path / "foreign.ckpt", "w") as archive:
        archive.writestr("foreign/readme.txt", "no data.pkl here")
    files["foreign"] = (tmp_path / "foreign.ckpt", "a zip archive without data.pkl")
    torch.save([1, 2, 3], tmp_path / "list.ckpt")
    files["list"] = (tmp_path / "list.ckpt", "it holds a list, not a dictionary")
    torch.save({"hyper_parameters": {"kind": "cnn_dmp"}}, tmp_path / "noweights.ckpt")
    files["noweights"] = (tmp_path / "noweights.ckpt", "no ['state_dict'] in it")
    return files


def test_broken_checkpoints_give_one_line_naming_the_file(tmp_path):
    good = tmp_path / "good.ckpt"
    torch.save({"state_dict": {"w": torch.zeros(1000)}, "hyper_parameters": {"kind": "cnn_dmp"}}, good)
    assert checkpoint_kind(good) == "cnn_dmp"
    for name, (path, why) in broken_files(tmp_path, good).items():
        with pytest.raises(CheckpointError) as info:
            load_policy(path)
        message = str(info.value)
        assert message.startswith(f"{path}: not a PyTorch Lightning checkpoint ("), (name, message)
        assert why in message and "\n" not in message, (name, message)
    with pytest.raises(FileNotFoundError, match="missing.ckpt"):
        read_checkpoint(tmp_path / "missing.ckpt")
    with pytest.raises(CheckpointError, match="not a regular file"):
        read_checkpoint(tmp_path)


def entry_point_error(main, cfg, capsys) -> str:
    """The one stderr line of an entry point's ``main(cfg)`` that exits with status 2."""
    with pytest.raises(SystemExit) as info:
        main(cfg)
    assert info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_evaluate_truncated_checkpoint_is_one_line(tmp_path, compose, capsys):
    """Through ``evaluate.py``'s main: torch's reader errors never reach the user as a traceback."""
    good = tmp_path / "good.ckpt"
    torch.save({"state_dict": {"w": torch.zeros(1000)}, "hyper_parameters": {"kind": "velocity"}}, good)
    truncated = tmp_path / "truncated.ckpt"
    truncated.write_bytes(good.read_bytes()[:300])
    cfg = compose("evaluate", f"ckpt={truncated}", "eval.kinds=[velocity]", f"paths.root_dir={tmp_path}")
    line = entry_point_error(evaluate.main, cfg, capsys)
    assert line.startswith(
        f"evaluate: {truncated}: not a PyTorch Lightning checkpoint (not a zip archive: truncated"
    )
    assert line.endswith("expected a .ckpt written by train.py")
    assert not (tmp_path / "data").exists()


def test_train_refuses_a_bad_resume_checkpoint_before_any_data(tmp_path, compose, capsys):
    marker = tmp_path / "pwned"
    evil = evil_checkpoint(tmp_path / "evil.ckpt", marker)
    empty = tmp_path / "empty.ckpt"
    empty.write_bytes(b"")
    rezipped = deflated(policy_checkpoint(tmp_path / "good.ckpt"), tmp_path / "deflated.ckpt")
    for path, why in (
        (evil, "nothing in it was run"),
        (empty, "empty file"),
        (rezipped, "compressed zip member(s)"),
    ):
        cfg = compose("train", f"ckpt_path={path}", f"paths.root_dir={tmp_path}")
        line = entry_point_error(train.main, cfg, capsys)
        assert line.startswith(f"train: ckpt_path={path}: {path}: not a PyTorch Lightning") and why in line
    assert not marker.exists() and not (tmp_path / "data").exists()


# ---------------------------------------------------------------------------- what train.py writes
def test_train_checkpoints_load_and_resume_weights_only(compose, tiny_reaching, tmp_path, monkeypatch):
    """A tiny ``train.py`` run's ``last.ckpt`` loads with ``weights_only=True`` (policy and
    discovery), and training resumes from it (Lightning's restore, ``weights_only=True`` too)."""
    from lightning.pytorch.trainer.connectors.checkpoint_connector import _CheckpointConnector

    restored = []
    resume_start = _CheckpointConnector.resume_start

    def spy(self, checkpoint_path=None, weights_only=None):
        restored.append((checkpoint_path, weights_only))
        return resume_start(self, checkpoint_path, weights_only=weights_only)

    monkeypatch.setattr(_CheckpointConnector, "resume_start", spy)
    common = ("model=velocity", "data.name=tiny-resume", *tiny_reaching, "++trainer.limit_val_batches=1")
    first = tmp_path / "outputs" / "train" / "first"
    cfg = compose(
        "train", *common, "++trainer.max_steps=2", f"paths.root_dir={tmp_path}", f"paths.output_dir={first}"
    )
    last = Path(train.main(cfg))
    assert torch.load(last, map_location="cpu", weights_only=True)["global_step"] >= 1
    assert load_policy(last).kind == "velocity"
    assert find_checkpoints(tmp_path / "outputs", ("velocity",)) == {"velocity": last}
    second = tmp_path / "outputs" / "train" / "second"
    cfg = compose(
        "train",
        *common,
        "++trainer.max_steps=4",
        "++trainer.val_check_interval=1",
        f"ckpt_path={last}",
        f"paths.root_dir={tmp_path}",
        f"paths.output_dir={second}",
    )
    restored.clear()
    resumed = Path(train.main(cfg))
    assert (str(last), True) in [(str(p), w) for p, w in restored]  # resumed, weights only
    assert resumed == second / "checkpoints" / "last.ckpt"
    assert read_checkpoint(last)["global_step"] == 2 and read_checkpoint(resumed)["global_step"] > 2


# ---------------------------------------------------------------------------- scenario files
def test_binary_scenario_is_one_line_before_any_checkpoint(tmp_path, compose, capsys):
    """A binary scenario file with an evil checkpoint beside it: the scenario is what
    ``evaluate.py`` reports (one line naming it), the checkpoint is never opened, no dataset
    appears."""
    marker = tmp_path / "pwned"
    evil = evil_checkpoint(tmp_path / "evil.ckpt", marker)
    binary = tmp_path / "scenario.yaml"
    binary.write_bytes(bytes(range(256)) * 4)
    cfg = compose("evaluate", f"eval.scenario={binary}", f"ckpt={evil}", f"paths.root_dir={tmp_path}")
    line = entry_point_error(evaluate.main, cfg, capsys)
    assert line.startswith(f"evaluate: {binary}: not UTF-8 or UTF-16 text"), line
    assert not marker.exists() and not (tmp_path / "data").exists()


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        ("placements:", "unknown top-level key(s) ['placement']"),  # a typo of a key
        ("radius: 0.035", "field 'radius' must be a length in metres"),  # a bad value
    ],
)
def test_bad_scenario_is_refused_before_checkpoints_and_data(compose, tmp_path, content, expected):
    replacement = {"placements:": "placement:", "radius: 0.035": "radius: thin"}[content]
    assert content in GOOD_SCENARIO
    path = tmp_path / "bad.yaml"
    path.write_text(GOOD_SCENARIO.replace(content, replacement, 1))
    marker = tmp_path / "pwned"
    evil = evil_checkpoint(tmp_path / "evil.ckpt", marker)
    cfg = compose("evaluate", f"eval.scenario={path}", f"ckpt={evil}", f"paths.root_dir={tmp_path}")
    with pytest.raises(ScenarioError) as info:
        evaluate.evaluate(cfg, tmp_path / "run")
    assert str(path) in str(info.value) and expected in str(info.value) and "\n" not in str(info.value)
    assert not marker.exists() and not (tmp_path / "data").exists() and not (tmp_path / "run").exists()


def test_out_of_reach_scenario_is_refused_before_checkpoints_and_data(compose, tmp_path):
    """The checks that need the robot (reach) also come before any checkpoint or dataset."""
    path = tmp_path / "far.yaml"
    path.write_text(
        "objects:\n  - {name: block, shape: box, size: [0.05, 0.07, 0.06], rgba: [0.5, 0.0, 0.5, 1.0]}\n"
        "placements:\n  - [0.90, 0.0, 0.0]\n"
    )
    ReachEvaluator(scenario=str(path))  # fields, table and camera are fine
    marker = tmp_path / "pwned"
    evil = evil_checkpoint(tmp_path / "evil.ckpt", marker)
    cfg = compose("evaluate", f"eval.scenario={path}", f"ckpt={evil}", f"paths.root_dir={tmp_path}")
    with pytest.raises(ScenarioError, match=r"far.yaml: objects\[0\] \(block\) .* is out of reach"):
        evaluate.evaluate(cfg, tmp_path / "run")
    assert not marker.exists() and not (tmp_path / "data").exists() and not (tmp_path / "run").exists()


def test_evaluate_never_instantiates_a_checkpoints_recorded_run(tmp_path):
    """A checkpoint whose recorded training run holds a Hydra ``_target_`` (or a path out of the
    data folder) is refused in one line naming it: nothing of the record is instantiated, no
    folder is made."""
    marker = tmp_path / "pwned"
    ckpt = tmp_path / "recorded.ckpt"
    run = {
        "experiment": None,
        "data_config": "quick",
        "seed": 1,
        "data": {"batch_size": {"_target_": "os.mkdir", "path": str(marker)}},
    }
    torch.save({"state_dict": {}, "hyper_parameters": {"kind": "velocity"}, "lfd_training_run": run}, ckpt)
    proc = run_entry_point("evaluate.py", f"ckpt={ckpt}", f"paths.root_dir={tmp_path}", cwd=tmp_path)
    assert_one_line_error(proc, "evaluate", str(ckpt), "data.batch_size must be a plain value")
    assert not marker.exists() and not (tmp_path / "data").exists()


# ---------------------------------------------------------------------------- checkpoints that do not fit
#: Tiny settings of each policy kind (a checkpoint of a few kB).
TINY_POLICY = {"image_size": 32, "n_steps": 30, "channels": [4, 4, 4, 8], "hidden": [16, 16]}


def policy_checkpoint(path: Path, kind: str = "velocity", state=None, **hparams) -> Path:
    """A checkpoint as ``train.py`` writes it (Lightning's keys) of a tiny ``kind`` policy; ``state``
    (``{key: tensor or None}``: None drops the key) and ``hparams`` change what is stored."""
    import lightning

    from lfd.visuomotor.policies import POLICIES

    policy = POLICIES[kind](**TINY_POLICY)
    state_dict = {**policy.state_dict(), **(state or {})}
    torch.save(
        {
            "state_dict": {k: v for k, v in state_dict.items() if v is not None},
            "hyper_parameters": {**policy.hparams, **hparams},
            "pytorch-lightning_version": lightning.__version__,
            "epoch": 0,
            "global_step": 0,
        },
        path,
    )
    return path


#: ``{case: (state changes, hyper-parameter changes, fragments of the one line)}``; each line also
#: names the file and the checkpoint's kind.
MISFITS = {
    "wrong shape": (
        {"bias_input": torch.zeros(3, 3)},
        {},
        ["state_dict['bias_input'] has shape (3, 3)", "(10,)"],
    ),
    "missing key": ({"bias_input": None}, {}, ["misses key(s) ['bias_input']"]),
    "extra key": ({"bogus.weight": torch.zeros(2)}, {}, ["has key(s) ['bogus.weight']"]),
    "negative n_joints": ({}, {"n_joints": -3}, ["VelocityPolicy.n_joints must be an integer >= 1, got -3"]),
    "unknown": (
        {},
        {"frobnicate": 1},
        ["hyper-parameter(s) ['frobnicate'] that VelocityPolicy does not take"],
    ),
    "another kind's": ({}, {"chunk_size": 8}, ["['chunk_size'] (taken by kind 'act', 'diffusion')"]),
    "float widths": (
        {},
        {"hidden": [2e5, 2e5]},
        ["VelocityPolicy.hidden[0] must be an integer >= 1, got 200000.0"],
    ),
    "huge widths": (
        {},
        {"hidden": [200_000, 200_000]},
        [
            "a model of more than 1024 MiB",
            "(200000, 200000)",
            "MAX_CHECKPOINT_MODEL_BYTES",
            "before allocating",
        ],
    ),
}


@pytest.mark.parametrize("case", list(MISFITS))
def test_a_checkpoint_that_does_not_fit_its_kind_is_one_line(tmp_path, case):
    """A checkpoint whose tensors or hyper-parameters do not fit its kind: one line naming the file,
    the kind and the key, shape or field, from every loader (never torch's multi-line error); the
    model a checkpoint asks for is bounded before it is allocated (``hidden=[200000, 200000]``
    would take 160 GB)."""
    state, hparams, fragments = MISFITS[case]
    path = policy_checkpoint(tmp_path / "misfit.ckpt", state=state, **hparams)
    with pytest.raises(CheckpointError) as info:
        load_policy(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{path}: a 'velocity' checkpoint"), message
    for fragment in fragments:
        assert fragment in message, message


def test_the_model_size_limit_is_checked_before_each_allocation(tmp_path, monkeypatch):
    """The limit holds for the model as a whole: a tiny policy passes it, and the same policy is
    refused once the limit is below its size (the first tensor past it is never made)."""
    import lfd.training

    path = policy_checkpoint(tmp_path / "tiny.ckpt")
    assert load_policy(path).kind == "velocity"
    monkeypatch.setattr(lfd.training, "MAX_CHECKPOINT_MODEL_BYTES", 1000)
    with pytest.raises(CheckpointError, match=r"a model of more than 0 MiB \(a tensor of shape"):
        load_policy(path)


def test_sawyer_checkpoint_with_a_reshaped_tensor_is_one_line(tmp_path):
    """The Sawyer models' loader checks the same way (one line naming the file, key and shapes)."""
    from lfd.model_reaching import SawyerModels

    models = SawyerModels(forward={"width": 8, "n_blocks": 1}, inverse={"hidden": [8]})
    state = models.state_dict()
    key = next(k for k, v in state.items() if v.ndim == 2)
    path = tmp_path / "sawyer.ckpt"
    torch.save({"state_dict": {**state, key: torch.zeros(1, 1)}, **lightning_keys(models)}, path)
    with pytest.raises(CheckpointError) as info:
        load_sawyer_models(path)
    assert str(info.value).startswith(f"{path}: a 'sawyer_models' checkpoint whose state_dict[{key!r}]")


def lightning_keys(module) -> dict:
    """The keys besides ``state_dict`` that Lightning writes (and its own loader needs)."""
    import lightning

    return {"hyper_parameters": dict(module.hparams), "pytorch-lightning_version": lightning.__version__}


def deflated(source: Path, path: Path) -> Path:
    """``source`` re-zipped with every member compressed (ZIP_DEFLATED)."""
    with zipfile.ZipFile(source) as src, zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as dst:
        for member in src.infolist():
            dst.writestr(member.filename, src.read(member.filename))
    return path


def test_a_checkpoint_rezipped_with_compression_is_refused(tmp_path):
    """torch maps a checkpoint's stored bytes: a re-zipped (deflated) one would be read as garbage
    tensors; it is refused in one line naming the file and a compressed member."""
    good = policy_checkpoint(tmp_path / "good.ckpt")
    assert torch.equal(read_checkpoint(good)["state_dict"]["bias_input"], load_policy(good).bias_input)
    bad = deflated(good, tmp_path / "deflated.ckpt")
    for load in (read_checkpoint, load_policy):
        with pytest.raises(CheckpointError) as info:
            load(bad)
        message = str(info.value)
        assert message.startswith(f"{bad}: not a PyTorch Lightning checkpoint (") and "\n" not in message
        assert "compressed zip member(s)" in message and "data.pkl" in message


def test_evaluate_a_checkpoint_asking_for_a_huge_model_is_one_line(tmp_path, compose, capsys):
    """``evaluate.py ckpt=...`` of a checkpoint whose hyper-parameters ask for a 160 GB model:
    one line naming the file and the limit, exit status 2, nothing allocated."""
    path = policy_checkpoint(tmp_path / "huge.ckpt", hidden=[200_000, 200_000])
    cfg = compose(
        "evaluate", f"ckpt={path}", "eval.kinds=[velocity]", *TINY_EVAL, f"paths.root_dir={tmp_path}"
    )
    line = entry_point_error(evaluate.main, cfg, capsys)
    assert line.startswith(
        f"evaluate: {path}: a 'velocity' checkpoint whose hyper-parameters ask for a model"
    )


#: A tiny dataset for the evaluation entry point tests (its config, never generated past the checks).
TINY_EVAL = ("data.image_size=32", "data.n_steps=30", "data.progress=false")


@pytest.mark.parametrize(
    ("change", "fragment"),
    [
        ({"kind": "cnn_dmp"}, "a 'cnn_dmp' checkpoint, this run's model is 'velocity'"),
        ({"hidden": [8]}, "whose state_dict misses key(s)"),
    ],
)
def test_train_refuses_to_resume_from_a_checkpoint_of_another_model(
    tmp_path, compose, capsys, change, fragment
):
    """``train.py ckpt_path=...`` of another kind's checkpoint, or of one with other layer sizes:
    one line naming the file and what differs, exit status 2, before any data is made."""
    hidden = change.get("hidden")
    path = policy_checkpoint(tmp_path / "other.ckpt", **({"hidden": hidden} if hidden else {}))
    if "kind" in change:
        ckpt = torch.load(path, weights_only=True)
        ckpt["hyper_parameters"]["kind"] = change["kind"]
        torch.save(ckpt, path)
    if hidden:  # the state_dict of the other sizes
        from lfd.visuomotor.policies import VelocityPolicy

        state = VelocityPolicy(**{**TINY_POLICY, "hidden": hidden}).state_dict()
        ckpt = torch.load(path, weights_only=True)
        ckpt["state_dict"] = state
        torch.save(ckpt, path)
    cfg = compose(
        "train", "model=velocity", "model.channels=[4,4,4,8]", "model.hidden=[16,16]", *TINY_EVAL,
        f"ckpt_path={path}", f"paths.root_dir={tmp_path}",
    )  # fmt: skip
    line = entry_point_error(train.main, cfg, capsys)
    assert line.startswith(f"train: ckpt_path={path}: {path}: a "), line
    assert fragment in line, line
    assert not (tmp_path / "data").exists()


def test_evaluate_sawyer_checkpoint_with_an_extra_tensor_is_one_line(tmp_path, compose, capsys):
    """``evaluate.py eval=sawyer eval.checkpoint=...`` of a Sawyer models checkpoint with a tensor its
    models lack: one line naming the file and the key, exit status 2."""
    from lfd.model_reaching import SawyerModels

    models = SawyerModels(forward={"width": 8, "n_blocks": 1}, inverse={"hidden": [8]})
    path = tmp_path / "sawyer.ckpt"
    state = {**models.state_dict(), "planted.weight": torch.zeros(2)}
    torch.save({"state_dict": state, **lightning_keys(models)}, path)
    cfg = compose("evaluate", "eval=sawyer", f"eval.checkpoint={path}", f"paths.root_dir={tmp_path}")
    line = entry_point_error(evaluate.main, cfg, capsys)
    assert line.startswith(f"evaluate: {path}: a 'sawyer_models' checkpoint whose state_dict has key(s)")
    assert "['planted.weight']" in line
