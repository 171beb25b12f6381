"""robomimic HDF5 export, read back with h5py: every key and attribute robomimic reads."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from lfd.interop import export_robomimic
from lfd.visuomotor.data import load_dataset


@pytest.fixture(scope="module")
def hdf5(tiny, tmp_path_factory):
    return export_robomimic(tiny, tmp_path_factory.mktemp("robomimic") / "tiny.hdf5", progress=False)


def test_layout_and_attributes(tiny, hdf5):
    data = load_dataset(tiny)
    with h5py.File(hdf5, "r") as f:
        grp = f["data"]
        demos = sorted(grp.keys(), key=lambda k: int(k[5:]))
        assert demos == [f"demo_{r.index}" for r in data.episodes]
        assert grp.attrs["total"] == sum(grp[d].attrs["num_samples"] for d in demos) == 7 * 30
        env = json.loads(grp.attrs["env_args"])
        assert set(env) == {"env_name", "type", "env_kwargs"} and isinstance(env["type"], int)
        assert env["env_kwargs"]["lfd_generator_config"]["n_steps"] == 30
        for name, split in (("train", "train"), ("valid", "val"), ("test", "test")):
            mask = f[f"mask/{name}"][()]
            assert mask.dtype.kind == "S"  # byte strings, as robomimic's masks
            assert sorted(m.decode() for m in mask) == sorted(f"demo_{r.index}" for r in data.split(split))
        scale = grp.attrs["action_scale"]
        for rec in data.episodes:
            demo = grp[f"demo_{rec.index}"]
            n = demo.attrs["num_samples"]
            assert n == 30
            assert set(demo.keys()) == {"obs", "next_obs", "actions", "rewards", "dones", "states"}
            assert (
                set(demo["obs"].keys())
                == set(demo["next_obs"].keys())
                == {
                    "agentview_image",
                    "robot0_joint_pos",
                    "robot0_joint_vel",
                    "robot0_eef_pos",
                    "robot0_eef_quat",
                    "object",
                }
            )
            img = demo["obs/agentview_image"][()]
            assert img.dtype == np.uint8 and img.shape == (n, 64, 64, 3)
            np.testing.assert_array_equal(img, rec.frames())  # lossless
            np.testing.assert_array_equal(demo["next_obs/agentview_image"][:-1], img[1:])
            np.testing.assert_array_equal(demo["obs/robot0_joint_pos"][()], rec.arrays["joints"])
            np.testing.assert_array_equal(demo["next_obs/robot0_joint_pos"][-1], rec.arrays["joints"][-1])
            actions = demo["actions"][()]
            assert actions.shape == (n, 7) and np.abs(actions).max() <= 1.0
            # the velocity commands that reproduce the demonstration: motion per control period
            period = np.diff(rec.arrays["joints"], axis=0) / np.diff(rec.arrays["t"])[:, None]
            np.testing.assert_allclose((actions * scale)[:-1], period, rtol=1e-10, atol=1e-12)
            np.testing.assert_array_equal(actions[-1], 0.0)
            np.testing.assert_array_equal(demo["dones"][()], np.eye(n)[-1])
            assert demo["rewards"][-1] == 1.0 and demo["rewards"][:-1].sum() == 0
            assert demo["states"].shape == (n, 21)
            np.testing.assert_allclose(demo["obs/robot0_eef_pos"][()], rec.arrays["ee_poses"][:, :3, 3])
        assert np.isclose(
            np.abs(np.concatenate([grp[d]["actions"][()] for d in demos])).max(axis=0), 1.0
        ).all()


def test_refuses_to_overwrite(tiny, hdf5):
    with pytest.raises(FileExistsError):
        export_robomimic(tiny, hdf5, progress=False)
