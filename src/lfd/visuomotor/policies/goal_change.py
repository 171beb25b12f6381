"""Online goal change of a DMP plan (Ijspeert et al. 2013) in closed form: the transformation system's
free response and the response to a goal step, for :meth:`CNNDMPPolicy.change_goal
<lfd.visuomotor.policies.cnn_dmp.CNNDMPPolicy.change_goal>`. ``layer`` is the plan's
:class:`lfd.dmp.DMPLayer`, ``dt`` its sample spacing, s."""

from __future__ import annotations

import numpy as np
import torch

from lfd.dmp import DMP, DMPLayer, DMPRunner, DMPState
from lfd.dmp.transform import substeps


def free_response(layer: DMPLayer, dt: float, offset, rate, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """The DMP transformation system's homogeneous solution sampled every ``dt`` s
    from position ``offset`` ``(n,)`` and velocity ``rate`` ``(n,)`` (per second):
    ``tau^2 h'' = -alpha_z beta_z h - alpha_z tau h'`` with ``layer``'s gains and ``tau``
    (exact, through the 2 x 2 system's matrix exponential). Returns positions and velocities,
    each ``(n_samples, n)`` float64."""
    from scipy.linalg import expm

    gains, tau = layer.gains, float(layer.tau)
    system = np.array([[0.0, 1.0], [-gains.alpha_z * gains.beta_z / tau**2, -gains.alpha_z / tau]])
    step = expm(system * dt)
    state = np.stack([np.asarray(offset, np.float64), np.asarray(rate, np.float64)])  # (2, n)
    out = np.empty((2, n_samples, state.shape[1]))
    for i in range(n_samples):
        out[:, i] = state
        state = step @ state
    return out[0], out[1]


@torch.inference_mode()
def goal_step_response(layer: DMPLayer, dt: float, change, weights, step: int, n_samples: int) -> np.ndarray:
    """How a goal change ``change`` ``(n,)`` / ``(B, n)`` at sample ``step`` moves samples
    ``step .. n_samples - 1`` of ``layer``'s DMP (``n_samples`` of them): ``(n_samples - step, n)`` /
    ``(B, n_samples - step, n)`` (the first row zero), float64.

    It is the DMP started at rest at zero at that sample's phase ``s_k``, with goal ``change``
    and the forcing change of :mod:`lfd.dmp.formulation`:

    * ``"pastor"``: ``- K change s`` (zero weights). As ``s = s_k s'`` with ``s'`` the phase
      of a DMP started at the switch, this is, per DoF, ``change`` times the DMP from 0 to 1
      with all weights ``1 - s_k`` from its start: one closed-form rollout of ``layer`` in float64, whatever ``step``.
    * ``"ijspeert"``: ``f(s) change`` (the same ``weights`` ``(n, K)`` / ``(B, n, K)``),
      stepped with :class:`lfd.dmp.DMPRunner` on the closed form's sub-steps.
    """
    rest = n_samples - step
    change = np.asarray(change, dtype=np.float64)
    device = next(iter(layer.buffers()), torch.zeros(())).device
    if layer.formulation == "pastor":
        phase = float(np.exp(-layer.gains.alpha_s * step * dt / layer.tau))
        one = torch.ones(1, 1, dtype=torch.float64, device=device)
        weights_k = torch.full((1, 1, layer.n_basis), 1.0 - phase, dtype=torch.float64, device=device)
        unit = layer(torch.zeros_like(one), one, weights_k)[0, :rest, 0].cpu().numpy()
        return unit[:, None] * change[..., None, :]
    gains, zero = layer.gains, np.zeros_like(change)
    dmp = DMP(
        n_basis=layer.n_basis,
        alpha_z=gains.alpha_z,
        beta_z=gains.beta_z,
        alpha_s=gains.alpha_s,
        overlap=gains.overlap,
        formulation=layer.formulation,
    )
    runner = DMPRunner(
        dmp, y0=zero, goal=change, tau=layer.tau, weights=weights, yd0=zero, substeps=substeps(dt / layer.tau)
    )
    runner.reset(DMPState(zero, zero, step * dt))
    return np.stack([zero] + [runner.step(dt).y for _ in range(rest - 1)], axis=-2)
