"""LeRobotDataModule: the lerobot-written reference is served, ours -> v3.0 -> ours is
lossless for states and actions (images within a PSNR bound), DMPs are fitted to foreign
data, clear errors for bad arguments and versions, both policies train on a v3.0 folder
(fast_dev_run) and the Hydra data config instantiates it."""

from __future__ import annotations

import json
from pathlib import Path

import lightning as L
import numpy as np
import pyarrow.parquet as pq
import pytest
import torch

from lfd.interop import LeRobotDataModule, LeRobotFolder
from lfd.visuomotor.data import ReachDataModule

REFERENCE = Path(__file__).resolve().parents[2] / "fixtures" / "lerobot_v3_reference"
#: PSNR bounds (dB) of the decoded frames against the originals (AV1, crf 30, 64 px).
MIN_PSNR_DB, MEAN_PSNR_DB = 30.0, 35.0


def psnr(a: torch.Tensor, b: torch.Tensor) -> float:
    mse = torch.mean((a.double() - b.double()) ** 2).item()
    return 10 * np.log10(1.0 / mse) if mse > 0 else float("inf")


def test_serves_the_lerobot_written_reference():
    folder = LeRobotFolder(REFERENCE)
    dm = LeRobotDataModule(REFERENCE, mode="velocity", batch_size=8)
    dm.setup()
    n = {k: len(v) for k, v in dm.datasets.items()}
    assert n == {
        "train": 20 + 30,
        "val": 25,
    }  # no val split in info.json: round(0.2 * 3) = 1 episode, the middle one
    item = dm.datasets["val"][3]
    assert item["image"].shape == (3, 64, 64) and item["step"] == 3 and item["index"] == 1
    np.testing.assert_array_equal(item["joints"].numpy(), folder.data["observation.state"][20 + 3, :7])
    np.testing.assert_array_equal(item["velocity"].numpy(), folder.data["observation.state"][20 + 3, 7:])
    torch.testing.assert_close(
        item["image"],
        torch.from_numpy(folder.frames(1, "observation.images.front")[3]).permute(2, 0, 1).float() / 255,
    )
    assert item["t"] == pytest.approx(0.3)
    assert dm.config.robot == "panda" and dm.config.image_size == 64
    with pytest.raises(ValueError, match="equal episode lengths"):
        LeRobotDataModule(REFERENCE, mode="dmp").setup()


@pytest.mark.parametrize("mode", ["velocity", "dmp"])
def test_round_trip_ours_lerobot_ours(tiny_root, tiny_lerobot, tiny_params, mode):
    ours = ReachDataModule(name="tiny", root=tiny_root, mode=mode, progress=False, **tiny_params)
    ours.setup()
    theirs = LeRobotDataModule(tiny_lerobot, mode=mode)
    theirs.setup()
    assert (
        theirs.config.n_steps == 30
        and theirs.config.duration == 4.0
        and theirs.config.robot == "pr2_right_arm"
    )
    values = []
    for split in ("train", "val", "test"):
        a, b = ours.datasets[split], theirs.datasets[split]
        assert len(a) == len(b)
        for i in range(len(a)):
            x, y = a[i], b[i]
            assert x.keys() == y.keys()
            for k in x:
                if k == "image":
                    values.append(psnr(x[k], y[k]))
                else:  # states, actions (velocity commands, DMP parameters, paths): bit for bit
                    assert torch.equal(x[k], y[k]), (split, i, k)
    assert min(values) > MIN_PSNR_DB and np.mean(values) > MEAN_PSNR_DB, (min(values), np.mean(values))
    for name in ("joints", "velocity"):
        torch.testing.assert_close(theirs.stats[name]["mean"], ours.stats[name]["mean"])


