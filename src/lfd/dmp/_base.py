"""What the movement primitives of :mod:`lfd.dmp` share, written once (as movement_primitives' ``DMPBase``).

* :class:`Parameterised`: the constructor arguments listed in ``_PARAMS`` are what is saved with
  the learned state and what ``repr`` shows (``DMP(n_basis=20, alpha_z=25.0, ...)``, which
  rebuilds the object); ``is_fitted``; ``_fitted(name, value)``, the value or the learned
  ``name_`` (``ValueError`` when unfitted).
* :class:`DMPBase`: the hyper-parameters of the DMP family, validated in one order
  (``n_basis`` an integer >= 1, the gains (:mod:`lfd.dmp.gains`), ``formulation``, ``ridge``
  a finite number >= 0; ``ValueError`` naming the first bad one), the gain properties
  ``alpha_z``, ``beta_z``, ``alpha_s`` (discrete DMPs) and ``overlap``, and the arguments that
  build a :class:`lfd.dmp.DMP` with the same settings (the DMPs that delegate to one).
* :class:`Primitive`: the learned state (``weights_``, the per-DoF vectors ``_VECTORS``, the
  scalars ``_SCALARS``) and its JSON persistence.
"""

from __future__ import annotations

from typing import ClassVar

from lfd import checks

from . import _io
from .fitting import DEFAULT_RIDGE, check_ridge
from .formulation import check_formulation
from .gains import DiscreteGains, Gains

#: Largest magnitude a saved DMP may hold in its per-DoF vectors (start, goal, velocities: a
#: kilometre in metres, 1e6 rad) and in its forcing weights; a file beyond them is refused on
#: load, since its rollout overflows to inf/NaN long before the values mean anything.
MAX_STATE_MAGNITUDE = 1e6
MAX_WEIGHT_MAGNITUDE = 1e12

#: The constructor arguments of a discrete DMP, in order.
DISCRETE_PARAMS = ("n_basis", "alpha_z", "beta_z", "alpha_s", "overlap", "formulation", "ridge")


class Parameterised:
    """Constructor arguments (``_PARAMS``), ``repr``, ``is_fitted`` (the attribute ``_FITTED`` is
    set) and ``_fitted`` for a primitive; learned attributes end in ``_``."""

    _PARAMS: ClassVar[tuple[str, ...]]
    _FITTED: ClassVar[str] = "weights_"

    def _params(self) -> dict:
        """Constructor arguments, as saved with the learned state."""
        return {name: getattr(self, name) for name in self._PARAMS}

    def __repr__(self) -> str:
        args = ", ".join(f"{name}={value!r}" for name, value in self._params().items())
        return f"{type(self).__name__}({args})"

    @property
    def is_fitted(self) -> bool:
        """Whether :meth:`fit` (or :meth:`load`) has set the learned attributes."""
        return hasattr(self, self._FITTED)

    def _fitted(self, name: str, value):
        """``value``, or the learned ``name_`` when ``value`` is None (error if not fitted)."""
        if value is not None:
            return value
        if not self.is_fitted:
            raise ValueError(
                f"{name} is required: the {type(self).__name__} is not fitted (call fit() or pass all arguments)"
            )
        return getattr(self, name + "_")


class DMPBase(Parameterised):
    """Hyper-parameters of a DMP: ``n_basis``, ``gains`` (of type ``_GAINS``), ``ridge`` and,
    where the subclass has one, ``formulation``; see :meth:`_set_params`."""

    _PARAMS: ClassVar[tuple[str, ...]] = DISCRETE_PARAMS
    _GAINS: ClassVar[type[Gains]] = DiscreteGains
    n_basis: int
    gains: Gains
    ridge: float
    formulation: str

    def _set_params(self, n_basis, gains: dict, formulation: str | None = None, ridge=DEFAULT_RIDGE) -> None:
        """Validate and set ``n_basis``, ``gains`` (``_GAINS.resolve(**gains)``), ``formulation``
        (unless None: the subclass has none) and ``ridge``, in this order."""
        self.n_basis = checks.positive_int(n_basis, "n_basis")
        self.gains = self._GAINS.resolve(**gains)
        if formulation is not None:
            self.formulation = check_formulation(formulation)
        self.ridge = check_ridge(ridge)

    alpha_z = property(lambda self: self.gains.alpha_z, doc="Damping gain of the transformation system.")
    beta_z = property(lambda self: self.gains.beta_z, doc="Spring gain of the transformation system.")
    alpha_s = property(lambda self: self.gains.alpha_s, doc="Decay rate of the canonical system.")
    overlap = property(lambda self: self.gains.overlap, doc="Basis activation at the neighbouring centre.")

    def _dmp_params(self, formulation: str | None = None) -> dict:
        """Arguments of a :class:`lfd.dmp.DMP` with these settings (``formulation``: default this one's)."""
        g = self.gains
        return {
            "n_basis": self.n_basis,
            "alpha_z": g.alpha_z,
            "beta_z": g.beta_z,
            "alpha_s": g.alpha_s,
            "overlap": g.overlap,
            "formulation": self.formulation if formulation is None else formulation,
            "ridge": self.ridge,
        }


