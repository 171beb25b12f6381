"""Feature statistics: exact quantiles, means and stds of vectors and of image channels,
against brute force over the exported frames and over random pixels."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lfd.interop import LeRobotFolder
from lfd.interop.lerobot.stats import STAT_KEYS, image_histograms, image_stats, vector_stats
from lfd.visuomotor.data import load_dataset


def test_stats_are_exact(tiny, tiny_lerobot):
    stats = json.loads((tiny_lerobot / "meta/stats.json").read_text())
    folder = LeRobotFolder(tiny_lerobot)
    state = folder.data["observation.state"].astype(np.float64)
    np.testing.assert_allclose(
        stats["observation.state"]["q50"], np.quantile(state, 0.5, axis=0), rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(
        stats["observation.state"]["q99"], np.quantile(state, 0.99, axis=0), rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(
        stats["action"]["std"], folder.data["action"].astype(np.float64).std(axis=0), atol=1e-12
    )
    assert stats["index"]["count"] == [210] and stats["index"]["max"] == [209]
    # images: per channel in [0, 1], against a brute-force pass over every source pixel
    frames = np.concatenate([r.frames() for r in load_dataset(tiny).episodes]).astype(np.float64) / 255
    img = stats["observation.images.front"]
    for c in range(3):
        px = frames[..., c].ravel()
        assert img["mean"][c][0][0] == pytest.approx(px.mean(), abs=1e-12)
        assert img["std"][c][0][0] == pytest.approx(px.std(), abs=1e-9)
        for q, key in zip((0.01, 0.1, 0.5, 0.9, 0.99), ("q01", "q10", "q50", "q90", "q99"), strict=True):
            assert img[key][c][0][0] == pytest.approx(np.quantile(px, q), abs=1e-12), key
    assert img["count"] == [210] and img["std"][0][0][0] > 0  # lerobot's own uint8 std overflows to 0
    # per-episode stats of episode 0 (the episodes parquet)
    row = folder.episodes[0]
    np.testing.assert_allclose(row["stats/observation.state/mean"], state[:30].mean(axis=0), atol=1e-12)
    assert row["stats/observation.state/count"] == [30]


def test_vector_stats_keys_shapes_and_dtypes():
    v = np.arange(12, dtype=np.int64).reshape(6, 2)
    s = vector_stats(v)
    assert list(s) == list(STAT_KEYS)
    assert s["min"].dtype == np.int64 and s["min"].tolist() == [0, 1] and s["max"].tolist() == [10, 11]
    assert s["count"].tolist() == [6] and s["mean"].dtype == np.float64
    np.testing.assert_array_equal(s["q50"], np.quantile(v.astype(np.float64), 0.5, axis=0))
    assert vector_stats(np.arange(5))["max"].tolist() == [4]  # (N,) -> one column


def test_image_stats_equal_brute_force_over_pixels():
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 256, (3, 7, 5, 3), dtype=np.uint8)
    frames[..., 2] = 200  # a constant channel: std 0, every quantile the value
    s = image_stats(image_histograms(frames[:1]) + image_histograms(frames[1:]), 3)
    assert list(s) == list(STAT_KEYS) and s["count"].tolist() == [3]
    for c in range(3):
        px = frames[..., c].ravel().astype(np.float64) / 255
        assert s["mean"].shape == (3, 1, 1)
        assert s["mean"][c, 0, 0] == pytest.approx(px.mean(), abs=1e-12)
        assert s["std"][c, 0, 0] == pytest.approx(px.std(), abs=1e-9)
        assert (s["min"][c, 0, 0], s["max"][c, 0, 0]) == (px.min(), px.max())
        for q, key in zip((0.01, 0.1, 0.5, 0.9, 0.99), ("q01", "q10", "q50", "q90", "q99"), strict=True):
            assert s[key][c, 0, 0] == pytest.approx(np.quantile(px, q), abs=1e-12), key
