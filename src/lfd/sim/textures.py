"""Table-top textures: what users' tables look like (wood, tiles, speckled laminate, cloth
stripes, plain paint in any colour), drawn as small images the renderer maps onto the table.

A :class:`TableTexture` is a handful of numbers (its kind, base colour, contrast, pattern scale
and angle, a noise seed) that :meth:`TableTexture.image` turns into the same pixels every time,
so a dataset stores the numbers (:meth:`TableTexture.as_array`), not the image.
"""

from __future__ import annotations

import colorsys
import math
from dataclasses import dataclass

import numpy as np

#: The patterns :func:`sample_table_texture` draws from, each equally often.
TEXTURE_KINDS = ("plain", "wood", "tiles", "speckle", "stripes")
#: Ranges of :func:`sample_table_texture`: the base colour's HSV value and saturation (any
#: hue: from a dark stained desk to a white laminate, grey to strongly coloured), the pattern's
#: contrast (the fraction by which it darkens the base colour at most) and scale (cycles across
#: the table top).
TEXTURE_RANGES = {
    "value": (0.25, 0.9),
    "saturation": (0.0, 0.6),
    "contrast": (0.05, 0.4),
    "scale": (2.0, 12.0),
}
#: Side (px) of the texture images.
TEXTURE_SIZE = 64


@dataclass(frozen=True)
class TableTexture:
    """A table-top texture.

    Attributes:
        kind: one of :data:`TEXTURE_KINDS`.
        colour: base RGB, each in ``[0, 1]``.
        contrast: in ``[0, 1)``: how much the pattern darkens the base colour at most.
        scale: > 0, pattern cycles across the table top.
        angle_deg: the pattern's orientation (degrees).
        seed: integer >= 0 seeding the noise of ``speckle`` and the grain of ``wood``.

    Raises:
        ValueError: naming the field when a value is invalid.
    """

    kind: str = "plain"
    colour: tuple[float, float, float] = (0.62, 0.60, 0.56)
    contrast: float = 0.0
    scale: float = 4.0
    angle_deg: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if self.kind not in TEXTURE_KINDS:
            raise ValueError(f"TableTexture.kind: expected one of {TEXTURE_KINDS}, got {self.kind!r}")
        colour = tuple(float(v) for v in self.colour)
        if len(colour) != 3 or not all(0.0 <= v <= 1.0 for v in colour):
            raise ValueError(f"TableTexture.colour: expected 3 values in [0, 1], got {self.colour}")
        if not 0.0 <= float(self.contrast) < 1.0:
            raise ValueError(f"TableTexture.contrast: expected a value in [0, 1), got {self.contrast}")
        if not (math.isfinite(float(self.scale)) and float(self.scale) > 0):
            raise ValueError(f"TableTexture.scale: expected a finite value > 0, got {self.scale}")
        if not math.isfinite(float(self.angle_deg)):
            raise ValueError(f"TableTexture.angle_deg: expected a finite value, got {self.angle_deg}")
        if int(self.seed) != self.seed or self.seed < 0:
            raise ValueError(f"TableTexture.seed: expected an integer >= 0, got {self.seed}")
        object.__setattr__(self, "colour", colour)
        for name in ("contrast", "scale", "angle_deg"):
            object.__setattr__(self, name, float(getattr(self, name)))
        object.__setattr__(self, "seed", int(self.seed))

    def image(self, size: int = TEXTURE_SIZE) -> np.ndarray:
        """``(size, size, 3)`` uint8: the base colour darkened by the pattern (0 .. ``contrast``)."""
        v, u = np.mgrid[0:size, 0:size] / size
        a = math.radians(self.angle_deg)
        along = u * math.cos(a) + v * math.sin(a)  # the pattern's coordinate, in table tops
        across = -u * math.sin(a) + v * math.cos(a)
        rng = np.random.default_rng(self.seed)
        if self.kind == "plain":
            shade = np.zeros((size, size))
        elif self.kind == "wood":  # grain lines that wander across the board
            wobble = rng.uniform(0.1, 0.4) * np.sin(2 * np.pi * (across * rng.uniform(1, 3) + rng.uniform()))
            shade = 0.5 + 0.5 * np.sin(2 * np.pi * self.scale * (along + 0.1 * wobble))
        elif self.kind == "tiles":  # square tiles with darker joints
            pos = np.stack([along, across]) * self.scale
            joint = np.min(np.abs(pos - np.round(pos)), axis=0) < 0.06
            shade = np.where(joint, 1.0, 0.15 * ((np.floor(pos[0]) + np.floor(pos[1])) % 2))
        elif self.kind == "speckle":  # laminate or granite: noise at the pattern's scale
            cells = max(2, int(round(self.scale * 2)))
            coarse = rng.uniform(size=(cells, cells))
            idx = np.minimum((np.stack([v, u]) * cells).astype(int), cells - 1)
            shade = 0.6 * coarse[idx[0], idx[1]] + 0.4 * rng.uniform(size=(size, size))
        else:  # stripes: a woven cloth or a striped mat
            shade = (np.floor(along * self.scale * 2) % 2).astype(float)
        rgb = np.asarray(self.colour)[None, None] * (1.0 - self.contrast * shade[..., None])
        return np.round(255 * np.clip(rgb, 0.0, 1.0)).astype(np.uint8)

    def as_array(self) -> np.ndarray:
        """``(8,)`` float64: kind index, colour, contrast, scale, angle, seed (the
        ``table_texture`` array of a dataset episode)."""
        return np.array(
            [
                TEXTURE_KINDS.index(self.kind),
                *self.colour,
                self.contrast,
                self.scale,
                self.angle_deg,
                self.seed,
            ],
            dtype=np.float64,
        )

    @classmethod
    def from_array(cls, a: np.ndarray) -> TableTexture:
        """Inverse of :meth:`as_array`.

        Raises:
            ValueError: not 8 values, or an unknown kind index.
        """
        a = np.asarray(a, dtype=np.float64).reshape(-1)
        if a.shape != (8,) or not np.all(np.isfinite(a)):
            raise ValueError(f"TableTexture.from_array: expected 8 finite values, got {a.shape[0]}")
        k = int(a[0])
        if k != a[0] or not 0 <= k < len(TEXTURE_KINDS):
            raise ValueError(
                f"TableTexture.from_array: kind index must be 0..{len(TEXTURE_KINDS) - 1}, got {a[0]}"
            )
        return cls(TEXTURE_KINDS[k], tuple(a[1:4]), a[4], a[5], a[6], int(a[7]))


def sample_table_texture(rng: np.random.Generator) -> TableTexture:
    """A random :class:`TableTexture` from :data:`TEXTURE_KINDS` and :data:`TEXTURE_RANGES`: kind
    uniform, any hue, value, saturation, contrast and scale uniform in their ranges, any angle."""
    r = TEXTURE_RANGES
    kind = TEXTURE_KINDS[int(rng.integers(len(TEXTURE_KINDS)))]
    colour = colorsys.hsv_to_rgb(rng.uniform(), rng.uniform(*r["saturation"]), rng.uniform(*r["value"]))
    return TableTexture(
        kind,
        tuple(colour),
        rng.uniform(*r["contrast"]),
        rng.uniform(*r["scale"]),
        rng.uniform(0.0, 180.0),
        int(rng.integers(2**31)),
    )
