"""ReachDataModule: generation on prepare_data, item layouts, stats, augmentation, Hydra configs."""

from pathlib import Path

import numpy as np
import pytest
import torch
from hydra.utils import instantiate

from lfd.visuomotor.data import DatasetError, ReachDataModule

TINY = dict(
    seed=3,
    n_train_objects=2,
    n_train_placements=3,
    n_test_objects=1,
    n_test_placements=1,
    image_size=32,
    n_steps=30,
    n_basis=8,
    batch_size=4,
    progress=False,
    num_gen_workers=1,
)


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("data")
    dm = ReachDataModule(name="tiny", root=root, **TINY)
    dm.prepare_data()
    assert dm.generation_report.generated == list(range(7))
    return root


def test_dmp_items(root):
    dm = ReachDataModule(name="tiny", root=root, mode="dmp", **TINY)
    dm.prepare_data()  # verifies only
    assert dm.generation_report.generated == []
    dm.setup("fit")
    assert set(dm.datasets) == {"train", "val"}
    assert len(dm.datasets["train"]) == 4 and len(dm.datasets["val"]) == 2
    batch = next(iter(dm.train_dataloader()))
    shapes = {k: tuple(v.shape) for k, v in batch.items()}
    assert shapes == {
        "image": (4, 3, 32, 32),
        "joints": (4, 7),
        "goal": (4, 7),
        "weights": (4, 7, 8),
        "y0": (4, 7),
        "tau": (4,),
        "t": (4, 30),
        "trajectory": (4, 30, 7),
        "ee_path": (4, 30, 3),
        "target_point": (4, 3),
        "top": (4,),
        "index": (4,),
        "target_pixels": (4, 2),
    }
    # the target's pixel: where the default camera (PyBullet-checked in tests/sim) sees the target point
    from lfd.sim.camera import Camera

    seen = Camera(width=32, height=32).project(batch["target_point"].double().numpy())
    np.testing.assert_allclose(batch["target_pixels"].numpy(), seen, atol=1e-3)
    assert ((batch["target_pixels"] > 0) & (batch["target_pixels"] < 32)).all()  # placements lie in view
    # the approach-mode label matches each episode's record
    modes = [str(dm.data.episodes[int(i)].arrays["approach_mode"]) for i in batch["index"]]
    assert batch["top"].tolist() == [float(m == "top") for m in modes]
    assert (
        batch["image"].dtype == torch.float32 and batch["image"].min() >= 0.0 and batch["image"].max() <= 1.0
    )
    torch.testing.assert_close(batch["joints"], batch["trajectory"][:, 0])
    torch.testing.assert_close(batch["goal"], batch["trajectory"][:, -1])
    assert dm.stats["weights"]["mean"].shape == (7, 8) and dm.stats["joints"]["std"].shape == (7,)
    dm.setup("test")
    assert len(next(iter(dm.test_dataloader()))["index"]) == 1


def test_velocity_items_and_augmentation(root):
    dm = ReachDataModule(name="tiny", root=root, mode="velocity", augment=True, **TINY)
    dm.setup()
    assert len(dm.datasets["train"]) == 4 * 30 and len(dm.datasets["test"]) == 30
    item = dm.datasets["train"][31]
    assert item["step"] == 1 and item["image"].shape == (3, 32, 32)
    assert item["target_point"].shape == (3,) and item["top"].shape == ()
    torch.testing.assert_close(
        item["target_point"], dm.datasets["train"][30]["target_point"]
    )  # one per episode
    torch.manual_seed(0)
    augmented = torch.stack([dm.datasets["train"][31]["image"] for _ in range(2)])
    assert not torch.equal(augmented[0], augmented[1])
    plain = dm.datasets["val"][0]["image"]  # no augmentation outside training
    shifted = ReachDataModule(name="tiny", root=root, mode="dmp", augment=True, **TINY)
    shifted.setup("fit")  # shifted images: no pixel label for training, the label where nothing moves
    assert (
        "target_pixels" not in shifted.datasets["train"][0] and "target_pixels" in shifted.datasets["val"][0]
    )
    assert torch.equal(plain, dm.datasets["val"][0]["image"])
    batch = next(iter(dm.val_dataloader()))
    assert batch["velocity"].shape == (4, 7) and batch["t"].shape == (4,)


def test_errors(root):
    with pytest.raises(ValueError, match="mode"):
        ReachDataModule(name="tiny", root=root, mode="pixels", **TINY)
    with pytest.raises(ValueError, match="n_train_placements"):
        ReachDataModule(name="tiny", root=root, **{**TINY, "n_train_placements": 0})
    with pytest.raises(DatasetError, match="stale dataset"):
        ReachDataModule(name="tiny", root=root, **{**TINY, "seed": 4}).setup()
    with pytest.raises(DatasetError, match="not found"):
        ReachDataModule(name="missing", root=root, **TINY).setup()
    with pytest.raises(DatasetError, match="shard 0 of 2"):
        ReachDataModule(name="tiny", root=root, shard=0, num_shards=2, **TINY).setup()
    dm = ReachDataModule(name="tiny", root=root, **TINY)
    with pytest.raises(RuntimeError, match="setup"):
        dm.stats  # noqa: B018


@pytest.mark.parametrize(
    ("name", "train", "placements", "test"), [("quick", 12, 16, 4), ("original", 27, 22, 4)]
)
def test_hydra_configs_compose_and_instantiate(compose, tmp_path, name, train, placements, test):
    data = compose("train", f"data={name}", "seed=9", f"paths.data_dir={tmp_path}").data
    assert data._target_ == "lfd.visuomotor.data.ReachDataModule"
    assert (data.n_train_objects, data.n_train_placements, data.n_test_objects) == (train, placements, test)
    dm = instantiate(data, _convert_="all")
    assert isinstance(dm, ReachDataModule)
    assert dm.path == tmp_path / f"{name}_s9" and dm.config.seed == 9 and dm.mode == "dmp"


def test_train_objects_keeps_the_first_objects_and_recomputes_the_stats(root):
    full = ReachDataModule(name="tiny", root=root, mode="dmp", **TINY)
    full.setup()
    one = ReachDataModule(name="tiny", root=root, mode="dmp", train_objects=1, **TINY)
    one.setup()
    train_full, train_one = full.data.split("train"), one.data.split("train")
    first = min(e.object_index for e in train_full)
    # every placement of the first training object, nothing of the other
    assert [e.index for e in train_one] == [e.index for e in train_full if e.object_index == first]
    assert len(one.datasets["train"]) == len(train_one) < len(full.datasets["train"])
    # validation and test are the same episodes
    for split in ("val", "test"):
        assert [e.index for e in one.data.split(split)] == [e.index for e in full.data.split(split)]
    # statistics from the kept episodes (the full split's differ): the mean of their start joints
    joints = np.concatenate([e.arrays["joints"] for e in train_one])
    expected = torch.from_numpy(joints.mean(0)).float()
    torch.testing.assert_close(one.stats["joints"]["mean"], expected)
    assert not torch.allclose(one.stats["joints"]["mean"], full.stats["joints"]["mean"])
    with pytest.raises(ValueError, match=r"train_objects: expected an int in \[1, 2\]"):
        ReachDataModule(name="tiny", root=root, train_objects=3, **TINY).setup()
    with pytest.raises(ValueError, match="ReachDataModule.train_objects"):
        ReachDataModule(name="tiny", root=root, train_objects=0, **TINY)
