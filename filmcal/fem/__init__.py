"""Axisymmetric FE contact model of a steel sphere on a steel flat with a film between.

The model of the paper's Hertzian experiments (section 2.1), in scikit-fem:
`SphereOnFlat` is built once per sphere radius and mesh (the steel bodies are
condensed onto their contact faces), then `SphereOnFlat.solve` evaluates a
film and force cheaply. `evaluate_point` is the campaign entry point (a
parameter dict in, a dict of outputs out), with a per-process model cache.
"""
from __future__ import annotations

from collections import OrderedDict
from typing import Any, Iterable, Sequence

from filmcal._validation import as_bool, as_finite
from filmcal.contact import DEFAULT_IMPRINT_MODEL, IMPRINT_MODELS, get_imprint_model, imprint_key
from filmcal.fem.forms import lame_parameters, oedometric_modulus_mpa
from filmcal.hertz import (STEEL_MODULUS_MPA, STEEL_POISSON, contact_modulus_mpa, hertz_approach_mm,
                               hertz_max_pressure_mpa, hertz_pressure_mpa, hertz_radius_mm)
from filmcal.fem.mesh import FILM_LAYERS, MeshSettings
from filmcal.contact.options import CONTACT_MODES, ContactOptions
from filmcal.fem.model import Film, SphereOnFlat
from filmcal.fem.result import FEResult
from filmcal.fem.thinlayer import ThinLayerResult, thin_layer_contact

__all__ = [
    "SphereOnFlat", "Film", "ContactOptions", "MeshSettings", "FILM_LAYERS", "FEResult", "CONTACT_MODES",
    "solve_sphere_on_flat", "solve_many", "evaluate_point", "imprint_columns", "OUTPUT_KEYS",
    "hertz_radius_mm", "hertz_max_pressure_mpa", "hertz_approach_mm", "hertz_pressure_mpa",
    "contact_modulus_mpa", "oedometric_modulus_mpa", "lame_parameters",
    "thin_layer_contact", "ThinLayerResult", "STEEL_MODULUS_MPA", "STEEL_POISSON", "get_model",
]

_MODELS: "OrderedDict[tuple, SphereOnFlat]" = OrderedDict()
_MAX_MODELS = 8


def get_model(sphere_radius_mm: float, mesh: MeshSettings | None = None, film_thickness_mm: float = 0.09,
              film_layers: int = FILM_LAYERS, body_modulus_mpa: float = STEEL_MODULUS_MPA,
              body_poisson: float = STEEL_POISSON) -> SphereOnFlat:
    """A `SphereOnFlat` for these settings, built once per process and kept (LRU of 8)."""
    mesh = MeshSettings() if mesh is None else mesh
    key = (float(sphere_radius_mm), mesh, float(film_thickness_mm), int(film_layers), float(body_modulus_mpa),
           float(body_poisson))
    if key in _MODELS:
        _MODELS.move_to_end(key)
        return _MODELS[key]
    model = SphereOnFlat(sphere_radius_mm, mesh, film_thickness_mm, film_layers, body_modulus_mpa, body_poisson)
    _MODELS[key] = model
    while len(_MODELS) > _MAX_MODELS:
        _MODELS.popitem(last=False)
    return model


def solve_sphere_on_flat(sphere_radius_mm: float, force_n: float, film: Film | None = None,
                         options: ContactOptions | None = None, mesh: MeshSettings | None = None,
                         film_thickness_mm: float = 0.09, film_layers: int = FILM_LAYERS,
                         activation_pressure_mpa: float | None = None, film_type=None,
                         imprint_model: str = DEFAULT_IMPRINT_MODEL, body_modulus_mpa: float = STEEL_MODULUS_MPA,
                         body_poisson: float = STEEL_POISSON) -> FEResult:
    """One evaluation of the FE model (reusing a cached model for this R and mesh).

    Parameters
    ----------
    sphere_radius_mm : float
        Sphere radius R (mm).
    force_n : float
        Normal force F (N).
    film : Film or None
        Film material; None for steel on steel.
    options : ContactOptions, optional
    mesh : MeshSettings, optional
    film_thickness_mm : float
    film_layers : int
    activation_pressure_mpa : float, optional
        Also read the imprint radius where the pressure exceeds this level.
    film_type : filmcal.films.FilmType, optional
        Also read the imprint of this film type (not with `activation_pressure_mpa`).
    imprint_model : {'activation', 'edge', 'capsule'}
        What the film records (default activation).
    body_modulus_mpa, body_poisson : float
        Elastic constants of the sphere and the flat (default steel).
    """
    model = get_model(sphere_radius_mm, mesh, film_thickness_mm, film_layers, body_modulus_mpa, body_poisson)
    return model.solve(film, force_n, options, activation_pressure_mpa, film_type, imprint_model)


