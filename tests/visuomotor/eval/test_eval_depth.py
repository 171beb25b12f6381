"""RGB-D policy input (``data.depth=true``): the TinyRenderer's depth against the scene's
geometry, the encoding shared by datasets and closed-loop evaluation, and the whole
pipeline (generate -> train both policies -> evaluate) on a tiny depth dataset, with the
refusals a user would hit when mixing RGB and RGB-D checkpoints, data and images."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
import torch
import yaml
from omegaconf import OmegaConf

import evaluate
import train
from lfd.robots import load_robot
from lfd.sim.approach import TABLE_Z
from lfd.sim.depth import (
    DEPTH_RANGE_M,
    RELIEF_DEADBAND_MM,
    RELIEF_RANGE_MM,
    linear_depth,
    plane_depth_mm,
    rgbd_image,
)
from lfd.sim.objects import ObjectSpec, Placement
from lfd.sim.scene import ReachScene
from lfd.visuomotor.data import ReachDataModule
from lfd.visuomotor.data.datasets import DMPReachDataset, VelocityReachDataset, load_dataset, policy_frames
from lfd.visuomotor.eval.rollout import observe
from lfd.visuomotor.policies import POLICIES, load_policy
from lfd.visuomotor.policies.control import PlanController
from lfd.visuomotor.policies.vision import image_to_tensor, permute_colour_channels

TINY = [
    "data.name=tinyd",
    "data.depth=true",
    "data.augment=false",  # colour jitter + shifts are RGB-only (refused with depth)
    "data.n_train_objects=2",
    "data.n_train_placements=3",
    "data.val_fraction=0.34",
    "data.n_test_objects=1",
    "data.n_test_placements=2",
    "data.n_val_objects=2",
    "data.n_val_object_placements=1",
    "data.image_size=32",
    "data.n_steps=30",
    "data.batch_size=4",
    "data.progress=false",
]
TINY_MODEL = ["model.channels=[4,4,8]", "model.hidden=[16,16]"]


def _tiny_data() -> dict:
    """:data:`TINY` as ReachDataModule arguments."""
    return {k.removeprefix("data."): yaml.safe_load(v) for k, v in (o.split("=", 1) for o in TINY)}


def _ray_to_plane(camera, u: float, v: float, plane_z: float) -> float:
    """Depth along the optical axis (m) of the point where pixel (u, v)'s ray meets the
    horizontal plane z = plane_z (torso frame): plain pinhole geometry, no renderer."""
    eye, target = np.array(camera.eye), np.array(camera.target)
    forward = (target - eye) / np.linalg.norm(target - eye)
    side = np.cross(forward, camera.up)
    side /= np.linalg.norm(side)
    up = np.cross(side, forward)
    f = 1.0 / math.tan(math.radians(camera.fov_deg) / 2)
    x_ndc, y_ndc = 2 * u / camera.width - 1, 1 - 2 * v / camera.height
    ray = forward + (x_ndc / f) * side + (y_ndc / f) * up  # forward component 1
    s = (plane_z - eye[2]) / ray[2]
    return float(s)  # the ray's forward component is 1, so s is the depth along the axis


def _within_pixel(depth_mm, camera, u: int, v: int, plane_z: float, tol_mm: float = 1.0) -> bool:
    """Whether a rendered depth lies between the plane's depths at pixel (u, v)'s corners
    (the renderer samples a point of the pixel; which one is its convention)."""
    corners = [_ray_to_plane(camera, u + a, v + b, plane_z) * 1000 for a in (0, 1) for b in (0, 1)]
    return min(corners) - tol_mm <= float(depth_mm) <= max(corners) + tol_mm


def test_linear_depth_inverts_the_projection():
    near, far = 0.05, 4.0
    z = np.array([0.1, 0.5, 1.0, 3.0])
    z_ndc = (far + near) / (far - near) - 2 * far * near / ((far - near) * z)  # OpenGL
    np.testing.assert_allclose(linear_depth((z_ndc + 1) / 2, near, far), z, rtol=1e-9)
    assert linear_depth(1.0, near, far) == pytest.approx(far)


@pytest.fixture(scope="module")
def scene():
    with ReachScene(load_robot("pr2_right_arm"), image_size=64) as s:
        yield s


def test_rendered_depth_matches_the_geometry(scene):
    """Table pixels at the table top's depth; the top face of a box nearer by what its
    height gives; RGB unchanged by asking for depth."""
    box = ObjectSpec(shape="box", dims=(0.10, 0.10, 0.12), rgba=(0.8, 0.2, 0.2, 1.0), mass=0.2, name="b")
    scene.reset(box, Placement(0.58, 0.0, 0.0))
    rgb, depth = scene.render(with_depth=True)
    assert rgb.shape == (64, 64, 3) and depth.shape == (64, 64) and depth.dtype == np.uint16
    np.testing.assert_array_equal(rgb, scene.render())
    cam = scene.camera
    for x, y in ((0.48, 0.25), (0.68, -0.25), (0.50, -0.12), (0.70, 0.2)):  # table top, beside the box
        u, v = np.floor(cam.project(np.array([x, y, TABLE_Z]))).astype(int)
        assert _within_pixel(depth[v, u], cam, u, v, TABLE_Z), (x, y)
    u, v = np.floor(cam.project(np.array([0.58, 0.0, TABLE_Z + 0.12]))).astype(int)
    assert _within_pixel(depth[v, u], cam, u, v, TABLE_Z + 0.12)  # the box's top face
    assert depth[v, u] < _ray_to_plane(cam, u + 0.5, v + 0.5, TABLE_Z) * 1000 - 100  # not the table behind it


def test_rgbd_encoding_and_its_errors():
    rgb = np.full((2, 3, 3), 7, np.uint8)
    low, high = DEPTH_RANGE_M
    mm = np.array([[0, 250, 875], [1500, 9000, 65535]], np.uint16)
    out = rgbd_image(rgb, mm)
    assert out.dtype == np.uint8 and out.shape == (2, 3, 4)
    np.testing.assert_array_equal(out[..., :3], rgb)
    assert out[..., 3].tolist() == [[0, 0, round((0.875 - low) / (high - low) * 255)], [255, 255, 255]]
    with pytest.raises(ValueError, match="same H, W"):
        rgbd_image(rgb, mm[:, :2])
    with pytest.raises(ValueError, match="uint8 rgb"):
        rgbd_image(rgb.astype(np.float32), mm)


def test_colour_permutation_keeps_the_depth_channel():
    torch.manual_seed(0)
    image = torch.rand(16, 4, 5, 5)
    out = permute_colour_channels(image)
    torch.testing.assert_close(out[:, 3], image[:, 3])
    assert not torch.equal(out[:, :3], image[:, :3])
    torch.testing.assert_close(out[:, :3].sort(dim=1).values, image[:, :3].sort(dim=1).values)


def test_image_to_tensor_channels():
    rgbd = np.zeros((8, 8, 4), np.uint8)
    rgbd[..., 3] = 255
    assert image_to_tensor(rgbd, 4)[0, 3].min() == 1.0
    assert image_to_tensor(rgbd).shape == (1, 3, 8, 8)  # RGB: a 4th channel is alpha
    with pytest.raises(ValueError, match="RGB-D images with 4 channels"):
        image_to_tensor(np.zeros((8, 8, 3), np.uint8), 4)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    return tmp_path_factory.mktemp("depth")


@pytest.fixture(scope="module")
def depth_checkpoints(compose, workspace):
    out = {}
    # the chunking policies (act, diffusion): tests/visuomotor/policies/test_policy_chunk_train.py
    for model in ("cnn_dmp", "velocity"):
        run = workspace / "outputs" / f"run-{model}"
        cfg = compose(
            "train",
            f"paths.root_dir={workspace}",
            *TINY,
            *TINY_MODEL,
            f"model={model}",
            "++trainer.max_steps=2",
            "++trainer.limit_val_batches=1",
            f"paths.output_dir={run}",
        )
        out[model] = train.main(cfg)
    return out


def test_depth_dataset_files_and_items(depth_checkpoints, workspace):
    data = load_dataset(workspace / "data" / "tinyd")
    assert data.config.depth
    rec = data.split("train")[0]
    depth, rgb = rec.frames("depth"), rec.frames()
    assert depth.shape == rgb.shape[:-1] == (30, 32, 32) and depth.dtype == np.uint16
    assert "depth" not in rec.arrays  # images are read on demand
    low, high = DEPTH_RANGE_M
    assert low * 1000 < np.median(depth) < high * 1000  # the table, about 1 m away
    item = DMPReachDataset(data, "train")[0]
    assert item["image"].shape == (4, 32, 32)
    np.testing.assert_allclose(
        item["image"][3].numpy(), rgbd_image(rgb[0], depth[0])[..., 3] / 255.0, atol=1e-6
    )
    assert VelocityReachDataset(data, "train")[5]["image"].shape == (4, 32, 32)
    for encoding in ("range", "relief"):  # the frames a DMP item needs, encoded alone: the same values
        every = policy_frames(rec, True, encoding)
        assert every.shape == (30, 32, 32, 4)
        np.testing.assert_array_equal(policy_frames(rec, True, encoding, steps=slice(0, 1)), every[:1])
        np.testing.assert_array_equal(policy_frames(rec, False, encoding, steps=slice(3, 7)), rgb[3:7])
        relief = DMPReachDataset(data, "train", depth_encoding=encoding).frames[0].numpy()
        np.testing.assert_array_equal(relief, every[0])


def test_depth_policies_evaluate_in_closed_loop(depth_checkpoints, compose, workspace):
    for kind, path in depth_checkpoints.items():
        policy = load_policy(path)
        assert policy.hparams.depth and policy.input_channels == 4
        with pytest.raises(ValueError, match="RGB-D images with 4 channels"):
            (policy.plan if kind == "cnn_dmp" else policy.act)(np.zeros((32, 32, 3), np.uint8), np.zeros(7))
    cfg = compose(
        "evaluate",
        f"paths.root_dir={workspace}",
        *TINY,
        "eval.colour_tta=[]",
        "eval.max_steps=8",
        "eval.n_gifs=1",
        f"ckpt=[{depth_checkpoints['cnn_dmp']},{depth_checkpoints['velocity']}]",
    )
    out_dir = workspace / "eval"
    evaluate.evaluate(cfg, out_dir)
    metrics = json.loads((out_dir / "metrics.json").read_text())
    assert set(metrics) == {"cnn_dmp", "velocity"} and all(m["episodes"] == 2 for m in metrics.values())
    assert sorted((out_dir / "rollouts").glob("*.gif"))  # GIFs are written from the RGB part


def test_observe_gives_each_policy_its_input(depth_checkpoints, scene):
    scene.reset()
    rgbd = observe(scene, PlanController(load_policy(depth_checkpoints["cnn_dmp"]), 0.1))
    assert rgbd.shape == (64, 64, 4)
    np.testing.assert_array_equal(rgbd[..., :3], scene.render())


def test_rgb_and_rgbd_do_not_mix_in_training(depth_checkpoints, workspace):
    """Training data must match the checkpoint's input: an RGB dataset is refused, naming the key."""
    policy = load_policy(depth_checkpoints["cnn_dmp"])
    config = load_dataset(workspace / "data" / "tinyd").config
    policy.check_data(config)
    with pytest.raises(ValueError, match="built with depth=True, the dataset has depth=False"):
        policy.check_data(dataclasses.replace(config, depth=False))


