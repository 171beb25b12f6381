"""Which weights ``last.ckpt`` holds: every evaluation scores it (``evaluate.py`` picks the
newest ``last.ckpt``), so its meaning is pinned here."""

import lightning as L
import pytest
import torch
from hydra.utils import instantiate
from lightning.pytorch.demos.boring_classes import BoringModel


class RisingValLoss(BoringModel):
    """A validation loss that gets worse at every check: the best is the first."""

    def validation_step(self, batch, batch_idx):
        self.log("val/loss", float(self.global_step))


def test_last_ckpt_is_the_best_monitored_checkpoint_not_the_final_weights(compose, tmp_path):
    """With the project's checkpoint callback (configs/callbacks/default.yaml: top-1 by the
    monitor, save_last) Lightning >= 2.6 writes last.ckpt only beside a new best checkpoint,
    so last.ckpt is the best step by the validation monitor, not the last step. Every number
    in docs/ was made so; under Lightning < 2.6 this fails."""
    cfg = compose("train", f"callbacks.model_checkpoint.dirpath={tmp_path}")
    callback = instantiate(cfg.callbacks.model_checkpoint)
    assert callback.monitor == "val/loss" and callback.save_top_k == 1 and callback.save_last
    trainer = L.Trainer(
        max_steps=6,
        val_check_interval=2,
        check_val_every_n_epoch=None,
        limit_val_batches=1,
        callbacks=[callback],
        logger=False,
        enable_progress_bar=False,
        enable_model_summary=False,
    )
    trainer.fit(RisingValLoss())
    assert trainer.global_step == 6
    last = torch.load(tmp_path / "last.ckpt", map_location="cpu", weights_only=True)
    assert last["global_step"] == 2  # the first validation, the best val/loss
    assert float(callback.best_model_score) == 2.0  # the val/loss logged at that check


def test_chunking_checkpoints_of_earlier_releases_still_load(tmp_path):
    """ACT and Diffusion Policy checkpoints written before the keypoint head left the harness hold
    its no-op settings and a second name of the backbone: they load, those entries dropped; a
    retired setting at a value that did something is refused."""
    from lfd.visuomotor.policies import ACTPolicy, load_policy

    kw = dict(chunk_size=4, backbone="trunk", channels=[4, 4], d_model=8, n_heads=2, dim_feedforward=16)
    kw |= dict(n_encoder_layers=1, n_vae_layers=1, image_size=24, n_steps=12)
    policy = ACTPolicy(**kw)
    state = dict(policy.state_dict())
    state |= {f"encoder.{k}": v for k, v in policy.backbone.state_dict().items()} | {
        "bias_input": torch.zeros(0)
    }
    retired = {"hidden": [], "bias_dim": 0, "global_pool": False, "aux_weight": 0.0, "mode_heads": False}
    path = tmp_path / "old.ckpt"
    torch.save(
        {
            "state_dict": state,
            "hyper_parameters": {**policy.hparams, **retired},
            "pytorch-lightning_version": L.__version__,
        },
        path,
    )
    old = load_policy(path)
    torch.testing.assert_close(old.state_dict(), policy.state_dict())
    assert old.hparams.kind == "act" and type(old) is ACTPolicy
    with pytest.raises(ValueError, match="ACTPolicy.bias_dim: not supported by chunking policies"):
        ACTPolicy(**kw, bias_dim=10)
