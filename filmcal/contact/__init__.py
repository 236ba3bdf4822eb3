"""What a film is and records: film laws, imprint models and their readings, roughness, contact options.

A ground-floor package: the FE model (`filmcal.fem`) and the wheel-rail model
(`filmcal.wheelrail`) both take their film from it (`film.FilmModel`, the laws of
`laws`) and read their pressure fields through it (`imprint`, `reading`), so that
a film and an imprint mean the same thing everywhere; it imports neither model
(docs/film-law.md).
"""
from filmcal.contact.geometry import outline_area_mm2, ring_signed_area_mm2
from filmcal.contact.imprint import (CAPSULE_RANGE_QUANTILE, DEFAULT_IMPRINT_MODEL, IMPRINT_MODELS,
                                     ActivationImprint, CapsuleImprint, EdgeImprint, ImprintModel,
                                     get_imprint_model, imprint_key, imprint_models_for,
                                     read_imprints)
from filmcal.contact.reading import (EDGE_WINDOW_MM, GridField, RadialProfile, film_tip_length_mm,
                                     read_radial_profile, tributary_areas_mm2)

__all__ = ["IMPRINT_MODELS", "DEFAULT_IMPRINT_MODEL", "CAPSULE_RANGE_QUANTILE", "ImprintModel", "EdgeImprint",
           "ActivationImprint", "CapsuleImprint", "get_imprint_model", "imprint_key", "imprint_models_for", "read_imprints",
           "EDGE_WINDOW_MM", "GridField", "RadialProfile", "film_tip_length_mm", "read_radial_profile",
           "tributary_areas_mm2", "outline_area_mm2", "ring_signed_area_mm2"]