def test_dmp_parameters_fitted_without_lfd_columns(tiny, tiny_lerobot, tmp_path):
    """Foreign data (no lfd/ columns): the DMP goal and weights are fitted per episode, the
    tool path comes from forward kinematics of robot_type."""
    from lfd.interop import export_lerobot

    out = export_lerobot(tiny, tmp_path / "ds", codec="h264", progress=False)
    ep_file = out / "meta/episodes/chunk-000/file-000.parquet"
    table = pq.read_table(ep_file)
    table = table.drop_columns([c for c in table.column_names if c.startswith("lfd/")])
    pq.write_table(table, ep_file)
    with_cols = LeRobotDataModule(tiny_lerobot, mode="dmp", n_basis=8)
    with_cols.setup("fit")
    fitted = LeRobotDataModule(out, mode="dmp", n_basis=8)
    fitted.setup("fit")
    a, b = with_cols.datasets["train"][0], fitted.datasets["train"][0]
    torch.testing.assert_close(b["goal"], a["goal"], atol=1e-6, rtol=0)
    torch.testing.assert_close(b["weights"], a["weights"], atol=1e-3, rtol=1e-4)
    torch.testing.assert_close(b["ee_path"], a["ee_path"], atol=1e-5, rtol=0)  # FK vs PyBullet's link state
    assert fitted.datasets.keys() == {"train", "val"}


def test_other_version_fails_early(reference_copy):
    info = json.loads((reference_copy / "meta" / "info.json").read_text())
    info["codebase_version"] = "v2.1"
    (reference_copy / "meta" / "info.json").write_text(json.dumps(info))
    with pytest.raises(ValueError, match="codebase_version is 'v2.1'"):
        LeRobotDataModule(reference_copy, mode="velocity").prepare_data()
    with pytest.raises(ValueError, match="codebase_version is 'v2.1'"):
        LeRobotDataModule(reference_copy, mode="velocity").setup()


def test_bad_arguments(tiny_lerobot):
    with pytest.raises(ValueError, match="mode"):
        LeRobotDataModule(tiny_lerobot, mode="images")
    with pytest.raises(ValueError, match="no video feature"):
        LeRobotDataModule(tiny_lerobot, mode="velocity", camera="top").setup()
    with pytest.raises(RuntimeError, match="setup"):
        _ = LeRobotDataModule(tiny_lerobot).stats


@pytest.mark.parametrize(
    "policy",
    ["cnn_dmp", "velocity"],
)
def test_policies_train_on_a_lerobot_folder(tiny_lerobot, tmp_path, policy):
    from lfd.visuomotor.policies import CNNDMPPolicy, VelocityPolicy

    common = dict(channels=[8, 8], hidden=[16], image_size=64, duration=4.0, n_steps=30, plot_every_n_val=0)
    if policy == "cnn_dmp":
        model, mode = CNNDMPPolicy(n_basis=8, rest_steps=2, **common), "dmp"
    else:
        model, mode = VelocityPolicy(**common), "velocity"
    dm = LeRobotDataModule(tiny_lerobot, mode=mode, batch_size=4)
    trainer = L.Trainer(
        fast_dev_run=True,
        accelerator="cpu",
        logger=False,
        enable_checkpointing=False,
        enable_progress_bar=False,
        default_root_dir=tmp_path,
    )
    trainer.fit(model, datamodule=dm)
    assert torch.isfinite(trainer.callback_metrics["train/loss"])
    if policy == "cnn_dmp":
        torch.testing.assert_close(model.goal_mean, dm.stats["goal"]["mean"])


def test_hydra_data_config(tiny_lerobot):
    from hydra import compose, initialize_config_dir
    from hydra.utils import instantiate

    import train

    configs = Path(__file__).resolve().parents[3] / "configs"
    with initialize_config_dir(config_dir=str(configs), version_base="1.3"):
        over = [
            f"data.root={tiny_lerobot}",
            "data.image_size=64",
            "data.n_steps=30",
            "data.n_basis=8",
            "model.channels=[8]",
            "model.hidden=[8]",
        ]
        cfg = compose("train", overrides=["data=lerobot", "model=cnn_dmp", *over])
        dm, model = train.instantiate_data_and_model(cfg)  # the policy takes the folder's settings
        dm.setup("fit")
        model.check_data(dm.config)
        assert dm.mode == "dmp" and len(dm.datasets["train"]) == 4 and model.hparams.n_basis == 8
        bad = instantiate(compose("train", overrides=["data=lerobot", *over, "data.n_steps=100"]).data)
        with pytest.raises(ValueError, match="n_steps=100"):
            bad.setup("fit")
        bad = instantiate(compose("train", overrides=["data=lerobot", *over, "data.n_basis=20"]).data)
        with pytest.raises(ValueError, match="n_basis=20"):
            bad.setup("fit")
