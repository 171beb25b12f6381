"""Suite-wide settings and fixtures.

torch's OpenMP threads busy-wait between parallel regions by default; on a small shared
machine (CI has 2 cores and the tests start worker processes) that stalls everything
else. Passive waiting must be chosen before torch loads its OpenMP runtime, hence here.

``compose(config_name, *overrides)`` composes the repository's Hydra configs the way the
entry points do (lightning-hydra-template's ``cfg_train`` / ``cfg_eval`` fixtures), with
``paths.root_dir`` in a fresh temporary folder unless an override sets it
(``paths.output_dir``: ``<root_dir>/run``).
"""

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from pathlib import Path

import numpy as np
import pytest

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
#: Overrides that shrink the reaching data and the visuomotor networks to seconds of CPU:
#: 2 training objects x 3 placements (1 of them validation), no test split, 32 px, 30 steps.
TINY_REACHING = (
    "data.n_train_objects=2",
    "data.n_train_placements=3",
    "data.val_fraction=0.34",
    "data.n_test_objects=0",
    "data.n_test_placements=0",
    "data.n_val_objects=4",  # explicit: every experiment sees the same tiny dataset
    "data.n_val_object_placements=3",
    "data.image_size=32",
    "data.n_steps=30",
    "data.batch_size=2",
    "data.progress=false",
    "model.channels=[4,4,4,8]",
    "model.hidden=[16,16]",
)


@pytest.fixture(scope="session")
def tiny_reaching() -> tuple[str, ...]:
    """:data:`TINY_REACHING`: overrides for a tiny reaching dataset (``data.name`` is the caller's)."""
    return TINY_REACHING


#: A tiny dataset with a test split, for the tests that train and evaluate through the entry points:
#: 2 training objects x 3 placements (1 of them validation), 1 test object x 2 placements, 32 px,
#: 30 steps, RGB (the data keys are explicit: an experiment may set its own).
TINY_DATA = (
    "data.name=tiny",
    "data.n_train_objects=2",
    "data.n_train_placements=3",
    "data.val_fraction=0.34",
    "data.n_test_objects=1",
    "data.n_test_placements=2",
    "data.depth=false",
    "data.n_val_objects=4",
    "data.n_val_object_placements=3",
    "data.image_size=32",
    "data.n_steps=30",
    "data.batch_size=4",
    "data.progress=false",
)


@pytest.fixture(scope="session")
def tiny_data() -> tuple[str, ...]:
    """:data:`TINY_DATA`: overrides for the tiny dataset with a test split (``data.name=tiny``)."""
    return TINY_DATA


@pytest.fixture(scope="session")
def compose(tmp_path_factory):
    """``compose(config_name, *overrides) -> DictConfig``: ``configs/<config_name>.yaml`` with
    the overrides (later ones win), its Hydra config set as the current run's, rooted in a
    new temporary folder (``paths.root_dir``; outputs in ``<root>/run``)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.hydra_config import HydraConfig

    def _compose(config_name: str, *overrides: str):
        root = tmp_path_factory.mktemp(config_name)
        GlobalHydra.instance().clear()
        with initialize_config_dir(config_dir=str(CONFIGS), version_base="1.3"):
            cfg = hydra_compose(
                config_name=config_name,
                overrides=[f"paths.root_dir={root}", "paths.output_dir=${paths.root_dir}/run", *overrides],
                return_hydra_config=True,
            )
        HydraConfig.instance().set_config(cfg)
        return cfg

    yield _compose
    GlobalHydra.instance().clear()


def _write_joint_state_bag(path: Path, kind: str, t, q, names, topic="/joint_states", t0=100.0) -> Path:
    """A JointState bag (``kind``: ros1, ros2, mcap) of ``q (T, n)`` named ``names``, stamped ``t0 + t``: joints
    in reverse order, a head pan (0.25 rad) after the first and a gripper at the end (joints a robot lacks),
    written by lfd's own :func:`lfd.io.rosbag.write_joint_states`."""
    from lfd.io.rosbag import write_joint_states

    q = np.asarray(q, dtype=np.float64)
    rev = list(range(len(names)))[::-1]
    order = rev[:1] + ["head_pan"] + rev[1:] + ["gripper"]
    labels = [names[i] if isinstance(i, int) else i for i in order]
    columns = np.stack([q[:, i] if isinstance(i, int) else np.full(len(q), 0.25) for i in order], axis=1)
    return write_joint_states(path, t, columns, labels, format=kind, topic=topic, t0=t0)


@pytest.fixture
def write_joint_state_bag():
    """``write(path, kind, t, q, names, topic="/joint_states", t0=100.0) -> path``: a ``sensor_msgs/JointState``
    bag written with rosbags' own writers (kind ros1, ros2 or mcap), joints in another order than ``names`` and
    two joints no robot here has (head_pan, gripper)."""
    return _write_joint_state_bag
