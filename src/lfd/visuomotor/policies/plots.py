"""Validation figures of the policies (TensorBoard sample plots)."""

from __future__ import annotations

import math

import numpy as np
import torch


def joint_figure(
    t: np.ndarray, predicted: np.ndarray, demonstrated: np.ndarray, title: str, ylabel: str = "rad"
):
    """Figure with one panel per joint: ``predicted`` vs ``demonstrated`` ``(T, n)`` over ``t (T,)`` s."""
    import matplotlib.pyplot as plt

    n = predicted.shape[1]
    cols = 4
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.4 * rows), sharex=True, squeeze=False)
    for j, ax in enumerate(axes.flat):
        if j >= n:
            ax.axis("off")
            continue
        ax.plot(t, demonstrated[:, j], "k-", lw=1.5, label="demonstrated")
        ax.plot(t, predicted[:, j], "r--", lw=1.5, label="predicted")
        ax.set_title(f"joint {j}", fontsize=9)
        ax.set_ylabel(ylabel, fontsize=8)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def log_sample_figure(module, batch: dict[str, torch.Tensor]) -> None:
    """``module.sample_figure(batch)`` to the first TensorBoard logger of ``module`` (a
    :class:`~lfd.visuomotor.policies.VisuomotorPolicy`) as ``val/sample``, on the global-zero
    rank only; nothing without a TensorBoard logger."""
    from lightning.pytorch.loggers import TensorBoardLogger

    tb = [lg for lg in module.loggers if isinstance(lg, TensorBoardLogger)]
    if not tb or not module.trainer.is_global_zero:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with torch.no_grad():
        fig = module.sample_figure(batch)
    tb[0].experiment.add_figure("val/sample", fig, global_step=module.global_step)
    plt.close(fig)
