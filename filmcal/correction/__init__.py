"""Corrections of contact areas measured with film, with their uncertainty:
sphere-on-flat imprints (`SphereCorrector`) and wheel-rail imprints
(`WheelRailCorrector`)."""
from filmcal.correction.sphere import CorrectedArea, SphereCorrector
from filmcal.correction.wheelrail import WheelRailCorrector

__all__ = ["CorrectedArea", "SphereCorrector", "WheelRailCorrector"]
