"""SpatialSoftmax, the keypoint trunk and the training augmentations: analytic keypoints,
shapes, gradients, masks on rendered frames."""

import numpy as np
import pytest
import torch

from lfd.visuomotor.policies.vision import (
    KeypointEncoder,
    SpatialSoftmax,
    foreground_mask,
    image_to_tensor,
    permute_colour_channels,
    scale_foreground_brightness,
)


@pytest.mark.parametrize(("h", "w", "row", "col"), [(5, 7, 0, 0), (5, 7, 4, 6), (8, 8, 3, 5), (16, 9, 10, 2)])
def test_one_hot_keypoint_is_its_location(h, w, row, col):
    """A (scaled) one-hot feature map puts the expected coordinate on the hot pixel:
    x = -1 + 2 col / (W - 1), y = -1 + 2 row / (H - 1)."""
    x = torch.zeros(2, 3, h, w)
    x[:, 1, row, col] = 1e4  # softmax of a huge one-hot is the one-hot itself
    keypoints = SpatialSoftmax(temperature=1.0)(x).view(2, 3, 2)
    expected = torch.tensor([-1 + 2 * col / (w - 1), -1 + 2 * row / (h - 1)])
    torch.testing.assert_close(keypoints[:, 1], expected.expand(2, 2))
    # channels 0 and 2 are uniform maps: their keypoint is the image centre
    torch.testing.assert_close(keypoints[:, 0], torch.zeros(2, 2), atol=1e-6, rtol=0)


def test_low_temperature_sharpens_to_the_argmax():
    x = torch.zeros(1, 1, 6, 6)
    x[0, 0, 1, 4] = 1.0  # a weak peak: at temperature 1 the expectation is pulled to the centre
    warm = SpatialSoftmax(temperature=1.0)(x)
    cold = SpatialSoftmax(temperature=1e-3)(x)
    target = torch.tensor([[-1 + 2 * 4 / 5, -1 + 2 * 1 / 5]])
    torch.testing.assert_close(cold, target)
    assert (warm - target).abs().max() > 0.3


def test_temperature_is_learned_and_positive():
    ss = SpatialSoftmax(temperature=0.5)
    assert ss.temperature.item() == pytest.approx(0.5)
    x = torch.randn(2, 4, 6, 6)
    ss(x).pow(2).sum().backward()
    assert ss.log_temperature.grad is not None and ss.log_temperature.grad.abs() > 0
    fixed = SpatialSoftmax(temperature=0.5, learn_temperature=False)
    assert not any(p.requires_grad for p in fixed.parameters())
    with pytest.raises(ValueError, match="temperature"):
        SpatialSoftmax(temperature=0.0)


def test_keypoint_encoder_shapes_and_range():
    enc = KeypointEncoder(channels=(8, 8, 8, 16))
    out = enc(torch.rand(3, 3, 32, 40))
    assert out.shape == (3, 32) and enc.out_dim == 32
    assert out.abs().max() <= 1.0


def test_spread_is_the_standard_deviation_of_a_uniform_block_in_cells():
    """A channel hot and uniform on a block of 2 columns x 4 rows spreads by the standard deviation
    of 2 and 4 consecutive cells (0.5 and sqrt(5) / 2), wherever the block is; a one-hot by (almost)
    nothing; the encoder appends the first ``spread_channels`` channels' spreads after the rest."""
    x = torch.full((2, 2, 24, 30), -1e4)
    x[0, 0, 10:14, 20:22] = 0.0
    x[1, 0, 0:4, 3:5] = 0.0
    x[:, 1, 5, 7] = 0.0
    spread = SpatialSoftmax(temperature=1.0).spread(x).view(2, 2, 2)
    torch.testing.assert_close(spread[:, 0], torch.tensor([[0.5, 5**0.5 / 2]]).expand(2, 2))
    assert float(spread[:, 1].max()) < 0.01
    enc = KeypointEncoder(channels=(4, 6), global_pool=True)
    image = torch.rand(3, 3, 32, 32)
    plain = enc(image)
    enc.spread_channels = 2
    out = enc(image)
    assert enc.out_dim == 3 * 6 + 4 and out.shape == (3, 22)
    torch.testing.assert_close(out[:, :18], plain)
    maps = enc.convs(image - 0.5)
    torch.testing.assert_close(out[:, 18:], enc.softargmax.spread(maps[:, :2]))


def test_global_pool_appends_each_channels_maximum():
    torch.manual_seed(0)
    enc = KeypointEncoder(channels=(4, 8), global_pool=True)
    image = torch.rand(2, 3, 20, 20)
    out = enc(image)
    assert out.shape == (2, 24) and enc.out_dim == 24
    maps = enc.convs(image - 0.5)
    torch.testing.assert_close(out[:, 16:], maps.flatten(2).max(dim=2).values)
    torch.testing.assert_close(out[:, :16], enc.softargmax(maps))
    # the keypoints alone cannot tell a faint feature from a strong one at the same place; the maxima can
    with torch.no_grad():
        scaled = KeypointEncoder(channels=(4, 8), global_pool=True)
        scaled.load_state_dict(enc.state_dict())
        scaled.convs[-1].weight.mul_(3.0)
        scaled.convs[-1].bias.mul_(3.0)
        scaled.softargmax.log_temperature.add_(np.log(3.0))
    other = scaled(image)
    torch.testing.assert_close(other[:, :16], out[:, :16])
    torch.testing.assert_close(other[:, 16:], 3.0 * out[:, 16:])


