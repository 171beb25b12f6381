"""Data for the Sawyer forward and inverse models (SPEC section 5).

* **Forward model**: joint configurations drawn uniformly within the joint limits and
  labelled with the end-effector position by the robot's batched forward kinematics.
  Training batches are fresh samples every step (:class:`FKSampleStream`); validation and
  test sets are fixed by the seed.
* **Inverse model**: one demonstration (scripted -- IK of the demonstration goal + a
  quintic in joint space -- or recorded, :func:`load_demo_csv`) plus, for nearby goals,
  third/fifth-order polynomial warps of it (:func:`warp_to_goals`) and straight joint-space
  paths into each goal from another goal (:func:`build_inverse_data`). Each path is
  followed with *exponential progress* (:func:`follow_paths`): the commanded joint
  velocity is the path tangent times the remaining fraction of the path over a time
  constant. A rest-to-rest timing would pair the largest Cartesian errors (at the start)
  with zero velocity, and the learned error -> velocity map would never leave the start
  pose in closed loop; with exponential progress, and paths arriving from several
  directions, the map is a convergent feedback law. Training pairs are
  ``(x_e(t) - goal, qd(t))`` with ``x_e`` from forward kinematics.

Units: metres, radians, seconds. Orientations are roll-pitch-yaw in degrees at the edges
(configs), i.e. extrinsic x-y-z rotations ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import lightning as L
import numpy as np
import torch
from lightning.pytorch.utilities import CombinedLoader
from scipy.spatial.transform import Rotation
from torch import Tensor
from torch.utils.data import DataLoader, IterableDataset, TensorDataset

from lfd.robots import load_robot
from lfd.sim.trajectory import via_quintic

__all__ = [
    "DEMO_GOAL",
    "SAWYER_START_DEG",
    "TASK_ORIENTATIONS_DEG",
    "DemoFileError",
    "FKSampleStream",
    "InverseData",
    "JointDemonstration",
    "SawyerFKDataModule",
    "SawyerInverseDataModule",
    "SawyerModelsDataModule",
    "build_inverse_data",
    "follow_paths",
    "fk_positions",
    "load_demo_csv",
    "make_demonstration",
    "pose_from_rpy",
    "sample_fk",
    "scripted_demo",
    "smoothstep",
    "solve_near",
    "warp_to_goals",
]

#: Start pose of the original experiments (deg), joints j0..j6.
SAWYER_START_DEG = (0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0)
#: Goal of the original demonstration (m), Sawyer world frame.
DEMO_GOAL = (0.035, -0.573, -0.04)
#: End-effector orientations (roll, pitch, yaw in deg) of the original tasks.
TASK_ORIENTATIONS_DEG = {"cube": (180.0, 0.0, 90.0), "cup": (-135.0, -90.0, 135.0)}


# ---------------------------------------------------------------------------- geometry
def pose_from_rpy(position: Sequence[float], rpy_deg: Sequence[float]) -> np.ndarray:
    """``(4, 4)`` pose from a position (m) and roll-pitch-yaw angles (deg, extrinsic x-y-z)."""
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_euler("xyz", np.asarray(rpy_deg, dtype=np.float64), degrees=True).as_matrix()
    pose[:3, 3] = np.asarray(position, dtype=np.float64)
    return pose


def fk_positions(robot, q) -> np.ndarray:
    """End-effector positions ``(..., 3)`` (m) of joint vectors ``q (..., n)`` (rad), one FK call."""
    q = np.asarray(q, dtype=np.float64)
    flat = robot.fk(torch.from_numpy(q.reshape(-1, q.shape[-1])))[:, :3, 3]
    return flat.numpy().reshape(*q.shape[:-1], 3)


def solve_near(robot, poses: np.ndarray, reference: np.ndarray, n_seeds: int = 16, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Full-pose IK of each target, choosing among several seeds the solution nearest ``reference``.

    Seeds per target: ``reference`` itself, half of the rest near it (Gaussian, 0.3 rad) and
    half uniform within the joint limits. Picking the successful solution closest to the
    reference keeps a family of targets on one IK branch.

    Args:
        robot: a :class:`lfd.robots.Robot`.
        poses: ``(G, 4, 4)`` target tool poses (m).
        reference: ``(n,)`` joint vector (rad) the solutions should stay close to.
        n_seeds: IK attempts per target (>= 1).
        seed: seed of the random seeds.

    Returns:
        ``q (G, n)`` (rad; the best attempt where none succeeded) and ``success (G,)`` bool.
    """
    poses = np.asarray(poses, dtype=np.float64)
    reference = np.asarray(reference, dtype=np.float64)
    n_targets, n = poses.shape[0], reference.shape[-1]
    gen = torch.Generator().manual_seed(seed)
    n_near = (n_seeds - 1) // 2
    near = torch.from_numpy(reference) + 0.3 * torch.randn(n_targets, n_near, n, generator=gen, dtype=torch.float64)
    uniform = robot.sample_q(n_targets * (n_seeds - 1 - n_near), gen).reshape(n_targets, -1, n)
    seeds = torch.cat(
        [torch.from_numpy(reference).expand(n_targets, 1, n), robot.clamp(near.reshape(-1, n)).reshape(near.shape), uniform], 1
    )
    targets = torch.from_numpy(poses)[:, None].expand(n_targets, n_seeds, 4, 4).reshape(-1, 4, 4)
    result = robot.ik(targets, q0=seeds.reshape(-1, n), restarts=0)
    q = result.q.reshape(n_targets, n_seeds, n)
    distance = (q - torch.from_numpy(reference)).norm(dim=-1)
    ok = result.success.reshape(n_targets, n_seeds)
    score = torch.where(ok, distance, distance + 1e3 + result.pos_error.reshape(n_targets, n_seeds) * 1e3)
    best = score.argmin(dim=1)
    rows = torch.arange(n_targets)
    return q[rows, best].numpy(), ok[rows, best].numpy()


