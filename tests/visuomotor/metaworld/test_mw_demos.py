"""Meta-World demonstration datasets and their items: deterministic, resumable, verified, and a
DMP fitted to an expert episode that reproduces the expert's success in closed loop."""

import numpy as np
import pytest
import torch

from lfd.io.files import DatasetError
from lfd.metaworld import MetaWorldTask, placement_seed, record_expert
from lfd.visuomotor.metaworld.datamodule import MetaWorldDataModule
from lfd.visuomotor.metaworld.demos import (
    MANIFEST,
    MetaWorldDataConfig,
    episode_file,
    generate_demonstrations,
    load_demonstrations,
)

TINY = {
    "task": "reach-v3",
    "seed": 3,
    "n_train": 3,
    "n_val": 2,
    "image_size": 32,
    "n_steps": 80,
    "n_basis": 10,
}


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    path = tmp_path_factory.mktemp("mw") / "reach"
    cfg = MetaWorldDataConfig(**TINY)
    generate_demonstrations(cfg, path, progress=False)
    return cfg, path


def test_generation_is_deterministic_and_resumes(tiny, tmp_path):
    cfg, path = tiny
    again = tmp_path / "again"
    generate_demonstrations(cfg, again, progress=False)
    first = load_demonstrations(path, cfg).manifest["files"]
    assert load_demonstrations(again, cfg).manifest["files"] == first  # same bytes, file by file
    # an interrupted run (no manifest, one episode missing) resumes to the same dataset
    (again / MANIFEST).unlink()
    (again / episode_file("val", 1)).unlink()
    generate_demonstrations(cfg, again, progress=False)
    assert load_demonstrations(again, cfg).manifest["files"] == first
    # a larger dataset begins with the same episodes (per-episode streams)
    more = tmp_path / "more"
    generate_demonstrations(MetaWorldDataConfig(**{**TINY, "n_train": 4}), more, progress=False)
    a = np.load(path / episode_file("train", 2))
    b = np.load(more / episode_file("train", 2))
    assert np.array_equal(a["frames"], b["frames"]) and np.array_equal(a["states"], b["states"])


def test_episodes_are_expert_successes_on_their_own_placements(tiny):
    cfg, path = tiny
    data = load_demonstrations(path, cfg)
    seen = set()
    for split in ("train", "val"):
        for e in data.split(split):
            a = e.arrays
            assert a["solved"].any() and a["frames"].shape == (80, 32, 32, 3) and a["states"].shape == (80, 4)
            assert int(a["reset_seed"]) == placement_seed(cfg.seed, split, e.index, int(a["attempt"]))
            seen.add(tuple(a["placement"].round(9)))
    assert len(seen) == cfg.n_train + cfg.n_val
    with MetaWorldTask("reach-v3", image_size=32) as task:  # the test stream holds none of them
        for i in range(5):
            task.reset(placement_seed(cfg.seed, "test", i))
            assert tuple(task.placement.round(9)) not in seen


def test_verification_refuses_changed_files_and_other_settings(tiny, tmp_path):
    cfg, path = tiny
    with pytest.raises(DatasetError, match="generated with other settings .*n_steps=80"):
        load_demonstrations(path, MetaWorldDataConfig(**{**TINY, "n_steps": 90}))
    # how many placements generation may try does not change a finished dataset
    more_attempts = MetaWorldDataConfig(**{**TINY, "max_attempts": cfg.max_attempts + 7})
    assert load_demonstrations(path, more_attempts).config.max_attempts == cfg.max_attempts
    import shutil

    copy = tmp_path / "copy"
    shutil.copytree(path, copy)
    f = copy / episode_file("train", 0)
    raw = bytearray(f.read_bytes())
    raw[len(raw) // 2] ^= 1
    f.write_bytes(bytes(raw))
    with pytest.raises(DatasetError, match="train-00000.npz is missing or changed"):
        load_demonstrations(copy, cfg)
    with pytest.raises(DatasetError, match="no manifest.json"):
        load_demonstrations(tmp_path / "absent")
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(DatasetError, match="is not an unfinished Meta-World dataset"):
        generate_demonstrations(cfg, other, progress=False)
    assert (other / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("task", "reach-v2", "task: expected a Meta-World task name"),
        ("n_train", 0, "data.n_train must be"),
        ("n_steps", 600, "data.n_steps must be an integer in 10..500"),
        ("camera", "front", "data.camera must be one of"),
        ("camera_fovy", 200, "data.camera_fovy must be degrees in 5..120"),
        ("camera_fovy", "wide", "data.camera_fovy must be degrees in 5..120"),
    ],
)
def test_bad_settings_are_one_line(key, value, message):
    with pytest.raises(ValueError, match=message):
        MetaWorldDataConfig(**{**TINY, key: value})


def test_field_of_view_is_content_and_unset_keeps_old_datasets_valid():
    """A set ``camera_fovy`` changes what an episode holds (its hash); unset, the settings and the
    hash are those of a dataset made before the setting existed (no ``camera_fovy`` key)."""
    plain, zoomed = MetaWorldDataConfig(**TINY), MetaWorldDataConfig(**{**TINY, "camera_fovy": 30})
    assert "camera_fovy" not in plain.to_dict() and zoomed.to_dict()["camera_fovy"] == 30.0
    assert plain.content_sha256() != zoomed.content_sha256()
    assert MetaWorldDataConfig(**{**TINY, "camera_fovy": None}).content_sha256() == plain.content_sha256()


