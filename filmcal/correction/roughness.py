"""How much the bodies' roughness grows an imprint and the contact without film, with its uncertainty.

The rough imprint (`filmcal.contact.rough_imprint`) enters a correction as ratios to the smooth solves of
the same configuration:

* the film's growth ``g_f = A_f,rough / A_f,smooth``: each imprint model's rough reading of the solve with
  the rough laws in series, over its own smooth reading (`FilmModel.recorded_area_mm2`);
* the growth of the contact without film ``g_0 = A_0,rough / A_0,smooth``: the rough bodies' nominal area
  against steel (`filmcal.wheelrail.film_contact.nominal_rough_area_mm2`) over the smooth area.

A correction multiplies its smooth factor ``A_0 / A_f`` by ``g_0 / g_f``. Each draw of the uncertain inputs
(`RoughnessInputs`: the coating's hardness, the scan's reading level, the spectrum, the realisation) gives
one pair; a body is given by its Ra (each draw's synthetic surface) or as a measured `RoughSurface`
(`filmcal.contact.surface_files`). `RoughGrowth` keeps the draws and their weights and summarises them with the Monte-Carlo error of
the mean. Ra = 0 on both bodies gives no law and the ratio 1 exactly.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from filmcal.contact.rough_imprint import RoughnessInputs
from filmcal.wheelrail.rough_growth import sphere_growth

__all__ = ["RoughGrowth", "sphere_growths", "wheel_rail_growth", "corrector_growths", "weighted_quantiles",
           "growth_modulus_mpa", "draw_bodies", "draw_laws", "solve_growths", "waviness_peak_mpa"]


def weighted_quantiles(values: np.ndarray, weights: np.ndarray, q: Sequence[float]) -> np.ndarray:
    """Quantiles of weighted samples (the weighted empirical CDF, interpolated at mid-steps)."""
    v = np.asarray(values, dtype=float)
    w = np.asarray(weights, dtype=float)
    order = np.argsort(v)
    v, w = v[order], w[order]
    cdf = (np.cumsum(w) - 0.5 * w) / w.sum()
    return np.interp(q, cdf, v)


@dataclass
class RoughGrowth:
    """Growth factors of one configuration over draws of the roughness inputs.

    Attributes
    ----------
    film : ndarray
        ``g_f`` per draw (rough over smooth imprint, this film model's reading).
    no_film : ndarray
        ``g_0`` per draw (rough over smooth contact without film); ones where not asked for.
    weights : ndarray
        Each draw's weight (sum 1).
    inputs : list of RoughnessInputs
    """

    film: np.ndarray
    no_film: np.ndarray
    weights: np.ndarray
    inputs: list = field(default_factory=list)

    def weight_square_sum(self) -> float:
        """``sum w^2`` over the distinct draws (a resampled set's repeats are one draw of their summed weight):
        ``1 / sum w^2`` is the effective number of draws, the Monte-Carlo error ``sd sqrt(sum w^2)``."""
        w = self.weights / self.weights.sum()
        if len(self.inputs) != len(w):
            return float(np.sum(w * w))
        merged: dict = {}
        for d, wk in zip(self.inputs, w):
            merged[d] = merged.get(d, 0.0) + float(wk)
        return float(sum(v * v for v in merged.values()))

    @property
    def factor(self) -> np.ndarray:
        """``g_0 / g_f`` per draw: what the roughness does to the correction factor."""
        return self.no_film / self.film

    def summary(self) -> dict:
        """Weighted mean, 90 % interval and Monte-Carlo standard error of each growth (in %), JSON-ready."""
        w = self.weights / self.weights.sum()
        n_eff = 1.0 / self.weight_square_sum()
        out = {"n_draws": int(len(w)), "effective_draws": n_eff}
        for name, g in (("film_growth", self.film), ("no_film_growth", self.no_film),
                        ("correction_factor_change", self.factor)):
            pct = 100.0 * (np.asarray(g, dtype=float) - 1.0)
            mean = float(np.sum(w * pct))
            sd = math.sqrt(float(np.sum(w * (pct - mean) ** 2)))
            lo, hi = weighted_quantiles(pct, w, [0.05, 0.95])
            out[name] = {"mean_pct": mean, "sd_pct": sd, "ci90_pct": [float(lo), float(hi)],
                         "mc_error_pct": sd / math.sqrt(n_eff) if len(w) > 1 else math.nan}  # 1 draw: unknown
        return out


def wheel_rail_growth(model, modulus_mpa: float, draws: Sequence[RoughnessInputs], offset_mm: float,
                      force_n: float, settings: dict, *, wheel=None,
                      rail=None, weights: Sequence[float] | None = None,
                      progress: Callable[[int, int], None] | None = None) -> RoughGrowth:
    """`RoughGrowth` of one film model at one modulus in a wheel-rail configuration over ``draws``
    (``settings``: `get_wheel_rail_model`'s keywords; `solve_growths` per draw). Draws that repeat (a
    resampled set) are solved once."""
    from filmcal.wheelrail import get_wheel_rail_model

    solver = get_wheel_rail_model(**settings)
    draws = list(draws)
    unique = list(dict.fromkeys(draws))
    films = {model.film.name: (model.film, float(modulus_mpa))}
    laws = [(d.reading_level, draw_laws(d, films, wheel=wheel, rail=rail, grid_mm=settings.get("grid_mm")))
            for d in unique]
    done = 0

    def step() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, len(unique))

    solved = dict(zip(unique, solve_growths([(model.film.name, model, float(modulus_mpa))], laws, offset_mm,
                                            force_n, solver, step)))
    g_0 = np.array([solved[d][0] for d in draws])
    g_f = np.array([solved[d][1][0] for d in draws])
    w = np.ones(len(draws)) if weights is None else np.asarray(weights, dtype=float)
    return RoughGrowth(g_f, g_0, w / w.sum(), draws)


def sphere_growths(inputs: dict, ra_um: float, films: Sequence[tuple[str, float, str, str]],
                   sphere_radius_mm: float = 450.0, force_kn: float = 50.0) -> dict[str, float]:
    """``g_f`` of each film ``(name, modulus_mpa, imprint, kinematics)`` on sphere-on-flat with a roughened flat,
    for one draw (given as `RoughnessInputs.to_dict`; a module-level task for worker processes)."""
    from filmcal.contact.film import FilmModel
    from filmcal.films import get_film

    draw = RoughnessInputs.from_dict(inputs)
    return {name: sphere_growth(FilmModel(get_film(name), imprint, kinematics), modulus, draw, ra_um,
                                sphere_radius_mm=sphere_radius_mm, force_n=1e3 * force_kn)
            for name, modulus, imprint, kinematics in films}


def growth_modulus_mpa(components) -> float:
    """The one modulus (MPa) at which a film's rough growths are solved: the weighted median of its models'
    posterior samples (``components``: ``(FilmModel, samples, weight)``). A growth ratio varies little across
    a posterior, and one modulus lets one rough law per draw serve every model of the film."""
    parts = [(np.asarray(e, dtype=float).ravel(), float(w)) for _, e, w in components]
    e = np.concatenate([v for v, _ in parts])
    w = np.concatenate([np.full(len(v), w / len(v)) for v, w in parts])
    return float(weighted_quantiles(e, w if w.sum() > 0 else np.ones_like(w), [0.5])[0])


def draw_bodies(draw: RoughnessInputs, *, wheel=None, rail=None, grid_mm: float | None = None) -> tuple:
    """The rough bodies of one draw as `draw_laws` solves them: ``(micro bodies, waviness)``, the bodies split at
    `filmcal.contact.waviness.WAVINESS_CUTOFF_CELLS` cells of the contact grid (``grid_mm``, default the
    wheel-rail model's) and the waviness laid at the draw's own phase (None without it)."""
    from filmcal.contact.waviness import WAVINESS_CUTOFF_CELLS
    from filmcal.wheelrail.settings import GRID_MM

    cutoff_um = 1e3 * WAVINESS_CUTOFF_CELLS * (GRID_MM if grid_mm is None else float(grid_mm))
    bodies = draw.bodies(wheel, rail).split(cutoff_um)
    # where the crests fall on the patch is unknown: each draw lays the waviness at its own phase
    return bodies, None if bodies.waviness is None else bodies.waviness.shifted([int(draw.seed), 7])


def draw_laws(draw: RoughnessInputs | None, films: dict, *, wheel=None, rail=None, law=None,
              grid_mm: float | None = None, keep: Callable | None = None) -> dict:
    """The rough laws of one draw on the wheel-rail contact: ``{film name: its law against the film, None: the
    law without film, "waviness": the bodies' long-wave heights}``.

    ``films`` maps each film's name to ``(FilmType, modulus_mpa)``. The bodies are split as `draw_bodies` splits
    them: the laws take the micro part, the solves the waviness (none for surfaces no longer than the cut-off,
    such as the synthetic ones). With ``draw`` None, ``law`` is a measured film-wheel law taken as it is for
    every film, and the contact without film stays smooth (None).

    ``keep(bodies, film, modulus_mpa, solve)``, when given, returns each law (``film`` None: steel on steel)
    instead of ``solve()``: a store that reads back the laws it kept (`filmcal.study.core.StudyRoughLaws.law`).
    """
    if draw is None:
        return {**{name: law for name in films}, None: None, "waviness": None}
    bodies, wavy = draw_bodies(draw, wheel=wheel, rail=rail, grid_mm=grid_mm)
    if bodies.smooth:
        return {**{name: None for name in films}, None: None, "waviness": None}

    def solved(film, modulus, solve):
        return solve() if keep is None else keep(bodies, film, modulus, solve)

    return {**{name: solved(f, float(m), lambda f=f, m=m: bodies.film_law(float(m), f.poisson, f.thickness_mm))
               for name, (f, m) in films.items()},
            None: solved(None, None, bodies.steel_law), "waviness": wavy}


def waviness_peak_mpa(draw: RoughnessInputs, offset_mm: float, force_n: float, settings: dict, *, wheel=None,
                      rail=None, keep: Callable | None = None) -> float | None:
    """Peak pressure (MPa) of the rough contact without film when the bodies carry waviness (`draw_laws`), or
    None without it: the elastic macro solve puts the load on the crests, and above the steel's elastic limit
    the real crests flatten (a larger contact than solved)."""
    from filmcal.wheelrail import get_wheel_rail_model

    laws = draw_laws(draw, {}, wheel=wheel, rail=rail, grid_mm=settings.get("grid_mm"), keep=keep)
    if laws.get("waviness") is None:
        return None
    result = get_wheel_rail_model(**settings).solve(offset_mm, force_n, roughness=laws.get(None),
                                                     waviness=laws["waviness"])
    return float(result.max_pressure_mpa)


def solve_growths(models, draws: Sequence[tuple[float | None, dict]], offset_mm: float, force_n: float, solver,
                  progress: Callable[[], None] | None = None) -> list[tuple[float, list[float]]]:
    """``g_0`` and each model's ``g_f`` at one offset and force, for each draw's laws (`draw_laws`).

    Parameters
    ----------
    models : sequence of (film name, FilmModel, modulus_mpa)
        Models of one film and kinematics share their solves (at one modulus).
    draws : sequence of (reading level, laws)
        Per draw: its scan reading level (None: a measured law, read like a smooth contact) and its laws
        ``{film name: law against the film, None: law without film, "waviness": long-wave heights}`` (None:
        smooth; `draw_laws`).
    solver
        A wheel-rail model (`filmcal.wheelrail.get_wheel_rail_model`). The smooth solves are made once for all
        draws; a configuration's first rough solve starts from its smooth one, each later draw's from the draw
        before (nearer: a quarter fewer Newton steps; over the full study's 420 growths the two starts agree within
        4e-4 relative, median 5e-6).
    progress : callable, optional
        Called after each draw.

    Returns
    -------
    list of (g_0, [g_f per model]), one per draw
    """
    from filmcal.wheelrail.film_contact import nominal_rough_area_mm2

    bare = solver.solve(offset_mm, force_n)
    groups: dict = {}
    for k, (name, model, modulus) in enumerate(models):
        groups.setdefault((name, model.kinematics, float(modulus)), []).append(k)
    smooth, base = {}, {}
    for key, members in groups.items():
        if any(laws.get(key[0]) is not None or laws.get("waviness") is not None for _, laws in draws):
            film0, law0, _ = models[members[0]][1].interface(key[2])
            smooth[key] = solver.solve(offset_mm, force_n, film=film0, roughness=law0, initial=bare)
            base.update({k: models[k][1].recorded_area_mm2(smooth[key]) for k in members})
    out = []
    last: dict = {}  # each configuration's last rough solve: the next draw's start (nearer than the smooth one)
    for level, laws in draws:
        g0 = 1.0
        wavy = laws.get("waviness")
        if laws.get(None) is not None or wavy is not None:
            last[None] = solver.solve(offset_mm, force_n, roughness=laws.get(None), initial=last.get(None, bare),
                                      waviness=wavy)
            g0 = nominal_rough_area_mm2(last[None], bare) / float(bare.area_mm2)
        gf = [1.0] * len(models)
        for key, members in groups.items():
            law = laws.get(key[0])
            if law is None and wavy is None:
                continue
            film, solver_law, rough_law = models[members[0]][1].interface(key[2], law)
            rough = last[key] = solver.solve(offset_mm, force_n, film=film, roughness=solver_law,
                                             initial=last.get(key, smooth[key]), waviness=wavy)
            for k in members:
                if base[k] > 0.0:
                    gf[k] = models[k][1].recorded_area_mm2(rough, rough_law, level) / base[k]
        out.append((g0, gf))
        if progress is not None:
            progress()
    return out


def corrector_growths(correctors: Sequence, weights: Sequence[float], offset_mm: float, force_n: float,
                      draws: Sequence[RoughnessInputs], *, wheel=None,
                      rail=None,
                      progress: Callable[[int, int], None] | None = None,
                      keep: Callable | None = None, modulus_mpa: float | None = None) -> dict[str, RoughGrowth]:
    """`RoughGrowth` of each wheel-rail corrector's film model (by its label) at one offset and force.

    Every model is solved at one modulus, ``modulus_mpa`` or else the weighted median of the correctors'
    moduli (`growth_modulus_mpa`), so that one rough law per draw serves all; models of one kinematics share their
    rough solves and read them each with its own imprint model (`solve_growths`, as the correction curves
    do). Repeated draws are solved once. ``keep`` is `draw_laws`'.
    """
    from filmcal.wheelrail import get_wheel_rail_model

    correctors = list(correctors)
    solver = get_wheel_rail_model(**correctors[0].settings)
    modulus = (growth_modulus_mpa([(c.film, c.modulus_mpa_, w) for c, w in zip(correctors, weights)])
               if modulus_mpa is None else float(modulus_mpa))
    film = correctors[0].film.film
    models = [(film.name, c.film, modulus) for c in correctors]
    unique = list(dict.fromkeys(draws))
    done = 0

    def step() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, 2 * len(unique))

    laws = []
    for d in unique:  # the laws (boundary elements) first, then the solves: each half of the work
        laws.append((d.reading_level, draw_laws(d, {film.name: (film, modulus)}, wheel=wheel, rail=rail,
                                                grid_mm=correctors[0].settings.get("grid_mm"), keep=keep)))
        step()
    solved = dict(zip(unique, solve_growths(models, laws, offset_mm, force_n, solver, step)))
    out = {}
    for k, c in enumerate(correctors):
        out[c.film.label] = RoughGrowth(np.array([solved[d][1][k] for d in draws]),
                                        np.array([solved[d][0] for d in draws]),
                                        np.full(len(draws), 1.0 / len(draws)), list(draws))
    return out