# ---------------------------------------------------------------------------- demonstrations
@dataclass(frozen=True)
class JointDemonstration:
    """One joint-space demonstration on a uniform time grid.

    Attributes:
        t: ``(T,)`` times (s), starting at 0, uniform.
        q: ``(T, n)`` joint angles (rad).
        source: where it came from (file path or ``"scripted"``), for messages.
    """

    t: np.ndarray
    q: np.ndarray
    source: str

    @property
    def duration(self) -> float:
        return float(self.t[-1])


class DemoFileError(ValueError):
    """A demonstration file is malformed; the message names the file, line and column."""


def load_demo_csv(path: str | Path, n_joints: int = 7, n_steps: int = 100) -> JointDemonstration:
    """Read a recorded demonstration ``time, j0, ..., j{n-1}`` and resample it uniformly.

    The first non-empty line not starting with ``#`` is the header; columns may come in
    any order and extra columns are ignored. Times are seconds, strictly increasing, at
    any (even irregular) rate; joints are radians. The samples are linearly interpolated
    onto ``n_steps`` uniform times from 0 to the recorded duration.

    Raises:
        FileNotFoundError: no file at ``path``.
        DemoFileError: missing columns, a short row, a non-numeric or non-finite value,
            a time not greater than the previous one, or fewer than 3 samples; the message
            reads ``<file>:<line>: column '<name>': <problem>``.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"demonstration file not found: {path}")
    wanted = ["time", *(f"j{i}" for i in range(n_joints))]
    rows: list[list[float]] = []
    header: dict[str, int] | None = None
    last_time, last_line = -math.inf, 0
    with path.open(newline="") as f:
        for line_no, fields in enumerate(csv.reader(f), start=1):
            fields = [x.strip() for x in fields]
            if not any(fields) or fields[0].startswith("#"):
                continue
            if header is None:
                header = {name.lower(): i for i, name in enumerate(fields)}
                missing = [c for c in wanted if c not in header]
                if missing:
                    raise DemoFileError(f"{path}:{line_no}: header is missing column(s) {', '.join(missing)}; expected {', '.join(wanted)}")
                continue
            row = []
            for name in wanted:
                col = header[name]
                if col >= len(fields) or fields[col] == "":
                    raise DemoFileError(f"{path}:{line_no}: column '{name}': value missing ({len(fields)} fields in this row)")
                try:
                    value = float(fields[col])
                except ValueError:
                    raise DemoFileError(f"{path}:{line_no}: column '{name}': {fields[col]!r} is not a number") from None
                if not math.isfinite(value):
                    raise DemoFileError(f"{path}:{line_no}: column '{name}': {fields[col]!r} is not finite")
                row.append(value)
            if row[0] <= last_time:
                raise DemoFileError(
                    f"{path}:{line_no}: column 'time': {row[0]} is not greater than the previous time {last_time} (line {last_line})"
                )
            last_time, last_line = row[0], line_no
            rows.append(row)
    if header is None or len(rows) < 3:
        raise DemoFileError(f"{path}: need a header and at least 3 samples, got {len(rows)} sample(s)")
    data = np.array(rows)
    t = data[:, 0] - data[0, 0]
    grid = np.linspace(0.0, t[-1], n_steps)
    q = np.stack([np.interp(grid, t, data[:, 1 + j]) for j in range(n_joints)], axis=1)
    return JointDemonstration(t=grid, q=q, source=str(path))


def scripted_demo(
    robot, start: np.ndarray, goal_pose: np.ndarray, duration: float = 4.0, n_steps: int = 100, n_seeds: int = 64, seed: int = 0
) -> JointDemonstration:
    """A demonstration from ``start (n,)`` (rad) to the IK solution of ``goal_pose (4, 4)``
    nearest the start, timed by a rest-to-rest quintic in joint space.

    Raises:
        ValueError: IK finds no solution of the goal pose within the joint limits.
    """
    q_goal, ok = solve_near(robot, goal_pose[None], start, n_seeds=n_seeds, seed=seed)
    if not ok[0]:
        raise ValueError(f"scripted_demo: no IK solution for the demonstration goal pose\n{np.round(goal_pose, 4)}")
    t = np.linspace(0.0, duration, n_steps)
    q, _, _ = via_quintic(t, np.array([0.0, duration]), np.stack([start, q_goal[0]]))
    return JointDemonstration(t=t, q=q, source="scripted")


def make_demonstration(
    robot,
    orientation_deg: Sequence[float] | None = None,
    demo_csv: str | Path | None = None,
    *,
    start_deg: Sequence[float] = SAWYER_START_DEG,
    demo_goal: Sequence[float] = DEMO_GOAL,
    duration: float = 4.0,
    n_steps: int = 100,
    seed: int = 0,
) -> JointDemonstration:
    """The demonstration of one task: the CSV file if given, else the scripted one from
    ``start_deg`` to ``demo_goal`` with the end-effector orientation ``orientation_deg``.

    Raises:
        ValueError: neither an orientation nor a file, or a recorded sample outside the
            joint limits (the message names the file).
    """
    if demo_csv is not None:
        demo = load_demo_csv(demo_csv, robot.n_dof, n_steps)
        outside = ~robot.within_limits(torch.from_numpy(demo.q)).numpy()
        if outside.any():
            raise DemoFileError(f"{demo.source}: {int(outside.sum())} resampled sample(s) outside the {robot.name} joint limits")
        return demo
    if orientation_deg is None:
        raise ValueError("make_demonstration: give an orientation_deg for the scripted demonstration or a demo_csv file")
    start = np.radians(np.asarray(start_deg, dtype=np.float64))
    return scripted_demo(robot, start, pose_from_rpy(demo_goal, orientation_deg), duration, n_steps, seed=seed)


# ---------------------------------------------------------------------------- augmentation
def smoothstep(p: np.ndarray, order: int) -> np.ndarray:
    """Rest-to-rest polynomial blend from 0 to 1 on ``p`` in [0, 1]: order 3
    (``3p^2 - 2p^3``) or 5 (``10p^3 - 15p^4 + 6p^5``)."""
    if order == 3:
        return p * p * (3 - 2 * p)
    if order == 5:
        return p**3 * (10 - 15 * p + 6 * p * p)
    raise ValueError(f"smoothstep: order must be 3 or 5, got {order}")


def warp_to_goals(demo_q: np.ndarray, goal_q: np.ndarray, orders: Sequence[int]) -> np.ndarray:
    """Paths ``(G, T, n)``: the demonstration ``demo_q (T, n)`` bent to end at each
    ``goal_q (G, n)`` by a third- or fifth-order polynomial blend of the offset,
    ``q_demo(p) + s(p) (q_goal - q_demo(1))``; ``orders (G,)`` picks 3 or 5 per path. The
    start and the demonstrated shape are kept; the path ends exactly at its goal."""
    p = np.linspace(0.0, 1.0, demo_q.shape[0])
    blend = np.stack([smoothstep(p, int(o)) for o in orders])  # (G, T)
    return demo_q[None] + blend[:, :, None] * (goal_q - demo_q[-1])[:, None, :]


def follow_paths(paths: np.ndarray, time_constant: float, dt: float, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Follow each path with exponential progress: ``sigma(t) = 1 - exp(-t / time_constant)``
    of its joint-space arc length, so the velocity is the tangent times ``(1 - sigma) / time_constant``.

    Args:
        paths: ``(G, P, n)`` joint paths (rad), ``P >= 2`` points each, not of zero length.
        time_constant: seconds for the remaining path to shrink by ``e``.
        dt: sample spacing (s); ``n_steps`` samples from ``t = 0``.

    Returns:
        ``t (N,)`` (s), positions ``q (G, N, n)`` (rad) and velocities ``qd (G, N, n)`` (rad/s).
    """
    steps = np.linalg.norm(np.diff(paths, axis=1), axis=-1)  # (G, P-1)
    length = steps.sum(axis=1)
    if np.any(length <= 1e-9):
        raise ValueError("follow_paths: a path has zero length (its goal is its start)")
    sigma_path = np.concatenate([np.zeros((len(paths), 1)), np.cumsum(steps, axis=1) / length[:, None]], axis=1)
    t = np.arange(n_steps) * dt
    sigma = 1.0 - np.exp(-t / time_constant)  # (N,)
    # Batched segment lookup: offset row g by 2g so one sorted array holds every path.
    offsets = 2.0 * np.arange(len(paths))[:, None]
    flat = (sigma_path + offsets).ravel()
    idx = np.searchsorted(flat, (sigma[None] + offsets).ravel(), side="right").reshape(len(paths), -1) - 1
    idx = np.clip(idx - np.arange(len(paths))[:, None] * paths.shape[1], 0, paths.shape[1] - 2)
    rows = np.arange(len(paths))[:, None]
    s0, s1 = sigma_path[rows, idx], sigma_path[rows, idx + 1]
    q0, q1 = paths[rows, idx], paths[rows, idx + 1]
    width = np.maximum(s1 - s0, 1e-12)
    frac = ((sigma[None] - s0) / width)[..., None]
    q = q0 + frac * (q1 - q0)
    tangent = (q1 - q0) / width[..., None]
    qd = tangent * ((1.0 - sigma) / time_constant)[None, :, None]
    return t, q, qd


