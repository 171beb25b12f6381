"""Gains of the DMP transformation and canonical systems, validated once (all dimensionless).

:class:`Gains` (``alpha_z``, ``beta_z``, basis ``overlap``) serves every DMP; :class:`DiscreteGains`
adds the canonical-system decay ``alpha_s`` of discrete DMPs. ``resolve`` fills the defaults
(``beta_z = alpha_z / 4``, critically damped; ``alpha_s = alpha_z / 3``) and raises ``ValueError``
naming the first gain that is not a finite number > 0 (``overlap``: not in ``(0, 1)``).
"""

from __future__ import annotations

from dataclasses import dataclass

from lfd import checks

__all__ = ["DiscreteGains", "Gains"]


@dataclass(frozen=True)
class Gains:
    """Transformation-system gains and basis overlap (all dimensionless).

    Attributes:
        alpha_z: damping gain of the transformation system.
        beta_z: spring gain (``alpha_z / 4``: critically damped).
        overlap: activation of a basis at its neighbour's centre, in ``(0, 1)``.
    """

    alpha_z: float
    beta_z: float
    overlap: float

    @staticmethod
    def _common(alpha_z, beta_z, overlap) -> dict:
        alpha_z = checks.positive_float(alpha_z, "alpha_z")
        return {
            "alpha_z": alpha_z,
            "beta_z": checks.positive_float(alpha_z / 4.0 if beta_z is None else beta_z, "beta_z"),
            "overlap": checks.unit_interval(overlap, "overlap"),
        }

    @classmethod
    def resolve(cls, alpha_z=25.0, beta_z=None, overlap=0.8) -> Gains:
        """Validated gains; ``beta_z`` defaults to ``alpha_z / 4``."""
        return cls(**cls._common(alpha_z, beta_z, overlap))


@dataclass(frozen=True)
class DiscreteGains(Gains):
    """:class:`Gains` plus ``alpha_s``, the canonical-system decay (``s(tau) = exp(-alpha_s)``)."""

    alpha_s: float

    @classmethod
    def resolve(cls, alpha_z=25.0, beta_z=None, alpha_s=None, overlap=0.8) -> DiscreteGains:
        """Validated gains; ``beta_z`` defaults to ``alpha_z / 4``, ``alpha_s`` to ``alpha_z / 3``."""
        common = cls._common(alpha_z, beta_z, overlap)
        alpha_s = checks.positive_float(common["alpha_z"] / 3.0 if alpha_s is None else alpha_s, "alpha_s")
        return cls(**common, alpha_s=alpha_s)
