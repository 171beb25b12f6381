"""Ridge-regularised fitting on coarse grids (30-50 samples, like 30 Hz skeleton data) and on LASA:
weight norms and fine-grid replay error, measured and bounded."""

import numpy as np
import pytest
from dmp_helpers import lasa_demo, smooth_demo

from lfd.dmp import DEFAULT_RIDGE, DMP, clear_caches, transform


def relative_rmse(a, b):
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=-1))) / np.ptp(b, axis=0).max())


def coarse_cases():
    """(name, t_coarse, y_coarse, t_fine, y_fine): a smooth motion sampled at 30-50 points and at 1000."""
    cases = []
    for seed, n in ((200, 30), (201, 40), (202, 50)):
        fine_t, coarse_t = np.linspace(0, n / 30.0, 1000), np.linspace(0, n / 30.0, n)
        _, fine_y = smooth_demo(np.random.default_rng(seed), t=fine_t, n_dims=7)
        _, coarse_y = smooth_demo(np.random.default_rng(seed), t=coarse_t, n_dims=7)
        cases.append((f"synthetic {n}", coarse_t, coarse_y, fine_t, fine_y))
    for name in ("WShape", "Leaf_1", "Spoon"):  # held out from choosing the default (benchmarks/dmp_ridge.py)
        t, y = lasa_demo(name)
        index = np.round(np.linspace(0, len(t) - 1, 40)).astype(int)
        cases.append((f"LASA {name} 40", t[index], y[index], t, y))
    return cases


def test_default_ridge_shrinks_weights_and_coarse_fits_replay_on_fine_grids(record_property):
    rows = {}
    for name, ct, cy, ft, fy in coarse_cases():
        plain = DMP(20, ridge=0.0).fit(ct, cy)
        ridged = DMP(20).fit(ct, cy)
        rows[name] = {
            "weight_norm_ridge0": float(np.linalg.norm(plain.weights_)),
            "weight_norm_default": float(np.linalg.norm(ridged.weights_)),
            "replay_ridge0": relative_rmse(plain.rollout(t=ft), fy),
            "replay_default": relative_rmse(ridged.rollout(t=ft), fy),
            "coarse_default": relative_rmse(ridged.rollout(t=ct), cy),
        }
    for name, row in rows.items():
        print(name, {k: f"{v:.3g}" for k, v in row.items()})
        record_property(name, row)
        assert row["weight_norm_default"] <= row["weight_norm_ridge0"] * (1 + 1e-9), name
        assert row["replay_default"] <= 1.5 * row["replay_ridge0"] + 1e-4, name  # no real loss of accuracy
        # a 30-50 sample fit replays on a 1000-sample grid about as well as it fits its samples
        assert row["replay_default"] < 5e-3, name
        assert row["replay_default"] < 3 * row["coarse_default"] + 2e-4, name
    assert DEFAULT_RIDGE == 1e-12


def test_fine_grid_replay_would_degrade_without_the_refined_operator(monkeypatch):
    """The measurement behind the refined operator: with the first-order hold on the 30-sample
    grid itself, the same fit replays several times worse on a fine grid."""
    name, ct, cy, ft, fy = coarse_cases()[0]
    refined = relative_rmse(DMP(20).fit(ct, cy).rollout(t=ft), fy)
    monkeypatch.setattr(transform, "MIN_STEPS_PER_TAU", 1)
    clear_caches()
    raw = relative_rmse(DMP(20).fit(ct, cy).rollout(t=ft), fy)
    clear_caches()
    assert raw > 3 * refined, (raw, refined)


def test_ridge_is_validated_and_saved(tmp_path):
    for bad in (-1.0, np.nan, "big"):
        with pytest.raises(ValueError, match="ridge"):
            DMP(ridge=bad)
    t = np.linspace(0, 1, 30)
    dmp = DMP(8, ridge=1e-6).fit(t, np.stack([np.sin(3 * t), t**2], -1))
    dmp.save(tmp_path / "r.json")
    loaded = DMP.load(tmp_path / "r.json")
    assert loaded.ridge == 1e-6
    np.testing.assert_array_equal(loaded.rollout(), dmp.rollout())
    strong = DMP(8, ridge=1e-2).fit(t, np.stack([np.sin(3 * t), t**2], -1))
    assert np.linalg.norm(strong.weights_) < np.linalg.norm(dmp.weights_)