def test_items_of_both_layouts(tiny):
    cfg, path = tiny
    kwargs = {k: v for k, v in TINY.items()}
    dm = MetaWorldDataModule(name=path.name, root=path.parent, mode="dmp", progress=False, **kwargs)
    dm.prepare_data()
    dm.setup("fit")
    item = dm.datasets["train"][0]
    assert item["image"].shape == (3, 32, 32) and item["joints"].shape == (4,)
    assert item["trajectory"].shape == (80, 4) and item["weights"].shape == (4, 10)
    torch.testing.assert_close(item["ee_path"], item["trajectory"][:, :3])
    assert len(dm.datasets["val"]) == 2
    vel = MetaWorldDataModule(name=path.name, root=path.parent, mode="velocity", progress=False, **kwargs)
    vel.setup("fit")
    assert len(vel.datasets["train"]) == 3 * 80
    it = vel.datasets["train"][81]
    assert int(it["index"]) == 1 and int(it["step"]) == 1
    states = dm.data.split("train")[1].states
    torch.testing.assert_close(it["command"], torch.tensor((states[2] - states[1]) / 0.0125).float())
    # training options: images from the first frames, augmentation; validation items stay frame 0
    window = MetaWorldDataModule(name=path.name, root=path.parent, dmp_frames=5, progress=False, **kwargs)
    window.setup("fit")
    first5 = torch.from_numpy(dm.data.split("train")[0].frames[:5]).permute(0, 3, 1, 2).float() / 255
    drawn = {
        int(((first5 - window.datasets["train"][0]["image"]) ** 2).flatten(1).sum(1).argmin())
        for _ in range(40)
    }
    assert len(drawn) >= 3 and drawn <= set(range(5))
    torch.testing.assert_close(window.datasets["val"][0]["image"], dm.datasets["val"][0]["image"])
    shaken = MetaWorldDataModule(name=path.name, root=path.parent, augment=True, progress=False, **kwargs)
    shaken.setup("fit")
    assert not torch.equal(shaken.datasets["train"][0]["image"], item["image"])
    torch.testing.assert_close(shaken.datasets["val"][0]["image"], dm.datasets["val"][0]["image"])
    fewer = MetaWorldDataModule(name=path.name, root=path.parent, train_episodes=2, progress=False, **kwargs)
    fewer.setup("fit")
    assert len(fewer.datasets["train"]) == 2 and len(fewer.datasets["val"]) == 2
    two = np.concatenate([e.states for e in dm.data.split("train")[:2]])
    np.testing.assert_allclose(
        fewer.stats["joints"]["mean"], two.mean(0), rtol=1e-5
    )  # statistics of those two
    with pytest.raises(ValueError, match="data.dmp_frames must be at most data.n_steps=80"):
        MetaWorldDataModule(name="x", root=path.parent, dmp_frames=81, **kwargs)
    with pytest.raises(ValueError, match="data.robot is None for Meta-World"):
        MetaWorldDataModule(name="x", root=path.parent, robot="sawyer", **kwargs)
    with pytest.raises(ValueError, match="data.train_episodes must be at most"):
        MetaWorldDataModule(name="x", root=path.parent, train_episodes=9, **kwargs)


@pytest.mark.parametrize("task_name", ["push-v3", "pick-place-v3", "drawer-open-v3"])
def test_fitted_dmp_reproduces_the_expert_in_closed_loop(task_name):
    """The controller's path: the DMP fitted to an expert episode's states, tracked as position
    targets from the same placement, solves the task (grasping and pushing included)."""
    from lfd.dmp import DMP

    with MetaWorldTask(task_name, image_size=32) as task:
        episode = record_expert(task, placement_seed(0, "train", 0), n_steps=150, render=False)
        assert episode.success
        t = np.arange(150) * task.control_dt
        plan = DMP(n_basis=20).fit(t, episode.states).rollout(np.arange(200) * task.control_dt)
        task.reset(episode.reset_seed)
        for k in range(199):
            task.step_to(plan[k + 1])
        assert task.success
        # and a plan that never closes the gripper does not pick (the check can fail)
        if task_name == "pick-place-v3":
            task.reset(episode.reset_seed)
            for k in range(199):
                task.step_to(np.array([*plan[k + 1, :3], -1.0]))
            assert not task.success


def test_goal_probe_script(tiny, tmp_path, capsys):
    """scripts/metaworld_goal_probe.py reports the goal (or the object's) error on both splits, one line
    for a bad folder."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "goal_probe", Path(__file__).resolve().parents[3] / "scripts" / "metaworld_goal_probe.py"
    )
    probe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(probe)
    _, path = tiny
    assert probe.main([str(path), "--steps", "2", "--channels", "4", "4"]) == 0
    out = capsys.readouterr().out
    assert "reach-v3: 3 train / 2 val goals" in out and "step     0: goal error train" in out
    # the object's start position: reach places a puck-like object, its height never varies (finite errors)
    assert probe.main([str(path), "--steps", "2", "--channels", "4", "4", "--target", "object"]) == 0
    out = capsys.readouterr().out
    assert "reach-v3: 3 train / 2 val objects" in out and "nan" not in out, out
    assert probe.main([str(tmp_path / "absent")]) == 2
    assert "no manifest.json" in capsys.readouterr().err
