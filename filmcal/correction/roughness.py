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

from filmcal.contact.rough_imprint import RoughnessInputs, rough_recorded_area_mm2
from filmcal.wheelrail.rough_growth import film_growth, no_film_growth, sphere_growth

__all__ = ["RoughGrowth", "sphere_growths", "wheel_rail_growth", "corrector_growths", "weighted_quantiles"]


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

    @property
    def factor(self) -> np.ndarray:
        """``g_0 / g_f`` per draw: what the roughness does to the correction factor."""
        return self.no_film / self.film

    def summary(self) -> dict:
        """Weighted mean, 90 % interval and Monte-Carlo standard error of each growth (in %), JSON-ready."""
        w = self.weights / self.weights.sum()
        n_eff = 1.0 / float(np.sum(w * w))
        out = {"n_draws": int(len(w)), "effective_draws": n_eff}
        for name, g in (("film_growth", self.film), ("no_film_growth", self.no_film),
                        ("correction_factor_change", self.factor)):
            pct = 100.0 * (np.asarray(g, dtype=float) - 1.0)
            mean = float(np.sum(w * pct))
            sd = math.sqrt(float(np.sum(w * (pct - mean) ** 2)))
            lo, hi = weighted_quantiles(pct, w, [0.05, 0.95])
            out[name] = {"mean_pct": mean, "sd_pct": sd, "ci90_pct": [float(lo), float(hi)],
                         "mc_error_pct": sd / math.sqrt(n_eff)}
        return out


def wheel_rail_growth(model, modulus_mpa: float, draws: Sequence[RoughnessInputs], offset_mm: float,
                      force_n: float, settings: dict, *, wheel=None,
                      rail=None, weights: Sequence[float] | None = None,
                      progress: Callable[[int, int], None] | None = None) -> RoughGrowth:
    """`RoughGrowth` of a wheel-rail configuration over ``draws`` (``settings``: `solve_wheel_rail`'s keywords).

    Draws that repeat (a resampled set) are solved once.
    """
    from filmcal.wheelrail import solve_wheel_rail

    def solve(film, law):
        return solve_wheel_rail(offset_mm, force_n, film=film, roughness=law, **settings)

    film0, law0, _ = model.interface(float(modulus_mpa))
    smooth_film = solve(film0, law0)
    smooth_bare = solve(None, None)
    draws = list(draws)
    done: dict[RoughnessInputs, tuple[float, float]] = {}
    g_f, g_0 = np.ones(len(draws)), np.ones(len(draws))
    for i, d in enumerate(draws):
        if d not in done:
            done[d] = (film_growth(model, modulus_mpa, d, solve, smooth_film, wheel, rail),
                       no_film_growth(d, solve, smooth_bare, wheel, rail))
        g_f[i], g_0[i] = done[d]
        if progress is not None:
            progress(i + 1, len(draws))
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


def corrector_growths(correctors: Sequence, weights: Sequence[float], offset_mm: float, force_n: float,
                      draws: Sequence[RoughnessInputs], *, wheel=None,
                      rail=None,
                      progress: Callable[[int, int], None] | None = None) -> dict[str, RoughGrowth]:
    """`RoughGrowth` of each wheel-rail corrector's film model (by its label) at one offset and force.

    Models of one kinematics share their rough solves (one per draw) and read them each with its own imprint
    model; every model is solved at one modulus, the weighted median of all the posteriors' moduli (a growth
    ratio varies little across a posterior), so that one rough law per draw serves all. The contact without
    film is solved once per draw for all. Repeated draws are solved once.
    """
    from filmcal.wheelrail import solve_wheel_rail

    correctors = list(correctors)
    settings = correctors[0].settings

    def solve(film, law):
        return solve_wheel_rail(offset_mm, force_n, film=film, roughness=law, **settings)

    groups: dict[str, list[int]] = {}
    for k, c in enumerate(correctors):
        groups.setdefault(c.film.kinematics, []).append(k)
    unique = list(dict.fromkeys(draws))
    total = len(unique) * (len(groups) + 1)
    done = 0

    def step() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    smooth_bare = solve(None, None)
    g0 = {}
    for d in unique:
        g0[d] = no_film_growth(d, solve, smooth_bare, wheel, rail)
        step()
    gf: dict[int, dict] = {k: {} for k in range(len(correctors))}
    # one modulus for all: the models' weighted median (one rough law per draw, shared by the kinematics)
    e = np.concatenate([c.modulus_mpa_ for c in correctors])
    w = np.concatenate([np.full(len(c.modulus_mpa_), weights[k] / len(c.modulus_mpa_))
                        for k, c in enumerate(correctors)])
    modulus = float(weighted_quantiles(e, w if w.sum() > 0 else np.ones_like(w), [0.5])[0])
    for members in groups.values():
        lead = correctors[members[0]].film
        film0, law0, _ = lead.interface(modulus)
        smooth = solve(film0, law0)
        base = {k: correctors[k].film.recorded_area_mm2(smooth) for k in members}
        for d in unique:
            bodies = d.bodies(wheel, rail)
            if bodies.smooth:
                for k in members:
                    gf[k][d] = 1.0
            else:
                film, law, rough_law = lead.interface(modulus, bodies)
                rough = solve(film, law)
                for k in members:
                    area = rough_recorded_area_mm2(correctors[k].film, rough, rough_law, d.reading_level)
                    gf[k][d] = area / base[k] if base[k] > 0 else 1.0
            step()
    out = {}
    for k, c in enumerate(correctors):
        out[c.film.label] = RoughGrowth(np.array([gf[k][d] for d in draws]), np.array([g0[d] for d in draws]),
                                        np.full(len(draws), 1.0 / len(draws)), list(draws))
    return out