def solve_many(sphere_radius_mm: float, points: Iterable[tuple[Film | None, float]],
               options: ContactOptions | None = None, mesh: MeshSettings | None = None,
               film_thickness_mm: float = 0.09, film_layers: int = FILM_LAYERS) -> list[FEResult]:
    """Evaluate many (film, force_n) points for one sphere radius, sharing the condensed bodies."""
    model = get_model(sphere_radius_mm, mesh, film_thickness_mm, film_layers)
    return [model.solve(film, force, options) for film, force in points]


OUTPUT_KEYS = ("contact_radius_mm", "contact_area_mm2", "max_pressure_mpa", "hertz_radius_mm",
               "radius_error_mm", "approach_mm", "film_strain_max", "n_active", "converged", "reason",
               "iterations", "elapsed_s")


def imprint_columns(films: Sequence, imprint_models: Sequence[str] | None = None) -> list[tuple[str, Any, str]]:
    """The (model, film type, output key) triples `evaluate_point` adds for `films`.

    Every model of `imprint_models` (default: all but ``edge``, whose reading
    is ``contact_radius_mm``) that can read a film (``activation`` needs an
    activation pressure, ``capsule`` a range) gives one key
    ``radius_<model>_<film>_mm``.
    """
    models = [m for m in IMPRINT_MODELS if m != "edge"] if imprint_models is None else list(imprint_models)
    out = []
    for m in models:
        model = get_imprint_model(m)
        if m == "edge":
            continue
        for film in films:
            try:
                model.check_film(film)
            except ValueError:
                if imprint_models is not None:
                    raise
                continue
            out.append((m, film, imprint_key(m, film)))
    return out


def evaluate_point(params: dict, films: Sequence = (), imprint_models: Sequence[str] | None = None) -> dict:
    """Evaluate one design point: the campaign's model.

    Parameters
    ----------
    params : dict
        ``sphere_radius_mm``, ``force_kn`` and, unless ``no_film`` is true,
        ``modulus_mpa`` and ``poisson``; optional ``sphere_contact``,
        ``flat_contact``, ``friction_coefficient``, ``kinematics``,
        ``element_size_mm``, ``film_thickness_mm``, ``activation_pressure_mpa``, ``body_modulus_mpa`` and
        ``body_poisson`` (the sphere's and the flat's; default steel).
    films : sequence of filmcal.films.FilmType
        Film types whose imprint radii to read from the same solve.
    imprint_models : sequence of str, optional
        Imprint models to read them with (default: ``activation`` and
        ``capsule``, each where the film type allows it; a model named here
        that cannot read a film is an error).

    Returns
    -------
    dict
        The scalar outputs listed in `OUTPUT_KEYS` (``contact_radius_mm`` is
        the edge), plus ``radius_<model>_<film>_mm`` for every (model, film)
        pair (see :func:`imprint_columns`); ``converged = False`` with a
        ``reason`` when the solve failed (never raises for that).
    """
    columns = imprint_columns(films, imprint_models)
    def get(name, default=None):
        v = params.get(name, default)
        return default if v is None or (isinstance(v, str) and v.strip() == "") else v

    no_film = as_bool("no_film", get("no_film", False))
    film = None if no_film else Film(as_finite("modulus_mpa", get("modulus_mpa")),
                                     as_finite("poisson", get("poisson", 0.33)))
    options = ContactOptions.from_columns(params)
    mesh = MeshSettings(element_size_mm=as_finite("element_size_mm", get("element_size_mm", 0.1)))
    act = get("activation_pressure_mpa")
    res = solve_sphere_on_flat(as_finite("sphere_radius_mm", get("sphere_radius_mm")),
                               1e3 * as_finite("force_kn", get("force_kn")), film, options, mesh,
                               as_finite("film_thickness_mm", get("film_thickness_mm", 0.09)),
                               activation_pressure_mpa=None if act is None else as_finite("activation_pressure_mpa", act),
                               body_modulus_mpa=as_finite("body_modulus_mpa", get("body_modulus_mpa", STEEL_MODULUS_MPA)),
                               body_poisson=as_finite("body_poisson", get("body_poisson", STEEL_POISSON)))
    summary = res.summary()
    out = {k: summary[k] for k in OUTPUT_KEYS}
    if columns:
        profile = res.profile()
        for model, film_type, key in columns:
            out[key] = float(get_imprint_model(model).radius_from_profile(profile, film_type))
    if act is not None:
        out["imprint_radius_mm"] = res.imprint_radius_mm
        out["imprint_area_mm2"] = res.imprint_area_mm2
    return out
