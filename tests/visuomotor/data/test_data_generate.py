"""Reaching-dataset generation: reload, determinism, resume, corruption, shards, discards."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from lfd.io.files import npz_bytes
from lfd.visuomotor.data import (
    DatasetError,
    GeneratorConfig,
    generate_dataset,
    load_dataset,
    merge_shards,
    verify_dataset,
)
from lfd.visuomotor.data.episodes import episode_path
from lfd.visuomotor.data.generate import dataset_dir, shard_indices

TINY = GeneratorConfig(
    seed=5,
    n_train_objects=2,
    n_train_placements=3,
    n_test_objects=1,
    n_test_placements=2,
    image_size=32,
    n_steps=40,
    n_basis=10,
)


def files_of(path: Path) -> dict[str, bytes]:
    return {f.relative_to(path).as_posix(): f.read_bytes() for f in sorted(path.rglob("*")) if f.is_file()}


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ref") / "tiny"
    report = generate_dataset(TINY, out, num_workers=1, progress=False)
    assert report.generated == list(range(TINY.n_episodes)) and report.skipped == 0
    return out


def test_generated_dataset_reloads(reference):
    data = load_dataset(reference, TINY)
    assert data.manifest["episodes"] == {"total": 8, "train": 4, "val": 2, "test": 2}
    assert [e.index for e in data.episodes] == list(range(8))
    for split, n in (("train", 4), ("val", 2), ("test", 2)):
        assert len(data.split(split)) == n

    # validation: known objects, placements never used in training; test: new objects
    # compared by value (shape, dimensions, colour), not by name
    def by_value(split):
        return {(e.obj.shape, e.obj.dims, e.obj.rgba) for e in data.split(split)}

    assert by_value("val") <= by_value("train")
    assert not by_value("test") & by_value("train")
    assert not {tuple(e.placement.as_array()) for e in data.split("test")} & {
        tuple(e.placement.as_array()) for e in data.split("train")
    }
    for e in data.episodes:
        a = e.arrays
        assert a["joints"].shape == a["velocities"].shape == (40, 7)
        assert a["ee_poses"].shape == a["object_poses"].shape == (40, 4, 4)
        assert a["dmp_weights"].shape == (7, 10) and a["dmp_goal"].shape == (7,)
        assert float(a["final_error"]) < 0.01
        np.testing.assert_allclose(a["ee_poses"][-1, :3, 3], e.target_point, atol=0.01)
        np.testing.assert_allclose(a["dmp_goal"], a["joints"][-1])
        assert e.frames().shape == (40, 32, 32, 3)
    assert set(data.stats) == {"joints", "velocity", "goal", "weights", "target_point"}
    assert data.stats["weights"]["std"].shape == (7, 10)
    train_goals = np.stack([e.arrays["dmp_goal"] for e in data.split("train")])
    np.testing.assert_allclose(data.stats["goal"]["mean"].numpy(), train_goals.mean(0), rtol=1e-5)
    # a finished dataset is only verified, not regenerated
    report = generate_dataset(TINY, reference, num_workers=1, progress=False)
    assert report.generated == [] and report.skipped == 8


def test_same_bytes_with_two_workers_and_no_scene_folder_left(reference, tmp_path, monkeypatch):
    """The workers' scenes are closed when the pool ends (a worker exits without running __del__):
    no ``lfd-scene-*`` temporary folder is left behind."""
    import tempfile

    scratch = tmp_path / "scratch"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))  # the forked workers inherit it
    out = tmp_path / "tiny"
    generate_dataset(TINY, out, num_workers=2, progress=False)
    assert files_of(out) == files_of(reference)
    assert list(scratch.iterdir()) == []


def test_resume_after_interruption_makes_only_missing_episodes(reference, tmp_path):
    out = tmp_path / "tiny"
    shutil.copytree(reference, out)
    # an interrupted run: no manifest / stats yet, two episodes not written
    for rel in ("manifest.json", "stats.json", episode_path(2), episode_path(6)):
        (out / rel).unlink()
    with pytest.raises(DatasetError, match="manifest.json not found"):
        load_dataset(out)
    report = generate_dataset(TINY, out, num_workers=1, progress=False)
    assert sorted(report.generated) == [2, 6] and report.skipped == 6
    assert files_of(out) == files_of(reference)


def test_resume_refuses_episodes_of_another_config(reference, tmp_path):
    out = tmp_path / "tiny"
    shutil.copytree(reference, out)
    (out / "manifest.json").unlink()
    other = GeneratorConfig(**{**TINY.to_dict(), "seed": 6})
    with pytest.raises(DatasetError, match="different config"):
        generate_dataset(other, out, num_workers=1, progress=False)


def test_corruption_and_staleness_are_detected(reference, tmp_path):
    out = tmp_path / "tiny"
    shutil.copytree(reference, out)
    victim = out / episode_path(3)
    blob = bytearray(victim.read_bytes())
    blob[len(blob) // 2] ^= 0xFF
    victim.write_bytes(bytes(blob))
    with pytest.raises(DatasetError, match=r"checksum mismatch for .*ep-00003\.npz"):
        load_dataset(out)
    victim.unlink()
    with pytest.raises(DatasetError, match=r"missing file .*ep-00003\.npz"):
        verify_dataset(out)
    shutil.copy(out / episode_path(4), victim)
    (out / episode_path(99)).write_bytes(b"")
    with pytest.raises(DatasetError, match="checksum mismatch"):
        verify_dataset(out)
    shutil.copy(reference / episode_path(3), victim)
    with pytest.raises(DatasetError, match="unlisted episode files"):
        verify_dataset(out)
    (out / episode_path(99)).unlink()
    stale = GeneratorConfig(**{**TINY.to_dict(), "image_size": 48})
    with pytest.raises(DatasetError, match=r"stale dataset .*image_size: on disk 32, requested 48"):
        load_dataset(out, stale)
    with pytest.raises(DatasetError, match="stale dataset"):
        generate_dataset(stale, out, num_workers=1, progress=False)
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["format_version"] = 0
    (out / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(DatasetError, match="format version"):
        verify_dataset(out)


def test_shards_merge_into_the_same_bytes(reference, tmp_path):
    assert shard_indices(8, 1, 3) == [1, 4, 7]
    shards = [dataset_dir(tmp_path, "tiny", i, 2) for i in range(2)]
    for i, d in enumerate(shards):
        assert d.name == f"tiny.shard-{i}-of-2"
        generate_dataset(TINY, d, num_workers=1, shard=i, num_shards=2, progress=False)
        assert json.loads((d / "manifest.json").read_text())["shard"] == {"index": i, "count": 2}
        with pytest.raises(DatasetError, match="merge_shards"):
            load_dataset(d)
    with pytest.raises(DatasetError, match=r"shards \[1\] of 2 are missing"):
        merge_shards(shards[:1], tmp_path / "partial")
    with pytest.raises(DatasetError, match="both shard 0"):
        merge_shards([shards[0], shards[0]], tmp_path / "twice")
    merged = merge_shards(shards, tmp_path / "tiny")
    assert files_of(merged) == files_of(reference)
    load_dataset(merged, TINY)


def test_discarded_attempts_are_counted(tmp_path):
    far = GeneratorConfig(
        **{
            **TINY.to_dict(),
            "n_train_objects": 1,
            "n_train_placements": 3,
            "n_test_objects": 0,
            "x_range": (0.45, 1.2),
            "val_fraction": 0.0,
        }
    )
    report = generate_dataset(far, tmp_path / "far", num_workers=1, progress=False)
    manifest = json.loads((tmp_path / "far" / "manifest.json").read_text())
    assert manifest["discarded"] == report.discarded
    assert manifest["discarded"]["ik_failed"] > 0
    data = load_dataset(tmp_path / "far", far)
    assert sum(e.discarded()["ik_failed"] for e in data.episodes) == manifest["discarded"]["ik_failed"]
    hopeless = GeneratorConfig(**{**far.to_dict(), "x_range": (1.3, 1.4), "max_attempts": 2})
    with pytest.raises(RuntimeError, match="no valid demonstration in 2 placements"):
        generate_dataset(hopeless, tmp_path / "hopeless", num_workers=1, progress=False)


def test_npz_bytes_are_deterministic():
    arrays = {
        "a": np.arange(5.0),
        "s": np.str_("train"),
        "x": np.float64(2.5),
        "f": np.asfortranarray(np.ones((3, 2))),
    }
    assert npz_bytes(arrays) == npz_bytes(dict(arrays))
    assert npz_bytes(arrays) != npz_bytes({**arrays, "x": np.float64(2.6)})


#: The scene options of a dataset: the value that draws one per episode, and the episode's array.
SCENE_OPTIONS = {
    "lighting": ("random", "lighting"),
    "camera_pose": ("jitter", "camera_pose"),
    "table_texture": ("random", "table_texture"),
    "clutter": (3, "clutter"),
}


def _drawn(setting: str, cfg, plan, attempts: int = 1):
    """The array episode ``plan`` of ``cfg`` must store for ``setting`` (None: nothing, the default);
    the clutter is drawn once per placement tried (``attempts``)."""
    from lfd.sim.camera import Camera
    from lfd.sim.clutter import clutter_as_array, sample_clutter
    from lfd.visuomotor.data.episodes import (
        clutter_rng,
        episode_camera,
        episode_lighting,
        episode_table_texture,
        placement_rng,
    )

    if setting == "clutter":
        if not cfg.clutter:
            return None
        places, items = placement_rng(cfg, plan), clutter_rng(cfg, plan)
        for _ in range(attempts):
            drawn = sample_clutter(items, cfg.clutter, plan.obj, cfg.placement_ranges.sample(places))
        return clutter_as_array(drawn)
    if setting == "camera_pose":
        base = Camera(width=cfg.image_size, height=cfg.image_size)
        camera = episode_camera(cfg, plan, base)
        return None if camera is base else camera.pose_array()
    drawn = (episode_lighting if setting == "lighting" else episode_table_texture)(cfg, plan)
    return None if drawn is None else drawn.as_array()


@pytest.mark.parametrize("setting", sorted(SCENE_OPTIONS))
def test_random_scene_options_are_recorded_keyed_and_leave_the_demonstrations(setting, reference, tmp_path):
    """``lighting="random"``, ``camera_pose="jitter"``, ``table_texture="random"``, ``clutter=3``: each
    episode under its own light / through its own camera / on its own table / among its own flat items
    (drawn again for every placement tried), recorded in the file and drawn from a
    keyed stream (the same draw for the same group, object and placement, whatever else the config
    says); the placements and trajectories of the plain dataset are unchanged, its frames are not; a
    plain config keeps its hash; a bad value is named. With the jitter, ``camera_view`` is the episode's
    camera."""
    from lfd.sim.camera import Camera
    from lfd.visuomotor.data.episodes import plan_episodes

    value, key = SCENE_OPTIONS[setting]
    assert setting not in TINY.to_dict()
    cfg = GeneratorConfig(**{**TINY.to_dict(), setting: value})
    assert cfg.sha256() != TINY.sha256()
    out = tmp_path / setting
    generate_dataset(cfg, out, num_workers=1, progress=False)
    varied, plain = load_dataset(out, cfg), load_dataset(reference, TINY)
    draws, tries = [], []
    for a, b, plan in zip(varied.episodes, plain.episodes, plan_episodes(cfg), strict=True):
        assert key in a.arrays and key not in b.arrays
        tries.append(1 + int(a.arrays["discarded"].sum()))
        np.testing.assert_array_equal(a.arrays[key], _drawn(setting, cfg, plan, tries[-1]))
        draws.append(a.arrays[key].tobytes())
        np.testing.assert_array_equal(a.placement.as_array(), b.placement.as_array())
        np.testing.assert_allclose(a.arrays["joints"], b.arrays["joints"], atol=1e-9)
        assert not np.array_equal(a.frames(), b.frames())
        if setting == "camera_pose":
            base = Camera(width=cfg.image_size, height=cfg.image_size)
            np.testing.assert_allclose(
                a.arrays["camera_view"], base.with_pose(a.arrays[key]).view_matrix, atol=1e-12
            )
            np.testing.assert_allclose(b.arrays["camera_view"], base.view_matrix, atol=1e-12)
    assert len(set(draws)) == len(draws)
    more = GeneratorConfig(**{**cfg.to_dict(), "n_test_placements": 3})
    assert [_drawn(setting, more, p, n).tobytes() for p, n in zip(plan_episodes(more)[:6], tries)] == draws[
        :6
    ]
    assert _drawn(setting, TINY, plan_episodes(TINY)[0]) is None
    with pytest.raises(ValueError, match=f"GeneratorConfig.{setting}: expected (one of|an int)"):
        GeneratorConfig(**{**TINY.to_dict(), setting: "wobbly"})
