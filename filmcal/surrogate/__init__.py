"""Gaussian-process surrogates of model outputs: fit, validate, refine, save/load.

`GPSurrogate` emulates one output of a model (e.g. the film-induced excess of
the contact radius over Hertz) over named inputs such as (modulus_mpa, poisson,
radius_mm, force_n). `leave_one_out` and `validate` measure its accuracy and the
calibration of its uncertainty, `select_batch` and `refine` add model runs where
it is least certain, `save_surrogate` / `load_surrogate` store it as arrays +
JSON, and `load_saved_surrogate` predicts a stored one with numpy alone.
"""
from filmcal._lazy import lazy_exports

# Names load on first use: reading a saved surrogate for prediction
# (`filmcal.surrogate.saved`) then imports neither scikit-learn nor scipy.
__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "filmcal.surrogate.adaptive": ["Batch", "RefinementResult", "RefinementStep", "refine", "sample_candidates",
                                   "select_batch", "weighted_std"],
    "filmcal.surrogate.gp": ["GPSurrogate"],
    "filmcal.surrogate.io": ["load_surrogate", "save_surrogate"],
    "filmcal.surrogate.kernels": ["kernel_from_dict", "kernel_to_dict", "make_kernel"],
    "filmcal.surrogate.saved": ["SavedSurrogate", "load_saved_surrogate"],
    "filmcal.surrogate.transforms": ["InputTransform", "OutputTransform"],
    "filmcal.surrogate.validation": ["LeaveOneOut", "ValidationResult", "leave_one_out", "validate"],
}, globals())
