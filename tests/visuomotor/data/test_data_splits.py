"""Split items come from streams keyed by (seed, group, object, placement), so
no experiment's test item is another experiment's training item -- compared by value
(geometry, colour, placement), never by name."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.visuomotor.data import GeneratorConfig, plan_episodes
from lfd.visuomotor.data.episodes import placement_rng
from lfd.visuomotor.data.fingerprint import training_overlap

QUICK = GeneratorConfig(
    seed=42,
    n_train_objects=12,
    n_train_placements=16,
    n_test_objects=4,
    n_test_placements=6,
    n_val_objects=4,
    n_val_object_placements=3,
)
ORIGINAL = GeneratorConfig(
    seed=42,
    n_train_objects=27,
    n_train_placements=22,
    n_test_objects=4,
    n_test_placements=10,
    n_val_objects=4,
    n_val_object_placements=6,
)


def values(obj) -> tuple:
    """An object by value: shape, dimensions, colour (rounded to 1e-9), no name."""
    return (obj.shape, *np.round(obj.dims, 9), *np.round(obj.rgba, 9))


def draws(cfg, plan, n: int = 3) -> set[tuple]:
    """The first ``n`` placements an episode may use (first try and retries)."""
    rng = placement_rng(cfg, plan)
    return {tuple(np.round(cfg.placement_ranges.sample(rng).as_array(), 9)) for _ in range(n)}


@pytest.mark.parametrize(("a", "b"), [(QUICK, ORIGINAL), (ORIGINAL, QUICK), (QUICK, QUICK)])
def test_no_test_or_val_object_is_a_training_object(a, b):
    train = {values(p.obj) for p in plan_episodes(b) if p.split == "train"}
    for p in plan_episodes(a):
        if p.group in ("val", "test"):
            assert values(p.obj) not in train, (p, "is a training object of the other experiment")
    # geometry alone (colour ignored) is distinct too
    train_geometry = {v[: 1 + len(v) - 5] for v in train}
    assert (
        not {values(p.obj)[: 1 + len(values(p.obj)) - 5] for p in plan_episodes(a) if p.group == "test"}
        & train_geometry
    )


@pytest.mark.parametrize(("a", "b"), [(QUICK, ORIGINAL), (ORIGINAL, QUICK)])
def test_no_test_placement_is_a_training_placement(a, b):
    train = set().union(*(draws(b, p) for p in plan_episodes(b) if p.split == "train"))
    for p in plan_episodes(a):
        if p.group == "test":
            assert not draws(a, p) & train
    # the audit's case: quick's first test episode and original's training episode of the same index differ now
    q = next(p for p in plan_episodes(QUICK) if p.split == "test")
    o = plan_episodes(ORIGINAL)[q.index]
    assert o.split == "train"
    assert not draws(QUICK, q) & draws(ORIGINAL, o)


def test_same_seed_same_test_items_across_experiments():
    """Test objects and placements are keyed by (group, object, placement): the two scales
    report on the same test objects (so their numbers compare), and on none of each other's
    training items."""
    q = [p for p in plan_episodes(QUICK) if p.group == "test"]
    o = {(p.object_index, p.placement_index): p for p in plan_episodes(ORIGINAL) if p.group == "test"}
    for p in q:
        assert values(p.obj) == values(o[(p.object_index, p.placement_index)].obj)
        assert draws(QUICK, p) == draws(ORIGINAL, o[(p.object_index, p.placement_index)])


def test_held_out_validation_objects_are_new():
    plans = plan_episodes(QUICK)
    val_objects = [p for p in plans if p.group == "val"]
    assert len(val_objects) == 12 and {p.split for p in val_objects} == {"val"}
    assert len({values(p.obj) for p in val_objects}) == 4
    assert {p.obj.shape for p in val_objects} == {"cylinder", "capsule", "sphere", "box"}
    assert [p.index for p in plans] == list(range(QUICK.n_episodes))
    assert plans[-1].group == "test"


def test_training_overlap_compares_values_not_names():
    from lfd.sim.objects import ObjectSpec, Placement

    plans = plan_episodes(QUICK)
    t = next(p for p in plans if p.split == "train")
    fp = {
        "train_objects": [
            {"name": t.obj.name, "shape": t.obj.shape, "dims": list(t.obj.dims), "rgba": list(t.obj.rgba)}
        ],
        "train_placements": [[0.5, 0.1, 0.2]],
    }
    renamed = ObjectSpec(t.obj.shape, t.obj.dims, t.obj.rgba, t.obj.mass, "my-own-can")
    hits = training_overlap(fp, [("case 0", renamed, Placement(0.6, 0.0, 0.0))])
    assert hits == [f"evaluation case case 0: object 'my-own-can' is training object '{t.obj.name}'"]
    hits = training_overlap(fp, [("case 1", plans[-1].obj, Placement(0.5, 0.1, 0.2))])
    assert len(hits) == 1 and "training placement #0" in hits[0]
    recoloured = ObjectSpec(t.obj.shape, t.obj.dims, (0.1, 0.2, 0.3, 1.0), t.obj.mass, "x")
    assert training_overlap(fp, [("case 2", recoloured, Placement(0.6, 0.0, 0.0))]) == []
    assert training_overlap(None, [("case 3", renamed, Placement(0.5, 0.1, 0.2))]) == []
