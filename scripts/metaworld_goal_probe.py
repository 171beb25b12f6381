"""Can the policies' image encoder find a Meta-World task's goal in its first camera image?

A diagnostic for the CNN -> DMP policy on Meta-World: the keypoint encoder of the policies
(:class:`lfd.visuomotor.policies.vision.KeypointEncoder`, the experiment's channels) with a
200-200 MLP, trained alone to regress each demonstration's DMP goal (the hand's end point, m)
from the episode's first frame, on the train split of a generated dataset; prints the mean goal
error on the train and validation splits every 250 steps. If the validation error stays at the
spread of the goals while the train error falls, the encoder memorises the training images
instead of locating the goal, whatever the DMP and the controller do.

With ``--target object`` the target is the object's start position instead (the placement's first
three entries): can the encoder find the puck, peg or block the hand has to grasp?

    python scripts/metaworld_goal_probe.py data/metaworld_push-v3_n50_s42 [--steps 1500] [--seed 0] [--target object]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch
from torch import nn


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a Meta-World demonstration dataset folder")
    parser.add_argument("--steps", type=int, default=1500)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--channels", type=int, nargs="+", default=[16, 32, 32])
    parser.add_argument(
        "--target",
        choices=("goal", "object"),
        default="goal",
        help="goal: the DMP goal (the hand's end point); object: the placement's first three entries "
        "(the object's start position in the tasks that place one)",
    )
    args = parser.parse_args(argv)

    from lfd.io.files import DatasetError
    from lfd.visuomotor.metaworld.demos import load_demonstrations
    from lfd.visuomotor.policies.vision import KeypointEncoder, mlp

    try:
        data = load_demonstrations(args.dataset)
    except DatasetError as e:
        print(f"metaworld_goal_probe: {e}", file=sys.stderr)
        return 2
    torch.manual_seed(args.seed)

    def split(name: str) -> tuple[torch.Tensor, torch.Tensor]:
        eps = data.split(name)
        images = torch.from_numpy(np.stack([e.frames[0] for e in eps])).permute(0, 3, 1, 2).float() / 255
        key = "dmp_goal" if args.target == "goal" else "placement"
        return images, torch.from_numpy(np.stack([e.arrays[key][:3] for e in eps])).float()

    (x_train, y_train), (x_val, y_val) = split("train"), split("val")
    mean, std = y_train.mean(0), y_train.std(0).clamp_min(1e-3)  # a coordinate the task never varies
    encoder = KeypointEncoder(args.channels)
    net = nn.Sequential(encoder, mlp(encoder.out_dim, [200, 200], 3))
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    print(
        f"{data.config.task}: {len(y_train)} train / {len(y_val)} val {args.target}s, "
        f"spread (std) {100 * std.norm():.1f} cm"
    )
    for step in range(args.steps + 1):
        if step % 250 == 0:
            net.eval()
            with torch.no_grad():
                err = [
                    100 * (net(x) * std + mean - y).norm(dim=1).mean()
                    for x, y in ((x_train, y_train), (x_val, y_val))
                ]
            print(
                f"step {step:5d}: {args.target} error train {err[0]:.2f} cm, validation {err[1]:.2f} cm",
                flush=True,
            )
        net.train()
        batch = torch.randint(len(y_train), (32,))
        loss = ((net(x_train[batch]) - (y_train[batch] - mean) / std) ** 2).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
