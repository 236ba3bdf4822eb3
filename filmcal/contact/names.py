"""The names of what a film records and of how it deforms: one place for every command, study and model."""
from __future__ import annotations

__all__ = ["IMPRINT_MODELS", "DEFAULT_IMPRINT_MODEL", "MIXTURE", "KINEMATICS", "DEFAULT_KINEMATICS"]

#: Names of the imprint models, in the order of the comparison.
IMPRINT_MODELS: tuple[str, ...] = ("edge", "activation", "capsule")
#: The imprint model of a solve without a study (a film colours where its activation pressure is exceeded).
DEFAULT_IMPRINT_MODEL = "activation"
#: A study's weighted mixture of the imprint models its comparison weighed (the default where a study is read).
MIXTURE = "mixture"
#: Film kinematics: the linear film, or the neo-Hookean large-strain film.
KINEMATICS: tuple[str, ...] = ("small", "large")
#: The kinematics of a solve without a study.
DEFAULT_KINEMATICS = "small"