@dataclass(frozen=True)
class InverseData:
    """Training pairs of one task's inverse model.

    Attributes:
        demo: the demonstration (kept in the model checkpoint).
        goals: ``(G, 3)`` goal position (m) of each path; row 0 is the demonstration.
        t: ``(N,)`` sample times (s) shared by all paths.
        q: ``(G, N, n)`` joint positions (rad) along each followed path.
        errors: ``(G, N, 3)`` inputs ``x_e - goal`` (m).
        velocities: ``(G, N, n)`` targets (rad/s).
        n_failed: augmentation goals dropped because IK found no solution.
    """

    demo: JointDemonstration
    goals: np.ndarray
    t: np.ndarray
    q: np.ndarray
    errors: np.ndarray
    velocities: np.ndarray
    n_failed: int


def build_inverse_data(
    robot,
    demo: JointDemonstration,
    n_goals: int = 125,
    goal_spread: Sequence[float] = (0.25, 0.15, 0.05),
    orders: Sequence[int] = (3, 5),
    cross_paths: int = 1,
    time_constant: float = 1.5,
    dt: float = 0.075,
    n_steps: int = 100,
    n_seeds: int = 8,
    seed: int = 0,
) -> InverseData:
    """Training paths of one task's inverse model.

    ``n_goals`` goals are drawn uniformly in a box of half-widths ``goal_spread`` (m) around
    the demonstration's end point, each with the demonstration's final orientation (IK
    nearest the demonstrated final configuration; goals without a solution are dropped and
    counted). Paths, all followed with :func:`follow_paths`:

    * the demonstration itself (row 0);
    * per goal, the demonstration warped to it by a polynomial blend of order
      ``orders[k % len(orders)]`` (:func:`warp_to_goals`): the approach from the start;
    * per goal (the demonstration's included), ``cross_paths`` straight joint-space paths
      from the configuration of another, random goal. Without them every path near a goal
      arrives from the start's side, the errors near the goals span one direction only and
      the learned map cannot correct errors in the others.
    """
    end_pose = robot.fk(torch.from_numpy(demo.q[-1:]))[0].numpy()
    rng = np.random.default_rng(seed)
    offsets = rng.uniform(-1.0, 1.0, size=(n_goals, 3)) * np.asarray(goal_spread, dtype=np.float64)
    poses = np.repeat(end_pose[None], n_goals, axis=0)
    poses[:, :3, 3] += offsets
    goal_q, ok = solve_near(robot, poses, demo.q[-1], n_seeds=n_seeds, seed=seed)
    goal_q = np.concatenate([demo.q[-1:], goal_q[ok]])
    order_list = [orders[k % len(orders)] for k in range(len(goal_q))]
    paths = [warp_to_goals(demo.q, goal_q, order_list)]
    ends = [goal_q]
    if len(goal_q) > 1:
        for _ in range(cross_paths):
            origin = (np.arange(len(goal_q)) + rng.integers(1, len(goal_q), len(goal_q))) % len(goal_q)  # never the goal itself
            p = np.linspace(0.0, 1.0, demo.q.shape[0])[None, :, None]
            paths.append(goal_q[origin][:, None] + p * (goal_q - goal_q[origin])[:, None])
            ends.append(goal_q)
    t, q, qd = follow_paths(np.concatenate(paths), time_constant, dt, n_steps)
    goals = fk_positions(robot, np.concatenate(ends))
    errors = fk_positions(robot, q) - goals[:, None, :]
    return InverseData(demo=demo, goals=goals, t=t, q=q, errors=errors, velocities=qd, n_failed=int((~ok).sum()))


