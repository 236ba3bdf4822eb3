"""Bayesian calibration of the film modulus per film type against measured imprints.

Data come from `load_dataset` (Table 1 of the reference paper, packaged as
``table1``, or a lab's own CSV file); models are compared and combined with
`compare_models` and `combine_posteriors`.

The model is seen only through the `RadiusModel` protocol
(``predict(modulus_mpa, poisson, sphere_radius_mm, force_n) -> (mean, std)``):
a validated surrogate of the FE model, or the FE model itself.
"""
from filmcal._lazy import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "filmcal.calibration.checks": ["CaseIntervals", "PredictiveCheck", "case_modulus_intervals", "predictive_check"],
    "filmcal.calibration.comparison": ["MixturePosterior", "ModelAssessment", "ModelComparison", "assess_model",
                                       "combine_posteriors", "compare_models"],
    "filmcal.calibration.datasets": ["Dataset", "PACKAGED_DATASETS", "load_dataset", "load_table1"],
    "filmcal.calibration.data": ["FILM_TYPES", "RadiusErrorData", "parse_load_range"],
    "filmcal.calibration.diagnostics": ["Diagnostics", "compute_diagnostics", "quadrature_quantiles"],
    "filmcal.calibration.likelihood": ["CalibrationProblem", "Priors", "RadiusModel"],
    "filmcal.elastic": ["oedometric_ratio"],
    "filmcal.calibration.pipeline": ["calibrate", "calibrate_film"],
    "filmcal.calibration.posterior": ["CalibrationResult", "load_posterior_netcdf", "load_result",
                                      "posterior_inference_data", "save_posterior_netcdf", "save_result",
                                      "summarize"],
    "filmcal.calibration.sampling": ["SamplerSettings", "read_chain", "run_chain"],
    "filmcal.calibration.tabulated": ["TabulatedRadiusModel"],
}, globals())
