"""Batched, differentiable kinematics and dynamics of a :class:`~lfd.robots.spec.RobotSpec`.

:class:`Robot` wraps an immutable spec (the *model*) and caches its constants as
tensors per (device, dtype) (the *data*). Every method takes a batch ``q`` of shape
``(B, n)`` as a NumPy array or a torch tensor and returns torch tensors on the
input's device with the input's floating dtype (NumPy/integer input -> float64).
There is no Python loop over the batch, only over the ``n`` joints.

Implementation notes. Each joint axis ``a_i`` is turned into the local ``z`` axis by a
constant rotation ``A_i`` (columns: two unit vectors orthogonal to ``a_i``, then
``a_i``; exact permutations for +-x/y/z), folded into the constant joint origins, so
every joint step is ``T_i = T_{i-1} @ O'_i @ Rz(q_i)``: one small GEMM with a constant
matrix plus a mix of two columns by ``cos q_i``, ``sin q_i``. Frames are kept in a
batch-last "column" layout ``(4 columns, 3 rows, B)`` so these are contiguous,
vectorised operations. Inverse dynamics is recursive Newton-Euler written in the
world frame, where both recursions become cumulative sums over the joints (one GEMM
with a triangular matrix of ones). On the CPU, batches above 16 384 rows are processed
in cache-sized blocks of rows (see ``_blockwise``); there is never a loop over rows.
"""

from __future__ import annotations

import os
from contextlib import nullcontext
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from lfd.io.files import write_text_atomic

from .batch import as_batch
from .ik import IKResult, solve_ik
from .kernel import ChainProgram
from .spec import RobotSpec, frame_with_z_axis
from .urdf import spec_to_urdf

__all__ = ["Robot"]

_CPU_BLOCK_ROWS = 16384


def _homogeneous_rotation(rotation: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = rotation
    return out


@dataclass(frozen=True)
class _Constants:
    """Spec constants in the internal z-axis joint frames, for one (device, dtype)."""

    first_cols: Tensor  # (4, 3, 1) column layout of O'_0 (base included), rows 0..2
    next_origins_t: tuple[Tensor, ...]  # n - 1 transposed O'_i (4, 4) of joints 1..n-1
    tool_t: Tensor  # (4, 4) transposed internal tool transform
    axis_frames: Tensor  # (n, 3, 3) A_i: URDF link frame = internal frame @ A_i^T
    com_weights: Tensor  # (n, 1, 4) centres of mass in the internal frames, as column weights (last 0)
    inertias: Tensor  # (n, 3, 3) inertia about the com, internal frames
    masses: Tensor  # (n,)
    prefix_sums: Tensor  # (2n, n): rows 0..n-1 inclusive, n..2n-1 exclusive prefix sums over the chain
    suffix_sums: Tensor  # (n, n): inclusive suffix sums (sums over the subtree)
    differences: Tensor  # (n, n): x_i - x_{i-1} (zero row for the first joint)
    lower: Tensor  # (n,)
    upper: Tensor  # (n,)
    continuous: Tensor  # (n,) bool


def _compile(spec: RobotSpec) -> dict[str, np.ndarray]:
    n = spec.n_dof
    frames = [frame_with_z_axis(a) for a in spec.joint_axis]
    h = [_homogeneous_rotation(f) for f in frames]
    origins = [spec.base_transform @ spec.joint_origin(0) @ h[0]]
    origins += [h[i - 1].T @ spec.joint_origin(i) @ h[i] for i in range(1, n)]
    origins = np.array(origins)
    frames = np.array(frames)
    return {
        "first_cols": origins[0, :3, :].T[:, :, None],
        "next_origins_t": np.swapaxes(origins[1:], 1, 2),
        "tool_t": (h[-1].T @ spec.tool_transform).T,
        "axis_frames": frames,
        "com_weights": np.pad(np.einsum("nkr,nk->nr", frames, spec.link_coms), ((0, 0), (0, 1)))[:, None],
        "inertias": np.swapaxes(frames, 1, 2) @ spec.link_inertias @ frames,
        "masses": spec.link_masses,
        "prefix_sums": np.vstack([np.tril(np.ones((n, n))), np.tril(np.ones((n, n)), -1)]),
        "suffix_sums": np.triu(np.ones((n, n))),
        "differences": np.vstack([np.zeros((1, n)), (np.eye(n) - np.eye(n, k=-1))[1:]]),
        "lower": spec.lower,
        "upper": spec.upper,
        "continuous": spec.continuous,
    }


def _origins(constants: dict[str, np.ndarray]) -> np.ndarray:
    """``(n, 4, 4)`` joint origins ``O'_i`` in the internal frames (base folded into the first)."""
    first = np.vstack([constants["first_cols"][:, :, 0].T, [0.0, 0.0, 0.0, 1.0]])
    return np.concatenate([first[None], np.swapaxes(constants["next_origins_t"], 1, 2)])


def _mix(matrix: Tensor, x: Tensor) -> Tensor:
    """Linear combination over joints: ``(k, n) @ (n, ..., B) -> (k, ..., B)`` as one GEMM.

    With triangular matrices of ones this gives cumulative sums over the chain.
    """
    return (matrix @ x.reshape(x.shape[0], -1)).view(matrix.shape[0], *x.shape[1:])


def _cross(a: Tensor, b: Tensor) -> Tensor:
    """Cross product of vectors stored along dim -2 (``(..., 3, B)``)."""
    a0, a1, a2 = a.unbind(-2)
    b0, b1, b2 = b.unbind(-2)
    return torch.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), dim=-2)


