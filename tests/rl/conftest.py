"""Shared fixtures of the PoWER tests: small demonstrations and fitted DMPs."""

import numpy as np
import pytest
from rl_helpers import quintic_demo

from lfd.dmp import DMP

#: Sawyer start pose [0, -50, 0, 120, 0, 0, 0] deg and a demonstrated final configuration (rad).
SAWYER_START = np.deg2rad([0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0])
SAWYER_DEMO_GOAL = np.array([1.51, -2.17, 2.04, -0.70, 0.85, 1.38, 0.56])


@pytest.fixture(scope="session")
def sawyer():
    from lfd.robots import load_robot

    return load_robot("sawyer")


@pytest.fixture(scope="session")
def sawyer_dmp():
    """20-basis DMP of a 4 s, 200-sample demonstration from the Sawyer start pose."""
    return DMP(n_basis=20).fit(*quintic_demo(SAWYER_START, SAWYER_DEMO_GOAL))


@pytest.fixture(scope="session")
def line_dmp():
    """1-DoF DMP of a 1 s, 100-sample quintic from 0 to 1 rad."""
    return DMP(n_basis=20).fit(*quintic_demo([0.0], [1.0], n_steps=100, duration=1.0))
