"""Corrections of contact areas measured with film, with their uncertainty."""
from filmcal.correction.sphere import CorrectedArea, SphereCorrector

__all__ = ["CorrectedArea", "SphereCorrector"]
