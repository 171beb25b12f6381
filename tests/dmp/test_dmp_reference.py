"""Same-data comparison with movement_primitives 0.9.1: reproduction no worse at equal n_basis."""

import numpy as np
import pytest
from dmp_helpers import lasa_demo, rmse, smooth_demo
from movement_primitives.dmp import DMP as ReferenceDMP

from lfd.dmp import DMP


def reference_reproduction(t, y, n_basis):
    """movement_primitives.dmp.DMP: imitate then open-loop rollout on the demo's own step."""
    dmp = ReferenceDMP(
        n_dims=y.shape[1], execution_time=t[-1] - t[0], dt=t[1] - t[0], n_weights_per_dim=n_basis
    )
    dmp.imitate(t - t[0], y)
    dmp.configure(start_y=y[0], goal_y=y[-1])
    _, positions = dmp.open_loop()
    return positions[: len(t)]


def demos():
    rng = np.random.default_rng(11)
    cases = {name: lasa_demo(name) for name in ("Angle", "CShape", "GShape", "Sshape", "Snake", "Khamesh")}
    for i in range(2):  # the visuomotor setting: 7 joints, 4 s, 100 steps
        cases[f"synthetic{i}"] = smooth_demo(rng, 100, 7, duration=4.0)
    return cases


@pytest.mark.parametrize("n_basis", [20, 50])
def test_reproduction_no_worse_than_movement_primitives(n_basis):
    ratios = {}
    for name, (t, y) in demos().items():
        ours = DMP(n_basis).fit(t, y).rollout(t=t)
        theirs = reference_reproduction(t, y, n_basis)
        n = min(len(theirs), len(y))
        ratios[name] = rmse(ours[:n], y[:n]) / rmse(theirs[:n], y[:n])
    assert max(ratios.values()) <= 1.0, ratios
