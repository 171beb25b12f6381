"""Flat clutter: the sampler's ranges and keep-away rule, the stored form, the scene drawing the
items in its images but not in its physics."""

import math

import numpy as np
import pytest

from lfd.robots import load_robot
from lfd.sim._pybullet import pybullet as p
from lfd.sim.clutter import (
    CLUTTER_CLEARANCE,
    CLUTTER_RANGES,
    CLUTTER_REGION,
    MAX_CLUTTER,
    FlatItem,
    clutter_as_array,
    clutter_from_array,
    sample_clutter,
)
from lfd.sim.objects import ObjectSpec, Placement
from lfd.sim.scene import ReachScene

BOX = ObjectSpec("box", (0.06, 0.08, 0.10), (0.9, 0.1, 0.1, 1.0), 0.3, "box")
CAN = ObjectSpec("cylinder", (0.04, 0.12), (0.1, 0.6, 0.9, 1.0), 0.3, "can")


def test_footprint_radius_is_the_half_diagonal_of_a_box_and_the_radius_of_a_round_object():
    assert BOX.footprint_radius == pytest.approx(0.05)
    assert CAN.footprint_radius == 0.04
    assert ObjectSpec("sphere", (0.03,), (1, 1, 1, 1), 0.1).footprint_radius == 0.03


def test_sampled_items_honour_the_ranges_keep_clear_of_the_object_and_each_other():
    place = Placement(0.6, 0.05, 0.4)
    rng = np.random.default_rng(0)
    draws = [sample_clutter(rng, MAX_CLUTTER, BOX, place) for _ in range(40)]
    again = np.random.default_rng(0)
    assert [sample_clutter(again, MAX_CLUTTER, BOX, place) for _ in range(3)] == draws[:3]
    r = CLUTTER_RANGES
    for items in draws:
        assert 1 <= len(items) <= MAX_CLUTTER
        circles = [(place.x, place.y, BOX.footprint_radius)] + [(i.x, i.y, i.radius) for i in items]
        for i in items:
            assert r["length"][0] <= i.length <= r["length"][1]
            assert i.width <= i.length and i.width <= r["width"][1]
            assert r["height"][0] <= i.height <= r["height"][1]
            assert r["value"][0] - 1e-9 <= max(i.colour) <= r["value"][1] + 1e-9
            assert CLUTTER_REGION["x"][0] <= i.x <= CLUTTER_REGION["x"][1]
            assert CLUTTER_REGION["y"][0] <= i.y <= CLUTTER_REGION["y"][1]
        for a in range(len(circles)):
            for b in range(a + 1, len(circles)):
                (xa, ya, ra), (xb, yb, rb) = circles[a], circles[b]
                assert math.hypot(xa - xb, ya - yb) >= ra + rb + CLUTTER_CLEARANCE - 1e-12
    counts = [len(items) for items in draws]
    assert max(counts) == MAX_CLUTTER and min(counts) < MAX_CLUTTER  # a full table gives fewer
    assert sample_clutter(rng, 0, BOX, place) == ()
    huge = ObjectSpec("box", (2.0, 2.0, 0.1), (1, 1, 1, 1), 1.0)  # covers the whole table
    assert sample_clutter(rng, 3, huge, place) == ()


def test_bad_counts_and_items_are_refused_naming_the_field():
    place = Placement(0.6, 0.0, 0.0)
    for n in (-1, MAX_CLUTTER + 1, 1.5, True):
        with pytest.raises(ValueError, match=r"sample_clutter: n must be an integer in \[0, 8\]"):
            sample_clutter(np.random.default_rng(0), n, BOX, place)
    with pytest.raises(ValueError, match="FlatItem.height: expected a length > 0 m"):
        FlatItem(0.5, 0.0, 0.0, 0.1, 0.05, 0.0)
    with pytest.raises(ValueError, match="FlatItem.x: expected a finite number"):
        FlatItem(float("nan"), 0.0, 0.0, 0.1, 0.05, 0.01)
    with pytest.raises(ValueError, match="FlatItem.colour: expected 3 values in"):
        FlatItem(0.5, 0.0, 0.0, 0.1, 0.05, 0.01, (1.2, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"clutter_from_array: expected \(n, 9\)"):
        clutter_from_array(np.zeros((2, 8)))


def test_items_round_trip_through_their_array():
    items = sample_clutter(np.random.default_rng(5), 4, CAN, Placement(0.55, -0.1, 0.0))
    a = clutter_as_array(items)
    assert a.shape == (len(items), 9) and a.dtype == np.float64
    assert clutter_from_array(a) == items
    assert clutter_as_array(()).shape == (0, 9) and clutter_from_array(np.zeros((0, 9))) == ()


def test_the_scene_draws_the_items_in_colour_and_depth_but_not_in_its_physics():
    """The items change the images only where they lie, bring the depth nearer by about their
    thickness there, leave the object's pixels, its physics and the physics world alone, and go without a
    trace; a bad value is refused in one line."""
    place = Placement(0.6, 0.0, 0.3)
    items = (
        FlatItem(0.50, 0.22, 0.3, 0.16, 0.10, 0.008, (0.9, 0.1, 0.8)),
        FlatItem(0.75, -0.22, -0.5, 0.20, 0.14, 0.004, (0.1, 0.8, 0.2)),
    )
    with ReachScene(load_robot("pr2_right_arm"), image_size=96) as scene:
        scene.reset(CAN, place)
        bodies = p.getNumBodies(physicsClientId=scene.client)
        rgb, depth = scene.render(with_depth=True)
        scene.set_clutter(items)
        scene.reset(CAN, place)  # lasts across reset
        assert p.getNumBodies(physicsClientId=scene.client) == bodies
        rgb2, depth2 = scene.render(with_depth=True)
        changed = np.any(rgb2 != rgb, axis=-1)
        assert changed.mean() > 0.01
        assert np.all(depth2[changed] <= depth[changed])
        lift = (depth.astype(int) - depth2.astype(int))[changed]
        # mm along the optical axis: an 8 mm top seen obliquely, and the items' side faces at their edges
        assert np.percentile(lift, 90) <= 12 and lift.max() <= 25
        on_magenta = (rgb2[..., 0] > 150) & (rgb2[..., 1] < 80) & (rgb2[..., 2] > 120)
        on_green = (rgb2[..., 1] > 120) & (rgb2[..., 0] < 80)
        assert on_magenta.sum() > 20 and on_green.sum() > 20  # both items in view, in their colours
        # the object's pixels (closer than the table by far) are untouched
        object_px = (depth.astype(int) < depth2.astype(int).max() - 60) & ~changed
        assert object_px.sum() > 0
        np.testing.assert_allclose(scene.object_pose()[:3, 3][:2], [place.x, place.y], atol=1e-6)
        wrist = scene.render_wrist()
        scene.set_clutter(())
        rgb3, depth3 = scene.render(with_depth=True)
        np.testing.assert_array_equal(rgb3, rgb)
        np.testing.assert_array_equal(depth3, depth)
        assert wrist.shape == (96, 96, 3)
        with pytest.raises(ValueError, match="ReachScene.set_clutter: expected a sequence of FlatItem"):
            scene.set_clutter([(0.5, 0.2)])
