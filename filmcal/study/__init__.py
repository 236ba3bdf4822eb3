"""Studies: one object that owns a study folder and runs the stages in it.

`Study` composes the stages (FE campaigns, radius surrogates, calibrations,
curves, cross-validation, report) in one folder, records what every artefact
was made from in a manifest, and is the only code that knows the folder's
layout (`StudyLayout`). `run_pipeline` is the whole job as declared stages.
No stage imports this package.
"""
from filmcal.study.core import (IMPRINT_MODELS, KINEMATICS, CalibrationSpec, FESettings, Study, correctors, output_column, seed_for)
from filmcal.study.batch import BatchInterrupted, correct_batch, read_batch
from filmcal.study.correct import (BodyRoughness, ScanReading, SphereMeasurement, WheelRailMeasurement,
                                   correct_measurement)
from filmcal.study.layout import StudyLayout, spec_key
from filmcal.study.stages import STAGES, PipelineSettings, run_pipeline

__all__ = ["Study", "StudyLayout", "FESettings", "CalibrationSpec", "PipelineSettings", "run_pipeline", "STAGES",
           "IMPRINT_MODELS", "KINEMATICS", "seed_for", "spec_key", "output_column", "correctors",
           "correct_measurement", "SphereMeasurement", "WheelRailMeasurement", "ScanReading", "BodyRoughness",
           "correct_batch", "read_batch", "BatchInterrupted"]
