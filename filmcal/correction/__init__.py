"""Corrections of contact areas measured with film, with their uncertainty:
sphere-on-flat imprints (`SphereCorrector`) and wheel-rail imprints
(`WheelRailCorrector`), correction curves over offset and load with
credible bands (`correction_curves`), scanned imprints read into an area and
outline (`read_imprint`), scanned sheets of several imprints found, numbered
and read (`read_sheet`), and the outline without film behind a measured one
(`correct_outline`)."""
from filmcal._lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "filmcal.correction.crossval": ["CaseCrossValidation", "cross_validate_case", "leave_one_case_out",
                                    "psis_leave_one_case_out"],
    "filmcal.correction.curves": ["CURVE_COLUMNS", "CorrectionCurves", "RoughConfiguration", "correction_curves",
                                  "curve_growths", "curve_rows", "curve_table", "growth_task", "read_curves_csv",
                                  "wheel_label", "write_curves_csv"],
    "filmcal.correction.imprint": ["Imprint", "measure_imprint", "otsu_threshold", "read_imprint",
                                   "stain_intensity"],
    "filmcal.correction.outline": ["CorrectedOutline", "ModelOutlines", "correct_outline", "hausdorff_distance_mm",
                                   "offset_outline", "outline_area_mm2", "outline_centroid_mm",
                                   "outline_perimeter_mm", "shrink_outline", "signed_distance_mm",
                                   "wheel_rail_outlines"],
    "filmcal.correction.sheet": ["Sheet", "SheetImprint", "find_imprints", "plot_sheet", "read_sheet", "scan_sheet",
                                 "write_sheet_table"],
    "filmcal.correction.sphere": ["CorrectedArea", "SphereCorrector"],
    "filmcal.correction.wheelrail": ["WheelRailCorrector"],
}, globals())
