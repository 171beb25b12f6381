"""GeneratorConfig validation and the episode plan."""

import pytest

from lfd.sim.objects import SIZE_SETS
from lfd.visuomotor.data import GeneratorConfig, plan_episodes


def test_validation_names_the_field():
    for kwargs, field in (
        ({"n_train_objects": 0}, "n_train_objects"),
        ({"image_size": 4}, "image_size"),
        ({"seed": -1}, "seed"),
        ({"val_fraction": 1.0}, "val_fraction"),
        ({"n_train_placements": 2, "val_fraction": 0.9}, "val_fraction"),
        ({"families": ("cylinder", "cone")}, "families"),
        ({"train_families": ()}, "train_families"),
        ({"train_families": ("box", "cube")}, "train_families"),
        ({"x_range": (0.7, 0.4)}, "x_range"),
        ({"duration": 0.0}, "duration"),
        ({"approach_fraction": 1.5}, "approach_fraction"),
        ({"wrist_camera": "yes"}, "wrist_camera"),
    ):
        with pytest.raises(ValueError, match=field):
            GeneratorConfig(**kwargs)
    with pytest.raises(ValueError, match="unknown keys"):
        GeneratorConfig.from_dict({"seed": 1, "colour": "red"})


def test_round_trip_and_canonical_types():
    cfg = GeneratorConfig(yaw_range_deg=[-90, 90], families=["box", "sphere"], tolerance=1)
    assert cfg == GeneratorConfig(
        yaw_range_deg=(-90.0, 90.0), families=("box", "sphere"), tolerance=0.01 * 100
    )
    assert GeneratorConfig.from_dict(cfg.to_dict()) == cfg
    assert (
        cfg.sha256()
        == GeneratorConfig(yaw_range_deg=(-90.0, 90.0), families=("box", "sphere"), tolerance=1.0).sha256()
    )
    assert cfg.sha256() != GeneratorConfig(seed=1).sha256()
    assert GeneratorConfig(duration=4.0, n_steps=101).control_dt == pytest.approx(0.04)


def test_plan_splits_by_placement_and_new_test_objects():
    cfg = GeneratorConfig(
        seed=4, n_train_objects=5, n_train_placements=10, n_test_objects=3, n_test_placements=4
    )
    plans = plan_episodes(cfg)
    assert plans == plan_episodes(cfg)  # deterministic
    assert [p.index for p in plans] == list(range(cfg.n_episodes)) == list(range(62))
    for j in range(5):
        mine = [p for p in plans if p.split != "test" and p.object_index == j]
        assert (
            len(mine) == 10 and sum(p.split == "val" for p in mine) == 2 and len({p.obj for p in mine}) == 1
        )
    test = [p for p in plans if p.split == "test"]
    assert len(test) == 12 and not {p.obj for p in test} & {p.obj for p in plans if p.split != "test"}
    assert [p.obj.shape for p in plans[::10][:4]] == ["cylinder", "capsule", "sphere", "box"]
    other = plan_episodes(GeneratorConfig(**{**cfg.to_dict(), "seed": 5}))
    assert [p.split for p in other] != [p.split for p in plans] or other[0].obj != plans[0].obj


def test_train_families_change_only_the_training_objects():
    """A training data mix (two boxes per round object here) leaves the held-out validation
    and test objects as they are, and a config without it keeps its old hash."""
    base = GeneratorConfig(
        seed=3,
        n_train_objects=6,
        n_train_placements=2,
        val_fraction=0.0,
        n_val_objects=4,
        n_val_object_placements=1,
        n_test_objects=4,
        n_test_placements=1,
    )
    mixed = GeneratorConfig(**{**base.to_dict(), "train_families": ["box", "cylinder", "box"]})
    assert "train_families" not in base.to_dict() and base.sha256() != mixed.sha256()
    assert GeneratorConfig.from_dict(mixed.to_dict()) == mixed
    plans, mixed_plans = plan_episodes(base), plan_episodes(mixed)
    for group in ("val", "test"):
        assert [p.obj for p in plans if p.group == group] == [p.obj for p in mixed_plans if p.group == group]
    shapes = [p.obj.shape for p in mixed_plans if p.group == "train"][::2]
    assert shapes == ["box", "cylinder", "box"] * 2
    assert [p.obj.shape for p in plans if p.group == "train"][::2] == [
        "cylinder",
        "capsule",
        "sphere",
        "box",
        "cylinder",
        "capsule",
    ]


@pytest.mark.parametrize("sizes", sorted(SIZE_SETS))
def test_validation_objects_outside_the_training_sizes(sizes):
    """``val_sizes="outside"``: every validation object has exactly one dimension outside its
    family's training range (in that dimension's band), the training and test objects do not
    change, and a config without the option keeps its old hash."""
    base = GeneratorConfig(
        sizes=sizes,
        seed=4,
        n_train_objects=4,
        n_train_placements=2,
        val_fraction=0.0,
        n_val_objects=40,
        n_val_object_placements=1,
        n_test_objects=4,
        n_test_placements=1,
    )
    outside = GeneratorConfig(**{**base.to_dict(), "val_sizes": "outside"})
    assert "val_sizes" not in base.to_dict() and base.sha256() != outside.sha256()
    assert ("sizes" in base.to_dict()) is (sizes != "classic")  # classic configs keep their hash
    assert GeneratorConfig.from_dict(outside.to_dict()) == outside
    plans, out_plans = plan_episodes(base), plan_episodes(outside)
    for group in ("train", "test"):
        assert [p.obj for p in plans if p.group == group] == [p.obj for p in out_plans if p.group == group]
    below = above = 0
    for p in (p for p in out_plans if p.group == "val"):
        ranges, bands = SIZE_SETS[sizes].inside[p.obj.shape], SIZE_SETS[sizes].outside[p.obj.shape]
        out = [k for k, (d, (lo, hi)) in enumerate(zip(p.obj.dims, ranges, strict=True)) if not lo <= d <= hi]
        assert len(out) == 1, (p.obj.name, p.obj.dims)
        d = p.obj.dims[out[0]]
        assert any(lo <= d <= hi for lo, hi in bands[out[0]]), (p.obj.name, d)
        below, above = below + (d < ranges[out[0]][0]), above + (d > ranges[out[0]][1])
    assert below >= 10 and above >= 10  # both sides, over 40 objects
    assert all(  # inside: the original draws
        all(
            lo <= d <= hi
            for d, (lo, hi) in zip(p.obj.dims, SIZE_SETS[sizes].inside[p.obj.shape], strict=True)
        )
        for p in plans
    )
    with pytest.raises(ValueError, match="GeneratorConfig.val_sizes: expected one of"):
        GeneratorConfig(**{**base.to_dict(), "val_sizes": "wider"})
    with pytest.raises(ValueError, match="GeneratorConfig.sizes: expected one of"):
        GeneratorConfig(**{**base.to_dict(), "sizes": "huge"})
