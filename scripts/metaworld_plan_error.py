"""Where along the way does a CNN -> DMP policy's plan leave the demonstrations?

A diagnostic for the CNN -> DMP policy on Meta-World: plans from each demonstration's first image
and start state (as the policy plans an episode) and prints, every 10 steps, the median distance
(cm) between the planned hand position and the demonstrated one, on the train and validation
splits of the dataset it was trained on, beside the demonstrations' own fitted DMPs ("fitted", the floor)
and, for a policy with ``placement_dim``, the plan its affine map gives from the demonstration's *true*
placement ("map": what the policy would do if it saw the placement exactly).
A plan that ends where the demonstration does but misses it half-way has found the goal and not
the object it must grasp on the way.

    python scripts/metaworld_plan_error.py outputs/.../checkpoints/last.ckpt data/metaworld_push-v3_n50_s42
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoint", type=Path, help="a CNN -> DMP checkpoint trained on Meta-World")
    parser.add_argument("dataset", type=Path, help="the Meta-World demonstration dataset folder")
    parser.add_argument("--every", type=int, default=10, help="steps between two printed errors")
    args = parser.parse_args(argv)

    from lfd.io.files import DatasetError
    from lfd.visuomotor.metaworld.datamodule import placements
    from lfd.visuomotor.metaworld.demos import load_demonstrations
    from lfd.visuomotor.policies import CNNDMPPolicy
    from lfd.visuomotor.policies.factory import load_policy

    try:
        data = load_demonstrations(args.dataset)
        policy = load_policy(args.checkpoint)
    except (DatasetError, FileNotFoundError, ValueError) as e:
        print(f"metaworld_plan_error: {e}", file=sys.stderr)
        return 2
    if not isinstance(policy, CNNDMPPolicy):
        print(
            f"metaworld_plan_error: {args.checkpoint} is a {policy.kind} policy, not cnn_dmp", file=sys.stderr
        )
        return 2
    steps = data.config.n_steps
    layer = policy.layer(steps)
    print(f"{data.config.task}: median hand error (cm) every {args.every} steps of {steps}")
    for split in ("train", "val"):
        planned, fitted, mapped = [], [], []
        through_placement = policy.through_placement
        for e in data.split(split):
            states = e.states
            with torch.no_grad():
                dmp = (
                    layer(
                        torch.as_tensor(states[:1], dtype=torch.float32),
                        torch.as_tensor(e.arrays["dmp_goal"][None], dtype=torch.float32),
                        torch.as_tensor(e.arrays["dmp_weights"][None], dtype=torch.float32),
                    )[0]
                    .double()
                    .numpy()
                )
            plan = policy.plan(e.frames[0], states[0], n_steps=steps)
            if through_placement:
                mapped_plan = policy.plan_from_placement(placements([e])[0], states[0], n_steps=steps)
                mapped.append(np.linalg.norm(mapped_plan[:, :3] - states[:, :3], axis=1))
            fitted.append(np.linalg.norm(dmp[:, :3] - states[:, :3], axis=1))
            planned.append(np.linalg.norm(plan[:, :3] - states[:, :3], axis=1))
        for name, err in (("plan", planned), ("map", mapped), ("fitted", fitted)):
            if not err:
                continue
            row = 100 * np.median(np.stack(err), axis=0)[:: args.every]
            print(f"{split:5s} {name:6s} " + " ".join(f"{v:4.1f}" for v in row), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
