"""Forward model of an arm: joint angles -> end-effector position, a residual MLP (thesis ch. 5).

Inputs are the joint angles normalised to ``[-1, 1]`` over the joint limits plus their
sines and cosines (the forward kinematics is a polynomial in those); outputs are
positions normalised by the mean and standard deviation of the end-effector position over
the joint ranges.

With ``yaw_equivariant`` (the default) the model uses the one symmetry every serial arm
has: turning the first joint by ``q0`` rotates the whole arm rigidly about that joint's
axis. The MLP sees ``q1 .. q_{n-1}`` only and predicts the position in the frame that
turns with joint 0; the prediction is then rotated by ``q0`` about the axis (Rodrigues'
formula; the axis and a point on it come from the robot model at ``q = 0``). This removes
one input dimension (docs/decisions.md); the network still learns the rest of the
kinematics from samples. ``yaw_equivariant=False`` gives the plain MLP on all joints. Both
normalisations are buffers computed from the robot model, so a checkpoint loads on its own.
Errors are reported in millimetres against the robot's forward kinematics: mean, median,
99th percentile and maximum of the Euclidean distance.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import lightning as L
import torch
from torch import Tensor, nn

from lfd.robots import load_robot
from lfd.training import make_activation, make_optimizer, save_own_hyperparameters

__all__ = [
    "ForwardModel",
    "ResidualMLP",
    "error_summary",
    "format_error_table",
    "position_errors_mm",
    "report_test_errors",
]

#: Samples of the robot's workspace used to normalise the forward model's outputs.
_OUTPUT_STATS_SAMPLES = 65_536


def position_errors_mm(predicted: Tensor, target: Tensor) -> Tensor:
    """Euclidean distances ``(B,)`` in millimetres between positions ``(B, 3)`` given in metres."""
    if predicted.shape != target.shape or predicted.shape[-1] != 3:
        raise ValueError(
            f"position_errors_mm: need two (B, 3) arrays, got {tuple(predicted.shape)} and {tuple(target.shape)}"
        )
    return 1000.0 * (predicted - target).norm(dim=-1)


def error_summary(errors_mm: Tensor) -> dict[str, float]:
    """``{"mean", "median", "p99", "max"}`` (mm) of errors ``(N,)`` in millimetres, and ``"n"``."""
    e = errors_mm.detach().double().flatten()
    if e.numel() == 0:
        raise ValueError("error_summary: no errors to summarise")
    return {
        "mean": float(e.mean()),
        "median": float(e.median()),
        "p99": float(torch.quantile(e, 0.99)),
        "max": float(e.max()),
        "n": int(e.numel()),
    }


def format_error_table(summary: dict[str, float], title: str = "forward model error (mm)") -> str:
    """Markdown table of an :func:`error_summary`."""
    return (
        f"{title}, {summary['n']} held-out configurations\n\n"
        "| mean | median | p99 | max |\n|---:|---:|---:|---:|\n"
        f"| {summary['mean']:.2f} | {summary['median']:.2f} | {summary['p99']:.2f} | {summary['max']:.2f} |"
    )


class _Block(nn.Module):
    """Pre-norm residual block ``x + W2 act(W1 LayerNorm(x))``."""

    def __init__(self, width: int, act: str) -> None:
        super().__init__()
        self.body = nn.Sequential(
            nn.LayerNorm(width), nn.Linear(width, width), make_activation(act), nn.Linear(width, width)
        )

    def forward(self, x: Tensor) -> Tensor:
        return x + self.body(x)


class ResidualMLP(nn.Sequential):
    """``in_dim -> width -> n_blocks`` residual blocks ``-> LayerNorm, act -> out_dim``."""

    def __init__(self, in_dim: int, out_dim: int, width: int, n_blocks: int, act: str) -> None:
        super().__init__(
            nn.Linear(in_dim, width),
            *(_Block(width, act) for _ in range(n_blocks)),
            nn.LayerNorm(width),
            make_activation(act),
            nn.Linear(width, out_dim),
        )


class ForwardModel(L.LightningModule):
    """Joint angles ``(B, n)`` (rad) -> end-effector position ``(B, 3)`` (m).

    Trains on batches ``(q, x)``; logs ``train/loss``, ``val/loss`` and ``{train,val}/err_mm``
    (mean error, mm); ``test`` logs ``test/err_mm_{mean,median,p99,max}`` and prints the table.

    Args:
        robot: robot name (:func:`lfd.robots.load_robot`), for the joint limits and the
            output normalisation.
        width, n_blocks: residual MLP size.
        activation: hidden activation (``silu``, ``gelu``, ``relu``, ``tanh``, ``sigmoid``).
        sincos: add ``sin q``, ``cos q`` to the normalised angles.
        yaw_equivariant: predict in the frame turning with joint 0 and rotate by ``q0``
            about its axis (see the module docstring); False: plain MLP of all joints.
        lr, weight_decay: AdamW settings (``lr`` is the peak of the one-cycle schedule).
        scheduler: ``"onecycle"``, ``"cosine"`` or ``"none"``.
        pct_start: fraction of the one-cycle schedule spent warming up.
    """

    def __init__(
        self,
        robot: str = "sawyer",
        width: int = 256,
        n_blocks: int = 4,
        activation: str = "silu",
        sincos: bool = True,
        yaw_equivariant: bool = True,
        lr: float = 2e-3,
        weight_decay: float = 0.0,
        scheduler: str = "onecycle",
        pct_start: float = 0.15,
    ) -> None:
        super().__init__()
        save_own_hyperparameters(self, locals())
        model = load_robot(robot)
        n = model.n_dof
        self.register_buffer("q_low", model.lower.float())
        self.register_buffer("q_high", model.upper.float())
        # joint 0's axis (unit, world frame) and a point on it: constant, joint 0 moves nothing before it
        zero = torch.zeros(1, n, dtype=torch.float64)
        self.register_buffer("axis", model.jacobian(zero)[0, 3:, 0].float())
        self.register_buffer("pivot", model.fk(zero, all_links=True)[0, 0, :3, 3].float())
        self.first = 1 if yaw_equivariant else 0  # first joint the MLP sees
        q = model.sample_q(_OUTPUT_STATS_SAMPLES, torch.Generator().manual_seed(0))
        x = self.to_model_frame(q.float(), model.fk(q)[:, :3, 3].float())
        self.register_buffer("x_mean", x.mean(0))
        self.register_buffer("x_std", x.std(0))
        m = n - self.first
        self.net = ResidualMLP(3 * m if sincos else m, 3, width, n_blocks, activation)
        self._test_errors: list[Tensor] = []

    def features(self, q: Tensor) -> Tensor:
        """MLP inputs ``(B, m)`` of joint angles ``q (B, n)``: the joints from :attr:`first` on."""
        q, low, high = q[:, self.first :], self.q_low[self.first :], self.q_high[self.first :]
        z = 2.0 * (q - low) / (high - low) - 1.0
        return torch.cat([z, torch.sin(q), torch.cos(q)], dim=-1) if self.hparams.sincos else z

    def _turn(self, angle: Tensor, x: Tensor) -> Tensor:
        """Rotate points ``x (B, 3)`` by ``angle (B,)`` rad about joint 0's axis (Rodrigues)."""
        a, v = self.axis, x - self.pivot
        cos, sin = torch.cos(angle)[:, None], torch.sin(angle)[:, None]
        return (
            self.pivot
            + v * cos
            + torch.cross(a.expand_as(v), v, dim=-1) * sin
            + a * (v @ a)[:, None] * (1.0 - cos)
        )

    def to_model_frame(self, q: Tensor, x: Tensor) -> Tensor:
        """World positions ``x (B, 3)`` in the frame the MLP predicts in (turning with joint 0
        when ``yaw_equivariant``, else the world frame)."""
        return self._turn(-q[:, 0], x) if self.first else x

    def _from_net(self, q: Tensor, y: Tensor) -> Tensor:
        x = y * self.x_std + self.x_mean
        return self._turn(q[:, 0], x) if self.first else x

    def forward(self, q: Tensor) -> Tensor:
        """End-effector positions ``(B, 3)`` (m) of joint angles ``q (B, n)`` (rad)."""
        q = torch.as_tensor(q, dtype=self.q_low.dtype, device=self.q_low.device)
        return self._from_net(q, self.net(self.features(q)))

    def loss(self, q: Tensor, x: Tensor) -> tuple[Tensor, Tensor]:
        """Mean squared error in normalised units (the MLP's frame) and the world-frame
        errors ``(B,)`` in mm."""
        predicted = self.net(self.features(q))
        loss = ((predicted - (self.to_model_frame(q, x) - self.x_mean) / self.x_std) ** 2).mean()
        with torch.no_grad():
            errors = position_errors_mm(self._from_net(q, predicted), x)
        return loss, errors

    def parameter_groups(self) -> list[dict[str, Any]]:
        hp = self.hparams
        return [{"params": list(self.parameters()), "lr": hp.lr, "weight_decay": hp.weight_decay}]

    def training_step(self, batch, batch_idx: int) -> Tensor:
        loss, errors = self.loss(*batch)
        self.log_dict({"train/loss": loss, "train/err_mm": errors.mean()}, prog_bar=True)
        return loss

    def validation_step(self, batch, batch_idx: int) -> None:
        loss, errors = self.loss(*batch)
        self.log_dict({"val/loss": loss, "val/err_mm": errors.mean()}, prog_bar=True)

    def test_step(self, batch, batch_idx: int) -> None:
        self._test_errors.append(self.loss(*batch)[1])

    def on_test_epoch_end(self) -> None:
        summary = report_test_errors(self, self._test_errors, "test/err_mm")
        self._test_errors = []
        print(format_error_table(summary))

    def configure_optimizers(self) -> dict[str, Any]:
        return make_optimizer(self, self.parameter_groups(), self.hparams.scheduler, self.hparams.pct_start)


def report_test_errors(module: L.LightningModule, errors: Iterable[Tensor], prefix: str) -> dict[str, float]:
    """Log ``<prefix>_{mean,median,p99,max}`` of the collected test errors (mm) and return the summary."""
    summary = error_summary(torch.cat(list(errors)))
    module.log_dict({f"{prefix}_{k}": v for k, v in summary.items() if k != "n"})
    return summary
