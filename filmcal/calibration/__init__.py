"""Bayesian calibration of the film modulus per film type against Table 1.

The model is seen only through the `RadiusModel` protocol
(``predict(modulus_mpa, poisson, sphere_radius_mm, force_n) -> (mean, std)``):
a validated surrogate of the FE model, or the FE model itself.
"""
from filmcal.calibration.checks import CaseIntervals, PredictiveCheck, case_modulus_intervals, predictive_check
from filmcal.calibration.data import FILM_TYPES, RadiusErrorData, load_table1, parse_load_range
from filmcal.calibration.diagnostics import Diagnostics, compute_diagnostics
from filmcal.calibration.likelihood import CalibrationProblem, Priors, RadiusModel
from filmcal.elastic import oedometric_ratio
from filmcal.calibration.pipeline import calibrate, calibrate_film
from filmcal.calibration.posterior import CalibrationResult, load_result, save_result, summarize
from filmcal.calibration.sampling import SamplerSettings, read_chain, run_chain

__all__ = [
    "FILM_TYPES", "RadiusErrorData", "load_table1", "parse_load_range",
    "RadiusModel", "Priors", "CalibrationProblem", "oedometric_ratio",
    "SamplerSettings", "run_chain", "read_chain", "Diagnostics", "compute_diagnostics",
    "PredictiveCheck", "CaseIntervals", "predictive_check", "case_modulus_intervals",
    "CalibrationResult", "summarize", "save_result", "load_result", "calibrate", "calibrate_film",
]
