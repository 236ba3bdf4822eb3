"""Gaussian-process surrogates of model outputs: fit, validate, refine, save/load.

`GPSurrogate` emulates one output of a model (e.g. the film-induced excess of
the contact radius over Hertz) over named inputs such as (modulus_mpa, poisson,
radius_mm, force_n). `leave_one_out` and `validate` measure its accuracy and the
calibration of its uncertainty, `select_batch` and `refine` add model runs where
it is least certain, `save_surrogate` / `load_surrogate` store it as arrays +
JSON.
"""
from filmcal.surrogate.adaptive import (
    Batch,
    RefinementResult,
    RefinementStep,
    refine,
    sample_candidates,
    select_batch,
    weighted_std,
)
from filmcal.surrogate.gp import GPSurrogate
from filmcal.surrogate.io import load_surrogate, save_surrogate
from filmcal.surrogate.kernels import kernel_from_dict, kernel_to_dict, make_kernel
from filmcal.surrogate.transforms import InputTransform, OutputTransform
from filmcal.surrogate.validation import LeaveOneOut, ValidationResult, leave_one_out, validate

__all__ = [
    "GPSurrogate",
    "InputTransform",
    "OutputTransform",
    "make_kernel",
    "kernel_to_dict",
    "kernel_from_dict",
    "LeaveOneOut",
    "ValidationResult",
    "leave_one_out",
    "validate",
    "Batch",
    "RefinementStep",
    "RefinementResult",
    "sample_candidates",
    "weighted_std",
    "select_batch",
    "refine",
    "save_surrogate",
    "load_surrogate",
]
