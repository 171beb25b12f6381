"""One Meta-World task as lfd's policies see it: seeded placements, a 4-D robot state, upright
camera images, position targets turned into Meta-World's delta actions, the task's own success.

The robot state is ``(4,)`` float64: the hand (end-effector) position ``x, y, z`` in metres
(Meta-World's world frame) and the gripper command last sent, -1 (open) .. 1 (closed); at reset
the gripper is open and the command is -1. Every policy sees this state and one camera image,
never Meta-World's 39-D observation vector (object and goal coordinates). The goal marker (the
scene's ``goal`` site) is drawn in the image with radius :data:`GOAL_MARKER_RADIUS`, so that a
task whose goal moves between placements (reach, push, pick-place) shows it.

A *placement* is the task's random reset vector (object and goal positions, ``(d,)`` within
:attr:`MetaWorldTask.placement_low` .. ``placement_high``), drawn by the task's own sampler (with
its rejection rules) from a reset seed that lfd takes from a seeded stream per split and episode
(:func:`placement_seed`), so train, validation and test episodes are independent draws.

Actions: a position target ``(4,)`` (state units) becomes Meta-World's action
``clip((target_xyz - offset - mocap_xyz) / action_scale, -1, 1)`` and ``clip(target_g, -1, 1)``:
the hand's mocap moves to where the hand point is at the target (at most ``action_scale`` = 1 cm
per step; ``offset`` is the hand point's offset from the mocap at reset) and the gripper gets the
command.

Rendering needs an OpenGL backend: ``MUJOCO_GL=egl`` (set here when unset) renders headless.
Some Meta-World cameras are rolled upside down; :meth:`MetaWorldTask.render` returns every image
upright (the world's up pointing up).
"""

from __future__ import annotations

import contextlib
import os
import warnings
from typing import Any

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")

__all__ = [
    "CAMERAS",
    "CONTROL_DT",
    "GOAL_MARKER_RADIUS",
    "MT10",
    "SPLIT_KEYS",
    "MetaWorldTask",
    "check_task",
    "placement_seed",
    "task_names",
]

#: The ten tasks of Meta-World's MT10 benchmark (development and model choice happen on these).
MT10 = (
    "reach-v3",
    "push-v3",
    "pick-place-v3",
    "door-open-v3",
    "drawer-open-v3",
    "drawer-close-v3",
    "button-press-topdown-v3",
    "peg-insert-side-v3",
    "window-open-v3",
    "window-close-v3",
)
#: Control period (s) of every Meta-World task: 5 physics steps of 2.5 ms per action.
CONTROL_DT = 0.0125
#: Fixed cameras of the Meta-World scenes.
CAMERAS = ("corner", "corner2", "corner3", "topview", "behindGripper", "gripperPOV")
#: Radius (m) the goal site is drawn with (Meta-World's own is 0.02 or less: 1-2 px at 96 px).
GOAL_MARKER_RADIUS = 0.03
#: Stream key of each split's placements (:func:`placement_seed`).
SPLIT_KEYS = {"train": 0, "val": 1, "test": 2}
#: Placement stream key (``np.random.default_rng([seed, PLACEMENT_STREAM, split key, i, attempt])``).
PLACEMENT_STREAM = 7


def task_names() -> tuple[str, ...]:
    """Every Meta-World task lfd can run (``metaworld.ALL_V3_ENVIRONMENTS``), sorted."""
    from metaworld.env_dict import ALL_V3_ENVIRONMENTS

    return tuple(sorted(ALL_V3_ENVIRONMENTS))


def check_task(name: Any) -> str:
    """``name`` if it is a Meta-World task, else ``ValueError`` naming the closest ones."""
    names = task_names()
    if not isinstance(name, str) or name not in names:
        import difflib

        close = difflib.get_close_matches(str(name), names, n=3) or names[:3]
        raise ValueError(
            f"task: expected a Meta-World task name such as {', '.join(close)} "
            f"({len(names)} tasks: lfd.metaworld.task_names()), got {name!r}"
        )
    return name


def placement_seed(seed: int, split: str, index: int, attempt: int = 0) -> int:
    """The reset seed of episode ``index`` (try ``attempt``) of ``split`` (:data:`SPLIT_KEYS`):
    from its own stream, so train, validation and test placements are independent draws and an
    episode's placement does not depend on how many episodes a dataset has."""
    if split not in SPLIT_KEYS:
        raise ValueError(f"split: expected one of {tuple(SPLIT_KEYS)}, got {split!r}")
    rng = np.random.default_rng([int(seed), PLACEMENT_STREAM, SPLIT_KEYS[split], int(index), int(attempt)])
    return int(rng.integers(2**31 - 1))


