"""The honest evaluation: scenario validation, the metric definitions, cluster
intervals and what an episode records about contacts and the object."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from lfd.robots import load_robot
from lfd.sim.approach import TABLE_Z, plan_approach
from lfd.sim.objects import ObjectSpec, Placement
from lfd.visuomotor.data import GeneratorConfig
from lfd.visuomotor.eval.evaluator import Case, ReachEvaluator
from lfd.visuomotor.eval.metrics import cluster_bootstrap_ci, summarise, wilson_interval
from lfd.visuomotor.eval.rollout import EpisodeTrace
from lfd.visuomotor.eval.scenario import ScenarioError, load_scenario

ROOT = Path(__file__).resolve().parents[3]
OBJECTS = """
objects:
  - {name: can, shape: cylinder, radius: 0.035, height: 0.14, rgba: [1.0, 0.5, 0.0, 1.0]}
  - {name: block, shape: box, size: [0.05, 0.07, 0.06], rgba: [0.5, 0.0, 0.5, 1.0]}
"""


@pytest.fixture(scope="module")
def robot():
    return load_robot("pr2_right_arm")


def scenario(tmp_path: Path, placements: str, objects: str = OBJECTS) -> Path:
    path = tmp_path / "s.yaml"
    path.write_text(objects + "placements:\n" + placements)
    return path


def test_yaw_in_degrees_must_be_explicit(tmp_path):
    with pytest.raises(
        ScenarioError, match=r"placements\[1\]: yaw = 45.0 rad lies outside \[-pi, pi\].*yaw_deg: 45"
    ):
        load_scenario(scenario(tmp_path, "  - [0.55, 0.0, 0.3]\n  - [0.55, 0.05, 45]\n"))
    sc = load_scenario(
        scenario(tmp_path, "  - {x: 0.55, y: 0.05, yaw_deg: 45}\n  - {x: 0.6, y: 0.0, yaw: -1.0}\n")
    )
    assert sc.placements[0].yaw == pytest.approx(math.pi / 4) and sc.placements[1].yaw == pytest.approx(-1.0)
    with pytest.raises(ScenarioError, match=r"placements\[0\]: give exactly one of 'yaw'"):
        load_scenario(scenario(tmp_path, "  - {x: 0.55, y: 0.05, yaw: 0.1, yaw_deg: 45}\n"))
    with pytest.raises(ScenarioError, match=r"placements\[0\]: field 'yaw_deg' must be a number of degrees"):
        load_scenario(scenario(tmp_path, "  - {x: 0.55, y: 0.05, yaw_deg: 400}\n"))


def test_placement_out_of_camera_image_is_an_error(tmp_path):
    # on the table (x <= 0.95, |y| <= 0.45) but the can's box leaves the 45 deg fixed camera
    path = scenario(tmp_path, "  - [0.55, 0.0, 0.0]\n  - [0.45, -0.40, 0.0]\n")
    with pytest.raises(
        ScenarioError, match=r"objects\[0\] \(can\) at placements\[1\] .* leaves the camera image"
    ):
        load_scenario(path)


def test_placement_out_of_reach_is_an_error(tmp_path, robot):
    # inside the camera image and on the table, but 0.9 m out: beyond the scripted expert's IK
    path = scenario(tmp_path, "  - [0.55, 0.0, 0.0]\n  - [0.90, 0.0, 0.0]\n")
    assert load_scenario(path).placements[1].x == 0.9  # no robot given: no reach check
    with pytest.raises(
        ScenarioError,
        match=r"objects\[1\] \(block\) at placements\[1\] \(0.9, 0.0\) m is out of reach \(top approach\)",
    ):
        load_scenario(path, robot=robot)


def test_objects_outside_training_ranges_warn_and_are_marked(tmp_path, capsys):
    import warnings

    objects = (
        OBJECTS
        + "  - {name: jar, shape: cylinder, radius: 0.044, height: 0.05, rgba: [0.9, 0.9, 0.8, 1.0]}\n"
    )
    path = scenario(
        tmp_path, "  - {x: 0.55, y: 0.0, yaw_deg: 0}\n  - {x: 0.72, y: 0.0, yaw_deg: 0}\n", objects
    )
    with pytest.warns(UserWarning, match=r"objects\[2\] \(jar\): height 0.050 m outside \[0.06, 0.24\]"):
        sc = load_scenario(path, training=GeneratorConfig())
    assert "outside the training ranges" in capsys.readouterr().out
    assert sc.ood(0, 0) == "" and sc.ood(1, 0) == ""
    assert "height" in sc.ood(2, 0) and "x 0.720 m outside [0.45, 0.7]" in sc.ood(0, 1)
    with warnings.catch_warnings():  # the wide sizes hold the jar (and the placements stay as they were)
        warnings.simplefilter("ignore")
        wide = load_scenario(path, training=GeneratorConfig(sizes="wide"))
    assert wide.ood(2, 0) == "" and "x 0.720 m" in wide.ood(0, 1)
    narrow = GeneratorConfig(families=("box",))
    with pytest.warns(UserWarning):
        assert "not among the training families" in load_scenario(path, training=narrow).ood(0, 0)


def test_user_objects_scenario(robot):
    """The hand-written user objects lie inside the generator's ranges (no warning); the OOD
    set lies outside them, every object marked ood."""
    import warnings

    path = ROOT / "configs" / "scenarios" / "user_objects.yaml"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sc = load_scenario(path, robot=robot, training=GeneratorConfig())
    assert len(sc.objects) == 6 and len(sc.placements) == 10
    assert {o.shape for o in sc.objects} == {"cylinder", "box", "sphere", "capsule"}
    for p in sc.placements:
        assert 0.48 <= p.x <= 0.68 and abs(p.y) <= 0.29 and abs(p.yaw) <= math.pi / 2 + 1e-9
    assert not any(sc.ood(i, 0) for i in range(6))
    with pytest.warns(UserWarning):
        ood = load_scenario(
            ROOT / "configs" / "scenarios" / "ood_objects.yaml", robot=robot, training=GeneratorConfig()
        )
    assert len(ood.objects) == 6 and all(ood.ood(i, 0) for i in range(6))
    with pytest.warns(UserWarning):  # the wide sizes hold four of them; the wide OOD set lies outside those
        ood = load_scenario(
            ROOT / "configs" / "scenarios" / "ood_objects.yaml",
            robot=robot,
            training=GeneratorConfig(sizes="wide"),
        )
        wide_ood = load_scenario(
            ROOT / "configs" / "scenarios" / "ood_wide_objects.yaml",
            robot=robot,
            training=GeneratorConfig(sizes="wide"),
        )
    assert [o.name for i, o in enumerate(ood.objects) if ood.ood(i, 0)] == ["tuna_tin", "grapefruit"]
    assert len(wide_ood.objects) == 6 and all(wide_ood.ood(i, 0) for i in range(6))


def test_cluster_bootstrap_matches_the_enumerated_distribution():
    # two equal clusters with values a, b: replicates are a (1/4), (a+b)/2 (1/2), b (1/4)
    v = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    c = np.array([0, 0, 0, 1, 1, 1])
    assert cluster_bootstrap_ci(v, c, n_boot=4000) == (0.0, 1.0)
    assert cluster_bootstrap_ci(v, c, level=0.4, n_boot=4000) == (0.5, 0.5)
    # errors that cluster by object: the cluster interval is much wider than Wilson's over episodes
    flags = np.repeat([1.0, 1.0, 0.0, 1.0], 10)
    objects = np.repeat(np.arange(4), 10)
    low, high = cluster_bootstrap_ci(flags, objects)
    w_low, w_high = wilson_interval(30, 40)
    assert high - low > 1.5 * (w_high - w_low)
    assert cluster_bootstrap_ci(flags, objects) == (low, high)  # deterministic
    with pytest.raises(ValueError, match="equal-length"):
        cluster_bootstrap_ci(flags, objects[:-1])


def test_success_needs_a_still_object_and_intervals_cluster():
    d = np.array([0.01, 0.01, 0.03, 0.2])
    kw = dict(jerk=[1.0] * 4, demo_jerk=[1.0] * 4, limit_violations=[0] * 4, latency_ms=[1.0])
    out = summarise(
        d,
        [True] * 4,
        displacement=[0.0, 0.05, 0.001, 0.0],
        clusters=[0, 0, 1, 1],
        object_distance=[0.05, 0.06, 0.07, 0.3],
        table_contact=[0, 1, 0, 0],
        object_contact=[0, 1, 0, 0],
        **kw,
    )
    assert out["success_5cm"] == 0.5  # the pushed object (5 cm) is no success
    assert out["success_2cm"] == 0.25
    assert out["approach_correct"] == 0.75  # the 20 cm episode fails the distance condition
    assert out["ci_clusters"] == 2 and "cluster" in out["ci_method"]
    assert out["object_distance_m"]["mean"] == pytest.approx(0.12)
    assert out["object_moved_2cm"] == 0.25 and out["arm_table_contacts"] == 0.25
    assert out["success_5cm_ci"][0] <= out["success_5cm"] <= out["success_5cm_ci"][1]


@pytest.mark.parametrize("name", ["mixed", "original_figure", "user_objects"])
def test_home_pose_is_never_approach_correct(robot, name):
    """An arm that never leaves home: the angle alone passes on some round-object placements
    (the old definition counted them), the new definition counts none."""
    home = robot.fk(robot.home[None]).numpy()[0]
    ev = ReachEvaluator()
    with _nothing():
        sc = load_scenario(ROOT / "configs" / "scenarios" / f"{name}.yaml", training=GeneratorConfig())
    rows = []
    for i, obj, j, pl in sc.cases():
        case = Case(i, j, obj, pl, plan_approach(obj, pl), None)
        trace = EpisodeTrace(np.stack([home] * 5), np.stack([home] * 5), 0, [1.0])
        rows.append(ev._row("cnn_dmp", case, trace, 0.04))
    assert not any(r["approach_correct"] for r in rows)
    assert not any(r["success_5cm"] for r in rows)
    if name == "original_figure":
        assert any(r["approach_angle_ok"] for r in rows)  # what the old definition would have counted


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_episode_records_object_push_and_contact(robot):
    """The arm teleported into the object pushes it: contact and displacement are recorded;
    an arm resting at home records neither."""
    from lfd.robots import solve_near
    from lfd.sim.scene import ReachScene
    from lfd.visuomotor.eval.rollout import run_episode

    obj = ObjectSpec("box", (0.06, 0.06, 0.08), (0.5, 0.5, 0.5, 1.0), 0.2, "b")
    pl = Placement(0.58, -0.1, 0.0)

    class Hold:
        needs_image, dt, actuation = False, 0.04, "position"
        input_channels, depth_encoding = 3, "range"

        def __init__(self, q):
            self.q = q

        def start(self, steps=None):
            pass

        def command(self, obs, step, latencies):
            return self.q, np.zeros_like(self.q)

    lower, upper = robot.lower.numpy(), robot.upper.numpy()
    lower, upper = (
        np.where(robot.continuous.numpy(), -np.inf, lower),
        np.where(robot.continuous.numpy(), np.inf, upper),
    )
    with ReachScene(robot, image_size=16) as scene:
        scene.reset(obj, pl)
        quiet = run_episode(scene, Hold(robot.home.numpy()), 20, lower, upper)
        assert (
            quiet.object_contact_steps == 0
            and quiet.table_contact_steps == 0
            and quiet.object_displacement < 1e-3
        )
        grasp = plan_approach(obj, pl, table_z=TABLE_Z).grasp_pose.copy()
        grasp[2, 3] -= 0.04  # fingers 4 cm into the box: the tool pushes through it
        q = solve_near(robot, grasp[None], robot.home.numpy(), n_seeds=16).q[0].numpy()
        scene.reset(obj, pl, q=q)
        pushed = run_episode(scene, Hold(q), 20, lower, upper)
    assert pushed.object_contact_steps > 0
    assert pushed.object_displacement > 0.005
