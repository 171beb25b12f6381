"""Objects to reach for: shape specs, randomised families and table placements.

Units: metres, kilograms, radians (degrees only in :class:`PlacementRanges`, which mirrors
the config). Placements are expressed in the robot base (torso) frame; the object stands
upright on the table, so a placement is a table position ``(x, y)`` plus a rotation
``yaw`` about the vertical axis.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

#: Shapes an :class:`ObjectSpec` may have, with the names of their ``dims`` entries.
SHAPE_DIMS: dict[str, tuple[str, ...]] = {
    "cylinder": ("radius", "height"),
    "capsule": ("radius", "length"),
    "sphere": ("radius",),
    "box": ("size_x", "size_y", "size_z"),
}
SHAPES: tuple[str, ...] = tuple(SHAPE_DIMS)


@dataclass(frozen=True)
class ObjectSpec:
    """One object instance.

    Attributes:
        shape: ``"cylinder" | "box" | "sphere" | "capsule"``.
        dims: dimensions in metres, named by :data:`SHAPE_DIMS`: cylinder ``(radius,
            height)``, capsule ``(radius, length)`` (length of the straight part between
            the two hemispherical caps), sphere ``(radius,)``, box ``(size_x, size_y,
            size_z)`` (full side lengths; ``size_z`` is vertical).
        rgba: colour, four floats in ``[0, 1]``.
        mass: kg, > 0.
        name: free-form label (e.g. ``"train-03-box"``).

    Raises:
        ValueError: naming the field when a value is invalid.
    """

    shape: str
    dims: tuple[float, ...]
    rgba: tuple[float, float, float, float]
    mass: float
    name: str = ""

    def __post_init__(self) -> None:
        if self.shape not in SHAPE_DIMS:
            raise ValueError(f"ObjectSpec.shape: expected one of {SHAPES}, got {self.shape!r}")
        dims = tuple(float(d) for d in self.dims)
        expected = SHAPE_DIMS[self.shape]
        if len(dims) != len(expected):
            raise ValueError(
                f"ObjectSpec.dims: a {self.shape} needs {len(expected)} values {expected}, got {len(dims)}: {dims}"
            )
        for label, value in zip(expected, dims, strict=True):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"ObjectSpec.dims: {label} must be a finite length > 0 m, got {value}")
        rgba = tuple(float(c) for c in self.rgba)
        if len(rgba) != 4 or not all(0.0 <= c <= 1.0 for c in rgba):
            raise ValueError(f"ObjectSpec.rgba: expected 4 values in [0, 1], got {self.rgba}")
        if not (math.isfinite(float(self.mass)) and float(self.mass) > 0):
            raise ValueError(f"ObjectSpec.mass: must be a finite mass > 0 kg, got {self.mass}")
        if not isinstance(self.name, str):
            raise ValueError(f"ObjectSpec.name: must be a string, got {type(self.name).__name__}")
        object.__setattr__(self, "dims", dims)
        object.__setattr__(self, "rgba", rgba)
        object.__setattr__(self, "mass", float(self.mass))

    @property
    def height(self) -> float:
        """Total height (m) of the upright object above the table."""
        if self.shape == "cylinder":
            return self.dims[1]
        if self.shape == "capsule":
            return self.dims[1] + 2 * self.dims[0]
        if self.shape == "sphere":
            return 2 * self.dims[0]
        return self.dims[2]

    @property
    def footprint_radius(self) -> float:
        """Radius (m) of the smallest circle about the vertical axis that holds the upright
        object's footprint (a box's half diagonal)."""
        if self.shape == "box":
            return 0.5 * math.hypot(self.dims[0], self.dims[1])
        return self.dims[0]

    @property
    def round(self) -> bool:
        """True for shapes symmetric about their vertical axis (cylinder, capsule, sphere)."""
        return self.shape != "box"

    def to_dict(self) -> dict[str, Any]:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ObjectSpec:
        return cls(
            shape=d["shape"],
            dims=tuple(d["dims"]),
            rgba=tuple(d["rgba"]),
            mass=d["mass"],
            name=d.get("name", ""),
        )


#: Size ranges (m) per family, uniform draws: what people put in front of a robot, from thin
#: tall cans (r 2 cm, h 24 cm) to squat jars (r 4.5 cm, h 6 cm), flat bricks (2.5 cm high) to
#: cubes, small and large spheres, short and long capsules. Every instance fits the PR2
#: gripper (opening ~9 cm: a box is grasped across a horizontal side <= 8.5 cm) and stands
#: stably (capsules with the objects' rolling friction, :mod:`lfd.sim.scene`).
FAMILY_SIZES: dict[str, tuple[tuple[float, float], ...]] = {
    "cylinder": ((0.02, 0.045), (0.06, 0.24)),
    "capsule": ((0.018, 0.035), (0.04, 0.15)),
    "sphere": ((0.035, 0.06),),
    "box": ((0.035, 0.085), (0.035, 0.085), (0.025, 0.13)),
}
#: Size bands just outside :data:`FAMILY_SIZES`, per family and dimension: the uniform ``(low,
#: high)`` ranges (m) below and above the training range. An object "outside the ranges"
#: (``sample_object(..., outside=True)``) has one dimension, chosen at random, drawn from one of
#: its bands, and the others from :data:`FAMILY_SIZES`: thinner pens and tins, taller cans, dice
#: and cartons, small and large balls, the way users' objects leave the generator's ranges one
#: property at a time. The bands stop where the scripted demonstration fails: a round object lower
#: than about 6 cm cannot be approached from the side (the forearm meets the table: a cylinder 5.5 cm
#: high or a ball of 2.75 cm radius fails at every placement tried, 6 cm and 3 cm succeed), so the
#: cylinder's height has no band below and the ball's radius one from 3 cm.
OUTSIDE_SIZES: dict[str, tuple[tuple[tuple[float, float], ...], ...]] = {
    "cylinder": (((0.012, 0.02), (0.045, 0.055)), ((0.24, 0.28),)),
    "capsule": (((0.012, 0.018), (0.035, 0.042)), ((0.02, 0.04), (0.15, 0.18))),
    "sphere": (((0.03, 0.035), (0.06, 0.07)),),
    "box": (((0.02, 0.035), (0.085, 0.10)), ((0.02, 0.035), (0.085, 0.10)), ((0.015, 0.025), (0.13, 0.18))),
}
#: The wider ranges of ``sizes="wide"``, what users put on a table (docs/decisions.md): pens
#: (r 1.2 cm) to 26 cm tall cans, tins and jars from 3 cm high, balls from a 3 cm marble-sized
#: sphere to 12 cm, egg-like to 23 cm capsules, dice (2 cm) to 20 cm cartons and 1.5 cm flat
#: blocks. Horizontal sizes stay within the PR2 gripper's opening (~9 cm); every extreme was
#: reached by the scripted expert at 12 random placements (a few IK misses at the tallest,
#: which generation redraws).
#: Round objects lower than ``lfd.sim.approach.SIDE_MIN_HEIGHT`` (6 cm) are approached from the
#: top, so cylinders and balls straddle the rule's boundary: :data:`WIDE_BOUNDARY` draws some of
#: them close to it.
WIDE_FAMILY_SIZES: dict[str, tuple[tuple[float, float], ...]] = {
    "cylinder": ((0.012, 0.045), (0.03, 0.26)),
    "capsule": ((0.015, 0.035), (0.005, 0.16)),
    "sphere": ((0.015, 0.06),),
    "box": ((0.02, 0.085), (0.02, 0.085), (0.015, 0.20)),
}
#: Bands just outside :data:`WIDE_FAMILY_SIZES` (as :data:`OUTSIDE_SIZES` is for the classic
#: ranges): out to 30 cm tall, 1.6 cm thin, 1 cm small. A capsule's straight part has no band
#: below (its range starts at 5 mm: a ball).
WIDE_OUTSIDE_SIZES: dict[str, tuple[tuple[tuple[float, float], ...], ...]] = {
    "cylinder": (((0.008, 0.012), (0.045, 0.055)), ((0.02, 0.03), (0.26, 0.30))),
    "capsule": (((0.010, 0.015), (0.035, 0.042)), ((0.16, 0.19),)),
    "sphere": (((0.01, 0.015), (0.06, 0.07)),),
    "box": (((0.012, 0.02), (0.085, 0.10)), ((0.012, 0.02), (0.085, 0.10)), ((0.01, 0.015), (0.20, 0.25))),
}
#: Dense cover of the approach rule's boundary with ``sizes="wide"``: per family, the
#: probability of drawing the dimension that sets the height (index) from a band around
#: 6 cm high instead of its whole range: cylinders 4.5-7.5 cm high, balls of 2.25-3.75 cm radius,
#: capsules with a straight part of 0.5-4 cm (4-11 cm high, by radius).
WIDE_BOUNDARY: dict[str, tuple[float, int, tuple[float, float]]] = {
    "cylinder": (0.3, 1, (0.045, 0.075)),
    "capsule": (0.3, 1, (0.005, 0.04)),
    "sphere": (0.3, 0, (0.0225, 0.0375)),
}


@dataclass(frozen=True)
class SizeRanges:
    """One set of object size ranges: ``inside`` (per family and dimension, the uniform
    training range, m), ``outside`` (the bands just outside it), ``boundary`` (per family:
    probability, dimension index and band of a denser draw) and ``edges`` (probability, fraction):
    with that probability one dimension, chosen at random, is drawn from that fraction of its
    range at its lower or upper end (equal chance), so that training covers the edges the
    objects just outside the ranges lie beyond."""

    inside: dict[str, tuple[tuple[float, float], ...]]
    outside: dict[str, tuple[tuple[tuple[float, float], ...], ...]]
    boundary: dict[str, tuple[float, int, tuple[float, float]]]
    edges: tuple[float, float] = (0.0, 0.0)


#: Edge draws of ``sizes="wide_edges"``: 30 % of the training objects have one dimension from the
#: lowest or highest 15 % of its range.
WIDE_EDGES = (0.3, 0.15)

#: The size sets a dataset may draw from, by name (``GeneratorConfig.sizes``): ``classic`` (the
#: original ranges), ``wide`` and ``wide_edges`` (the wide ranges, denser at their edges:
#: :data:`WIDE_EDGES`; the same objects outside them).
SIZE_SETS: dict[str, SizeRanges] = {
    "classic": SizeRanges(FAMILY_SIZES, OUTSIDE_SIZES, {}),
    "wide": SizeRanges(WIDE_FAMILY_SIZES, WIDE_OUTSIDE_SIZES, WIDE_BOUNDARY),
    "wide_edges": SizeRanges(WIDE_FAMILY_SIZES, WIDE_OUTSIDE_SIZES, WIDE_BOUNDARY, WIDE_EDGES),
}
#: Mass range (kg) for every family.
MASS_RANGE = (0.1, 0.5)
#: Colour draws (HSV): saturation from greys and pastels to full colour, value from near
#: black to bright.
SATURATION_RANGE, VALUE_RANGE = (0.1, 1.0), (0.15, 1.0)
#: Colours closer than this (Euclidean RGB distance) to the table's are drawn again: an
#: object the colour of the table is invisible to a camera (the table is
#: ``lfd.sim.scene.TABLE_RGBA``, repeated here to keep this module free of PyBullet).
TABLE_RGB, MIN_TABLE_CONTRAST = (0.62, 0.60, 0.56), 0.2


def sample_object(
    rng: np.random.Generator, shape: str, name: str = "", outside: bool = False, sizes: str = "classic"
) -> ObjectSpec:
    """One random instance of the family ``shape``: size from the size set ``sizes``
    (:data:`SIZE_SETS`: uniform in its ``inside`` ranges, or, with the probability of its
    ``boundary`` entry, the height-setting dimension from the boundary band, and with that of its
    ``edges``, one dimension from an end of its range), a random
    colour (hue uniform, saturation :data:`SATURATION_RANGE`, value :data:`VALUE_RANGE`, at
    least :data:`MIN_TABLE_CONTRAST` from the table's colour), mass from :data:`MASS_RANGE`.
    ``outside``: one dimension, chosen at random, from just outside its range instead
    (the set's ``outside`` bands, each with equal chance)."""
    if shape not in SHAPE_DIMS:
        raise ValueError(f"sample_object: shape must be one of {SHAPES}, got {shape!r}")
    if sizes not in SIZE_SETS:
        raise ValueError(f"sample_object: sizes must be one of {tuple(SIZE_SETS)}, got {sizes!r}")
    ranges = SIZE_SETS[sizes]
    dims = tuple(float(rng.uniform(lo, hi)) for lo, hi in ranges.inside[shape])
    if shape in ranges.boundary and not outside:
        chance, k, (lo, hi) = ranges.boundary[shape]
        if rng.uniform() < chance:
            dims = (*dims[:k], float(rng.uniform(lo, hi)), *dims[k + 1 :])
    chance, fraction = ranges.edges
    if chance > 0 and not outside and rng.uniform() < chance:
        k = int(rng.integers(len(dims)))
        lo, hi = ranges.inside[shape][k]
        width = fraction * (hi - lo)
        lo, hi = (lo, lo + width) if rng.uniform() < 0.5 else (hi - width, hi)
        dims = (*dims[:k], float(rng.uniform(lo, hi)), *dims[k + 1 :])
    if outside:
        k = int(rng.integers(len(dims)))
        bands = ranges.outside[shape][k]
        lo, hi = bands[int(rng.integers(len(bands)))]
        dims = (*dims[:k], float(rng.uniform(lo, hi)), *dims[k + 1 :])
    while True:
        hue, sat, val = rng.uniform(0, 1), rng.uniform(*SATURATION_RANGE), rng.uniform(*VALUE_RANGE)
        rgb = _hsv_to_rgb(float(hue), float(sat), float(val))
        if math.dist(rgb, TABLE_RGB) >= MIN_TABLE_CONTRAST:
            break
    return ObjectSpec(
        shape=shape, dims=dims, rgba=(*rgb, 1.0), mass=float(rng.uniform(*MASS_RANGE)), name=name
    )


def sample_objects(
    rng: np.random.Generator,
    n: int,
    families: tuple[str, ...] = SHAPES,
    prefix: str = "obj",
    sizes: str = "classic",
) -> list[ObjectSpec]:
    """``n`` instances cycling through ``families`` (so each family is represented as
    evenly as possible), named ``f"{prefix}-{i:02d}-{shape}"``, sizes from ``sizes``
    (:data:`SIZE_SETS`)."""
    if n < 0:
        raise ValueError(f"sample_objects: n must be >= 0, got {n}")
    if not families:
        raise ValueError("sample_objects: families must not be empty")
    shapes = [families[i % len(families)] for i in range(n)]
    return [
        sample_object(rng, shape, f"{prefix}-{i:02d}-{shape}", sizes=sizes) for i, shape in enumerate(shapes)
    ]


def _hsv_to_rgb(h: float, s: float, v: float) -> tuple[float, float, float]:
    i = int(h * 6) % 6
    f = h * 6 - math.floor(h * 6)
    p, q, t = v * (1 - s), v * (1 - f * s), v * (1 - (1 - f) * s)
    return [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)][i]


@dataclass(frozen=True)
class Placement:
    """Object position on the table in the torso frame: ``x``, ``y`` (m), ``yaw`` (rad)
    about the vertical axis."""

    x: float
    y: float
    yaw: float

    def as_array(self) -> np.ndarray:
        """``(3,)`` float64 ``[x, y, yaw]``."""
        return np.array([self.x, self.y, self.yaw], dtype=np.float64)


@dataclass(frozen=True)
class PlacementRanges:
    """Uniform placement ranges: ``x``, ``y`` in metres (torso frame), ``yaw`` in degrees.
    Defaults are the original ranges (x 0.45..0.70 m, y -0.30..0.30 m, yaw -90..90 deg)."""

    x: tuple[float, float] = (0.45, 0.70)
    y: tuple[float, float] = (-0.30, 0.30)
    yaw_deg: tuple[float, float] = (-90.0, 90.0)

    def __post_init__(self) -> None:
        for field in ("x", "y", "yaw_deg"):
            lo, hi = getattr(self, field)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(
                    f"PlacementRanges.{field}: expected finite (low, high) with low <= high, got {(lo, hi)}"
                )
            object.__setattr__(self, field, (float(lo), float(hi)))

    def sample(self, rng: np.random.Generator) -> Placement:
        x, y = rng.uniform(*self.x), rng.uniform(*self.y)
        yaw = math.radians(rng.uniform(*self.yaw_deg))
        return Placement(float(x), float(y), float(yaw))