# ---------------------------------------------------------------------------- forward-model samples
def sample_fk(robot, n: int, generator: torch.Generator) -> tuple[Tensor, Tensor]:
    """``n`` configurations uniform within the joint limits (float32, rad) and their
    end-effector positions (float32, m; FK evaluated in float64)."""
    q = robot.sample_q(n, generator)
    return q.float(), robot.fk(q)[:, :3, 3].float()


class FKSampleStream(IterableDataset):
    """Fresh ``(q (B, n), x (B, 3))`` batches for each training step, ``batches_per_epoch``
    per pass. Pass ``k`` draws from a generator seeded with ``(seed, k)``, so a run is
    reproducible and no two epochs see the same samples."""

    def __init__(self, robot_name: str, batch_size: int, batches_per_epoch: int, seed: int) -> None:
        self.robot = load_robot(robot_name)
        self.batch_size, self.batches_per_epoch, self.seed = batch_size, batches_per_epoch, seed
        self.epoch = 0

    def __len__(self) -> int:
        return self.batches_per_epoch

    def __iter__(self) -> Iterator[tuple[Tensor, Tensor]]:
        gen = torch.Generator().manual_seed(self.seed * 1_000_003 + self.epoch)
        self.epoch += 1
        for _ in range(self.batches_per_epoch):
            yield sample_fk(self.robot, self.batch_size, gen)


