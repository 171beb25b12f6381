"""Shared fixtures of the format tests: one tiny lfd dataset (7 episodes, 64 px, 30 steps)
generated once, and its LeRobot v3.0 export (AV1, lerobot's default)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

REFERENCE = Path(__file__).resolve().parents[1] / "fixtures" / "lerobot_v3_reference"
#: Generator settings of the tiny dataset (also a valid ReachDataModule / Hydra data override set).
TINY = dict(
    seed=3,
    n_train_objects=2,
    n_train_placements=3,
    n_test_objects=1,
    n_test_placements=1,
    n_val_objects=0,  # configs/data/quick.yaml holds out 4 validation objects; the tiny set none
    n_val_object_placements=0,
    image_size=64,
    n_steps=30,
    n_basis=8,
)


@pytest.fixture(scope="session")
def tiny_params() -> dict:
    """The tiny dataset's generator settings (ReachDataModule keyword arguments)."""
    return dict(TINY)


@pytest.fixture(scope="session")
def tiny_root(tmp_path_factory) -> Path:
    """Folder holding the generated dataset ``tiny``."""
    from lfd.visuomotor.data import ReachDataModule

    root = tmp_path_factory.mktemp("formats")
    ReachDataModule(name="tiny", root=root, progress=False, num_gen_workers=1, **TINY).prepare_data()
    return root


@pytest.fixture(scope="session")
def tiny(tiny_root) -> Path:
    return tiny_root / "tiny"


@pytest.fixture(scope="session")
def tiny_lerobot(tiny, tmp_path_factory) -> Path:
    from lfd.interop import export_lerobot

    return export_lerobot(tiny, tmp_path_factory.mktemp("lerobot") / "tiny", progress=False)


@pytest.fixture()
def reference_copy(tmp_path) -> Path:
    """A writable copy of the lerobot-written reference dataset."""
    dst = tmp_path / "reference"
    shutil.copytree(REFERENCE, dst)
    for p in dst.rglob("*"):
        p.chmod(0o755 if p.is_dir() else 0o644)
    return dst
