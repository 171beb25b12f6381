"""Flat clutter on the table: what else lies on a user's table besides the object to reach
(papers, notebooks, mats, coasters, a phone), drawn as thin boxes around the object.

The items are **seen, not touched**: the scene draws them in its backdrop (fixed and wrist
camera, colour and depth), not in the physics world, so they never push the object or stop the
arm. They are flat (:data:`CLUTTER_RANGES`: at most 8 mm high, below the lowest object the
generator makes, 1.5 cm) so that the object to reach stays the only thing standing on the
table: the task stays well posed without telling the policy which object is meant.

A :class:`FlatItem` is nine numbers (:meth:`FlatItem.as_array`); a dataset stores an episode's
items as ``(n, 9)`` (:func:`clutter_as_array`, :func:`clutter_from_array`).
"""

from __future__ import annotations

import colorsys
import math
from dataclasses import dataclass

import numpy as np

from lfd.sim.objects import ObjectSpec, Placement

__all__ = [
    "CLUTTER_CLEARANCE",
    "CLUTTER_RANGES",
    "CLUTTER_REGION",
    "MAX_CLUTTER",
    "FlatItem",
    "clutter_as_array",
    "clutter_from_array",
    "sample_clutter",
]

#: Ranges of :func:`sample_clutter` (metres; colour as HSV value and saturation, any hue): from a
#: coaster or a phone to an A4 sheet or a place mat, 2-8 mm thick.
CLUTTER_RANGES = {
    "length": (0.05, 0.24),
    "width": (0.04, 0.16),
    "height": (0.002, 0.008),
    "value": (0.2, 0.95),
    "saturation": (0.0, 0.7),
}
#: Where item centres are drawn (torso frame, m): the table in front of the robot, a little wider
#: than the objects' placement ranges so that items also lie at the image's edges.
CLUTTER_REGION = {"x": (0.38, 0.85), "y": (-0.40, 0.40)}
#: m: the least gap between an item and the object's footprint circle (and between two items).
CLUTTER_CLEARANCE = 0.03
#: Most items per episode (:func:`sample_clutter`, ``data.clutter``, ``eval.clutter``).
MAX_CLUTTER = 8
#: Draws per item before :func:`sample_clutter` gives up on it (the table is full).
_TRIES = 50


@dataclass(frozen=True)
class FlatItem:
    """A thin box lying on the table.

    Attributes:
        x, y: centre in the torso frame (m).
        yaw: rotation about the vertical (rad).
        length, width: side lengths (m), > 0.
        height: thickness (m), > 0.
        colour: RGB, each in ``[0, 1]``.

    Raises:
        ValueError: naming the field when a value is invalid.
    """

    x: float
    y: float
    yaw: float
    length: float
    width: float
    height: float
    colour: tuple[float, float, float] = (0.9, 0.9, 0.88)

    def __post_init__(self) -> None:
        for name in ("x", "y", "yaw", "length", "width", "height"):
            value = float(getattr(self, name))
            if not math.isfinite(value):
                raise ValueError(f"FlatItem.{name}: expected a finite number, got {getattr(self, name)!r}")
            if name in ("length", "width", "height") and value <= 0:
                raise ValueError(f"FlatItem.{name}: expected a length > 0 m, got {value}")
            object.__setattr__(self, name, value)
        colour = tuple(float(v) for v in self.colour)
        if len(colour) != 3 or not all(0.0 <= v <= 1.0 for v in colour):
            raise ValueError(f"FlatItem.colour: expected 3 values in [0, 1], got {self.colour}")
        object.__setattr__(self, "colour", colour)

    @property
    def radius(self) -> float:
        """Half the footprint's diagonal (m): the item lies within this circle about its centre."""
        return 0.5 * math.hypot(self.length, self.width)

    def as_array(self) -> np.ndarray:
        """``(9,)`` float64: x, y, yaw, length, width, height, colour."""
        return np.array(
            [self.x, self.y, self.yaw, self.length, self.width, self.height, *self.colour], dtype=np.float64
        )


def clutter_as_array(items: tuple[FlatItem, ...]) -> np.ndarray:
    """``(n, 9)`` float64, one :meth:`FlatItem.as_array` row per item (the ``clutter`` array of a
    dataset episode)."""
    return np.array([i.as_array() for i in items], dtype=np.float64).reshape(len(items), 9)


def clutter_from_array(a: np.ndarray) -> tuple[FlatItem, ...]:
    """Inverse of :func:`clutter_as_array`.

    Raises:
        ValueError: not ``(n, 9)`` finite values, or a row that is no valid :class:`FlatItem`.
    """
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 9 or not np.all(np.isfinite(a)):
        raise ValueError(f"clutter_from_array: expected (n, 9) finite values, got shape {a.shape}")
    return tuple(FlatItem(*row[:6], colour=tuple(row[6:9])) for row in a)


def sample_clutter(
    rng: np.random.Generator, n: int, obj: ObjectSpec, placement: Placement
) -> tuple[FlatItem, ...]:
    """Up to ``n`` random :class:`FlatItem` around an object.

    Sizes, thickness and colour uniform in :data:`CLUTTER_RANGES` (any hue, any yaw), centres
    uniform in :data:`CLUTTER_REGION`; an item is drawn again when its footprint circle comes
    within :data:`CLUTTER_CLEARANCE` of the object's footprint circle or of an earlier item's.
    After 50 draws for one item the table counts as full and fewer than ``n`` items come back.
    The same ``rng`` state gives the same items.

    Args:
        rng: the random stream.
        n: items wanted, ``0 <= n <=`` :data:`MAX_CLUTTER`.
        obj, placement: the object to keep clear of and where it stands (torso frame).

    Raises:
        ValueError: ``n`` not an integer in ``[0, MAX_CLUTTER]``.
    """
    if isinstance(n, bool) or int(n) != n or not 0 <= n <= MAX_CLUTTER:
        raise ValueError(f"sample_clutter: n must be an integer in [0, {MAX_CLUTTER}], got {n!r}")
    r, region = CLUTTER_RANGES, CLUTTER_REGION
    taken = [(placement.x, placement.y, obj.footprint_radius)]
    items: list[FlatItem] = []
    for _ in range(int(n)):
        for _ in range(_TRIES):
            length = rng.uniform(*r["length"])
            width = min(rng.uniform(*r["width"]), length)
            item = FlatItem(
                rng.uniform(*region["x"]),
                rng.uniform(*region["y"]),
                rng.uniform(-math.pi / 2, math.pi / 2),
                length,
                width,
                rng.uniform(*r["height"]),
                colorsys.hsv_to_rgb(rng.uniform(), rng.uniform(*r["saturation"]), rng.uniform(*r["value"])),
            )
            if all(
                math.hypot(item.x - x, item.y - y) >= item.radius + rad + CLUTTER_CLEARANCE
                for x, y, rad in taken
            ):
                items.append(item)
                taken.append((item.x, item.y, item.radius))
                break
    return tuple(items)