def test_evaluation_renders_each_policy_its_input(depth_checkpoints, compose, workspace):
    """An RGB dataset's cases serve an RGB-D checkpoint (the evaluator renders each policy
    its own input, as experiment=quick does for CNN -> DMP); any other mismatch is refused."""
    common = [
        "evaluate",
        f"paths.root_dir={workspace}",
        *TINY,
        "eval.colour_tta=[]",
        "data.depth=false",
        "data.name=tinyrgb",
        "eval.n_gifs=0",
    ]
    cfg = compose(*common, "eval.max_steps=4", f"ckpt={depth_checkpoints['cnn_dmp']}", "eval.kinds=[cnn_dmp]")
    metrics = evaluate.evaluate(cfg, workspace / "eval-rgb-cases")
    assert metrics["cnn_dmp"]["episodes"] == 2 and "tinyrgb" in metrics["cnn_dmp"]["cases"]
    assert not load_dataset(workspace / "data" / "tinyrgb").config.depth
    cfg = compose(
        *common, "data.image_size=24", f"ckpt={depth_checkpoints['cnn_dmp']}", "eval.kinds=[cnn_dmp]"
    )
    with pytest.raises(ValueError, match="built with image_size=32, the dataset has image_size=24"):
        evaluate.evaluate(cfg, workspace / "eval-mix")


