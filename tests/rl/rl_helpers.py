"""Helpers of the PoWER tests (a module with its own name: ``from conftest import ...`` would find
whichever test folder's conftest was imported first)."""

import numpy as np


def quintic_demo(start, goal, n_steps: int = 200, duration: float = 4.0):
    """Minimum-jerk (quintic, zero end velocity/acceleration) joint trajectory: ``t (T,)``, ``y (T, D)``."""
    t = np.linspace(0.0, duration, n_steps)
    s = t / duration
    profile = 10 * s**3 - 15 * s**4 + 6 * s**5
    return t, np.asarray(start) + (np.asarray(goal) - np.asarray(start)) * profile[:, None]
