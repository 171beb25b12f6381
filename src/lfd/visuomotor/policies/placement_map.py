"""The placement map of :class:`~lfd.visuomotor.policies.cnn_dmp.CNNDMPPolicy`: a fixed regression from
a scene's placement (object and goal positions) and the start state to a plan, fitted on the
training demonstrations.

- :func:`fit_ridge_kernel`: the affine ridge regression of targets on inputs plus a Gaussian-kernel
  ridge correction of its residuals (the map of the single DMP over the whole episode).
- :class:`SegmentedMap`: the same regression onto *two* DMPs, split where a discrete command (Meta-World's
  gripper) switches. Over a whole episode, demonstrations whose grasp comes at different times average to
  a dip towards the object that is too shallow and leaves too early; split at the switch, each segment's
  DMP goal is where the hand is when the command switches (a fixed offset from the object to grasp, which
  an affine map recovers exactly) and the second segment starts in step with the grasp. Its duration
  (the switch step) is regressed too. The switching dimension's new value is held back
  ``switch_delay`` steps: a position-controlled hand trails its plan by a few steps, a gripper command
  acts at once (docs/decisions.md).

Inputs are in the policy's normalised units ``(E, d)``; states ``(E, T, n)`` in the state's units.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from lfd.dmp import DMP

#: A state dimension that moves more than this in one control step switches (Meta-World's gripper
#: command jumps between -1, 0, 0.6 and 1; the hand moves at most 1 cm per step).
MIN_JUMP = 0.5
#: Steps at the start where a switch does not split (the reset's gripper state is not the expert's
#: first command: every Meta-World demonstration jumps at step 1).
SKIP_STEPS = 2
#: Most training demonstrations a checkpoint's segmented map may hold (a bound on what loading allocates).
MAX_CENTRES = 100_000


def gaussian_kernel(a: torch.Tensor, b: torch.Tensor, scale: float) -> torch.Tensor:
    """Gaussian kernel ``(A, B)`` of inputs ``(A, d)`` and ``(B, d)`` with length ``scale`` > 0."""
    return torch.exp(-torch.cdist(a, b.to(a.dtype)).square() / (2.0 * scale**2))


def fit_ridge_kernel(
    x: torch.Tensor, y: torch.Tensor, ridge: float, scale: float, kernel_ridge: float
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """Affine ridge regression of ``y (E, m)`` on ``x (E, d)`` (penalty ``ridge`` on the slopes, not the
    bias) and, with ``scale > 0``, the kernel ridge regression (penalty ``kernel_ridge``) of its residuals.

    Returns:
        ``(slopes (d, m), bias (m,), centres (E, d), coefficients (E, m))``; no centres (``E = 0``) when
        ``scale == 0``. The prediction is ``x @ slopes + bias + kernel(x, centres) @ coefficients``.
    """
    x_mean, y_mean = x.mean(0), y.mean(0)
    xc = x - x_mean
    a = torch.linalg.solve(xc.T @ xc + ridge * torch.eye(x.shape[1], dtype=x.dtype), xc.T @ (y - y_mean))
    bias = y_mean - x_mean @ a
    if scale <= 0:
        return a, bias, x[:0], y[:0]
    k = gaussian_kernel(x, x, scale)
    coefficients = torch.linalg.solve(k + kernel_ridge * torch.eye(len(k), dtype=k.dtype), y - (x @ a + bias))
    return a, bias, x, coefficients


def switch_steps(states: np.ndarray) -> np.ndarray | None:
    """The step of each demonstration ``(E, T, n)`` where a dimension first jumps by more than
    :data:`MIN_JUMP` (after :data:`SKIP_STEPS`), or None when some demonstration never does (nothing to
    split consistently). Later switches stay inside the second segment."""
    jumps = np.abs(np.diff(states, axis=1)).max(axis=2) > MIN_JUMP  # (E, T - 1): jump into step t + 1
    jumps[:, : SKIP_STEPS - 1] = False
    if not jumps.any(axis=1).all():
        return None
    return jumps.argmax(1) + 1


class SegmentedMap(nn.Module):
    """Placement -> two DMPs split at the demonstrations' first switch (module docstring).

    Args:
        n: state dimensions; n_basis: basis functions per dimension and segment; dt: control period, s.
        inputs: the normalised inputs' width ``d`` (placement and start state).
        scale, kernel_ridge: the regression's (:func:`fit_ridge_kernel`; ``ridge`` is :meth:`fit`'s).
        switch_delay: steps the switching dimension's new value waits at the boundary, >= 0.

    Empty (:attr:`fitted` False) until :meth:`fit` finds a consistent switch.
    """

    def __init__(
        self,
        n: int,
        n_basis: int,
        dt: float,
        scale: float,
        kernel_ridge: float,
        switch_delay: int,
        inputs: int,
    ) -> None:
        super().__init__()
        self.n, self.n_basis, self.dt, self.inputs = n, n_basis, dt, inputs
        self.scale, self.kernel_ridge, self.switch_delay = scale, kernel_ridge, switch_delay
        self.register_buffer("slopes", torch.zeros(0, 0, dtype=torch.float64))
        for name in ("bias", "mean", "std"):
            self.register_buffer(name, torch.zeros(0, dtype=torch.float64))
        self.register_buffer("centres", torch.zeros(0, 0, dtype=torch.float64))
        self.register_buffer("coefficients", torch.zeros(0, 0, dtype=torch.float64))
        self.register_buffer("second_length", torch.zeros((), dtype=torch.long))  # samples of segment 2's fit

    @property
    def fitted(self) -> bool:
        return self.bias.numel() > 0

    @property
    def size(self) -> int:
        """Regressed values per demonstration: two goals and weight sets and the switch step."""
        return 2 * (self.n + self.n * self.n_basis) + 1

    def _dmp(self) -> DMP:
        return DMP(n_basis=self.n_basis)

    def fit(self, x: torch.Tensor, states: np.ndarray, ridge: float) -> bool:
        """Fit on normalised inputs ``(E, d)`` and the demonstrations' states ``(E, T, n)`` (slope penalty
        ``ridge``); returns whether
        the demonstrations switch consistently (else the map stays empty)."""
        states = np.asarray(states, dtype=np.float64)
        steps = switch_steps(states)
        if steps is None:
            self._set(*(torch.zeros((0,) * k, dtype=torch.float64) for k in (2, 1, 2, 2, 1, 1)), 0)
            return False
        t_total = states.shape[1]
        length = t_total - int(steps.min())  # segment 2 of every demonstration, padded with its last state
        rows = []
        for s, c in zip(states, steps):
            first = s[: c + 1].copy()
            first[-1] = np.where(
                np.abs(s[c] - s[c - 1]) > MIN_JUMP, s[c - 1], s[c]
            )  # the switch starts segment 2
            second = np.pad(s[c:], ((0, length - (len(s) - c)), (0, 0)), mode="edge")  # held at its end
            a = self._dmp().fit(np.arange(c + 1) * self.dt, first)
            b = self._dmp().fit(np.arange(length) * self.dt, second)
            rows.append(np.concatenate([a.goal_, a.weights_.ravel(), [c], b.goal_, b.weights_.ravel()]))
        y = torch.as_tensor(np.stack(rows))
        mean, std = y.mean(0), y.std(0).clamp_min(1e-9)
        fit = fit_ridge_kernel(x.double(), (y - mean) / std, ridge, self.scale, self.kernel_ridge)
        self._set(*fit, mean, std, length)
        return True

    def _set(self, slopes, bias, centres, coefficients, mean, std, length: int) -> None:
        for name, value in zip(
            ("slopes", "bias", "centres", "coefficients", "mean", "std"),
            (slopes, bias, centres, coefficients, mean, std),
        ):
            setattr(self, name, value.detach().to(torch.float64).clone())
        self.second_length = torch.tensor(length, dtype=torch.long)

    def resize_for(self, state: dict, prefix: str) -> None:
        """Size the buffers to a checkpoint's ``state`` (keys ``prefix + name``) before it loads; a
        checkpoint without them keeps the map empty.

        Raises:
            ValueError: the checkpoint's buffers are not consistent (one line naming them).
        """
        shapes = {}
        for name, own in self._buffers.items():
            saved = state.setdefault(prefix + name, own)
            if not isinstance(saved, torch.Tensor) or saved.ndim != own.ndim:
                got = tuple(saved.shape) if isinstance(saved, torch.Tensor) else type(saved).__name__
                raise ValueError(
                    f"CNNDMPPolicy: the checkpoint's {prefix}{name} is {got}, expected {own.ndim} dims"
                )
            shapes[name] = tuple(saved.shape)
        m = shapes["bias"][0] if shapes["bias"] else 0
        length = state[prefix + "second_length"]
        if m and (
            m != self.size
            or shapes["slopes"][0] != self.inputs
            or shapes["centres"][1:] != (self.inputs,)
            or length.numel() != 1
            or not 2 <= int(length) <= MAX_CENTRES
            or shapes["mean"] != (m,)
            or shapes["std"] != (m,)
            or shapes["slopes"][1] != m
            or shapes["coefficients"][1:] != (m,)
            or shapes["centres"][0] != shapes["coefficients"][0]
            or shapes["centres"][0] > MAX_CENTRES
        ):
            raise ValueError(
                f"CNNDMPPolicy: the checkpoint's {prefix}* buffers do not form a map from {self.inputs} "
                f"to {self.size} values"
            )
        for name, shape in shapes.items():
            self._buffers[name] = torch.zeros(shape, dtype=self._buffers[name].dtype)

    def params(self, x: torch.Tensor) -> np.ndarray:
        """The regressed segment values ``(B, size)`` for normalised inputs ``(B, d)``."""
        x = x.double()
        y = x @ self.slopes + self.bias
        if self.centres.shape[0]:
            y = y + gaussian_kernel(x, self.centres, self.scale) @ self.coefficients
        return (y * self.std + self.mean).cpu().numpy()

    def plan(self, x: torch.Tensor, start: np.ndarray, n_steps: int) -> np.ndarray:
        """Plans ``(B, n_steps, n)`` from normalised inputs ``(B, d)`` and start states ``(B, n)``: segment 1
        from the start to its goal over the regressed switch step, segment 2 from there; past segment 2's
        duration its DMP converges to its goal."""
        n, k = self.n, self.n_basis
        one = n + n * k
        out = []
        for y, s0 in zip(self.params(x), np.asarray(start, dtype=np.float64).reshape(-1, n)):
            c = int(np.clip(round(float(y[one])), 2, n_steps - 1))
            a = self._dmp().rollout(
                t=np.arange(c + 1) * self.dt,
                y0=s0,
                goal=y[:n],
                tau=c * self.dt,
                weights=y[n:one].reshape(n, k),
            )
            g2, w2 = y[one + 1 : one + 1 + n], y[one + 1 + n :].reshape(n, k)
            switched = np.abs(g2 - a[-1]) > MIN_JUMP  # the switched dimension starts switched
            start2 = np.where(switched, g2, a[-1])
            length = int(self.second_length)
            b = self._dmp().rollout(
                t=np.arange(n_steps - c) * self.dt, y0=start2, goal=g2, tau=(length - 1) * self.dt, weights=w2
            )
            plan = np.concatenate([a[:-1], b])
            d = min(self.switch_delay, n_steps - c)
            if d:
                plan[c : c + d, switched] = a[-1, switched]
            out.append(plan)
        return np.stack(out)
