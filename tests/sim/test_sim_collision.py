"""The collision world and the one self-collision rule (lfd.sim.collision)."""

from __future__ import annotations

import doctest
from types import SimpleNamespace

import numpy as np
import pytest

from lfd.robots import load_robot
from lfd.sim import collision
from lfd.sim.collision import CollisionWorld
from lfd.sim.scene import ReachScene

#: The rule's pairs per robot (links: -1 base, 0..n-1 the joints' children); the PR2's are the
#: reaching scenes' (the main job's self-collision filter).
PAIRS = {
    "pr2_right_arm": [(-1, 1), (-1, 2), (0, 2), (2, 4), (4, 6)],
    "sawyer": [(-1, 1)],
    "wam4": [(0, 2)],
}


def test_doctest():
    result = doctest.testmod(collision, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0


@pytest.mark.parametrize("name", sorted(PAIRS))
def test_one_rule_for_scenes_and_collision_worlds(name):
    robot = load_robot(name)
    with ReachScene(robot, image_size=8) as scene:
        assert scene.overlapping_links == PAIRS[name]
    world = CollisionWorld(robot)
    links = range(-1, robot.n_dof)
    candidates = {(a, b) for a in links for b in links if b > a + 1}
    assert set(world.self_pairs) == candidates - set(PAIRS[name])
    world.close()


def test_obstacles_are_added_and_removed():
    world = CollisionWorld(load_robot("wam4"))
    box = SimpleNamespace(center=np.array([0.4, 0, 0.6]), size=np.array([0.2, 0.2, 0.2]), yaw=0.0)
    bent = np.array([0.0, 0.0, 0.0, 1.57])
    world.add_obstacle(box)
    assert world.check(bent).kind == "obstacle"
    world.remove_obstacle(box)
    assert not world.check(bent).in_collision
    with pytest.raises(ValueError, match="not an obstacle"):
        world.remove_obstacle(box)
    at_base = SimpleNamespace(center=np.zeros(3), size=np.full(3, 0.1), yaw=0.0)
    assert world.base_overlaps(at_base) and not world.obstacles
    world.close()