def _world_inertia_times(rot: Tensor, inertias: Tensor, v: Tensor) -> Tensor:
    """``R I R^T v`` for frames ``rot`` (n, 3 columns, 3 rows, B), local inertias (n, 3, 3), ``v`` (n, 3, k, B)."""
    local = (rot[:, :, :, None] * v[:, None]).sum(2)  # R^T v: (n, 3, k, B)
    local = torch.bmm(inertias, local.reshape(inertias.shape[0], 3, -1)).view(local.shape)
    return (rot[:, :, :, None] * local[:, :, None]).sum(1)


def _blockwise(fn, *batches: Tensor):
    """``fn(*batches)``; on the CPU, batches over ``_CPU_BLOCK_ROWS`` rows go through in blocks.

    Each block's working set then stays in cache (about 1.5 MB of frames in float64),
    which on a 2-core machine makes FK of 100 000 rows 2-3x faster than one pass.
    Outputs (a tensor or a tuple of tensors) are concatenated along the batch.
    """
    if batches[0].device.type != "cpu" or batches[0].shape[0] <= _CPU_BLOCK_ROWS:
        return fn(*batches)
    parts = [fn(*block) for block in zip(*(b.split(_CPU_BLOCK_ROWS) for b in batches))]
    if isinstance(parts[0], tuple):
        return tuple(torch.cat(outputs) for outputs in zip(*parts))
    return torch.cat(parts)


def _to_homogeneous(cols: Tensor) -> Tensor:
    """Column layout ``(..., 4, 3, B)`` -> homogeneous matrices ``(B, ..., 4, 4)``."""
    top = cols.movedim(-1, 0).transpose(-1, -2)  # (B, ..., 3, 4)
    bottom = cols.new_tensor([0.0, 0.0, 0.0, 1.0]).expand(*top.shape[:-2], 1, 4)
    return torch.cat((top, bottom), dim=-2)


