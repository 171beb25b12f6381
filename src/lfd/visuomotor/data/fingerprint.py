"""Dataset fingerprints in checkpoints, and the check that an evaluation is not run on
a policy's own training items.

A fingerprint (:func:`dataset_fingerprint`) is a JSON-ready dict: the SHA-256 of the
dataset's ``manifest.json`` (which itself hashes every episode file), the generator
config's hash, the split keys (:func:`lfd.visuomotor.data.episodes.split_keys`) and the *training
items*: every training object's geometry and colour and every training placement.
:func:`training_overlap` compares evaluation cases with those items by value (shape,
dimensions, colour; x, y, yaw), never by name, and returns one message per overlap.

Example::

    >>> from lfd.sim.objects import ObjectSpec, Placement
    >>> fp = {"train_objects": [{"name": "train-00-box", "shape": "box", "dims": [0.05, 0.05, 0.05],
    ...        "rgba": [1, 0, 0, 1]}], "train_placements": [[0.5, 0.0, 0.1]], "manifest_sha256": "x"}
    >>> box = ObjectSpec("box", (0.05, 0.05, 0.05), (1, 0, 0, 1), 0.2, "mine")
    >>> training_overlap(fp, [("objects[0] (mine)", box, Placement(0.6, 0.1, 0.0))])[0][:40]
    'evaluation case objects[0] (mine): objec'
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from lfd.io.files import sha256_file
from lfd.sim.objects import ObjectSpec, Placement
from lfd.visuomotor.data.episodes import split_keys

#: Values closer than this (m, rad, colour units) count as the same item.
SAME_ITEM_TOL = 1e-6


def dataset_fingerprint(data) -> dict[str, Any]:
    """Fingerprint of a loaded :class:`~lfd.visuomotor.data.ReachData` (module docstring)."""
    train = data.split("train")
    objects: dict[tuple, dict[str, Any]] = {}
    for e in train:
        o = e.obj
        objects.setdefault(
            (o.shape, o.dims, o.rgba),
            {"name": o.name, "shape": o.shape, "dims": list(o.dims), "rgba": list(o.rgba)},
        )
    return {
        "manifest_sha256": sha256_file(data.path / "manifest.json"),
        "config_sha256": data.config.sha256(),
        "split_keys": split_keys(data.config),
        "seed": data.config.seed,
        "train_objects": list(objects.values()),
        "train_placements": [[e.placement.x, e.placement.y, e.placement.yaw] for e in train],
    }


def _same_object(item: dict[str, Any], obj: ObjectSpec) -> bool:
    return (
        item["shape"] == obj.shape
        and len(item["dims"]) == len(obj.dims)
        and np.allclose(item["dims"], obj.dims, atol=SAME_ITEM_TOL, rtol=0)
        and np.allclose(item["rgba"], obj.rgba, atol=SAME_ITEM_TOL, rtol=0)
    )


def training_overlap(
    fingerprint: dict[str, Any] | None, cases: Iterable[tuple[str, ObjectSpec, Placement]]
) -> list[str]:
    """Messages naming every evaluation case (``(label, object, placement)``) whose object
    (geometry and colour) or placement (x, y, yaw) is one of the fingerprint's training
    items; empty when there is none or no fingerprint."""
    if not fingerprint:
        return []
    placements = np.asarray(
        fingerprint.get("train_placements") or np.zeros((0, 3)), dtype=np.float64
    ).reshape(-1, 3)
    out = []
    for label, obj, pl in cases:
        for item in fingerprint.get("train_objects", []):
            if _same_object(item, obj):
                out.append(
                    f"evaluation case {label}: object {obj.name!r} is training object {item['name']!r}"
                )
        if len(placements):
            hit = np.flatnonzero(np.abs(placements - pl.as_array()).max(axis=1) < SAME_ITEM_TOL)
            if hit.size:
                x, y, yaw = placements[hit[0]]
                out.append(
                    f"evaluation case {label}: placement ({pl.x}, {pl.y}, {pl.yaw}) is training placement "
                    f"#{hit[0]} ({x}, {y}, {yaw})"
                )
    return out