class MetaWorldTask:
    """A Meta-World task with lfd's state, placements, images and actions (module docstring).

    Args:
        task: a Meta-World task name (:func:`task_names`), e.g. ``"push-v3"``.
        image_size: side (px) of the square camera images.
        camera: one of :data:`CAMERAS`.
        fovy: the camera's vertical field of view in degrees (None: the scene's, 45 for
            ``corner``); a narrower one zooms in on the middle of the same view.

    Raises:
        ValueError: unknown task or camera, an image size outside 16..1024, or ``fovy`` outside 5..120.

    Use as a context manager (or call :meth:`close`) to free the renderer.
    """

    def __init__(
        self, task: str, image_size: int = 96, camera: str = "corner", fovy: float | None = None
    ) -> None:
        check_task(task)
        if camera not in CAMERAS:
            raise ValueError(f"camera: expected one of {CAMERAS}, got {camera!r}")
        if isinstance(image_size, bool) or not isinstance(image_size, int) or not 16 <= image_size <= 1024:
            raise ValueError(f"image_size: expected an int in 16..1024 px, got {image_size!r}")
        if fovy is not None and (
            isinstance(fovy, bool) or not isinstance(fovy, (int, float)) or not 5.0 <= float(fovy) <= 120.0
        ):
            raise ValueError(f"fovy: expected degrees in 5..120 or None, got {fovy!r}")
        from metaworld.env_dict import ALL_V3_ENVIRONMENTS
        from metaworld.policies import ENV_POLICY_MAP

        self.task, self.image_size, self.camera = task, image_size, camera
        env = ALL_V3_ENVIRONMENTS[task](
            render_mode="rgb_array", camera_name=camera, width=image_size, height=image_size
        )
        quality = env.model.vis.quality
        quality.shadowsize, quality.offsamples = 0, 0  # ~10x faster software rendering, same scene
        import mujoco

        self._camera_id = int(mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_CAMERA, camera))
        if fovy is not None:
            env.model.cam_fovy[self._camera_id] = float(fovy)
        self.fovy = None if fovy is None else float(fovy)
        self._enlarge_goal_marker(env)
        self.env = env
        self._expert = ENV_POLICY_MAP[task]()
        self.max_path_length = int(env.max_path_length)
        self.action_scale = float(env.action_scale)
        self.placement_low = np.asarray(env._random_reset_space.low, dtype=np.float64)
        self.placement_high = np.asarray(env._random_reset_space.high, dtype=np.float64)
        self.control_dt = float(env.frame_skip * env.model.opt.timestep)
        if abs(self.control_dt - CONTROL_DT) > 1e-12:
            raise ValueError(f"{task}: control period {self.control_dt} s, lfd expects {CONTROL_DT} s")
        self._obs: np.ndarray | None = None
        self.placement: np.ndarray | None = None
        self._upside_down: bool | None = None
        self._gripper = -1.0
        self.success = False

    @staticmethod
    def _enlarge_goal_marker(env) -> None:
        import mujoco

        site = mujoco.mj_name2id(env.model, mujoco.mjtObj.mjOBJ_SITE, "goal")
        if site >= 0:
            env.model.site_size[site, 0] = max(env.model.site_size[site, 0], GOAL_MARKER_RADIUS)

    # ------------------------------------------------------------------ episode
    def reset(self, seed: int) -> np.ndarray:
        """Start an episode at the placement the task's own sampler draws from ``seed`` (its
        rejection rules, e.g. reach's object-goal distance, included); returns the state.
        :attr:`placement` then holds the placement ``(d,)``.

        Raises:
            ValueError: ``seed`` is not an int >= 0.
        """
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed: expected an int >= 0, got {seed!r}")
        env = self.env
        if not env._set_task_called:
            import pickle

            from metaworld import Task

            # Meta-World's way to set the observation mode (the expert reads the goal from the full
            # observation vector, which no policy sees). The pickle is made here, never read from a file.
            data = {
                "env_cls": type(env),
                "rand_vec": self.placement_low.copy(),
                "partially_observable": False,
            }
            env.set_task(Task(env_name=self.task, data=pickle.dumps(data)))
        env._freeze_rand_vec, env.seeded_rand_vec = False, True  # draw from env.np_random, seeded here
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env.seed(int(seed))  # Meta-World ignores reset(seed=...)
            self._obs, _ = env.reset()
        import mujoco

        # Meta-World moves the goal site after its last forward pass: without this the first image
        # of an episode shows the goal marker where the previous placement's put it
        mujoco.mj_forward(env.model, env.data)
        self.placement = np.asarray(env._last_rand_vec, dtype=np.float64).copy()
        # the state's hand point (between the finger pads) sits a fixed offset from the mocap body
        self._offset = np.asarray(self._obs[:3], dtype=np.float64) - env.data.mocap_pos[0]
        self._gripper, self.success = -1.0, False
        return self.state()

    def state(self) -> np.ndarray:
        """``(4,)`` float64: hand position (m) and the last gripper command."""
        hand = np.asarray(self._obs[:3], dtype=np.float64)
        return np.array([*hand, self._gripper])

    def render(self) -> np.ndarray:
        """Upright camera image ``(image_size, image_size, 3)`` uint8: the camera's view turned
        so that the world's up points up in the image (Meta-World defines some cameras, e.g.
        ``corner``, rolled upside down: their image is rotated by 180 degrees, never mirrored)."""
        image = self.env.render()
        return np.ascontiguousarray(image[::-1, ::-1] if self._camera()[2] else image)

    def _camera(self) -> tuple[np.ndarray, np.ndarray, bool]:
        """The camera's position ``(3,)`` m, rotation ``(3, 3)`` (columns: its x, y, z axes in the
        world) and whether its image is upside down (its "up" axis points down in the world)."""
        cam = self._camera_id
        rotation = self.env.data.cam_xmat[cam].reshape(3, 3).copy()
        if self._upside_down is None:
            self._upside_down = bool(rotation[2, 1] < 0)
        return self.env.data.cam_xpos[cam].copy(), rotation, self._upside_down

    def project(self, points) -> np.ndarray:
        """Where world points appear in :meth:`render`'s upright image.

        Args:
            points: ``(..., 3)`` m, Meta-World's world frame.

        Returns:
            ``(..., 2)`` float64 pixel coordinates ``(u, v)``: ``u`` to the right, ``v`` down, in
            pixels from the image's top-left corner (the top-left pixel's centre is ``(0.5, 0.5)``).
            Points behind the camera get NaN.

        Raises:
            RuntimeError: before the first :meth:`reset` (the camera's pose is MuJoCo's after a
                forward pass).
            ValueError: ``points`` is not ``(..., 3)`` or not finite.
        """
        if self._obs is None:
            raise RuntimeError("MetaWorldTask.project: call reset() first")
        p = np.asarray(points, dtype=np.float64)
        if p.ndim < 1 or p.shape[-1] != 3 or not np.isfinite(p).all():
            raise ValueError(f"points: expected finite (..., 3) m, got shape {p.shape}")
        position, rotation, upside_down = self._camera()
        local = (p - position) @ rotation  # camera frame: x right, y up, looking along -z
        depth = -local[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            size = float(self.image_size)
            fovy = float(self.env.model.cam_fovy[self._camera_id])
            focal = (size / 2.0) / np.tan(np.radians(fovy) / 2.0)
            u = size / 2.0 + focal * local[..., 0] / depth
            v = size / 2.0 - focal * local[..., 1] / depth
        if upside_down:
            u, v = size - u, size - v
        uv = np.stack([u, v], axis=-1)
        uv[depth <= 0] = np.nan
        return uv

    def action_for(self, target: np.ndarray) -> np.ndarray:
        """Meta-World's action ``(4,)`` float32 that moves the hand's mocap to ``target[:3]`` (m,
        at most ``action_scale`` per axis and step) and commands the gripper ``target[3]``."""
        target = np.asarray(target, dtype=np.float64)
        if target.shape != (4,) or not np.all(np.isfinite(target)):
            raise ValueError(f"target: expected 4 finite values (x, y, z m, gripper), got {target!r}")
        delta = (target[:3] - self._offset - self.env.data.mocap_pos[0]) / self.action_scale
        return np.clip(np.array([*delta, target[3]]), -1.0, 1.0).astype(np.float32)

    def step(self, action: np.ndarray) -> bool:
        """One control step with Meta-World's ``action`` ``(4,)`` in [-1, 1]; returns whether the
        task counts as solved at this step (``info["success"]``; :attr:`success` stays True once set)."""
        action = np.asarray(action, dtype=np.float32)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self._obs, _, _, _, info = self.env.step(action)
        self._gripper = float(np.clip(action[3], -1.0, 1.0))
        solved = bool(info["success"])
        self.success = self.success or solved
        return solved

    def step_to(self, target: np.ndarray) -> bool:
        """:meth:`step` with :meth:`action_for` ``(target)``."""
        return self.step(self.action_for(target))

    def expert_action(self) -> np.ndarray:
        """The scripted expert's action ``(4,)`` at the current state (``metaworld.policies``)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return np.clip(np.asarray(self._expert.get_action(self._obs), dtype=np.float32), -1.0, 1.0)

    def close(self) -> None:
        env, self.env = getattr(self, "env", None), None
        if env is not None:
            with warnings.catch_warnings(), contextlib.suppress(Exception):
                warnings.simplefilter("ignore")
                env.close()  # the EGL context may already be gone at interpreter exit

    def __enter__(self) -> MetaWorldTask:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
