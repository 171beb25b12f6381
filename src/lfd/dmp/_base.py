"""Behaviour shared by :class:`~lfd.dmp.DMP` and :class:`~lfd.dmp.RhythmicDMP`: learned-state
bookkeeping and JSON persistence."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

from lfd import checks

from . import _io


class Primitive(ABC):
    """Base class: subclasses set ``_KIND``, the per-DoF vectors and scalars they learn, and
    implement ``_params`` (constructor arguments). Learned attributes end in ``_``."""

    _KIND: ClassVar[str]
    _VECTORS: ClassVar[tuple[str, ...]] = ("y0", "goal")  # (D,) or (B, D) learned vectors
    _SCALARS: ClassVar[dict] = {"tau": checks.positive_float, "n_steps": checks.positive_int}
    #: Constructor arguments added after format version 1 was fixed, with the value that a
    #: file written before they existed implies (read by :meth:`load` when one is missing).
    _MISSING_PARAMS: ClassVar[dict] = {}
    n_basis: int

    @abstractmethod
    def _params(self) -> dict:
        """Constructor arguments, as saved with the learned state."""

    def __repr__(self) -> str:
        args = ", ".join(f"{name}={value!r}" for name, value in self._params().items())
        return f"{type(self).__name__}({args})"

    @property
    def is_fitted(self) -> bool:
        """Whether :meth:`fit` (or :meth:`load`) has set the learned attributes."""
        return hasattr(self, "weights_")

    def _fitted(self, name: str, value):
        """``value``, or the learned ``name_`` when ``value`` is None (error if not fitted)."""
        if value is not None:
            return value
        if not self.is_fitted:
            raise ValueError(
                f"{name} is required: the {type(self).__name__} is not fitted (call fit() or pass all arguments)"
            )
        return getattr(self, name + "_")

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
        except TypeError as exc:
            raise ValueError(f"{path}: bad {cls.__name__} parameters {params}") from exc
        if fitted is not None:
            try:
                primitive._restore(fitted)
            except (KeyError, ValueError) as exc:
                raise ValueError(f"{path}: bad fitted state: {exc}") from exc
        return primitive

    def _restore(self, fitted: dict) -> None:
        weights = checks.finite_array(fitted["weights"], "weights", ndim=(2, 3))
        if weights.shape[-1] != self.n_basis:
            raise ValueError(f"weights have {weights.shape[-1]} basis functions, expected {self.n_basis}")
        vectors = {name: checks.finite_array(fitted[name], name, ndim=(1, 2)) for name in self._VECTORS}
        for name, vector in vectors.items():
            if vector.shape != weights.shape[:-1]:
                raise ValueError(f"{name} has shape {vector.shape}, expected {weights.shape[:-1]}")
        scalars = {name: convert(fitted[name], name) for name, convert in self._SCALARS.items()}
        for name, value in {"weights": weights, **vectors, **scalars}.items():
            setattr(self, name + "_", value)
