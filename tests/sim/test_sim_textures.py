"""Table-top textures: the sampler's ranges, the images of each kind, the scene drawing them."""

import numpy as np
import pytest

from lfd.robots import load_robot
from lfd.sim.objects import ObjectSpec, Placement
from lfd.sim.scene import ReachScene
from lfd.sim.textures import TEXTURE_KINDS, TEXTURE_RANGES, TEXTURE_SIZE, TableTexture, sample_table_texture

BOX = ObjectSpec("box", (0.05, 0.06, 0.08), (0.9, 0.1, 0.1, 1.0), 0.3, "box")


def test_sampled_textures_honour_their_ranges_cover_every_kind_and_round_trip():
    rng = np.random.default_rng(0)
    textures = [sample_table_texture(rng) for _ in range(200)]
    assert textures[:5] == [sample_table_texture(r) for r in [np.random.default_rng(0)] for _ in range(5)]
    assert {t.kind for t in textures} == set(TEXTURE_KINDS)
    for t in textures:
        lo, hi = TEXTURE_RANGES["value"]
        assert lo - 1e-9 <= max(t.colour) <= hi + 1e-9  # HSV value = the largest channel
        assert TEXTURE_RANGES["contrast"][0] <= t.contrast <= TEXTURE_RANGES["contrast"][1]
        assert TEXTURE_RANGES["scale"][0] <= t.scale <= TEXTURE_RANGES["scale"][1]
        assert TableTexture.from_array(t.as_array()) == t
    values = [max(t.colour) for t in textures]
    assert min(values) < 0.35 and max(values) > 0.8  # dark and light tables both drawn


def test_each_kind_draws_its_pattern_within_the_contrast_and_the_same_pixels_every_time():
    base = (0.8, 0.5, 0.3)
    for kind in TEXTURE_KINDS:
        t = TableTexture(kind, base, 0.3, 5.0, 30.0, 7)
        img = t.image()
        assert img.shape == (TEXTURE_SIZE, TEXTURE_SIZE, 3) and img.dtype == np.uint8
        np.testing.assert_array_equal(img, t.image())
        top = np.round(255 * np.array(base))
        low = np.round(255 * np.array(base) * 0.7)
        assert np.all(img <= top + 1) and np.all(img >= low - 1)  # darkened by at most the contrast
        spread = img[..., 0].astype(int).max() - img[..., 0].astype(int).min()
        assert spread == 0 if kind == "plain" else spread > 20, (kind, spread)
    a, b = (
        TableTexture("wood", base, 0.3, 5.0, 0.0, 1).image(),
        TableTexture("wood", base, 0.3, 5.0, 90.0, 1).image(),
    )
    assert not np.array_equal(a, b)  # the angle turns the grain


def test_bad_texture_values_are_named():
    for kwargs, field in (
        ({"kind": "marble"}, "kind"),
        ({"colour": (1.2, 0.0, 0.0)}, "colour"),
        ({"contrast": 1.0}, "contrast"),
        ({"scale": 0.0}, "scale"),
        ({"angle_deg": float("nan")}, "angle_deg"),
        ({"seed": -1}, "seed"),
    ):
        with pytest.raises(ValueError, match=f"TableTexture.{field}"):
            TableTexture(**kwargs)
    with pytest.raises(ValueError, match="TableTexture.from_array: expected 8"):
        TableTexture.from_array(np.zeros(5))
    with pytest.raises(ValueError, match="kind index"):
        TableTexture.from_array(np.array([9, 0.5, 0.5, 0.5, 0.1, 4, 0, 0]))


def test_the_scene_draws_the_table_with_its_texture_not_the_depth_and_back_to_plain():
    """A texture recolours the table and leaves the object and the depth; it lasts across resets; None
    gives back exactly the plain table's images."""
    robot = load_robot("pr2_right_arm")
    with ReachScene(robot, image_size=48) as scene:
        scene.reset(BOX, Placement(0.58, 0.0, 0.0))
        rgb, depth = scene.render(with_depth=True)
        texture = TableTexture("tiles", (0.2, 0.3, 0.7), 0.3, 6.0, 20.0, 3)
        scene.set_table_texture(texture)
        scene.reset(BOX, Placement(0.58, 0.0, 0.0))
        tex_rgb, tex_depth = scene.render(with_depth=True)
        np.testing.assert_array_equal(tex_depth, depth)
        table = (slice(30, 34), slice(20, 28))  # a patch of table in front of the object
        assert np.abs(tex_rgb[table].astype(int) - rgb[table].astype(int)).mean() > 20
        assert tex_rgb[table][..., 2].mean() > tex_rgb[table][..., 0].mean()  # blue, the grey table is not
        for colour in ((0.9, 0.1, 0.1), (0.1, 0.9, 0.1), (0.9, 0.1, 0.1)):  # each texture its own, in turn
            scene.set_table_texture(TableTexture("plain", colour))
            scene.reset(BOX, Placement(0.58, 0.0, 0.0))
            patch = scene.render()[table].reshape(-1, 3).mean(axis=0)
            assert np.argmax(patch) == np.argmax(colour), (colour, patch)
        scene.set_table_texture(None)
        scene.reset(BOX, Placement(0.58, 0.0, 0.0))
        np.testing.assert_array_equal(scene.render(), rgb)
        with pytest.raises(ValueError, match="ReachScene.set_table_texture"):
            scene.set_table_texture("oak")