def test_quick_gives_cnn_dmp_depth_and_velocity_rgb(compose):
    """experiment=quick: each policy trains on its validated input; evaluate.py reads the RGB
    dataset's cases (the same objects and placements)."""
    seen = {}
    for model in ("cnn_dmp", "velocity"):
        cfg = compose("train", "experiment=quick", f"model={model}", "seed=5")
        data = OmegaConf.to_container(cfg.data, resolve=True)
        args = POLICIES[model].data_arguments(data)  # what train.py gives the policy
        seen[model] = (args["depth"], args["depth_encoding"], cfg.data.depth_encoding, cfg.data.name)
    assert seen == {
        "cnn_dmp": (True, "relief", "relief", "quick96o600dvwle_s5"),
        "velocity": (False, "range", "range", "quick96o600dvwle_s5"),
    }
    train_cfg = compose("train", "experiment=quick", "model=velocity", "seed=5")
    assert train_cfg.data.depth and not train_cfg.data.input_depth  # one RGB-D dataset, RGB input
    cfg = compose("evaluate", "experiment=quick", "seed=5")
    assert (cfg.data.depth, cfg.data.name) == (True, "quick96o600dvwle_s5")


def test_an_rgb_policy_trains_on_an_rgbd_datasets_colour_frames(depth_checkpoints, compose, workspace):
    """data.input_depth=false: the items of an RGB-D dataset are its RGB frames (the same
    bytes), an RGB policy trains on them, and RGB-D items from an RGB dataset are refused."""
    data = load_dataset(workspace / "data" / "tinyd")
    rgb_items, rgbd_items = DMPReachDataset(data, "train", depth=False), DMPReachDataset(data, "train")
    assert rgb_items[0]["image"].shape == (3, 32, 32)
    np.testing.assert_array_equal(rgb_items[0]["image"].numpy(), rgbd_items[0]["image"][:3].numpy())
    assert VelocityReachDataset(data, "train", depth=False)[5]["image"].shape == (3, 32, 32)
    run = workspace / "outputs" / "run-velocity-rgb"
    cfg = compose(
        "train",
        f"paths.root_dir={workspace}",
        *TINY,
        *TINY_MODEL,
        "model=velocity",
        "data.input_depth=false",
        "++trainer.max_steps=2",
        "++trainer.limit_val_batches=1",
        f"paths.output_dir={run}",
    )
    policy = load_policy(train.main(cfg))
    assert policy.input_channels == 3 and not policy.hparams.depth
    with pytest.raises(ValueError, match="input_depth: true needs a dataset recorded with depth: true"):
        ReachDataModule(name="x", root=workspace / "data", depth=False, input_depth=True)


