"""The default (quick-scale) dataset, generated in full (slow: about a minute per core)."""

import pytest

from lfd.visuomotor.data import ReachDataModule


@pytest.mark.slow
def test_quick_scale_dataset(tmp_path):
    # the defaults are configs/data/quick.yaml's, but for the held-out validation objects
    dm = ReachDataModule(
        name="quick", root=tmp_path, progress=False, n_val_objects=4, n_val_object_placements=3
    )
    dm.prepare_data()
    dm.setup()
    counts = dm.data.manifest["episodes"]
    # + 4 held-out validation objects x 3 placements
    assert counts == {"total": 228, "train": 156, "val": 48, "test": 24}
    discarded = sum(dm.data.manifest["discarded"].values())
    assert discarded / (counts["total"] + discarded) < 0.1
    assert max(float(e.arrays["final_error"]) for e in dm.data.episodes) < 0.01
    assert {e.obj.shape for e in dm.data.split("test")} == {"cylinder", "capsule", "sphere", "box"}
