"""Inference time per control step and training time per optimiser step of the four visuomotor
policies (CNN -> DMP, velocity CNN, ACT, Diffusion Policy), untrained, in one process.

Inference: one closed-loop policy call on a uint8 frame, batch 1, torch intra-op threads as
the evaluator uses them (``eval.torch_threads``, default 1), median of ``--calls`` calls after
warm-up. The cost per control step differs by policy: CNN -> DMP plans once per episode (one
call per ``2 (n_steps - 1)`` steps in the evaluator), the velocity CNN and ACT (temporal
ensembling, a query every step) call every step, Diffusion Policy every ``n_action_steps``
steps (every call is one whole DDIM sampling). The ratio column is each policy's call against
the velocity CNN's, measured in the same process.

Training: the median wall time of one optimiser step (forward, backward, AdamW) on a synthetic
batch of ``data.batch_size`` items at the experiment's image size (no data loading, which is
the same for all), with all threads; x 4000 steps gives the experiment=quick budget.

    python benchmarks/policy_step_time.py [--image-size 96] [--calls 30] [--steps 5] [--threads 1]

Defaults: experiment=quick's sizes (96 px, trunk channels [16, 32, 32], batch 32) and each
model config's defaults (configs/model/*.yaml), ResNet-18 for ACT and Diffusion Policy.
Prints a markdown table.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch

from lfd.visuomotor.policies import ACTPolicy, CNNDMPPolicy, DiffusionPolicy, VelocityPolicy


def policies(size: int, backbone: str) -> dict[str, torch.nn.Module]:
    common = dict(image_size=size, channels=[16, 32, 32], n_steps=100, duration=4.0)
    return {
        "cnn_dmp": CNNDMPPolicy(global_pool=True, aux_weight=1.0, mode_heads=True, **common),
        "velocity": VelocityPolicy(**common),
        f"act ({backbone})": ACTPolicy(backbone=backbone, **common),
        f"diffusion ({backbone})": DiffusionPolicy(backbone=backbone, **common),
    }


def call(kind: str, policy, frame: np.ndarray, q: np.ndarray):
    if kind == "cnn_dmp":
        return policy.plan(frame, q, n_steps=199)
    if kind == "velocity":
        return policy.act(frame, q, 0.5)
    return policy.act_chunk(frame, q)


def median_ms(fn, n: int) -> float:
    fn()
    fn()
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


def train_batch(kind: str, b: int, size: int) -> dict[str, torch.Tensor]:
    g = torch.Generator().manual_seed(0)
    batch = {
        "image": torch.rand(b, 3, size, size, generator=g),
        "joints": torch.randn(b, 7, generator=g) * 0.1,
        "t": torch.rand(b, generator=g) * 4.0,
        "top": (torch.rand(b, generator=g) > 0.5).float(),
        "target_point": torch.randn(b, 3, generator=g) * 0.1,
        "command": torch.randn(b, 7, generator=g) * 0.1,
    }
    if kind == "cnn_dmp":
        batch.update(
            goal=torch.randn(b, 7, generator=g),
            weights=torch.randn(b, 7, 20, generator=g),
            trajectory=torch.randn(b, 100, 7, generator=g) * 0.1,
            ee_path=torch.randn(b, 100, 3, generator=g) * 0.1,
        )
    elif kind != "velocity":
        batch["chunk"] = torch.randn(b, 50 if kind.startswith("act") else 16, 7, generator=g) * 0.1
    return batch


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--image-size", type=int, default=96)
    parser.add_argument("--calls", type=int, default=30)
    parser.add_argument("--steps", type=int, default=5)
    parser.add_argument(
        "--threads", type=int, default=1, help="torch threads for inference (eval.torch_threads)"
    )
    parser.add_argument("--batch", type=int, default=32)
    parser.add_argument("--backbone", default="resnet18", choices=["resnet18", "trunk"])
    args = parser.parse_args()
    torch.manual_seed(0)
    frame = np.random.default_rng(0).integers(0, 255, (args.image_size, args.image_size, 3), dtype=np.uint8)
    q = np.zeros(7)
    pols = policies(args.image_size, args.backbone)
    rows = {}
    torch.set_num_threads(args.threads)
    for kind, p in pols.items():
        p.eval()
        rows[kind] = [median_ms(lambda k=kind, p=p: call(k, p, frame, q), args.calls)]
    torch.set_num_threads(torch.get_num_threads() if args.threads > 1 else 2)
    for kind, p in pols.items():
        p.train()
        opt = torch.optim.AdamW(p.parameters(), lr=1e-4)
        batch = train_batch(kind, args.batch, args.image_size)

        def step(p=p, opt=opt, batch=batch):
            loss = p.losses(batch)["loss"]
            opt.zero_grad()
            loss.backward()
            opt.step()

        rows[kind].append(median_ms(step, args.steps))
    ref = rows["velocity"][0]
    calls_per_step = {"cnn_dmp": 1 / 198, "velocity": 1.0}
    print(f"image {args.image_size} px, inference threads {args.threads}, training batch {args.batch}\n")
    print(
        "| policy | parameters | ms per call | calls per step | ms per step (mean) | vs velocity "
        "| training ms/step | 4000 steps, min |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for kind, (infer, train) in rows.items():
        p = pols[kind]
        per = calls_per_step.get(
            kind, 1.0 if kind.startswith("act") else 1 / p.hparams.get("n_action_steps", 1)
        )
        n = sum(x.numel() for x in p.parameters())
        print(
            f"| {kind} | {n / 1e6:.2f} M | {infer:.1f} | {per:.3g} | {infer * per:.2f} | {infer / ref:.1f}x "
            f"| {train:.0f} | {train * 4000 / 60e3:.0f} |"
        )


if __name__ == "__main__":
    main()
