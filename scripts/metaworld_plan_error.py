"""Where along the way does a CNN -> DMP policy's plan leave the demonstrations?

A diagnostic for the CNN -> DMP policy on Meta-World: plans from each demonstration's first image
and start state (as the policy plans an episode) and prints, every 10 steps, the median distance
(cm) between the planned hand position and the demonstrated one, on the train and validation
splits of the dataset it was trained on, beside the demonstrations' own fitted DMPs ("fitted", the floor)
and, for a policy with ``placement_dim``, the plan its affine map gives from the demonstration's *true*
placement ("map": what the policy would do if it saw the placement exactly).
A plan that ends where the demonstration does but misses it half-way has found the goal and not
the object it must grasp on the way.

With ``--rollouts N`` it also runs the first N validation placements of the task in closed loop
(planned once, as ``eval.dmp_replan_every=null``) and prints the successes of the plan from the
image and, for a policy with ``placement_dim``, of the map's plan from the episode's *true*
placement: whether the misses come from what the network sees or from the map. A third count,
"true pixels", plans from the placement that the points' *true pixels* alone give (each point's
position regressed on its pixel over the training placements, quadratic least squares): the most a
head that sees only where the points appear (``keypoint_head=supervised``) can expect; below the
true placement's count where a point's depth along the line of sight matters (a goal in the air).

    python scripts/metaworld_plan_error.py outputs/.../last.ckpt data/metaworld_push-v3_n50_s42 [--rollouts 30]
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
    parser.add_argument("--rollouts", type=int, default=0, help="closed-loop validation episodes (0: none)")
    parser.add_argument("--horizon", type=int, default=200, help="control steps per closed-loop episode")
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
    if args.rollouts > 0:
        rollouts(policy, data.config, args.rollouts, args.horizon, list(data.split("train")))
    return 0


class _TruePlacement:
    """The policy's map planning from a known placement (``plan`` as :class:`PlanController` calls it)."""

    def __init__(self, policy, placement: np.ndarray) -> None:
        self.policy, self.placement = policy, placement
        self.input_channels, self.depth_encoding = policy.input_channels, policy.depth_encoding

    def plan(self, image, joints, n_steps: int | None = None) -> np.ndarray:
        return self.policy.plan_from_placement(self.placement, joints, n_steps=n_steps)


def pixel_regression(config, train_eps) -> callable:
    """A function ``(p,)`` placement (m) -> ``(p,)`` what the placement's points' pixels alone give:
    each 3-D point regressed on its pixel (quadratic least squares over ``train_eps``); padding
    stays zero."""
    from lfd.visuomotor.metaworld.datamodule import placement_pixels, placements
    from lfd.visuomotor.policies.line_of_sight import pixel_design

    def _quadratic(uv: np.ndarray) -> np.ndarray:
        return pixel_design(torch.from_numpy(np.asarray(uv, dtype=np.float64))).numpy()

    x, pixels = placements(train_eps), placement_pixels(config, train_eps)
    fits = []
    for k in range(x.shape[1] // 3):
        uv = pixels[:, 2 * k : 2 * k + 2]
        if np.isnan(uv).any():
            continue
        scale = (uv.mean(0), uv.std(0) + 1e-9)
        coef = np.linalg.lstsq(_quadratic((uv - scale[0]) / scale[1]), x[:, 3 * k : 3 * k + 3], rcond=None)[0]
        fits.append((k, scale, coef))

    def estimate(placement: np.ndarray, pixel: np.ndarray) -> np.ndarray:
        out = np.zeros_like(placement)
        for k, (mean, std), coef in fits:
            out[3 * k : 3 * k + 3] = _quadratic((pixel[None, 2 * k : 2 * k + 2] - mean) / std)[0] @ coef
        return out

    return estimate


def rollouts(policy, config, n: int, horizon: int, train_eps=()) -> None:
    """Successes of the image's plan and (with ``placement_dim``) the true placement's plan and the
    true pixels' plan (:func:`pixel_regression` on ``train_eps``) on the first ``n`` validation
    placements of ``config.task``, ``horizon`` control steps each."""
    from lfd.metaworld.env import MetaWorldTask, placement_seed
    from lfd.visuomotor.metaworld.datamodule import padded_placement
    from lfd.visuomotor.policies.control import PlanController
    from lfd.visuomotor.protocols import Observation

    modes = ("image", "true placement", "true pixels") if policy.through_placement else ("image",)
    from_pixels = pixel_regression(config, train_eps) if policy.through_placement else None
    wins = dict.fromkeys(modes, 0)
    with MetaWorldTask(
        config.task, image_size=config.image_size, camera=config.camera, fovy=config.camera_fovy
    ) as task:
        for i in range(n):
            for mode in modes:
                state = task.reset(placement_seed(config.seed, "val", i))
                planner = policy
                if mode != "image":
                    placement = padded_placement(task.placement)
                    if mode == "true pixels":
                        m = placement.size // 3
                        pixel = np.full(2 * m, np.nan)
                        n_points = task.placement.size // 3
                        pixel[: 2 * n_points] = task.project(placement[: 3 * n_points].reshape(-1, 3)).ravel()
                        placement = from_pixels(placement, pixel)
                    planner = _TruePlacement(policy, placement)
                controller = PlanController(planner, task.control_dt)
                controller.start(horizon)
                for step in range(horizon):
                    image = task.render() if controller.needs_image else None
                    obs = Observation(image=image, joints=state.copy(), time=step * task.control_dt)
                    target, _ = controller.command(obs, step, [])
                    if task.step_to(np.asarray(target, dtype=np.float64)):
                        wins[mode] += 1
                        break
                    state = task.state()
    print(
        f"{config.task}: closed-loop successes on {n} validation placements (planned once): "
        + ", ".join(f"{mode} {k} / {n}" for mode, k in wins.items()),
        flush=True,
    )


if __name__ == "__main__":
    raise SystemExit(main())
