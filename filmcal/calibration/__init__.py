"""Bayesian calibration of the film modulus per film type against Table 1.

The model is seen only through the `RadiusModel` protocol
(``predict(modulus_mpa, poisson, sphere_radius_mm, force_n) -> (mean, std)``):
a validated surrogate of the FE model, or the FE model itself.
"""
from filmcal._lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "filmcal.calibration.checks": ["CaseIntervals", "PredictiveCheck", "case_modulus_intervals", "predictive_check"],
    "filmcal.calibration.data": ["FILM_TYPES", "RadiusErrorData", "load_table1", "parse_load_range"],
    "filmcal.calibration.diagnostics": ["Diagnostics", "compute_diagnostics"],
    "filmcal.calibration.likelihood": ["CalibrationProblem", "Priors", "RadiusModel"],
    "filmcal.elastic": ["oedometric_ratio"],
    "filmcal.calibration.pipeline": ["calibrate", "calibrate_film"],
    "filmcal.calibration.posterior": ["CalibrationResult", "load_result", "save_result", "summarize"],
    "filmcal.calibration.sampling": ["SamplerSettings", "read_chain", "run_chain"],
}, globals())
