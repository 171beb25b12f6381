"""scripts/show_dataset.py draws a grid from a generated dataset."""

import importlib.util
from pathlib import Path

import pytest

from lfd.visuomotor.data import GeneratorConfig, generate_dataset

SCRIPT = Path(__file__).resolve().parents[3] / "scripts" / "show_dataset.py"


def load_script():
    spec = importlib.util.spec_from_file_location("show_dataset", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_show_dataset_writes_png(tmp_path):
    cfg = GeneratorConfig(
        seed=2,
        n_train_objects=2,
        n_train_placements=1,
        n_test_objects=1,
        n_test_placements=1,
        val_fraction=0.0,
        image_size=32,
        n_steps=20,
        n_basis=5,
    )
    generate_dataset(cfg, tmp_path / "ds", num_workers=1, progress=False)
    out = load_script().main([str(tmp_path / "ds"), "--out", str(tmp_path / "grid.png"), "--n", "3"])
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(SystemExit, match="no episodes in split 'val'"):
        load_script().main([str(tmp_path / "ds"), "--split", "val"])
