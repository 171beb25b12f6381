"""Object specs, families and placements."""

import math

import numpy as np
import pytest

from lfd.sim.approach import SIDE_MIN_HEIGHT
from lfd.sim.objects import (
    FAMILY_SIZES,
    MASS_RANGE,
    SATURATION_RANGE,
    SHAPES,
    SIZE_SETS,
    VALUE_RANGE,
    ObjectSpec,
    PlacementRanges,
    SizeRanges,
    _hsv_to_rgb,
    sample_object,
    sample_objects,
)
from lfd.sim.scene import TABLE_RGBA


def test_spec_validation_names_the_field():
    with pytest.raises(ValueError, match="shape"):
        ObjectSpec("cone", (0.1,), (1, 0, 0, 1), 0.2)
    with pytest.raises(ValueError, match="dims"):
        ObjectSpec("box", (0.1, 0.1), (1, 0, 0, 1), 0.2)
    with pytest.raises(ValueError, match="radius"):
        ObjectSpec("sphere", (-0.1,), (1, 0, 0, 1), 0.2)
    with pytest.raises(ValueError, match="rgba"):
        ObjectSpec("sphere", (0.1,), (1, 0, 0), 0.2)
    with pytest.raises(ValueError, match="mass"):
        ObjectSpec("sphere", (0.1,), (1, 0, 0, 1), 0.0)


@pytest.mark.parametrize(
    ("shape", "dims", "height", "round_"),
    [
        ("cylinder", (0.03, 0.1), 0.1, True),
        ("capsule", (0.02, 0.1), 0.14, True),
        ("sphere", (0.04,), 0.08, True),
        ("box", (0.05, 0.06, 0.07), 0.07, False),
    ],
)
def test_height_and_roundness(shape, dims, height, round_):
    spec = ObjectSpec(shape, dims, (0.5, 0.5, 0.5, 1.0), 0.3)
    assert spec.height == pytest.approx(height)
    assert spec.round is round_
    assert ObjectSpec.from_dict(spec.to_dict()) == spec


def test_families_are_seeded_and_cycle():
    a = sample_objects(np.random.default_rng(3), 9, prefix="train")
    b = sample_objects(np.random.default_rng(3), 9, prefix="train")
    assert a == b
    assert [o.shape for o in a[:4]] == list(SHAPES)
    assert a[0].name == "train-00-cylinder"
    assert len({o.rgba for o in a}) == 9


def test_sample_object_is_valid_for_every_shape():
    rng = np.random.default_rng(0)
    for shape in SHAPES:
        for _ in range(20):
            spec = sample_object(rng, shape)
            assert spec.shape == shape
            assert math.dist(spec.rgba[:3], TABLE_RGBA[:3]) >= 0.2  # visible against the table


def test_generator_covers_what_users_bring():
    """Thin tall cans to squat jars, flat bricks to cubes, dark and pale colours."""
    rng = np.random.default_rng(5)
    cyl = [sample_object(rng, "cylinder") for _ in range(300)]
    boxes = [sample_object(rng, "box") for _ in range(300)]
    aspect = [o.dims[1] / (2 * o.dims[0]) for o in cyl]  # height / diameter
    assert min(aspect) < 0.9 and max(aspect) > 4.0
    assert min(o.dims[2] for o in boxes) < 0.03 and max(o.dims[2] for o in boxes) > 0.12
    assert any(max(abs(a - b) for a, b in zip(o.dims[:2], o.dims[1:])) < 0.01 for o in boxes)  # near-cubes
    value = [max(o.rgba[:3]) for o in cyl + boxes]
    spread = [max(o.rgba[:3]) - min(o.rgba[:3]) for o in cyl + boxes]
    assert min(value) < 0.25 and max(value) > 0.95  # dark and bright
    assert any(v > 0.85 and s < 0.15 for v, s in zip(value, spread))  # pale


def test_placement_ranges_sample_within_bounds():
    ranges = PlacementRanges()
    rng = np.random.default_rng(1)
    pts = np.array([ranges.sample(rng).as_array() for _ in range(200)])
    assert pts[:, 0].min() >= 0.45 and pts[:, 0].max() <= 0.70
    assert pts[:, 1].min() >= -0.30 and pts[:, 1].max() <= 0.30
    assert np.abs(pts[:, 2]).max() <= math.pi / 2
    with pytest.raises(ValueError, match="PlacementRanges.x"):
        PlacementRanges(x=(0.7, 0.4))


@pytest.mark.parametrize("sizes", sorted(SIZE_SETS))
def test_size_sets_are_honoured_and_seeded(sizes):
    """Every draw lies in its set's training ranges, draws repeat with the seed, and the
    ranges are reached at both ends."""
    ranges = SIZE_SETS[sizes].inside
    for shape in SHAPES:
        a = [sample_object(np.random.default_rng([1, i]), shape, sizes=sizes) for i in range(300)]
        b = [sample_object(np.random.default_rng([1, i]), shape, sizes=sizes) for i in range(300)]
        assert a == b
        dims = np.array([o.dims for o in a])
        for k, (lo, hi) in enumerate(ranges[shape]):
            assert lo <= dims[:, k].min() < lo + 0.1 * (hi - lo), (shape, k)
            assert hi - 0.1 * (hi - lo) < dims[:, k].max() <= hi, (shape, k)
    with pytest.raises(ValueError, match="sample_object: sizes must be one of"):
        sample_object(np.random.default_rng(0), "box", sizes="huge")