def test_plane_depth_is_the_pinhole_geometry_and_the_rendered_table(scene):
    """The relief reference: the table plane's depth per pixel centre is the plain pinhole
    ray of ``_ray_to_plane``. The TinyRenderer's table top lies a few mm nearer than the
    plane (its depth interpolation across the table's two big triangles; the offset shrinks
    with resolution): at 96 px, the quick experiment's, within RELIEF_DEADBAND_MM, so the
    table encodes as 0."""
    cam = scene.camera
    plane = cam.plane_depth_mm(TABLE_Z)
    assert plane.shape == (64, 64)
    for u, v in ((5, 40), (32, 32), (60, 50), (20, 25)):
        assert plane[v, u] == pytest.approx(_ray_to_plane(cam, u + 0.5, v + 0.5, TABLE_Z) * 1000, rel=1e-9)
    np.testing.assert_array_equal(
        plane, plane_depth_mm(cam.view_matrix, cam.projection_matrix, 64, 64, TABLE_Z)
    )
    with ReachScene(load_robot("pr2_right_arm"), image_size=96) as big:
        cam, plane = big.camera, big.camera.plane_depth_mm(TABLE_Z)
        rgb, depth = big.render(with_depth=True)
    table = np.zeros_like(plane, dtype=bool)
    for x in np.linspace(0.40, 0.90, 11):  # pixels well inside the table top
        for y in np.linspace(-0.4, 0.4, 11):
            u, w = np.floor(cam.project(np.array([x, y, TABLE_Z]))).astype(int)
            if 0 <= u < 96 and 0 <= w < 96:
                table[w, u] = True
    gap = plane[table] - depth[table].astype(float)
    assert table.sum() > 80 and gap.min() > 0 and gap.max() < RELIEF_DEADBAND_MM, (gap.min(), gap.max())
    relief = rgbd_image(rgb, depth, plane)[..., 3]
    assert relief[table].max() == 0  # the table is 0 in the relief encoding
    with pytest.raises(ValueError, match=r"relief_reference: expected \(H, W\) = \(96, 96\)"):
        rgbd_image(rgb, depth, plane[:10])


