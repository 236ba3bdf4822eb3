"""Corrections of contact areas measured with film, with their uncertainty:
sphere-on-flat imprints (`SphereCorrector`) and wheel-rail imprints
(`WheelRailCorrector`), correction curves over offset and load with
credible bands (`correction_curves`), scanned imprints read into an area and
outline (`read_imprint`), and the outline without film behind a measured one
(`correct_outline`)."""
from filmcal.correction.curves import (CURVE_COLUMNS, CorrectionCurves, correction_curves, curve_rows,
                                       read_curves_csv, rough_law, wheel_label, write_curves_csv)
from filmcal.correction.imprint import Imprint, measure_imprint, otsu_threshold, read_imprint, stain_intensity
from filmcal.correction.outline import (CorrectedOutline, ModelOutlines, correct_outline, hausdorff_distance_mm,
                                        offset_outline, outline_area_mm2, outline_centroid_mm, outline_perimeter_mm,
                                        shrink_outline, signed_distance_mm, wheel_rail_outlines)
from filmcal.correction.sphere import CorrectedArea, SphereCorrector
from filmcal.correction.wheelrail import WheelRailCorrector

__all__ = ["CorrectedArea", "SphereCorrector", "WheelRailCorrector", "CorrectionCurves", "correction_curves",
           "CURVE_COLUMNS", "curve_rows", "write_curves_csv", "read_curves_csv", "rough_law", "wheel_label",
           "Imprint", "read_imprint", "measure_imprint", "stain_intensity", "otsu_threshold",
           "CorrectedOutline", "ModelOutlines", "correct_outline", "wheel_rail_outlines", "shrink_outline",
           "offset_outline", "signed_distance_mm", "hausdorff_distance_mm", "outline_area_mm2",
           "outline_centroid_mm", "outline_perimeter_mm"]
