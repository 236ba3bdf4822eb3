"""Corrections of contact areas measured with film, with their uncertainty:
sphere-on-flat imprints (`SphereCorrector`) and wheel-rail imprints
(`WheelRailCorrector`), and correction curves over offset and load with
credible bands (`correction_curves`)."""
from filmcal.correction.curves import CorrectionCurves, correction_curves
from filmcal.correction.sphere import CorrectedArea, SphereCorrector
from filmcal.correction.wheelrail import WheelRailCorrector

__all__ = ["CorrectedArea", "SphereCorrector", "WheelRailCorrector", "CorrectionCurves", "correction_curves"]