def test_relief_encoding_measures_height_in_front_of_the_table(scene):
    """A box's top face stands in front of the table plane by the ray length its height
    gives; a taller box encodes brighter; the colour channels are unchanged."""
    cam = scene.camera
    plane = cam.plane_depth_mm(TABLE_Z)
    levels = {}
    for height in (0.06, 0.12):
        box = ObjectSpec(
            shape="box", dims=(0.08, 0.08, height), rgba=(0.2, 0.6, 0.2, 1.0), mass=0.2, name="b"
        )
        scene.reset(box, Placement(0.58, 0.0, 0.0))
        rgb, depth = scene.render(with_depth=True)
        out = rgbd_image(rgb, depth, plane)
        np.testing.assert_array_equal(out[..., :3], rgb)
        u, v = np.floor(cam.project(np.array([0.58, 0.0, TABLE_Z + height]))).astype(int)
        v += 1  # just below the top face's far edge: on the top face
        expected = (
            _ray_to_plane(cam, u + 0.5, v + 0.5, TABLE_Z)
            - _ray_to_plane(cam, u + 0.5, v + 0.5, TABLE_Z + height)
        ) * 1000
        expected = (expected - RELIEF_DEADBAND_MM) / RELIEF_RANGE_MM * 255
        assert abs(int(out[v, u, 3]) - expected) <= 3, (height, out[v, u, 3], expected)
        levels[height] = int(out[v, u, 3])
    assert levels[0.12] > levels[0.06] > 0


@pytest.fixture(scope="module")
def relief_checkpoint(compose, workspace, depth_checkpoints):
    run = workspace / "outputs" / "run-cnn_dmp-relief"
    cfg = compose(
        "train",
        f"paths.root_dir={workspace}",
        *TINY,
        *TINY_MODEL,
        "model=cnn_dmp",
        "data.depth_encoding=relief",
        "++trainer.max_steps=2",
        "++trainer.limit_val_batches=1",
        f"paths.output_dir={run}",
    )
    return train.main(cfg)


def test_relief_training_items_are_what_evaluation_renders(relief_checkpoint, workspace):
    """data.depth_encoding=relief: the checkpoint records it, its training items hold the
    relief channel, and the evaluator's first observation of an episode (the same object at
    the same placement) is that episode's training image, byte for byte."""
    policy = load_policy(relief_checkpoint)
    assert policy.hparams.depth_encoding == "relief" and policy.input_channels == 4
    data = load_dataset(workspace / "data" / "tinyd")
    rec = data.split("train")[0]
    item = DMPReachDataset(data, "train", depth_encoding="relief")[0]
    relief = item["image"][3].numpy() * 255
    assert (
        relief.max() > 20 and np.median(relief) <= 2
    )  # the object; the table: 0 at 96 px, a level or two at this coarse 32 px
    with ReachScene(load_robot(data.config.robot), image_size=data.config.image_size) as scene:
        scene.reset(rec.obj, rec.placement)
        first = observe(scene, PlanController(policy, 0.1))
    np.testing.assert_array_equal(
        first, (item["image"].permute(1, 2, 0).numpy() * 255).round().astype(np.uint8)
    )
    assert first.shape == (32, 32, 4)


def test_depth_encoding_mismatches_are_refused(
    relief_checkpoint, depth_checkpoints, compose, workspace, capsys
):
    with pytest.raises(
        ValueError, match="depth_encoding: 'relief' is an encoding of the depth channel; the input is RGB"
    ):
        ReachDataModule(
            name="x", root=workspace / "data", depth=True, input_depth=False, depth_encoding="relief"
        )
    with pytest.raises(
        ValueError, match=r"depth_encoding: expected one of \('range', 'relief'\), got 'height'"
    ):
        ReachDataModule(name="x", root=workspace / "data", depth=True, depth_encoding="height")
    with pytest.raises(ValueError, match="depth_encoding: 'relief' needs depth=true"):
        POLICIES["cnn_dmp"](n_basis=5, channels=[4, 4], hidden=[8], image_size=32, depth_encoding="relief")
    # a model config that sets a data setting is refused (train.py gives the data config's)
    cfg = compose(
        "train",
        f"paths.root_dir={workspace}",
        *TINY,
        *TINY_MODEL,
        "model=cnn_dmp",
        "data.depth_encoding=relief",
        "+model.depth_encoding=range",
        "++trainer.max_steps=1",
        "++trainer.limit_val_batches=1",
        f"paths.output_dir={workspace / 'outputs' / 'run-mismatch'}",
    )
    with pytest.raises(SystemExit):
        train.main(cfg)
    assert "model.depth_encoding: set by the data config (data.depth_encoding)" in capsys.readouterr().err
    # training a range checkpoint on relief items names both encodings
    import lightning as L

    policy = load_policy(depth_checkpoints["cnn_dmp"]).train()
    relief = ReachDataModule(
        **{**_tiny_data(), "seed": 42, "depth_encoding": "relief", "root": workspace / "data"}
    )
    trainer = L.Trainer(max_steps=1, logger=False, enable_checkpointing=False, enable_progress_bar=False)
    with pytest.raises(
        ValueError, match="built with depth_encoding='range', the datamodule serves depth_encoding='relief'"
    ):
        trainer.fit(policy, datamodule=relief)
