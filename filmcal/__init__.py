"""filmcal: calibrate finite-element models of Prescale pressure-measurement film
against sphere-on-flat experiments and correct wheel-rail contact areas measured
with film, with their uncertainty.

Units inside the package: millimetre, newton, megapascal (N/mm^2). Names carry
their unit where a number has one (``radius_mm``, ``force_n``, ``modulus_mpa``).

The public API is re-exported here and imported on first use, so that
``import filmcal`` (and the command line's start-up) stays fast.
"""
from __future__ import annotations

from filmcal._lazy import lazy_exports

from filmcal._versions import __version__

_EXPORTS = {
    "filmcal.fem": ["SphereOnFlat", "Film", "ContactOptions", "MeshSettings", "FEResult", "get_model",
                    "solve_sphere_on_flat", "solve_many", "evaluate_point", "oedometric_modulus_mpa",
                    "thin_layer_contact"],
    "filmcal.hertz": ["hertz_radius_mm", "hertz_max_pressure_mpa", "contact_modulus_mpa"],
    "filmcal.doe": ["Parameter", "DesignSpace", "OptimalLatinHypercube", "latin_design", "augment_design",
                    "design_quality", "read_design_csv", "write_design_csv"],
    "filmcal.surrogate": ["GPSurrogate", "validate", "leave_one_out", "refine", "save_surrogate",
                          "load_surrogate"],
    "filmcal.campaign": ["Campaign", "CampaignSummary", "RunStore", "LocalPoolExecutor", "DaskExecutor",
                         "SerialExecutor"],
    "filmcal.calibration": ["load_table1", "RadiusErrorData", "calibrate_film", "CalibrationResult",
                            "RadiusModel", "Priors"],
    "filmcal.surrogate.radius": ["SurrogateRadiusModel", "FERadiusModel", "SurrogateDomain"],
    "filmcal.study": ["Study", "FESettings", "CalibrationSpec", "PipelineSettings", "run_pipeline",
                      "correct_measurement", "SphereMeasurement", "WheelRailMeasurement", "ScanReading",
                      "BodyRoughness", "correct_batch", "BatchInterrupted"],
    "filmcal.contact.roughness": ["RoughSurface", "Roughness"],
    "filmcal.contact.rough_imprint": ["RoughnessInputs", "ROUGHNESS_PRIOR", "load_roughness_inputs",
                                      "sample_roughness_prior"],
    "filmcal.contact.surface_files": ["read_surface_file"],
    "filmcal.contact.film": ["FilmModel"],
    "filmcal.wheelrail.film_contact": ["solve_film_contact", "FilmContactCase", "WheelRoughness"],
    "filmcal.films": ["FilmType", "FilmRegistry", "get_film"],
    "filmcal.wheelrail": ["get_profile", "load_profile_csv", "place_wheel_on_rail", "solve_wheel_rail",
                          "solve_wheel_rail_many", "WheelRailModel", "HalfSpaceContactSolver", "FilmLayer"],
    "filmcal.correction": ["SphereCorrector", "WheelRailCorrector", "CorrectedArea", "correction_curves",
                           "CorrectionCurves", "read_imprint", "measure_imprint", "Imprint", "correct_outline",
                           "CorrectedOutline", "ModelOutlines", "wheel_rail_outlines", "read_sheet", "Sheet"],
    "filmcal.report": ["build_report", "write_report"],
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
__all__ = ["__version__", *__all__]
