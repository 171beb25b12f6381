"""Mixed precision, what ``trainer=gpu`` runs (Lightning's ``16-mixed`` autocast), for every policy kind.

There is no GPU here: ``bf16-mixed`` on the CPU takes Lightning's same autocast path, and float16
autocast on the CPU checks the CNN -> DMP head's range. A GPU run (``trainer=gpu``, H100, 2026-12-05)
stopped in its first validation step with ``q contains NaN or inf``: the DMP rollout ran its matrix
products in float16, where the forcing term overflows (docs/policies.md, "GPU training")."""

from pathlib import Path

import pytest
import torch
from _chunk_batches import TINY_MODELS
from hydra.utils import instantiate

import train
from lfd.visuomotor.policies import load_policy

#: Per kind: its tiny data and network (the step-wise kinds' epochs outlast 3 steps: validate at step 3);
#: "tiny_reaching" and "tiny_data" stand for those conftest fixtures' overrides.
RUNS = {
    "cnn_dmp": ["data.name=tiny-reaching", "tiny_reaching", "model=cnn_dmp"],
    "velocity": [
        "data.name=tiny-reaching",
        "tiny_reaching",
        "model=velocity",
        "++trainer.val_check_interval=3",
    ],
    "act": ["tiny_data", "model=act", *TINY_MODELS["act"], "++trainer.val_check_interval=3"],
    "diffusion": [
        "tiny_data",
        "model=diffusion",
        *TINY_MODELS["diffusion"],
        "++trainer.val_check_interval=3",
    ],
}


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("mixed_precision")


@pytest.fixture(scope="module")
def tiny(tiny_reaching, tiny_data) -> dict:
    return {"tiny_reaching": tiny_reaching, "tiny_data": tiny_data}


def _config(compose, tiny: dict, workspace: Path, kind: str, *overrides: str):
    run = [o for arg in RUNS[kind] for o in tiny.get(arg, [arg])]
    return compose(
        "train",
        f"paths.root_dir={workspace}",
        *run,
        "++trainer.max_steps=3",
        "++trainer.limit_val_batches=1",
        f"paths.output_dir={workspace / 'outputs' / 'train' / kind}",
        *overrides,
    )


@pytest.mark.parametrize("kind", list(RUNS))
def test_every_policy_trains_under_mixed_precision(kind, compose, tiny, workspace):
    cfg = _config(compose, tiny, workspace, kind, "++trainer.precision=bf16-mixed")
    ckpt = Path(train.main(cfg))
    state = torch.load(ckpt, map_location="cpu", weights_only=True)
    assert 1 <= state["global_step"] <= 3  # last.ckpt is the best-on-validation step
    weights = {k: v for k, v in state["state_dict"].items() if v.is_floating_point()}
    assert weights and all(v.dtype == torch.float32 for v in weights.values())  # autocast, not a cast
    assert all(bool(torch.isfinite(v).all()) for v in weights.values())
    scores = [c["best_model_score"] for k, c in state["callbacks"].items() if k.startswith("ModelCheckpoint")]
    assert scores and all(bool(torch.isfinite(torch.as_tensor(s))) for s in scores)  # val/loss


@pytest.mark.parametrize("dtype", [torch.float16, torch.bfloat16])
def test_dmp_policy_losses_under_autocast_match_float32(dtype, compose, tiny, workspace):
    cfg = _config(compose, tiny, workspace, "cnn_dmp")
    ckpt = workspace / "outputs" / "train" / "cnn_dmp" / "checkpoints" / "last.ckpt"
    if not ckpt.is_file():  # run alone (-k): train the float32 policy here
        train.main(cfg)
    policy = load_policy(ckpt)
    data = instantiate(cfg.data)
    data.prepare_data()
    data.setup("validate")
    batch = next(iter(data.val_dataloader()))
    with torch.no_grad():
        reference = policy.losses(batch)
        with torch.autocast("cpu", dtype=dtype):
            mixed = policy.losses(batch)
    for key in ("traj_mse", "final_joint_err", "ee_mse", "final_ee_err_m"):
        assert mixed[key].dtype == torch.float32, key  # the rollout and FK leave autocast
        torch.testing.assert_close(mixed[key], reference[key], rtol=0.05, atol=1e-4, msg=key)
