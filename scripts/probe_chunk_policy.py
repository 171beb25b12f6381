"""Probe a trained ACT or Diffusion Policy checkpoint offline, on a dataset's validation episodes
(never the test split): where its closed-loop failures start (docs/policies.md, issue 35).

    python scripts/probe_chunk_policy.py CKPT [--data data/quick96o300d_s42] [--episodes 4] [--offset 0.05]

Prints, on the first ``--episodes`` held-out validation episodes (their recorded frames and
joints, the demonstrated future joints as the reference):

* the chunk error (mean |chunk - demonstration|, rad) at steps 0, 5, 10, 20, 40, 60 and 80
  (those within the episodes; "teacher-forced": the policy sees the demonstrated states);
* the sensitivity to a joint offset: how much the chunk moves (mean over joints, rad, at its
  first, middle and last sample) when every input joint is ``--offset`` rad higher. A policy
  that steers back moves its later samples *less* than the offset; one whose deviations grow
  moves them more;
* Diffusion Policy only: the network's error by diffusion step with each item's own condition
  and with the conditions of other items (shuffled: how much it uses the observation), and the
  sampled chunks' error, their spread between two noise draws and their roughness (mean
  absolute second difference) against the demonstrations'.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

STEPS = (0, 5, 10, 20, 40, 60, 80)


def _items(records, k: int, steps: tuple[int, ...]) -> dict[str, np.ndarray]:
    """Images (uint8 frames), joints and demonstrated chunks at ``steps`` of each record."""
    images, joints, chunks = [], [], []
    for r in records:
        with np.load(r.path) as z:
            frames = z["frames"]
        q = r.arrays["joints"]
        for t in steps:
            idx = np.minimum(np.arange(t + 1, t + k + 1), len(q) - 1)
            images.append(frames[t])
            joints.append(q[t])
            chunks.append(q[idx])
    return {"frames": np.stack(images), "joints": np.stack(joints), "chunk": np.stack(chunks)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checkpoint", type=Path)
    parser.add_argument(
        "--data", type=Path, default=Path("data/quick96o300d_s42"), help="the training dataset"
    )
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument(
        "--offset", type=float, default=0.05, help="joint offset (rad) of the sensitivity test"
    )
    args = parser.parse_args(argv)

    from lfd.visuomotor.data.datasets import load_dataset
    from lfd.visuomotor.policies import load_policy

    torch.set_num_threads(1)
    try:
        policy = load_policy(args.checkpoint)
        data = load_dataset(args.data)
    except (ValueError, FileNotFoundError) as e:
        print(f"probe_chunk_policy: {e}", file=sys.stderr)
        return 2
    if policy.kind not in ("act", "diffusion"):
        print(
            f"probe_chunk_policy: {args.checkpoint} holds a {policy.kind!r} policy, not act or diffusion",
            file=sys.stderr,
        )
        return 2
    records = [r for r in data.split("val") if r.group == "val"][: args.episodes]
    if not records:
        print(f"probe_chunk_policy: {args.data} has no held-out validation objects", file=sys.stderr)
        return 2
    k = policy.hparams.chunk_size
    steps = tuple(t for t in STEPS if t < policy.hparams.n_steps)
    items = _items(records, k, steps)
    torch.manual_seed(0)
    chunk = policy.act_chunk(items["frames"], items["joints"])  # (N, k, n)
    err = np.abs(chunk - items["chunk"]).mean(axis=(1, 2)).reshape(len(records), len(steps))
    print(f"{policy.kind} {args.checkpoint}: {len(records)} validation episodes, chunk of {k}")
    print("chunk error (rad) at steps " + ", ".join(map(str, steps)) + ":")
    for r, e in zip(records, err):
        print(f"  {r.obj.name:24s} " + " ".join(f"{x:.3f}" for x in e))
    torch.manual_seed(0)
    moved = policy.act_chunk(items["frames"], items["joints"] + args.offset) - chunk
    first, middle, last = (float(moved[:, i].mean()) for i in (0, k // 2, k - 1))
    print(
        f"joints +{args.offset} rad moves the chunk by {first:+.3f} (first) {middle:+.3f} (middle) "
        f"{last:+.3f} (last sample) rad"
    )
    if policy.kind == "diffusion":
        _diffusion(policy, items)
    return 0


@torch.no_grad()
def _diffusion(policy, items) -> None:
    img, q, _ = policy._observation(items["frames"], items["joints"])
    x0 = policy.normalise("joints", torch.as_tensor(items["chunk"], dtype=torch.float32))
    cond = policy.condition(img, q)
    g = torch.Generator().manual_seed(0)
    shuffled = cond[torch.randperm(len(cond), generator=g)]
    noise_model = policy.noise
    print(f"network error by diffusion step ({noise_model.prediction} prediction; x0 error in std units):")
    for t in (10, 30, 50, 70, 90):
        tt = torch.full((len(x0),), t)
        noise = torch.randn(x0.shape, generator=g)
        xt = noise_model.add_noise(x0, noise, tt)
        target = noise_model.target(x0, noise)
        own, other = policy.unet(xt, tt, cond), policy.unet(xt, tt, shuffled)
        a = noise_model.alphas_cumprod[t]
        x0_hat = noise_model.split(own, t, xt)[0]
        print(
            f"  t={t:3d} sqrt(abar)={float(a.sqrt()):.2f} MSE {float(((own - target) ** 2).mean()):.4f} "
            f"shuffled {float(((other - target) ** 2).mean()):.4f} x0 error {float((x0_hat - x0).abs().mean()):.3f}"
        )
    reference = torch.as_tensor(items["chunk"], dtype=torch.float32)

    def rough(x: torch.Tensor) -> float:
        return float((x[:, 2:] - 2 * x[:, 1:-1] + x[:, :-2]).abs().mean())

    torch.manual_seed(0)
    a = policy.predict_chunk(img, q)
    torch.manual_seed(1)
    b = policy.predict_chunk(img, q)
    error = float((a - reference).abs().mean())
    print(
        f"sampled chunks ({policy.hparams.n_inference_steps} DDIM steps): error {error:.3f} rad, "
        f"between two noise draws {float((a - b).abs().mean()):.3f} rad, roughness {rough(a):.4f} "
        f"vs the demonstrations' {rough(reference):.4f}"
    )


if __name__ == "__main__":
    raise SystemExit(main())