class SawyerFKDataModule(L.LightningDataModule):
    """Forward-model data: fresh uniform samples for training, fixed validation and test sets.

    Args:
        robot: robot name for :func:`lfd.robots.load_robot`.
        batch_size: samples per training step.
        batches_per_epoch: training steps per epoch (each on new samples).
        n_val, n_test: sizes of the fixed validation / test sets (seeds ``seed + 1``, ``seed + 2``).
        eval_batch_size: batch size of validation and test.
        seed: seed of all sampling.
    """

    def __init__(
        self,
        robot: str = "sawyer",
        batch_size: int = 256,
        batches_per_epoch: int = 1600,
        n_val: int = 20_000,
        n_test: int = 100_000,
        eval_batch_size: int = 20_000,
        seed: int = 0,
    ) -> None:
        super().__init__()
        for name, value in (
            ("batch_size", batch_size),
            ("batches_per_epoch", batches_per_epoch),
            ("n_val", n_val),
            ("n_test", n_test),
            ("eval_batch_size", eval_batch_size),
        ):
            if int(value) < 1:
                raise ValueError(f"SawyerFKDataModule.{name}: expected an int >= 1, got {value!r}")
        self.robot_name = robot
        self.batch_size, self.batches_per_epoch = int(batch_size), int(batches_per_epoch)
        self.n_val, self.n_test, self.eval_batch_size, self.seed = int(n_val), int(n_test), int(eval_batch_size), int(seed)
        self._stream: FKSampleStream | None = None
        self._fixed: dict[str, TensorDataset] = {}

    def fixed_set(self, split: str) -> TensorDataset:
        """The fixed ``"val"`` or ``"test"`` set as a ``TensorDataset(q, x)`` (built once)."""
        if split not in self._fixed:
            offset, n = {"val": (1, self.n_val), "test": (2, self.n_test)}[split]
            self._fixed[split] = TensorDataset(
                *sample_fk(load_robot(self.robot_name), n, torch.Generator().manual_seed(self.seed + offset))
            )
        return self._fixed[split]

    def train_dataloader(self) -> DataLoader:
        if self._stream is None:
            self._stream = FKSampleStream(self.robot_name, self.batch_size, self.batches_per_epoch, self.seed)
        return DataLoader(self._stream, batch_size=None)

    def val_dataloader(self) -> DataLoader:
        return DataLoader(self.fixed_set("val"), batch_size=self.eval_batch_size)

    def test_dataloader(self) -> DataLoader:
        return DataLoader(self.fixed_set("test"), batch_size=self.eval_batch_size)


