"""Training step time of the main job's two policies (``experiment=quick``): float32 against
bfloat16 mixed precision, in one process, on the same batches of the experiment's dataset.

One optimiser step as Lightning runs it: the losses under autocast (``trainer.precision=bf16-mixed``)
or without (``32-true``), backward and AdamW outside it. The median over ``--steps`` batches after
warm-up, each variant starting from the same weights. The ratio is float32's time over bf16's
(> 1: bf16 is faster). Also printed: each variant's loss on the first batch (the same network, the
same batch), so the speed-up is seen to leave the loss alone.

bfloat16 is native on CPUs with AVX512-BF16 or AMX (``lfd.training.cpu_bf16_supported``); elsewhere
``train.py`` trains in float32 and this script says so.

    python benchmarks/training_step.py [--steps 30] [--kinds cnn_dmp velocity]

The dataset is the experiment's (generated under ``data/`` when missing, about a minute).
"""

from __future__ import annotations

import argparse
import copy
import statistics
import time
from pathlib import Path

import torch
from hydra import compose, initialize_config_dir

from lfd.cli.train import instantiate_data_and_model
from lfd.training import Adaptable, AdaptationSource, cpu_bf16_supported

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
VARIANTS = {"float32": None, "bf16-mixed": torch.bfloat16}


def setup(kind: str, n_batches: int):
    with initialize_config_dir(config_dir=str(CONFIGS), version_base=None):
        cfg = compose("train", overrides=["experiment=quick", f"model={kind}"])
    datamodule, model = instantiate_data_and_model(cfg)
    datamodule.prepare_data()
    datamodule.setup("fit")
    if isinstance(model, Adaptable) and isinstance(datamodule, AdaptationSource):  # as train.py does
        model.adapt(datamodule.adaptation_data())
    batches = []
    for batch in datamodule.train_dataloader():
        batches.append(batch)
        if len(batches) == n_batches:
            break
    return model, batches


def step_times(model, batches, dtype, warmup: int = 5) -> tuple[float, float]:
    """(median ms per optimiser step, loss of the first batch) for a copy of ``model``."""
    torch.manual_seed(0)
    model = copy.deepcopy(model).train()
    opt = torch.optim.AdamW(model.parameters(), lr=1e-4)

    def step(batch) -> float:
        with torch.autocast("cpu", dtype=dtype or torch.float32, enabled=dtype is not None):
            loss = model.losses(batch)["loss"]
        opt.zero_grad()
        loss.backward()
        opt.step()
        return float(loss.detach())

    first = step(batches[0])
    for batch in batches[1:warmup]:
        step(batch)
    times = []
    for batch in batches[warmup:]:
        t0 = time.perf_counter()
        step(batch)
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times), first


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--steps", type=int, default=30, help="timed steps per variant (after 5 warm-up steps)"
    )
    parser.add_argument("--kinds", nargs="+", default=["cnn_dmp", "velocity"])
    args = parser.parse_args()
    native = cpu_bf16_supported()
    print(
        f"torch {torch.__version__}, {torch.get_num_threads()} threads, native bfloat16: {native}"
        + ("" if native else " (train.py trains in float32 here)")
    )
    print("| policy | float32 (ms/step) | bf16-mixed (ms/step) | ratio | loss, first batch: float32 / bf16 |")
    print("|---|---|---|---|---|")
    for kind in args.kinds:
        model, batches = setup(kind, args.steps + 5)
        (ref_ms, ref_loss), (ours_ms, ours_loss) = (step_times(model, batches, d) for d in VARIANTS.values())
        print(
            f"| {kind} | {ref_ms:.1f} | {ours_ms:.1f} | {ref_ms / ours_ms:.2f}x | {ref_loss:.5g} / {ours_loss:.5g} |"
        )


if __name__ == "__main__":
    main()
