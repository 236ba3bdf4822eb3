"""filmcal: calibrate finite-element models of Prescale pressure-measurement film
against sphere-on-flat experiments and correct wheel-rail contact areas measured
with film, with their uncertainty.

Units inside the package: millimetre, newton, megapascal (N/mm^2). Names carry
their unit where a number has one (``radius_mm``, ``force_n``, ``modulus_mpa``).
"""
from __future__ import annotations

__version__ = "0.1.0"

__all__ = ["__version__"]