def test_wide_sizes_cover_users_tables_and_the_approach_boundary():
    """1.5 to 26 cm, pens to plates, and round objects on both sides of the side/top
    boundary, drawn densely near it."""
    rng = np.random.default_rng(2)
    objs = {s: [sample_object(rng, s, sizes="wide") for _ in range(1000)] for s in SHAPES}
    uniform_draws = SizeRanges(SIZE_SETS["wide"].inside, SIZE_SETS["wide"].outside, {})
    with pytest.MonkeyPatch.context() as mp:  # the same ranges without the boundary draws
        mp.setitem(SIZE_SETS, "uniform", uniform_draws)
        objs_uniform = {s: [sample_object(rng, s, sizes="uniform") for _ in range(1000)] for s in SHAPES}
    heights = [o.height for group in objs.values() for o in group]
    assert min(heights) < 0.02 and max(heights) > 0.25
    assert min(o.dims[0] for o in objs["cylinder"]) < 0.013  # pen-thin
    for shape, top_share in (("cylinder", 0.15), ("sphere", 0.15), ("capsule", 0.04)):
        h = np.array([o.height for o in objs[shape]])
        top, side = (h < SIDE_MIN_HEIGHT).mean(), (h >= SIDE_MIN_HEIGHT).mean()
        assert top > top_share and side > 0.5, shape
        near = (np.abs(h - SIDE_MIN_HEIGHT) < 0.015).mean()
        uniform = (np.abs(np.array([o.height for o in objs_uniform[shape]]) - SIDE_MIN_HEIGHT) < 0.015).mean()
        assert near > 1.4 * uniform, (shape, near, uniform)  # denser than a uniform draw (1.6-3x measured)
    # every box fits the gripper: a horizontal side <= 8.5 cm
    assert all(min(o.dims[:2]) <= 0.085 for o in objs["box"])


def _at_ends(d: np.ndarray, lo: float, hi: float, fraction: float) -> float:
    """Share of ``d`` within ``fraction`` of the range ``[lo, hi]`` from either end."""
    return float(((d < lo + fraction * (hi - lo)) | (d > hi - fraction * (hi - lo))).mean())


def test_wide_edges_are_denser_at_the_ends_and_keep_the_objects_outside():
    """``wide_edges``: the same ranges as ``wide``, each end's 15 % drawn about 1.3-1.5 times as
    often as a uniform draw puts there; its objects outside the ranges (validation) are ``wide``'s,
    draw for draw, and ``wide`` itself draws as a set without edges does."""
    lo_hi = SIZE_SETS["wide"].inside
    chance, fraction = SIZE_SETS["wide_edges"].edges
    assert (
        SIZE_SETS["wide_edges"].inside == lo_hi
        and SIZE_SETS["wide_edges"].outside == SIZE_SETS["wide"].outside
    )
    for shape in SHAPES:
        edge = np.array(
            [
                sample_object(np.random.default_rng([4, i]), shape, sizes="wide_edges").dims
                for i in range(3000)
            ]
        )
        wide = np.array(
            [sample_object(np.random.default_rng([4, i]), shape, sizes="wide").dims for i in range(3000)]
        )
        for k, (lo, hi) in enumerate(lo_hi[shape]):
            if shape in SIZE_SETS["wide"].boundary and SIZE_SETS["wide"].boundary[shape][1] == k:
                continue  # the boundary band moves this dimension's uniform share
            # uniform: 2 x 15 % = 30 %; edges add chance / (number of dimensions) of the draws
            expected = 2 * fraction + chance / len(lo_hi[shape]) * (1 - 2 * fraction)
            assert abs(_at_ends(wide[:, k], lo, hi, fraction) - 2 * fraction) < 0.035, (shape, k)
            assert abs(_at_ends(edge[:, k], lo, hi, fraction) - expected) < 0.035, (shape, k, expected)
        for i in range(50):
            a = sample_object(np.random.default_rng([5, i]), shape, outside=True, sizes="wide")
            assert a == sample_object(np.random.default_rng([5, i]), shape, outside=True, sizes="wide_edges")


def test_classic_sizes_draw_as_before():
    """The classic set draws exactly what the generator drew before size sets existed (its
    random stream is unchanged, so every earlier dataset's objects are reproduced)."""
    rng, ref = np.random.default_rng(9), np.random.default_rng(9)
    for shape in SHAPES * 3:
        obj = sample_object(rng, shape)
        dims = tuple(float(ref.uniform(lo, hi)) for lo, hi in FAMILY_SIZES[shape])
        while True:  # the colour draw, as sample_object makes it
            hsv = ref.uniform(0, 1), ref.uniform(*SATURATION_RANGE), ref.uniform(*VALUE_RANGE)
            rgb = _hsv_to_rgb(*(float(v) for v in hsv))
            if math.dist(rgb, TABLE_RGBA[:3]) >= 0.2:
                break
        ref.uniform(*MASS_RANGE)
        assert obj.dims == dims and obj.rgba[:3] == rgb