# ---------------------------------------------------------------------------- inverse-model data
class SawyerInverseDataModule(L.LightningDataModule):
    """Inverse-model data of one or more tasks (end-effector orientations).

    Each task gets its demonstration (:func:`make_demonstration`) and its augmented paths
    (:func:`build_inverse_data`); 10 % of the augmented paths (``val_fraction``, never the
    demonstration) are held out for validation. Batches are dictionaries ``{task: (errors
    (B, 3), velocities (B, n))}``.

    Args:
        tasks: ``{name: {"orientation_deg": [r, p, y], "demo_csv": path}}`` with either key
            (the recorded file wins when both are given); default the original cube and cup
            orientations with scripted demonstrations.
        robot: robot name.
        start_deg, demo_goal, duration, n_demo_steps: the scripted demonstration.
        n_goals, goal_spread, orders, cross_paths, time_constant, dt, n_steps: augmentation
            (see :func:`build_inverse_data`).
        val_fraction: fraction of paths held out.
        batch_size: samples per step and task.
        seed: seed of goal sampling, IK seeds and the split.
    """

    def __init__(
        self,
        tasks: Mapping[str, Mapping] | None = None,
        robot: str = "sawyer",
        start_deg: Sequence[float] = SAWYER_START_DEG,
        demo_goal: Sequence[float] = DEMO_GOAL,
        duration: float = 4.0,
        n_demo_steps: int = 100,
        n_goals: int = 125,
        goal_spread: Sequence[float] = (0.25, 0.15, 0.05),
        orders: Sequence[int] = (3, 5),
        cross_paths: int = 1,
        time_constant: float = 1.5,
        dt: float = 0.075,
        n_steps: int = 100,
        val_fraction: float = 0.1,
        batch_size: int = 128,
        seed: int = 0,
    ) -> None:
        super().__init__()
        tasks = {k: dict(v) for k, v in (tasks or {k: {"orientation_deg": v} for k, v in TASK_ORIENTATIONS_DEG.items()}).items()}
        for name, task in tasks.items():
            unknown = set(task) - {"orientation_deg", "demo_csv"}
            if unknown or not task:
                raise ValueError(f"SawyerInverseDataModule.tasks.{name}: expected orientation_deg and/or demo_csv, got {sorted(task)}")
        if not 0.0 <= val_fraction < 1.0:
            raise ValueError(f"SawyerInverseDataModule.val_fraction: expected a number in [0, 1), got {val_fraction}")
        self.tasks = tasks
        self.robot_name = robot
        self.demo_kwargs = {
            "start_deg": tuple(start_deg),
            "demo_goal": tuple(demo_goal),
            "duration": duration,
            "n_steps": n_demo_steps,
            "seed": seed,
        }
        self.augment_kwargs = {
            "n_goals": n_goals,
            "goal_spread": tuple(goal_spread),
            "orders": tuple(orders),
            "cross_paths": cross_paths,
            "time_constant": time_constant,
            "dt": dt,
            "n_steps": n_steps,
            "seed": seed,
        }
        self.val_fraction, self.batch_size, self.seed = val_fraction, int(batch_size), seed
        self.data: dict[str, InverseData] = {}
        self._splits: dict[str, dict[str, TensorDataset]] = {}

    def prepare(self) -> dict[str, InverseData]:
        """Build (once) and return every task's :class:`InverseData`."""
        if not self.data:
            robot = load_robot(self.robot_name)
            for name, task in self.tasks.items():
                demo = make_demonstration(robot, task.get("orientation_deg"), task.get("demo_csv"), **self.demo_kwargs)
                self.data[name] = build_inverse_data(robot, demo, **self.augment_kwargs)
                self._splits[name] = self._split(self.data[name])
        return self.data

    def setup(self, stage: str | None = None) -> None:
        self.prepare()

    def _split(self, data: InverseData) -> dict[str, TensorDataset]:
        n_paths = len(data.goals)
        order = 1 + np.random.default_rng(self.seed).permutation(n_paths - 1)
        n_val = int(round(self.val_fraction * (n_paths - 1)))
        split = {"val": order[:n_val], "train": np.concatenate([[0], order[n_val:]])}

        def pairs(rows: np.ndarray) -> TensorDataset:
            e = torch.from_numpy(data.errors[rows].reshape(-1, 3)).float()
            v = torch.from_numpy(data.velocities[rows].reshape(-1, data.velocities.shape[-1])).float()
            return TensorDataset(e, v)

        return {k: pairs(rows) for k, rows in split.items() if len(rows)}

    def loaders(self, split: str) -> dict[str, DataLoader]:
        """``{task: DataLoader}`` of one split (``"train"`` shuffles)."""
        self.prepare()
        gen = torch.Generator().manual_seed(self.seed)
        return {
            name: DataLoader(s[split], batch_size=self.batch_size, shuffle=split == "train", generator=gen)
            for name, s in self._splits.items()
            if split in s
        }

    def train_dataloader(self) -> CombinedLoader:
        return CombinedLoader(self.loaders("train"), mode="max_size_cycle")

    def val_dataloader(self) -> CombinedLoader:
        return CombinedLoader(self.loaders("val"), mode="max_size")


