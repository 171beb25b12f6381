"""Gains of the DMP transformation and canonical systems, validated once (all dimensionless).

:class:`Gains` (``alpha_z``, ``beta_z``, basis ``overlap``) serves every DMP; :class:`DiscreteGains`
adds the canonical-system decay ``alpha_s`` of discrete DMPs. ``resolve`` fills the defaults
(``beta_z = alpha_z / 4``, critically damped; ``alpha_s = alpha_z / 3``) and raises ``ValueError``
naming the first gain outside its range: ``alpha_z`` and ``beta_z`` in ``[MIN_GAIN, MAX_GAIN]``,
``alpha_s`` in ``[MIN_GAIN, MAX_ALPHA_S]``, ``overlap`` in ``(0, 1)``. The ranges are far wider than
any DMP in use (``alpha_z`` 25, ``alpha_s`` 8.3 by default) and keep the rollout finite: beyond
``MAX_ALPHA_S`` the last basis activations ``exp(-alpha_s * c)`` vanish and the normalised forcing
term is 0/0; beyond ``MAX_GAIN`` the discriminant ``alpha_z**2`` stops being a float soon after.
"""

from __future__ import annotations

from dataclasses import dataclass

from lfd import checks

__all__ = ["MAX_ALPHA_S", "MAX_GAIN", "MIN_GAIN", "DiscreteGains", "Gains"]

#: Smallest and largest accepted ``alpha_z`` and ``beta_z`` (and smallest ``alpha_s``).
MIN_GAIN = 1e-6
MAX_GAIN = 1e4
#: Largest accepted canonical decay ``alpha_s`` (``exp(-100)`` is still a normal float32).
MAX_ALPHA_S = 100.0


def _gain(value, name: str, high: float = MAX_GAIN) -> float:
    return checks.check_float(value, name, low=MIN_GAIN, high=high)


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
        alpha_z = _gain(alpha_z, "alpha_z")
        return {
            "alpha_z": alpha_z,
            "beta_z": _gain(alpha_z / 4.0 if beta_z is None else beta_z, "beta_z"),
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
        if alpha_s is None:
            alpha_s = _gain(common["alpha_z"] / 3.0, "alpha_s (alpha_z / 3 by default)", MAX_ALPHA_S)
        else:
            alpha_s = _gain(alpha_s, "alpha_s", MAX_ALPHA_S)
        return cls(**common, alpha_s=alpha_s)