def test_image_to_tensor_accepts_rendered_and_dataset_layouts():
    frame = np.random.default_rng(0).integers(0, 256, size=(12, 10, 3), dtype=np.uint8)
    t = image_to_tensor(frame)
    assert t.shape == (1, 3, 12, 10) and t.dtype == torch.float32
    torch.testing.assert_close(t[0, :, 2, 3], torch.tensor(frame[2, 3] / 255.0, dtype=torch.float32))
    chw = torch.rand(2, 3, 12, 10)
    assert image_to_tensor(chw) is not None and torch.equal(image_to_tensor(chw), chw)
    with pytest.raises(ValueError, match="channels-last"):
        image_to_tensor(np.zeros((3, 12, 10), dtype=np.uint8))


def test_colour_permutation_reorders_channels_per_image():
    torch.manual_seed(0)
    image = torch.stack([torch.full((4, 5), float(c)) for c in range(3)])[None].repeat(
        64, 1, 1, 1
    )  # channel c == c
    out = permute_colour_channels(image)
    orders = out[:, :, 0, 0].long()
    assert torch.equal(orders.sort(dim=1).values, torch.arange(3).expand(64, 3))  # a permutation per image
    assert len({tuple(o.tolist()) for o in orders}) == 6  # all six orders occur
    assert torch.equal(out, orders[:, :, None, None].float().expand_as(out))  # whole planes move together


@pytest.fixture(scope="module")
def rendered_batch():
    """RGB-D frames (uint8, the policies' input) of one box at three placements and the
    object's pixels in each, found independently: where the colour differs from a render
    of the empty scene."""
    from lfd.robots import load_robot
    from lfd.sim.depth import rgbd_image
    from lfd.sim.objects import ObjectSpec, Placement
    from lfd.sim.scene import ReachScene

    box = ObjectSpec("box", (0.05, 0.06, 0.10), (0.2, 0.5, 0.8, 1.0), 0.3, "box")
    frames, objects = [], []
    with ReachScene(load_robot("pr2_right_arm"), image_size=64) as scene:
        scene.reset()
        empty = scene.render()
        for x, y in ((0.5, -0.2), (0.6, 0.0), (0.65, 0.2)):
            scene.reset(box, Placement(x, y, 0.3))
            rgb, depth = scene.render(with_depth=True)
            frames.append(rgbd_image(rgb, depth))
            objects.append((rgb != empty).any(axis=-1))
    return image_to_tensor(np.stack(frames), 4), torch.as_tensor(np.stack(objects))


def test_foreground_mask_finds_the_object_in_a_rendered_batch(rendered_batch):
    image, objects = rendered_batch
    mask = foreground_mask(image)[:, 0]
    assert mask.shape == objects.shape and objects.sum(dim=(1, 2)).min() > 20
    inter, union = (mask & objects).sum(dim=(1, 2)), (mask | objects).sum(dim=(1, 2))
    assert (inter / union).min() > 0.8  # a rim at the base, nearly at the table's depth, may be missed
    assert not (mask & ~objects).any()  # never a table pixel
    assert not foreground_mask(image[:1]).any()  # a batch of one has no reference: no foreground
    with pytest.raises(ValueError, match=r"RGB-D batch \(B, 4, H, W\)"):
        foreground_mask(image[:, :3])


def test_brightness_augment_scales_only_the_objects_colour(rendered_batch):
    image, _ = rendered_batch
    image = image.repeat(200, 1, 1, 1)  # three placements, 200 draws each
    torch.manual_seed(0)
    out = scale_foreground_brightness(image, 0.3, 2.0)
    mask = foreground_mask(image).expand(-1, 3, -1, -1)
    assert torch.equal(out[:, 3], image[:, 3])  # depth untouched
    assert torch.equal(out[:, :3][~mask], image[:, :3][~mask])  # table and floor untouched
    assert out.min() >= 0 and out.max() <= 1
    # one factor per image: unclipped foreground pixels are all scaled by it
    ratio = torch.where(
        mask & (out[:, :3] < 1) & (image[:, :3] > 0.05), out[:, :3] / image[:, :3].clamp(min=1e-6), torch.nan
    )
    factor = ratio.flatten(1).nanmedian(dim=1).values
    spread = (ratio.flatten(1) - factor[:, None]).abs().nan_to_num(0).amax(dim=1)
    assert spread.max() < 0.05
    assert factor.min() >= 0.3 - 1e-3 and factor.max() <= 2.0 + 1e-3
    # log-uniform: half the draws below the geometric mean of the range
    assert abs((factor < (0.3 * 2.0) ** 0.5).float().mean().item() - 0.5) < 0.08
    with pytest.raises(ValueError, match="0 < low <= high"):
        scale_foreground_brightness(image, 0.0, 2.0)
