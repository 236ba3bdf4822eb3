"""The names of what a film records and of how it deforms: one place for every command, study and model."""
from __future__ import annotations

__all__ = ["IMPRINT_MODELS", "DEFAULT_IMPRINT_MODEL", "MIXTURE", "KINEMATICS", "DEFAULT_KINEMATICS",
           "FE_MODEL_REVISION", "APPLICATION_MODEL_REVISION", "FILM_LAYERS"]

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
#: Revision of the in-house FE model's numbers: part of every study's FE spec, so
#: that a change of its default mesh or of a reading recomputes the runs made
#: before it. 2: two film layers and the edge tip fitted to the second formulation;
#: 3: the film's volumetric term at the element centres and the closing-load edge; 4: a large-strain
#: film's indefinite tangent (heavy compression on fine meshes) solved by LU instead of stopping; 5: the
#: levels near a film's edge read from the edge shape fitted over 0.2 mm of nodal forces, not 0.3 mm.
FE_MODEL_REVISION = 5
#: Revision of the application model's numbers (the half-space contact with the film law, its readings and the
#: rough bodies' boundary-element laws): part of the spec of every study artefact the application makes (the
#: curves, the rough wheel's laws and growths, the outlines, the kept wheel-rail supports), so that a change
#: of a reading or a solver makes them again. 1: the outline behind a film read on every cell edge; the rough
#: laws' loads after a stalled conjugate gradient solved by the projected gradient; 2: the capsule imprint (and a
#: rough film's coverage) integrated as layers of sub-cell contours, not summed over the cells; 3: a hard
#: contact's edge (no film: the areas without film) read as the signed distance of the unloaded cells' separation.
APPLICATION_MODEL_REVISION = 3
#: Element layers through the film by default. One bilinear layer (the paper's
#: mesh) reads the edge 0.004 mm inside the converged contact on average and
#: up to 0.012 mm for nu >= 0.4; two read within 0.0053 mm of the second
#: formulation (filmcal.fem.reference) over E 500-10000 MPa, nu 0.25-0.45 at
#: 1.7 times the cost; three are no closer (``python bench/fe_reference.py``).
FILM_LAYERS = 2