class Primitive(DMPBase):
    """A DMP with learned state: subclasses set ``_KIND`` (the file's type field) and the per-DoF
    vectors and scalars they learn."""

    _KIND: ClassVar[str]
    _VECTORS: ClassVar[tuple[str, ...]] = ("y0", "goal")  # (D,) or (B, D) learned vectors
    _SCALARS: ClassVar[dict] = {"tau": checks.positive_float, "n_steps": checks.positive_int}
    #: Constructor arguments added after format version 1 was fixed, with the value that a
    #: file written before they existed implies (read by :meth:`load` when one is missing).
    _MISSING_PARAMS: ClassVar[dict] = {}

    def save(self, path) -> None:
        """Write hyper-parameters and learned state to a JSON file (temp file + atomic rename).

        Args:
            path: file path ending in ``.json`` (e.g. ``"reach.dmp.json"``); its directory must exist.

        Raises:
            ValueError: ``path`` does not end in ``.json``.
        """
        fitted = None
        if self.is_fitted:
            names = ("weights", *self._VECTORS, *self._SCALARS)
            fitted = {name: getattr(self, name + "_") for name in names}
        _io.write_json(path, self._KIND, self._params(), fitted)

    @classmethod
    def load(cls, path):
        """Read an instance written by :meth:`save`.

        Raises:
            FileNotFoundError: no such file.
            ValueError: wrong file type/version or inconsistent contents.
        """
        params, fitted = _io.read_json(path, cls._KIND)
        params = {**cls._MISSING_PARAMS, **params}
        try:
            primitive = cls(**params)
        except (TypeError, ValueError) as exc:  # the constructor's own checks: one line naming the file
            raise ValueError(f"{path}: bad {cls.__name__} parameters: {exc}") from None
        if fitted is not None:
            try:
                primitive._restore(fitted)
            except (KeyError, TypeError, ValueError) as exc:
                raise ValueError(f"{path}: bad fitted state: {exc}") from exc
        return primitive

    def _restore(self, fitted: dict) -> None:
        weights = _bounded(
            checks.finite_array(fitted["weights"], "weights", ndim=(2, 3)), "weights", MAX_WEIGHT_MAGNITUDE
        )
        if weights.shape[-1] != self.n_basis:
            raise ValueError(f"weights have {weights.shape[-1]} basis functions, expected {self.n_basis}")
        vectors = {
            name: _bounded(checks.finite_array(fitted[name], name, ndim=(1, 2)), name, MAX_STATE_MAGNITUDE)
            for name in self._VECTORS
        }
        for name, vector in vectors.items():
            if vector.shape != weights.shape[:-1]:
                raise ValueError(f"{name} has shape {vector.shape}, expected {weights.shape[:-1]}")
        scalars = {name: convert(fitted[name], name) for name, convert in self._SCALARS.items()}
        for name, value in {"weights": weights, **vectors, **scalars}.items():
            setattr(self, name + "_", value)


def _bounded(array, name: str, limit: float):
    """``array`` when every |value| <= ``limit``; ``ValueError`` naming ``name`` otherwise."""
    if array.size and float(abs(array).max()) > limit:
        raise ValueError(f"{name} must have every |value| <= {limit:g}, got {float(abs(array).max()):g}")
    return array
