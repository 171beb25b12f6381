"""CNN -> DMP policy: one camera image and the start joints -> a whole joint trajectory.

Network: conv trunk + spatial soft-argmax keypoints, concatenated with the normalised
start joints and a learned bias input, 3 x 200 ReLU units, then the DMP goal ``(n,)`` and
forcing weights ``(n, K)`` in normalised units (de-normalised with the training split's
statistics). The parameters go through the differentiable :class:`lfd.dmp.DMPLayer`, so
the default loss compares the resulting joint trajectory with the demonstration (plus,
optionally, the end-effector path through the robot's batched forward kinematics). The
goal is predicted from the image: no object pose and no IK solution is used.

With ``placement_dim`` the head goes through the scene instead: the keypoint head predicts the
episode's *placement* (object and goal positions, a training-only label) from the image, and the
DMP parameters are an affine function of that placement and the start joints: the ridge
regression of the demonstrations' parameters on their true placements. At run time the predicted
placement feeds the map. A map this simple generalises from a few dozen demonstrations where a
head regressing 80 forcing weights from the image memorises them.

In closed loop (:meth:`CNNDMPPolicy.controller`) the policy plans once on the first image, or,
with ``replan_every=k``, also changes the DMP's goal online every ``k`` steps from a new image
(:meth:`CNNDMPPolicy.predict_goal`, :meth:`CNNDMPPolicy.change_goal`; Ijspeert et al. 2013,
goal change): the DMP keeps its position, velocity and phase, only its goal is switched.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from lfd.dmp import DMPLayer
from lfd.visuomotor.policies import goal_change
from lfd.visuomotor.policies.base import check_sizes
from lfd.visuomotor.policies.control import PlanController
from lfd.visuomotor.policies.keypoint import KeypointPolicy
from lfd.visuomotor.policies.line_of_sight import open_directions
from lfd.visuomotor.policies.placement_map import SegmentedMap, fit_ridge_kernel, gaussian_kernel
from lfd.visuomotor.policies.plots import joint_figure
from lfd.visuomotor.policies.vision import mlp

LOSSES = ("trajectory", "params")
#: What the placement head sees (``keypoint_head``): every keypoint, or only the supervised ones.
KEYPOINT_HEADS = ("all", "supervised", "supervised_spread", "supervised_depth")
#: Hidden units of the depth heads (``supervised_depth``): none (32 memorised pick-place's; docs/decisions.md).
DEPTH_HIDDEN = ()
#: Penalty of the kernel ridge regression of the placement map's correction (``map_kernel_scale``),
#: in the normalised parameters' units (chosen with the length scale on validation placements).
KERNEL_RIDGE = 0.1
#: Most training demonstrations a checkpoint's kernel correction may hold (a bound on what loading allocates).
MAX_MAP_CENTRES = 100_000


@dataclass(frozen=True)
class DMPPlan:
    """A planned DMP trajectory and the DMP parameters that changing its goal needs (float64).

    Attributes:
        trajectory: ``(T, n)`` / ``(B, T, n)`` rad, sampled every ``control_dt`` s from the start.
        start: ``(n,)`` / ``(B, n)`` the DMP's start ``y0`` (the episode's start joints).
        goal: ``(n,)`` / ``(B, n)`` the goal the trajectory converges to (de-normalised).
        weights: ``(n, K)`` / ``(B, n, K)`` forcing weights (de-normalised).
        velocity: the trajectory's exact velocity, same shape, per second (None: not known; a
            re-plan then takes central differences of ``trajectory``).
    """

    trajectory: np.ndarray
    start: np.ndarray
    goal: np.ndarray
    weights: np.ndarray
    velocity: np.ndarray | None = None


class CNNDMPPolicy(KeypointPolicy):
    """Image + start joints -> DMP parameters -> joint trajectory ``(T, n)``.

    Args:
        loss: ``"trajectory"``: mean squared joint error (rad^2) of the DMP rollout against
            the demonstrated trajectory; ``"params"``: mean squared error of the normalised
            goal and weights (the original's objective, kept for the ablation).
        ee_weight: weight of the end-effector path term (mean squared tool position error,
            m^2, through batched FK) added to the trajectory loss.
        final_weight: extra weight of the last ``final_fraction`` of the trajectory (where
            the arm closes in on the object) in the trajectory loss.
        final_fraction: fraction of the samples at the end that ``final_weight`` applies to.
        rest_steps: the trajectory loss also covers this many samples after the
            demonstration's end, where the target is its last sample (the demonstrations end
            at rest). Without them the goal is a free parameter: the weights alone can bring
            the rollout to the demonstrated end point at ``t = tau`` with a goal elsewhere,
            and the DMP then runs off towards that goal once its forcing term dies out.
            The samples use the same DMP run on past ``tau`` (:meth:`layer`), as the closed
            loop does. 0 compares only the demonstrated ``T`` samples.
        n_basis: DMP basis functions per joint (must match the dataset's).
        alpha_z: DMP damping gain.
        placement_dim: 0 (default) or the size of the batches' ``placement`` (m; the datamodule's
            training-only label, e.g. Meta-World's zero-padded random reset vector): the head then
            predicts the normalised placement from the image alone and an affine map gives the
            normalised DMP parameters from ``[placement, start joints]``. The map is the ridge
            regression of the training demonstrations' parameters on their placements
            (:meth:`fit_params_map`, at ``setup("fit")``) and stays fixed; training minimises the
            placement's mean squared error (``placement_mse``; ``loss`` is then not used) and the
            other metrics are those of the predicted placement (what runs).
        map_kernel_scale: with ``placement_dim``, the length scale (in the normalised
            ``[placement, start joints]``'s units) of a Gaussian-kernel correction added to the
            affine map: the kernel ridge regression (penalty :data:`KERNEL_RIDGE`) of the affine
            map's residuals on the training demonstrations, so that the map also follows what
            is not affine in the placement (e.g. when the expert reaches a hole later for a far
            box); 0: the affine map alone. Default 2.0 (chosen on validation placements).
        map_segments: with ``placement_dim``, also fit a
            :class:`~lfd.visuomotor.policies.placement_map.SegmentedMap` (two DMPs split where the
            demonstrations' gripper switches, same regression) and plan with it when every
            demonstration switches (:attr:`plans_in_segments`); training and its metrics use the
            single DMP. No re-planning (``replan_every``). Default False.
        switch_delay: with ``map_segments``, steps the switched command waits at the boundary
            (the position-controlled hand trails its plan), an integer >= 0. Default 3.
        keypoint_weight: the weight of a loss that puts the encoder's first keypoints where known
            points appear in the image: the mean squared distance, in the soft-argmax's ``[-1, 1]``
            units, to the batches' pixel labels (px; NaN entries, e.g. a shorter placement's
            padding, are left out), added to the training loss. With ``placement_dim``: the first
            ``ceil(placement_dim / 3)`` keypoints onto the placement's 3-D points (an object's and
            a goal's position), ``placement_pixels``; without: the first keypoint onto the grasp
            target point, ``target_pixels`` (:func:`lfd.visuomotor.data.datasets.target_pixel_labels`).
            Training-only labels: from a few dozen images a head that regresses the placement
            alone tells the images apart by whatever varies most (a large goal marker) instead of
            finding a small object; a keypoint told where it is cannot. 0 (default): no such loss.
        keypoint_head: ``"all"`` (default): the placement head sees every keypoint; ``"supervised"``:
            only the ``keypoint_weight`` ones, so that the placement is a smooth function of where
            the objects are and nothing else; ``"supervised_spread"``: those keypoints and how far
            their channels' responses spread around them
            (:meth:`~lfd.visuomotor.policies.vision.SpatialSoftmax.spread`), i.e. the objects'
            apparent sizes: where a point lies along the camera's line of sight (a goal in the
            air) shows in them, not in its position in the image; ``"supervised_depth"``: the
            placement from the supervised keypoints alone as with ``"supervised"``, plus, for each
            point whose position the training placements show is not fixed by its pixel (a goal
            in the air, :data:`~lfd.visuomotor.policies.line_of_sight.DEPTH_MIN_M`), a learned
            offset along the direction its pixel leaves open (its line of sight,
            :meth:`fit_depth_directions`), a linear read-out of that keypoint and its channel's
            spread alone (:data:`DEPTH_HIDDEN`); a task whose points
            all lie on a surface trains exactly as with ``"supervised"``. All but ``"all"`` need
            ``keypoint_weight > 0``.
        normalise_trajectory: compare trajectories in units of each state dimension's train-split
            standard deviation (the ``joints`` statistics) instead of raw units (rad^2). For states
            with small ranges in their units (Meta-World's hand in metres, a few cm of spread) the
            raw squared error and its gradients are ~1e-3 of the reaching task's, below what Adam
            resolves in the conv trunk (the trunk's keypoints then never move); unit-free, they are not.
        **common: :class:`~lfd.visuomotor.policies.keypoint.KeypointPolicy` arguments (the
            keypoint head's and the harness's).
    """

    kind = "cnn_dmp"
    label = "CNN -> DMP"
    colour = "tab:blue"
    item_mode = "dmp"
    DATA_ARGUMENTS = (*KeypointPolicy.DATA_ARGUMENTS, "n_basis")

    def __init__(
        self,
        *,
        loss: str = "trajectory",
        ee_weight: float = 0.0,
        final_weight: float = 0.0,
        final_fraction: float = 0.25,
        rest_steps: int = 50,
        normalise_trajectory: bool = False,
        placement_dim: int = 0,
        map_kernel_scale: float = 2.0,
        map_segments: bool = False,
        switch_delay: int = 3,
        keypoint_weight: float = 0.0,
        keypoint_head: str = "all",
        n_basis: int = 20,
        alpha_z: float = 25.0,
        **common,
    ) -> None:
        check_sizes("CNNDMPPolicy", n_basis=n_basis)
        if isinstance(placement_dim, bool) or not isinstance(placement_dim, int) or placement_dim < 0:
            raise ValueError(f"CNNDMPPolicy.placement_dim: expected an integer >= 0, got {placement_dim!r}")
        if isinstance(map_kernel_scale, bool) or not (
            isinstance(map_kernel_scale, (int, float))
            and np.isfinite(map_kernel_scale)
            and map_kernel_scale >= 0
        ):
            raise ValueError(
                f"CNNDMPPolicy.map_kernel_scale: expected a finite number >= 0, got {map_kernel_scale!r}"
            )
        if isinstance(keypoint_weight, bool) or not (
            isinstance(keypoint_weight, (int, float)) and 0 <= keypoint_weight < float("inf")
        ):
            raise ValueError(
                f"CNNDMPPolicy.keypoint_weight: expected a finite number >= 0, got {keypoint_weight!r}"
            )
        if not isinstance(map_segments, bool) or (map_segments and not placement_dim):
            raise ValueError(
                f"CNNDMPPolicy.map_segments: expected a bool (true needs placement_dim > 0), got {map_segments!r}"
            )
        if isinstance(switch_delay, bool) or not isinstance(switch_delay, int) or switch_delay < 0:
            raise ValueError(f"CNNDMPPolicy.switch_delay: expected an integer >= 0, got {switch_delay!r}")
        if keypoint_head not in KEYPOINT_HEADS:
            raise ValueError(
                f"CNNDMPPolicy.keypoint_head: expected one of {KEYPOINT_HEADS}, got {keypoint_head!r}"
            )
        if keypoint_head != "all" and not (keypoint_weight > 0 and placement_dim):
            raise ValueError(
                f"CNNDMPPolicy.keypoint_head: {keypoint_head!r} needs keypoint_weight > 0 and placement_dim > 0"
            )
        super().__init__(**common)
        if loss not in LOSSES:
            raise ValueError(f"CNNDMPPolicy.loss: expected one of {LOSSES}, got {loss!r}")
        if not isinstance(normalise_trajectory, bool):
            raise ValueError(
                f"CNNDMPPolicy.normalise_trajectory: expected a bool, got {normalise_trajectory!r}"
            )
        if rest_steps < 0:
            raise ValueError(f"CNNDMPPolicy.rest_steps: expected an integer >= 0, got {rest_steps}")
        n = self.hparams.n_joints
        self.dmp = DMPLayer(
            n_basis=n_basis, n_steps=self.hparams.n_steps, dt=self.control_dt, alpha_z=alpha_z
        )
        self._horizon_layers: dict[int, DMPLayer] = {}  # longer closed-loop plans, same tau (not state)
        stats = {"joints": (n,), "goal": (n,), "weights": (n, n_basis)}
        if placement_dim:
            self.params_map = nn.Linear(placement_dim + n, n + n * n_basis)  # set by fit_params_map
            # the kernel correction: centres (E, p + n) and coefficients (E, n + n K), E = the number
            # of training demonstrations (none until fit_params_map; sized from a checkpoint on load)
            self.register_buffer("map_centres", torch.zeros(0, placement_dim + n))
            self.register_buffer("map_coefficients", torch.zeros(0, n + n * n_basis))
            if map_segments:  # plans in two DMPs split at the demonstrations' switch (fit_params_map)
                self.segmented_map = SegmentedMap(
                    n,
                    n_basis,
                    self.control_dt,
                    map_kernel_scale,
                    KERNEL_RIDGE,
                    switch_delay,
                    placement_dim + n,
                )
            # the placement is the scene's: from the image alone (the start state would let the
            # head tell training episodes apart instead of looking at the objects)
            points = self.placement_points
            if keypoint_weight > 0 and points > self.encoder.n_channels:
                raise ValueError(
                    f"CNNDMPPolicy.keypoint_weight: {points} supervised keypoints, the encoder has "
                    f"{self.encoder.n_channels}"
                )
            if keypoint_head in ("supervised_spread", "supervised_depth"):
                self.encoder.spread_channels = points
            self._build(
                placement_dim,
                {**stats, "placement": (placement_dim,)},
                joints_input=False,
                head_keypoints=points if keypoint_head != "all" else None,
                head_spreads=keypoint_head != "supervised_depth",
            )
            # each point's open direction, normalised units (zero until fit_depth_directions)
            self.register_buffer("depth_directions", torch.zeros(points, placement_dim))
            if keypoint_head == "supervised_depth":
                with torch.random.fork_rng(devices=[]):  # the rest initialises as with "supervised"
                    self.depth_heads = nn.ModuleList(mlp(4, DEPTH_HIDDEN, 1) for _ in range(points))
        else:
            self._build(n + n * n_basis, stats)

    def refine_head(self, out: torch.Tensor, keypoints: torch.Tensor) -> torch.Tensor:
        """With ``keypoint_head="supervised_depth"``: each point's depth head, fed its keypoint and
        its channel's spread ``(B, 4)``, moves the predicted placement along that point's row of
        :attr:`depth_directions` (zero rows: no change)."""
        if self.hparams.get("keypoint_head") != "supervised_depth":
            return out
        m, p = self.placement_points, self.hparams.placement_dim
        spreads = keypoints[:, keypoints.shape[1] - 2 * m :]
        depth = torch.cat(
            [
                head(torch.cat([keypoints[:, 2 * k : 2 * k + 2], spreads[:, 2 * k : 2 * k + 2]], dim=1))
                for k, head in enumerate(self.depth_heads)
            ],
            dim=1,
        )
        offset = depth @ self.depth_directions.to(depth)
        blocks = [out[:, h * p : (h + 1) * p] + offset for h in range(self.n_heads)]
        return torch.cat([*blocks, out[:, self.n_heads * p :]], dim=1)

    def predict_params(self, image: torch.Tensor, joints: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Normalised DMP goal ``(B, n)`` and weights ``(B, n, K)``."""
        out = self.features(image, joints)
        if self.through_placement:
            out = self._params_from_placement(out, joints)
        return self._split_params(out)

    @property
    def placement_points(self) -> int:
        """The placement's 3-D points, ``ceil(placement_dim / 3)`` (the last one may be padding):
        the keypoints that ``keypoint_weight`` supervises."""
        return -(-int(self.hparams.get("placement_dim", 0)) // 3)

    @property
    def through_placement(self) -> bool:
        """Whether the policy goes through the placement (``placement_dim`` > 0; older checkpoints: no)."""
        return bool(self.hparams.get("placement_dim", 0))

    def _need_placement_map(self, method: str) -> None:
        if not self.through_placement:
            raise ValueError(f"CNNDMPPolicy.{method}: the policy has no placement map (placement_dim=0)")

    def _params_from_placement(self, placement_n: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        """Normalised placement ``(B, p)`` and start joints ``(B, n)`` -> head-like output ``(B, n + n K)``."""
        x = torch.cat([placement_n, self.normalise("joints", joints)], dim=1)
        out = self.params_map(x)
        if self.map_centres.shape[0]:
            out = out + self._kernel(x, self.map_centres) @ self.map_coefficients
        return out

    def _kernel(self, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
        """Gaussian kernel ``(A, B)`` of the map's inputs ``(A, d)`` and ``(B, d)``."""
        return gaussian_kernel(a, b, float(self.hparams.get("map_kernel_scale", 0.0)))

    @property
    def plans_in_segments(self) -> bool:
        """Whether plans come from the fitted segmented map (its demonstrations switched)."""
        return hasattr(self, "segmented_map") and self.segmented_map.fitted

    def _segmented_plan(self, placement_n: torch.Tensor, q: torch.Tensor, n_steps: int | None) -> np.ndarray:
        """The segmented map's plans ``(B, T, n)`` (float64) from the normalised placement."""
        x = torch.cat([placement_n, self.normalise("joints", q)], dim=1)
        return self.segmented_map.plan(x, q.double().cpu().numpy(), n_steps or self.hparams.n_steps)

    def on_load_checkpoint(self, checkpoint: dict) -> None:
        """The harness's hook; then sizes the map's kernel correction to the checkpoint's number of
        training demonstrations (a checkpoint without one, of an earlier release, gets none: the
        affine map alone).

        Raises:
            ValueError: the checkpoint's correction does not fit the map's inputs and outputs.
        """
        super().on_load_checkpoint(checkpoint)
        state = checkpoint.get("state_dict")
        if not self.through_placement or not isinstance(state, dict):
            return
        if "map_kernel_scale" not in checkpoint.get("hyper_parameters", {}):
            self.hparams["map_kernel_scale"] = 0.0  # an earlier release's: the affine map alone
        for name in ("map_centres", "map_coefficients"):
            own = self._buffers[name]
            saved = state.setdefault(name, own)
            if (
                not isinstance(saved, torch.Tensor)
                or saved.ndim != 2
                or saved.shape[1] != own.shape[1]
                or saved.shape[0] > MAX_MAP_CENTRES
            ):
                got = tuple(saved.shape) if isinstance(saved, torch.Tensor) else type(saved).__name__
                raise ValueError(
                    f"CNNDMPPolicy: the checkpoint's {name} is {got}, "
                    f"expected (E, {own.shape[1]}) with E <= {MAX_MAP_CENTRES}"
                )
            self._buffers[name] = torch.zeros(saved.shape, dtype=own.dtype, device=own.device)
        if hasattr(self, "segmented_map"):
            self.segmented_map.resize_for(state, "segmented_map.")
        directions = state.setdefault("depth_directions", self.depth_directions)  # earlier releases: none
        if not isinstance(directions, torch.Tensor) or directions.shape != self.depth_directions.shape:
            got = (
                tuple(directions.shape) if isinstance(directions, torch.Tensor) else type(directions).__name__
            )
            raise ValueError(
                f"CNNDMPPolicy: the checkpoint's depth_directions is {got}, "
                f"expected {tuple(self.depth_directions.shape)}"
            )
        if state["map_centres"].shape[0] != state["map_coefficients"].shape[0]:
            raise ValueError(
                "CNNDMPPolicy: the checkpoint's map_centres and map_coefficients differ in length"
            )

    def fit_params_map(
        self,
        placement: torch.Tensor,
        joints: torch.Tensor,
        goal: torch.Tensor,
        weights: torch.Tensor,
        ridge: float = 0.1,
        states: torch.Tensor | None = None,
    ) -> None:
        """Set the affine map of ``placement_dim`` to the ridge regression of the demonstrations'
        normalised DMP parameters on their normalised placements and start states (the training
        split's statistics must be in the buffers) and, with ``map_kernel_scale``, its kernel
        correction to the kernel ridge regression of the affine map's residuals; freeze both.

        Args:
            placement: ``(E, placement_dim)`` m; joints: ``(E, n)`` start states; goal: ``(E, n)``;
                weights: ``(E, n, K)``: the training demonstrations.
            ridge: the penalty on the map's weights (not its bias), > 0.
            states: ``(E, T, n)`` the demonstrations' states: with ``map_segments``, the
                :class:`~lfd.visuomotor.policies.placement_map.SegmentedMap` is fitted on them too
                (it stays empty when some demonstration never switches: plans use the single DMP).

        Raises:
            ValueError: the policy has no placement map, ``ridge`` is not a finite number > 0, or
                ``map_segments`` without ``states``.
        """
        self._need_placement_map("fit_params_map")
        if not (isinstance(ridge, (int, float)) and np.isfinite(ridge) and ridge > 0):
            raise ValueError(f"CNNDMPPolicy.fit_params_map: ridge must be a finite number > 0, got {ridge!r}")
        with torch.no_grad():
            x = torch.cat(
                [self.normalise("placement", placement), self.normalise("joints", joints)], dim=1
            ).double()
            y = torch.cat(
                [self.normalise("goal", goal), self.normalise("weights", weights).flatten(1)], dim=1
            ).double()
            scale = float(self.hparams.get("map_kernel_scale", 0.0))
            a, bias, centres, coefficients = fit_ridge_kernel(x, y, ridge, scale, KERNEL_RIDGE)
            self.params_map.weight.copy_(a.T)
            self.params_map.bias.copy_(bias)
            self.map_centres = centres.to(self.params_map.weight)
            self.map_coefficients = coefficients.to(self.params_map.weight)
            if hasattr(self, "segmented_map"):
                if states is None:
                    raise ValueError(
                        "CNNDMPPolicy.fit_params_map: map_segments needs the demonstrations' states"
                    )
                self.segmented_map.fit(x, states.detach().cpu().numpy(), ridge)
        self.params_map.requires_grad_(False)

    def fit_depth_directions(self, placement: torch.Tensor, pixels: torch.Tensor) -> torch.Tensor:
        """Set :attr:`depth_directions` from the training placements: each point's open direction
        (:func:`~lfd.visuomotor.policies.line_of_sight.open_directions`: its line of sight, scaled
        to one root mean square, where that exceeds 1 cm), in normalised placement
        units; zero rows elsewhere. The placement statistics must be in the buffers.

        Args:
            placement: ``(E, placement_dim)`` m; pixels: ``(E, 2 m)`` px, ``[u_0, v_0, ...]`` (NaN:
                padding, left out).

        Returns:
            ``(m,)`` each point's residual root mean square (m; 0 where not fitted).

        Raises:
            ValueError: wrong shapes.
        """
        self._need_placement_map("fit_depth_directions")
        m, p = self.placement_points, self.hparams.placement_dim
        if placement.ndim != 2 or placement.shape[1] != p or pixels.shape != (len(placement), 2 * m):
            raise ValueError(
                f"CNNDMPPolicy.fit_depth_directions: expected placement (E, {p}) and pixels (E, {2 * m}), "
                f"got {tuple(placement.shape)} and {tuple(pixels.shape)}"
            )
        metres, rms = open_directions(placement, pixels)
        zero = torch.zeros(1, p, dtype=self.depth_directions.dtype, device=self.depth_directions.device)
        rows = self.normalise("placement", metres.to(zero)) - self.normalise("placement", zero)
        self.depth_directions = rows.to(self.depth_directions)
        return rms

    def setup(self, stage: str) -> None:
        """The harness's ``setup`` and, at ``fit`` with ``placement_dim``, :meth:`fit_params_map` on
        the datamodule's training items (and, with ``keypoint_head="supervised_depth"``,
        :meth:`fit_depth_directions` on their ``placement_pixels``)."""
        super().setup(stage)
        if stage != "fit" or not self.through_placement:
            return
        train = getattr(self.trainer.datamodule, "datasets", {}).get("train")
        if train is None or len(train) == 0 or "placement" not in train[0]:
            raise ValueError(
                f"CNNDMPPolicy(placement_dim={self.hparams.placement_dim}): the datamodule's training items "
                "have no 'placement' (Meta-World's demonstrations have)"
            )
        items = [train[i] for i in range(len(train))]
        keys = ("placement", "joints", "goal", "weights")
        states = (
            torch.stack([item["trajectory"] for item in items]) if hasattr(self, "segmented_map") else None
        )
        self.fit_params_map(
            *(torch.stack([item[k] for item in items]).to(self.device) for k in keys), states=states
        )
        if self.hparams.get("keypoint_head") == "supervised_depth":
            if "placement_pixels" not in items[0]:
                raise ValueError(
                    "CNNDMPPolicy(keypoint_head='supervised_depth'): the datamodule's training items have "
                    "no 'placement_pixels'"
                )
            self.fit_depth_directions(
                torch.stack([item["placement"] for item in items]).to(self.device),
                torch.stack([item["placement_pixels"] for item in items]).to(self.device),
            )

    def _placement_target(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        """The batch's normalised ``placement`` ``(B, placement_dim)``; one line if it has none that fits."""
        p = batch.get("placement")
        dim = self.hparams.placement_dim
        if p is None or p.ndim != 2 or p.shape[1] != dim:
            got = "none" if p is None else f"shape {tuple(p.shape)}"
            raise ValueError(
                f"CNNDMPPolicy(placement_dim={dim}): batches need a 'placement' of shape (B, {dim}), got {got}"
            )
        return self.normalise("placement", p)

    def _keypoint_mse(self, keypoints: torch.Tensor, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        """Mean squared distance (soft-argmax units) of the first ``m`` keypoints from the batch's
        ``placement_pixels`` (``m`` = :attr:`placement_points`) or, without a placement, ``target_pixels``
        (``m = 1``), ``(B, 2 m)`` px; NaN targets left out. One line if the batch has none."""
        key, m = (
            ("placement_pixels", self.placement_points) if self.through_placement else ("target_pixels", 1)
        )
        pixels = batch.get(key)
        if pixels is None or pixels.ndim != 2 or pixels.shape[1] != 2 * m:
            got = "none" if pixels is None else f"shape {tuple(pixels.shape)}"
            raise ValueError(
                f"CNNDMPPolicy(keypoint_weight > 0): batches need '{key}' of shape (B, {2 * m}) "
                f"(the datamodules serve them unless data.augment shifts the images), got {got}"
            )
        target = self.encoder.pixel_keypoints(pixels.view(len(pixels), m, 2), batch["image"].shape[-1])
        target = target.flatten(1).to(keypoints)
        known = torch.isfinite(target)
        if not known.any():
            return keypoints.new_zeros(())
        return ((keypoints[:, : 2 * m] - torch.nan_to_num(target)) ** 2)[known].mean()

    def _split_params(self, out: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Head output ``(B, n + n K)`` -> normalised goal ``(B, n)`` and weights ``(B, n, K)``."""
        n = self.hparams.n_joints
        return out[:, :n], out[:, n:].reshape(-1, n, self.hparams.n_basis)

    def layer(self, n_steps: int | None = None) -> DMPLayer:
        """The DMP layer giving ``n_steps`` samples (default: the demonstrations' ``T``) of the
        same DMP (same duration ``tau``): past ``tau`` the forcing term has died out and the
        spring-damper keeps converging to the goal, smoothly and at rest in the limit."""
        if n_steps is None or n_steps == self.hparams.n_steps:
            return self.dmp
        if n_steps < 2:
            raise ValueError(f"CNNDMPPolicy: n_steps must be >= 2, got {n_steps}")
        layer = self._horizon_layers.get(n_steps)
        if layer is None:
            d = self.dmp
            layer = DMPLayer(
                n_basis=d.n_basis,
                n_steps=n_steps,
                dt=self.control_dt,
                alpha_z=d.gains.alpha_z,
                tau=d.tau,
                formulation=d.formulation,
            )
            self._horizon_layers[n_steps] = layer
        return layer.to(self.device)

    def rollout(
        self, joints: torch.Tensor, goal_n: torch.Tensor, weights_n: torch.Tensor, n_steps: int | None = None
    ) -> torch.Tensor:
        """Joint trajectory ``(B, T, n)`` rad from the start joints and normalised parameters
        (``T = n_steps``, default the demonstrations' length, see :meth:`layer`)."""
        goal = self.denormalise("goal", goal_n)
        weights = self.denormalise("weights", weights_n)
        return self.layer(n_steps)(joints, goal, weights)

    def forward(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        """Images ``(B, 3, H, W)`` in [0, 1], start joints ``(B, n)`` rad -> trajectory ``(B, T, n)`` rad."""
        return self.rollout(joints, *self.predict_params(image, joints))

    def losses(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        joints = batch["joints"]
        supervise = self.hparams.get("keypoint_weight", 0.0) > 0
        more = {"with_keypoints": True} if supervise else {}
        params, aux, *encoded = self.head_outputs(batch["image"], joints, top=batch.get("top"), **more)
        placement_mse = None
        keypoint_mse = self._keypoint_mse(encoded[0], batch) if supervise else None
        if self.through_placement:
            placement_mse = F.mse_loss(params, self._placement_target(batch))
            params = self._params_from_placement(params, joints)
        goal_n, weights_n = self._split_params(params)
        goal_err = F.mse_loss(goal_n, self.normalise("goal", batch["goal"]))
        weights_err = F.mse_loss(weights_n, self.normalise("weights", batch["weights"]))
        rest = self.hparams.rest_steps
        target, ee_target = _hold_last(batch["trajectory"], rest), _hold_last(batch["ee_path"], rest)
        trajectory = self.rollout(joints, goal_n, weights_n, n_steps=self.hparams.n_steps + rest)
        error = trajectory - target
        if self.hparams.get("normalise_trajectory", False):
            error = error / self.joints_std
        sq = (error**2).mean(dim=(0, 2))
        out = {
            "param_mse": goal_err + weights_err,
            "traj_mse": sq.mean(),
            "final_joint_err": (trajectory[:, -1] - target[:, -1]).norm(dim=-1).mean(),
        }
        need_ee = self.hparams.ee_weight > 0 or not self.training
        if need_ee:
            ee = self.tool_positions(trajectory)
            out["ee_mse"] = ((ee - ee_target) ** 2).sum(-1).mean()
            out["final_ee_err_m"] = (ee[:, -1] - ee_target[:, -1]).norm(dim=-1).mean()
        if self.hparams.loss == "params":
            out["loss"] = out["param_mse"]
        else:
            weights = self.time_weights().to(sq)
            out["loss"] = (sq * weights).mean() / weights.mean()
            if self.hparams.ee_weight > 0:
                out["loss"] = out["loss"] + self.hparams.ee_weight * out["ee_mse"]
        if placement_mse is not None:  # the map is fixed (fit_params_map): only the perception learns
            out["placement_mse"] = out["loss"] = placement_mse
        if keypoint_mse is not None:
            out["keypoint_mse"] = keypoint_mse
            out["loss"] = out["loss"] + self.hparams.keypoint_weight * keypoint_mse
            # root mean square per coordinate, in image pixels
            out["keypoint_err_px"] = keypoint_mse.sqrt() * self.encoder.pixels_per_unit(
                batch["image"].shape[-1]
            )
        return self.add_aux_losses(out, aux, batch)

    def time_weights(self) -> torch.Tensor:
        """``(T + rest_steps,)`` weights of the trajectory loss over time: ``1 + final_weight``
        on the last ``final_fraction`` of the demonstration and on the rest samples, else 1."""
        hp = self.hparams
        t = torch.cat(
            [torch.linspace(0.0, 1.0, hp.n_steps), torch.ones(hp.rest_steps)]
        )  # rest = end of the motion
        return 1.0 + hp.final_weight * (t >= 1.0 - hp.final_fraction).float()

    def sample_figure(self, batch: dict[str, torch.Tensor]):
        predicted = self(batch["image"][:1], batch["joints"][:1])[0].cpu().numpy()
        t = batch["t"][0].cpu().numpy()
        return joint_figure(
            t, predicted, batch["trajectory"][0].cpu().numpy(), f"CNN->DMP, episode {int(batch['index'][0])}"
        )

    def controller(
        self, dt: float, replan_every: int | None = None, replan_weights: bool = False
    ) -> PlanController:
        """A :class:`~lfd.visuomotor.policies.control.PlanController`: one :meth:`plan` on the
        episode's first observation, then the plan tracked every ``dt`` (s); with
        ``replan_every=k`` (an int >= 1) the DMP's goal is re-predicted from the camera every
        ``k`` steps and changed online (:meth:`predict_goal`, :meth:`change_goal`), and with
        ``replan_weights=True`` its forcing weights too (:meth:`replan`)."""
        return PlanController(self, dt, replan_every=replan_every, replan_weights=replan_weights)

    @torch.inference_mode()
    def plan(self, image, joints, n_steps: int | None = None) -> np.ndarray:
        """The planning call of :meth:`controller`: camera image(s) uint8 ``(H, W, 3)`` / ``(B, H, W, 3)`` and
        current joints ``(n,)`` / ``(B, n)`` rad -> planned joint trajectory ``(T, n)`` /
        ``(B, T, n)`` rad (float64), sampled every :attr:`control_dt` seconds, starting at
        ``joints``; ``T = n_steps`` (default: the demonstrations' length; longer plans run the
        same DMP on past its duration, see :meth:`layer`)."""
        img, q, batched = self._observation(image, joints)
        if self.plans_in_segments:
            traj = self._segmented_plan(self.features(img, q), q, n_steps)
        else:
            traj = self.rollout(q, *self.predict_params(img, q), n_steps=n_steps).double().cpu().numpy()
        return traj if batched else traj[0]

    @torch.inference_mode()
    def plan_from_placement(self, placement, joints, n_steps: int | None = None) -> np.ndarray:
        """The plan of the placement map (``placement_dim``) from a known placement ``(p,)`` / ``(B, p)`` m
        and start joints ``(n,)`` / ``(B, n)``: what :meth:`plan` would give if the network saw the
        placement exactly (a diagnostic: ``scripts/metaworld_plan_error.py``). Same shapes as :meth:`plan`.

        Raises:
            ValueError: the policy has no placement map.
        """
        self._need_placement_map("plan_from_placement")
        q = torch.as_tensor(np.asarray(joints), dtype=torch.float32, device=self.device)
        p = torch.as_tensor(np.asarray(placement), dtype=torch.float32, device=self.device)
        batched = q.ndim == 2
        q, p = q.reshape(-1, self.hparams.n_joints), p.reshape(-1, self.hparams.placement_dim)
        if self.plans_in_segments:
            traj = self._segmented_plan(self.normalise("placement", p), q, n_steps)
        else:
            params = self._split_params(self._params_from_placement(self.normalise("placement", p), q))
            traj = self.rollout(q, *params, n_steps=n_steps).double().cpu().numpy()
        return traj if batched else traj[0]

    @torch.inference_mode()
    def plan_dmp(self, image, joints, n_steps: int | None = None) -> DMPPlan:
        """:meth:`plan` with the DMP's parameters: the same trajectory (bit for bit) and its start,
        goal and weights, for :meth:`change_goal` (the first planning call of a re-planning
        :meth:`controller`).

        Raises:
            ValueError: the policy plans in segments (``map_segments``): re-planning changes one DMP."""
        if self.plans_in_segments:
            raise ValueError(
                "CNNDMPPolicy: re-planning (eval.dmp_replan_every) needs model.map_segments=false"
            )
        img, q, batched = self._observation(image, joints)
        goal_n, weights_n = self.predict_params(img, q)
        goal, weights = self.denormalise("goal", goal_n), self.denormalise("weights", weights_n)
        traj, velocity, _ = self.layer(n_steps)(q, goal, weights, return_derivatives=True)
        values = [traj, q, goal, weights, velocity]
        values = [x.double().cpu().numpy() for x in values]
        return DMPPlan(*(values if batched else [x[0] for x in values]))

    @torch.inference_mode()
    def predict_goal(self, image, start_joints) -> np.ndarray:
        """The network's DMP goal ``(n,)`` / ``(B, n)`` rad (float64, de-normalised) for camera
        image(s) as in :meth:`plan` and the episode's *start* joints ``(n,)`` / ``(B, n)`` (the
        network was trained with the start state as input, so a re-planning controller passes
        the start, not the current joints)."""
        img, q, batched = self._observation(image, start_joints)
        goal = self.denormalise("goal", self.predict_params(img, q)[0]).double().cpu().numpy()
        return goal if batched else goal[0]

    def replan(self, plan: DMPPlan, step: int, image, start_joints) -> DMPPlan:
        """``plan`` with its DMP's goal *and* forcing weights re-predicted from a new camera image at
        sample ``step`` (the re-planning controller's ``replan_weights=True``).

        The network sees ``image`` with the episode's *start* joints (its training input) and gives
        new parameters ``(g', w')``. From ``step`` on the plan follows the DMP with these parameters
        from its current position and velocity: that is the new parameters' rollout from the
        episode's start plus the transformation system's free response to the difference in
        position and velocity at ``step`` (exact: the forcing depends only on the phase, ``y0``,
        ``g'`` and ``w'``, so two solutions differ by a solution of the homogeneous spring-damper
        ``tau^2 h'' = -alpha_z beta_z h - alpha_z tau h'``). The hand leaves the old plan without
        a jump in position or velocity and converges onto the new one (time constant
        ``2 tau / alpha_z``, critically damped by default).

        Args:
            plan: from :meth:`plan_dmp` (or an earlier :meth:`change_goal` / :meth:`replan`).
            step: the sample at which the plan changes, ``1 <= step < T - 1`` (velocities are
                central differences of the sampled paths).
            image: camera image uint8 ``(H, W, 3)`` (unbatched plans only).
            start_joints: ``(n,)`` the episode's start state.

        Returns:
            A new :class:`DMPPlan` (same start; the new goal and weights).

        Raises:
            ValueError: a batched plan, or ``step`` outside ``1 .. T - 2``.
        """
        trajectory = np.asarray(plan.trajectory)
        n_samples = trajectory.shape[-2]
        if trajectory.ndim != 2:
            raise ValueError(
                f"CNNDMPPolicy.replan: expected an unbatched (T, n) plan, got {trajectory.shape}"
            )
        if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or not 1 <= step < n_samples - 1:
            raise ValueError(f"CNNDMPPolicy.replan: step must be an int in 1..{n_samples - 2}, got {step!r}")
        new = self.plan_dmp(image, start_joints, n_steps=n_samples)
        old_velocity, new_velocity = (
            _central_velocity(p.trajectory, self.control_dt) if p.velocity is None else p.velocity
            for p in (plan, new)
        )
        offset = trajectory[step] - new.trajectory[step]
        rate = old_velocity[step] - new_velocity[step]
        position, velocity = self.free_response(offset, rate, n_samples - step)
        out, out_velocity = new.trajectory.copy(), np.array(new_velocity, dtype=np.float64)
        out[step:] += position
        out_velocity[step:] += velocity
        return replace(new, trajectory=out, velocity=out_velocity)

    def free_response(self, offset, rate, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
        """:func:`lfd.visuomotor.policies.goal_change.free_response` of this policy's DMP."""
        return goal_change.free_response(self.layer(), self.control_dt, offset, rate, n_samples)

    def change_goal(self, plan: DMPPlan, step: int, goal) -> DMPPlan:
        """``plan`` with its DMP's goal switched to ``goal`` at sample ``step`` (online goal change,
        Ijspeert et al. 2013): the DMP keeps its integration state at that sample (position,
        velocity, phase), its weights and ``tau``; only the goal changes, at once, as in
        :mod:`lfd.dmp.stepping` (in the ``"pastor"`` formulation the ``- K (g - y0) s`` term
        follows the new goal too), and samples ``step + 1 ..`` are integrated anew.

        The DMP is linear in its goal, so the new samples are the old ones plus the response
        of the same DMP started at rest at zero at ``step``'s phase to the goal step
        ``dg = goal - g`` and to the forcing change that the switch makes (see
        :meth:`goal_step_response`). An unchanged goal leaves the plan exactly as it was; the
        DMP re-integrated from its state with the new goal agrees with this to rounding.

        Args:
            plan: from :meth:`plan_dmp` (or an earlier :meth:`change_goal`).
            step: the sample (control step) at which the goal changes, ``0 <= step < T``.
            goal: ``(n,)`` / ``(B, n)`` rad, the new goal (e.g. :meth:`predict_goal`'s).

        Returns:
            A new :class:`DMPPlan` (same start and weights, goal ``goal``).
        """
        goal = np.asarray(goal, dtype=np.float64)
        if goal.shape != plan.goal.shape or not np.all(np.isfinite(goal)):
            raise ValueError(
                f"CNNDMPPolicy.change_goal: expected a finite goal of shape {plan.goal.shape}, got {goal.shape}"
            )
        n_samples = plan.trajectory.shape[-2]
        if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or not 0 <= step < n_samples:
            raise ValueError(
                f"CNNDMPPolicy.change_goal: step must be an int in 0..{n_samples - 1}, got {step!r}"
            )
        change = goal - plan.goal
        trajectory, velocity = plan.trajectory.copy(), plan.velocity
        if step + 1 < n_samples and np.any(change != 0.0):
            response = self.goal_step_response(change, plan.weights, int(step), n_samples)
            trajectory[..., step + 1 :, :] += response[..., 1:, :]
            velocity = None  # the response's velocity is not computed: central differences if needed
        return replace(plan, trajectory=trajectory, goal=goal, velocity=velocity)

    @torch.inference_mode()
    def goal_step_response(self, change, weights, step: int, n_samples: int) -> np.ndarray:
        """:func:`lfd.visuomotor.policies.goal_change.goal_step_response` of this policy's DMP."""
        layer = self.layer(n_samples)
        return goal_change.goal_step_response(layer, self.control_dt, change, weights, step, n_samples)


def _central_velocity(trajectory: np.ndarray, dt: float) -> np.ndarray:
    """``(..., T, n)`` samples every ``dt`` s -> their velocity by central differences (one-sided at the ends)."""
    return np.gradient(np.asarray(trajectory, dtype=np.float64), dt, axis=-2)


def _hold_last(path: torch.Tensor, extra: int) -> torch.Tensor:
    """``(B, T, d)`` -> ``(B, T + extra, d)``: the path followed by ``extra`` copies of its last sample."""
    if extra == 0:
        return path
    return torch.cat([path, path[:, -1:].expand(-1, extra, -1)], dim=1)