class Robot:
    """Batched FK, Jacobian, inverse dynamics and IK for one :class:`RobotSpec`.

    Example::

        >>> from lfd.robots import load_robot
        >>> robot = load_robot("sawyer")
        >>> q = robot.home[None]                       # (1, 7) rad
        >>> robot.fk(q).shape                          # tool pose in the world
        torch.Size([1, 4, 4])
        >>> bool(robot.ik(robot.fk(q)).success[0])
        True
    """

    def __init__(self, spec: RobotSpec) -> None:
        if not isinstance(spec, RobotSpec):
            raise TypeError(f"Robot needs a RobotSpec, got {type(spec).__name__}")
        self.spec = spec
        self._numpy_constants = _compile(spec)
        self._program = ChainProgram(_origins(self._numpy_constants), self._numpy_constants["tool_t"].T)
        self._cache: dict[tuple[torch.device, torch.dtype], _Constants] = {}

    def __repr__(self) -> str:
        return f"Robot(name={self.name!r}, n_dof={self.n_dof})"

    # ------------------------------------------------------------------ properties
    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def n_dof(self) -> int:
        return self.spec.n_dof

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.spec.joint_names

    # Limits and the home pose are built once per robot (float64, CPU) and shared by every
    # caller: treat them as read-only (``.clone()`` before modifying one in place).
    @cached_property
    def lower(self) -> Tensor:
        """(n,) float64 lower position limits, rad (-pi for continuous joints)."""
        return torch.tensor(self.spec.lower)

    @cached_property
    def upper(self) -> Tensor:
        """(n,) float64 upper position limits, rad (pi for continuous joints)."""
        return torch.tensor(self.spec.upper)

    @cached_property
    def continuous(self) -> Tensor:
        """(n,) bool, joints without position limits."""
        return torch.tensor(self.spec.continuous)

    @cached_property
    def home(self) -> Tensor:
        """(n,) float64 named home pose, rad."""
        return torch.tensor(self.spec.home)

    @cached_property
    def velocity_limits(self) -> Tensor:
        """(n,) float64, rad/s."""
        return torch.tensor(self.spec.velocity_limits)

    @cached_property
    def effort_limits(self) -> Tensor:
        """(n,) float64, N m."""
        return torch.tensor(self.spec.effort_limits)

    # ------------------------------------------------------------------ helpers
    def _constants(self, like: Tensor) -> _Constants:
        key = (like.device, like.dtype)
        if key not in self._cache:
            tensors = {
                k: torch.tensor(
                    np.array(v), device=like.device, dtype=torch.bool if v.dtype == bool else like.dtype
                )
                for k, v in self._numpy_constants.items()
            }
            tensors["next_origins_t"] = tensors["next_origins_t"].unbind(0)
            self._cache[key] = _Constants(**tensors)
        return self._cache[key]

    def _batch(self, x, name: str = "q", like: Tensor | None = None) -> Tensor:
        return as_batch(x, name, self.n_dof, like=like, robot=self.name)

    def _chain(self, q: Tensor, keep_frames: bool) -> tuple[Tensor | None, Tensor]:
        """Internal joint frames ``(n, 4, 3, B)`` (None unless ``keep_frames``) and tool frame ``(4, 3, B)``,
        from the compiled sparse program (:mod:`lfd.robots.kernel`)."""
        frames, tool = self._program.run(q, keep_frames)
        return (torch.stack(frames) if keep_frames else None), tool

    @staticmethod
    def _jacobian_from(frames: Tensor, tool: Tensor) -> Tensor:
        """Geometric Jacobian ``(B, 6, n)`` from internal frames ``(n, 4, 3, B)`` and tool ``(4, 3, B)``."""
        z, origin = frames[:, 2], frames[:, 3]
        linear = _cross(z, tool[3] - origin)
        return torch.cat((linear, z), dim=1).permute(2, 1, 0)

    def kinematics(self, q) -> tuple[Tensor, Tensor]:
        """Tool pose ``(B, 4, 4)`` and geometric Jacobian ``(B, 6, n)`` from one pass over the chain.

        Same conventions as :meth:`fk` and :meth:`jacobian`; cheaper than calling both.
        """
        return _blockwise(self._kinematics, self._batch(q))

    def _kinematics(self, q: Tensor) -> tuple[Tensor, Tensor]:
        frames, tool = self._chain(q, keep_frames=True)
        return _to_homogeneous(tool), self._jacobian_from(frames, tool)

    # ------------------------------------------------------------------ kinematics
    def fk(self, q, all_links: bool = False) -> Tensor:
        """Forward kinematics in the world frame (base transform included).

        Args:
            q: (B, n) joint angles, rad.
            all_links: if False return the tool pose ``(B, 4, 4)``; if True return
                ``(B, n + 1, 4, 4)``: index ``i < n`` is the frame of link ``i`` (the
                child of joint ``i``, i.e. the joint frame after its rotation, as in
                the URDF and PyBullet's ``getLinkState(body, i)``), index ``n`` the tool.

        Returns:
            Homogeneous transforms (m), differentiable with respect to ``q``, in ``q``'s dtype
            (float32 for half-precision ``q``), computed outside autocast (mixed precision).
        """
        q = self._batch(q)
        if q.dtype not in (torch.float32, torch.float64):
            q = q.float()  # half precision keeps ~3 digits of an angle: mm at the tool
        device = q.device.type  # mixed precision: FK stays in q's dtype, outside autocast
        with torch.autocast(device, enabled=False) if torch.is_autocast_enabled(device) else nullcontext():
            if all_links:
                return _blockwise(self._fk_all_links, q)
            if q.requires_grad and torch.is_grad_enabled():
                return _blockwise(self._fk_tool, q)
            if q.device.type == "cpu":
                # NumPy asks for huge pages: no first-touch page fault per 4 kB of a large output
                out = torch.from_numpy(
                    np.empty((q.shape[0], 4, 4), dtype=str(q.dtype).removeprefix("torch."))
                )
            else:
                out = q.new_empty(q.shape[0], 4, 4)
            with torch.no_grad():
                self._program.tool_into(q, out)
            return out

    def fk_positions(self, q) -> Tensor:
        """Tool positions ``(..., 3)`` (m, world frame) of joint vectors ``q (..., n)`` (rad).

        Any number of leading dimensions (e.g. ``(B, T, n)`` trajectories), one FK call
        over all of them; NumPy input gives float64 tensors like :meth:`fk`.

        Example::

            >>> from lfd.robots import load_robot
            >>> robot = load_robot("sawyer")
            >>> robot.fk_positions(robot.home.expand(2, 5, 7)).shape
            torch.Size([2, 5, 3])
        """
        q = q if isinstance(q, Tensor) else torch.from_numpy(np.asarray(q, dtype=np.float64))
        if q.ndim == 0 or q.shape[-1] != self.n_dof:
            raise ValueError(
                f"q must have shape (..., {self.n_dof}) for robot {self.name!r}, got {tuple(q.shape)}"
            )
        return self.fk(q.reshape(-1, self.n_dof))[:, :3, 3].reshape(*q.shape[:-1], 3)

    def _fk_tool(self, q: Tensor) -> Tensor:
        return _to_homogeneous(self._chain(q, keep_frames=False)[1])

    def _fk_all_links(self, q: Tensor) -> Tensor:
        frames, tool = self._chain(q, keep_frames=True)
        c = self._constants(q)
        batch = q.shape[0]
        rotations = (c.axis_frames @ frames[:, :3].reshape(self.n_dof, 3, 3 * batch)).view(
            self.n_dof, 3, 3, batch
        )
        links = torch.cat((rotations, frames[:, 3:]), dim=1)
        return _to_homogeneous(torch.cat((links, tool[None])))

    def jacobian(self, q) -> Tensor:
        """Geometric Jacobian ``(B, 6, n)`` at the tool point, world frame.

        Rows 0..2 map joint velocities (rad/s) to the tool point's linear velocity
        (m/s), rows 3..5 to the tool's angular velocity (rad/s).
        """
        return _blockwise(self._jacobian, self._batch(q))

    def _jacobian(self, q: Tensor) -> Tensor:
        return self._jacobian_from(*self._chain(q, keep_frames=True))

    # ------------------------------------------------------------------ dynamics
    def inverse_dynamics(self, q, qd, qdd, gravity=(0.0, 0.0, -9.81)) -> Tensor:
        """Joint torques ``(B, n)`` (N m) by recursive Newton-Euler, fixed base.

        Args:
            q, qd, qdd: (B, n) joint positions (rad), velocities (rad/s) and
                accelerations (rad/s^2); ``qd`` and ``qdd`` take ``q``'s dtype/device.
            gravity: (3,) gravitational acceleration in the world frame, m/s^2.

        Link inertials are the spec's; the tool carries no mass.
        """
        q = self._batch(q)
        qd, qdd = self._batch(qd, "qd", like=q), self._batch(qdd, "qdd", like=q)
        if qd.shape != q.shape or qdd.shape != q.shape:
            raise ValueError(
                f"q, qd and qdd must have the same shape, got {[tuple(x.shape) for x in (q, qd, qdd)]}"
            )
        g = torch.as_tensor(gravity, dtype=q.dtype, device=q.device)
        if g.shape != (3,) or not bool(torch.isfinite(g).all()):
            raise ValueError(f"gravity must be 3 finite numbers, got {gravity!r}")
        return _blockwise(lambda *state: self._inverse_dynamics(*state, g), q, qd, qdd)

    def _inverse_dynamics(self, q: Tensor, qd: Tensor, qdd: Tensor, g: Tensor) -> Tensor:
        c = self._constants(q)
        n = self.n_dof
        frames, _ = self._chain(q, keep_frames=True)
        rot, z, origin = frames[:, :3], frames[:, 2], frames[:, 3]  # (n, 3, 3, B), (n, 3, B), (n, 3, B)
        batch = q.shape[0]

        # Forward recursion, world frame: angular velocity/acceleration (own and parent's).
        rate = z * qd.T[:, None]
        omega, omega_parent = _mix(c.prefix_sums, rate).split(n)
        alpha, alpha_parent = _mix(c.prefix_sums, z * qdd.T[:, None] + _cross(omega_parent, rate)).split(n)

        # Acceleration of points r fixed in a link, alpha x r + omega (omega . r) - r |omega|^2, for two
        # point sets at once (concatenated along the batch): each joint origin relative to its parent's
        # (carried by the parent link; summed along the chain) and each com relative to its joint origin.
        step = _mix(c.differences, origin)  # o_i - o_{i-1}, zero for the first joint
        com = torch.bmm(c.com_weights, frames.view(n, 4, -1)).view(n, 3, -1)  # com - o_i, world axes
        ang_acc = torch.cat((alpha_parent, alpha), dim=-1)
        ang_vel = torch.cat((omega_parent, omega), dim=-1)
        offset = torch.cat((step, com), dim=-1)
        centripetal = ang_vel * (ang_vel * offset).sum(1, keepdim=True) - offset * ang_vel.square().sum(
            1, keepdim=True
        )
        transport, spin = (_cross(ang_acc, offset) + centripetal).tensor_split([batch], dim=-1)
        acc_com = _mix(c.prefix_sums[:n], transport) - g[:, None] + spin

        # Newton-Euler wrench of each link, moments about the world origin.
        force = c.masses[:, None, None] * acc_com
        rates = torch.stack((alpha, omega), dim=2)
        inertia_alpha, inertia_omega = _world_inertia_times(rot, c.inertias, rates).unbind(2)
        gyro, com_moment = _cross(
            torch.cat((omega, origin + com), dim=-1), torch.cat((inertia_omega, force), dim=-1)
        ).tensor_split([batch], dim=-1)
        moment = inertia_alpha + gyro + com_moment

        # Backward recursion: sums over each subtree, moments then moved to each joint origin.
        joint_force, joint_moment = _mix(c.suffix_sums, torch.cat((force, moment), dim=1)).split(3, dim=1)
        return (z * (joint_moment - _cross(origin, joint_force))).sum(1).T

    # ------------------------------------------------------------------ limits
    def within_limits(self, q) -> Tensor:
        """(B,) bool: every non-continuous joint within ``[lower, upper]`` (inclusive)."""
        q = self._batch(q)
        c = self._constants(q)
        inside = (q >= c.lower) & (q <= c.upper)
        return (inside | c.continuous).all(dim=1)

    def clamp(self, q) -> Tensor:
        """(B, n): clamp non-continuous joints into their limits, wrap continuous ones into
        ``[lower, lower + 2 pi)`` (i.e. ``[-pi, pi)``). Differentiable where not clamped."""
        q = self._batch(q)
        c = self._constants(q)
        wrapped = c.lower + torch.remainder(q - c.lower, 2 * torch.pi)
        return torch.where(c.continuous, wrapped, torch.clamp(q, c.lower, c.upper))

    def sample_q(
        self,
        batch_size: int,
        generator: torch.Generator | None = None,
        dtype: torch.dtype = torch.float64,
        device: torch.device | str = "cpu",
    ) -> Tensor:
        """(batch_size, n) configurations uniform within ``[lower, upper]``, rad.

        Drawn on the CPU with ``generator`` (reproducible), then moved to ``device``.
        """
        u = torch.rand(batch_size, self.n_dof, generator=generator, dtype=torch.float64)
        q = self.lower + u * (self.upper - self.lower)
        return q.to(device=device, dtype=dtype)

    # ------------------------------------------------------------------ IK
    def ik(self, target, q0=None, **options) -> IKResult:
        """Batched inverse kinematics (Levenberg-Marquardt): :func:`lfd.robots.ik.solve_ik`
        with this robot; ``options`` (``position_only``, ``max_iters``, ``tol_pos``,
        ``tol_rot``, ``restarts``, ``restart_batch``, ``seed``) are passed on."""
        return solve_ik(self, target, q0, **options)

    # ------------------------------------------------------------------ URDF
    def to_urdf(self, path: str | os.PathLike | None = None) -> str:
        """URDF text of this robot; written atomically to ``path`` if given.

        Links: ``base_link`` (the world frame, base transform folded into the first
        joint), one child link per movable joint (``spec.link_names``) and a fixed
        ``tool_link``. In PyBullet joint indices ``0..n-1`` are the movable joints in
        chain order and index ``n`` is the tool joint, so ``getLinkState(body, n)`` is
        the tool frame. See :func:`lfd.robots.urdf.spec_to_urdf`.
        """
        text = spec_to_urdf(self.spec)
        if path is not None:
            write_text_atomic(Path(path), text)
        return text