class SawyerModelsDataModule(L.LightningDataModule):
    """Both models' data in one datamodule: batches ``{"forward": (q, x), "inverse": {task: (e, qd)}}``.

    Training cycles the (small) inverse-model sets while the forward model gets
    ``batches_per_epoch`` fresh batches; validation runs both fixed sets; test is the
    forward model's fixed test set.

    Args:
        forward: :class:`SawyerFKDataModule` arguments.
        inverse: :class:`SawyerInverseDataModule` arguments.
    """

    def __init__(self, forward: Mapping | None = None, inverse: Mapping | None = None) -> None:
        super().__init__()
        self.forward = SawyerFKDataModule(**dict(forward or {}))
        self.inverse = SawyerInverseDataModule(**dict(inverse or {}))

    def setup(self, stage: str | None = None) -> None:
        if stage in (None, "fit", "validate"):
            self.inverse.prepare()

    def train_dataloader(self) -> CombinedLoader:
        return CombinedLoader({"forward": self.forward.train_dataloader(), "inverse": self.inverse.loaders("train")}, mode="max_size_cycle")

    def val_dataloader(self) -> CombinedLoader:
        return CombinedLoader({"forward": self.forward.val_dataloader(), "inverse": self.inverse.loaders("val")}, mode="max_size")

    def test_dataloader(self) -> DataLoader:
        return self.forward.test_dataloader()
