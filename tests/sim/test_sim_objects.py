"""Object specs, families and placements."""

import math

import numpy as np
import pytest

from lfd.sim.objects import SHAPES, ObjectSpec, PlacementRanges, sample_object, sample_objects
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
