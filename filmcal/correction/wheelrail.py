"""Correction of wheel-rail film imprints: the contact area without film, with its uncertainty.

For the measured configuration (offset eta, force F, profiles) the wheel-rail
model gives the area without film A_0 and with the calibrated film A_f(E). The
film's effect depends smoothly on E over a posterior, so A_f is solved at five
moduli log-spaced between the 0.1 % and 99.9 % posterior quantiles of E and
log(A_0 / A_f) is interpolated (quadratic in log E) for every posterior
sample: the rule of `filmcal.correction.correction_curves`, so that a
corrector and the curves interpolate the same solves. Models of one film type
and kinematics differ only in what they read of a solve (edge, activation
contour, capsule): correctors that share a `SupportAreas` solve once per
modulus for all of them, over the moduli spanning all their posteriors, and a
study can keep those solved areas (`SupportAreas` takes a cache).

A_f is the area the calibrated film records: the application's reading plus
the transfer term of `filmcal.contact.transfer` (`FilmModel.transfer_term`: the
continuum FE film that was calibrated against the film law solved here, a
shift with its sign and a standard deviation s_T). The corrected area of a
sample is

    A = (A_m + u eps_1) * (A_0 / A_f(E)) * (1 + 2 sigma / r_m * eps_2) / (1 + s_T / A_f * eps_3),

A_m the measured area, u the user's area uncertainty, r_m = sqrt(A_m / pi)
its equivalent radius and sigma the scatter of one imprint's radius about the
model (inferred on the sphere-on-flat tests), carried over as a relative area
scatter; eps_1..3 standard normal. An uncertain offset (standard uncertainty
u) moves each sample's factor along its secant slope in the offset over
eta -/+ u, by u times a standard normal draw. On rough bodies each sample is further
multiplied by ``g_0 / g_f`` of one draw of the roughness inputs
(`filmcal.correction.roughness`: the rough/smooth growth of the contact
without film over that of the film's reading).
"""
from __future__ import annotations

import numpy as np

from typing import Protocol, Sequence

from filmcal.wheelrail.settings import GRID_MM, NOMINAL_RADIUS_MM, RAIL, RAIL_INCLINATION, WHEEL
from filmcal.contact.film import FilmModel
from filmcal.correction.sphere import MAX_RELATIVE_STD, CorrectedArea, _summarise

__all__ = ["WheelRailCorrector", "SupportAreas", "SupportCache", "support_moduli", "nominal_modulus_mpa"]

def support_moduli(moduli: Sequence[np.ndarray]) -> np.ndarray:
    """The moduli at which the film is solved for models that share their solves.

    `filmcal.correction.moduli.modulus_grid`'s nodes (the one grid over E of the corrector and the curves):
    log-spaced between the smallest 0.1 % and the largest 99.9 % quantile of the models' samples of E (one
    modulus when they all coincide).
    """
    from filmcal.correction.moduli import modulus_grid

    return modulus_grid(moduli)[0]


class SupportCache(Protocol):
    """Where solved support areas are kept between runs (e.g. a study folder)."""

    def get(self, offset_mm: float, force_n: float, support: "SupportAreas") -> dict | None: ...

    def put(self, offset_mm: float, force_n: float, support: "SupportAreas", areas: dict) -> None: ...

    def flush(self) -> None:
        """Write what `put` kept (called once the answer it served is given)."""


class SupportAreas:
    """The wheel-rail solves that correctors of one film type and kinematics share.

    For an (offset, force): one solve without film, and one solve with the
    film per support modulus (`support_moduli` of all the models' samples),
    from which every model reads the area it records.

    Parameters
    ----------
    models : sequence of FilmModel
        The models (one film type and kinematics; different imprint readings).
    moduli : sequence of ndarray
        Each model's posterior samples of E at the film's nominal nu.
    settings : dict
        Keyword arguments of `filmcal.wheelrail.solve_wheel_rail` (profiles, inclination, grid).
    cache : SupportCache, optional
        Solved areas kept between runs; consulted before solving, given every new solve.
    """

    def __init__(self, models: Sequence[FilmModel], moduli: Sequence[np.ndarray], settings: dict,
                 cache: SupportCache | None = None) -> None:
        models = list(models)
        if not models or len(models) != len(moduli):
            raise ValueError("give one array of moduli per model")
        if len({(m.film, m.kinematics) for m in models}) != 1 or len({m.label for m in models}) != len(models):
            raise ValueError("models that share solves have one film type and kinematics and differ in imprint")
        self.models = models
        self.moduli_mpa = support_moduli(moduli)
        self.settings = dict(settings)
        self.cache = cache
        self.n_solves = 0
        self._solved: dict[tuple[float, float], dict] = {}

    def __call__(self, offset_mm: float, force_n: float) -> dict:
        """``area_no_film_mm2``, ``no_film`` (the contact without film's peak pressure, length and width of its
        outline and centroid on the rail), ``modulus_grid_mpa``, and per model label: ``area_film_mm2`` (the area the
        calibrated film records at each modulus: the application's reading plus the transfer term's shift) and
        ``transfer_shift_mm2`` and ``transfer_std_mm2`` (the term's shift, included in ``area_film_mm2``, and
        its standard deviation there)."""
        key = (float(offset_mm), float(force_n))
        if key not in self._solved:
            areas = self.cache.get(*key, self) if self.cache is not None else None
            if areas is None or "transfer_shift_mm2" not in areas or "no_film" not in areas:
                areas = self._solve(*key)
                if self.cache is not None:
                    self.cache.put(*key, self, areas)
            self._solved[key] = areas
        return self._solved[key]

    def _solve(self, offset_mm: float, force_n: float) -> dict:
        from filmcal.wheelrail import solve_wheel_rail

        bare = solve_wheel_rail(offset_mm, force_n, film=None, **self.settings)
        a0 = float(bare.area_mm2)
        points = np.concatenate([np.asarray(ring) for ring in bare.outline_mm])
        recorded = {m.label: [] for m in self.models}
        shift = {m.label: [] for m in self.models}
        spread = {m.label: [] for m in self.models}
        for e in self.moduli_mpa:
            film, law, _ = self.models[0].interface(float(e))
            result = solve_wheel_rail(offset_mm, force_n, film=film, roughness=law, **self.settings)
            for m in self.models:
                term = m.transfer_term(float(e), result)
                recorded[m.label].append(m.recorded_area_mm2(result) + term.shift_mm2)
                shift[m.label].append(term.shift_mm2)
                spread[m.label].append(term.std_mm2)
        self.n_solves += 1 + len(self.moduli_mpa)
        return {"area_no_film_mm2": a0, "modulus_grid_mpa": [float(e) for e in self.moduli_mpa],
                "area_film_mm2": recorded, "transfer_shift_mm2": shift, "transfer_std_mm2": spread,
                "no_film": {"max_pressure_mpa": float(bare.max_pressure_mpa),
                            "length_mm": float(np.ptp(points[:, 0])), "width_mm": float(np.ptp(points[:, 1])),
                            "centroid_rail_y_mm": float(bare.centroid_rail_y_mm)}}


def empty_imprint(model, force_n: float, eta_mm: float, option: str, max_pressure_mpa: float | None = None):
    """The input error of a load at which a film's imprint model records nothing (no correction exists)."""
    from filmcal._errors import InputError

    peak = f"the film's peak pressure {max_pressure_mpa:.0f} MPa against " if max_pressure_mpa is not None else ""
    return InputError(f"{option}: at {force_n / 1e3:g} kN and eta {eta_mm:g} mm the {model.label} imprint records "
                      f"nothing ({peak}the film's activation pressure {model.film.activation_pressure_mpa:g} MPa): "
                      "no correction exists at this load; give a larger force")


def nominal_modulus_mpa(posterior: dict, nominal_poisson: float) -> np.ndarray:
    """Posterior samples of E at the film's nominal nu, with the same oedometric modulus M.

    A thin film held laterally responds to M = E(1-nu)/((1+nu)(1-2nu)) alone,
    so a posterior sampled with nu free is carried over to the film model
    (which uses the nominal nu) sample by sample at equal M; with nu fixed at
    the nominal value the samples are unchanged.
    """
    from filmcal.elastic import oedometric_ratio

    e = np.asarray(posterior["modulus_mpa"], dtype=float).ravel()
    nu = np.asarray(posterior.get("poisson", nominal_poisson), dtype=float)
    nu = np.broadcast_to(nu.ravel() if nu.ndim else nu, e.shape)
    return e * oedometric_ratio(nu) / oedometric_ratio(nominal_poisson)


class WheelRailCorrector:
    """Correct wheel-rail imprints measured with one film type.

    Parameters
    ----------
    posterior : dict of ndarray
        Posterior samples ``modulus_mpa``, ``sigma_mm`` (and ``poisson``).
    film : FilmModel
        The film model the posterior was calibrated under
        (`filmcal.contact.film.FilmModel`: film type, imprint model,
        kinematics): the film's area is what that model records.
    wheel, rail : str
        Profile names (or CSV paths) as `filmcal.wheelrail.solve_wheel_rail` takes them.
    rail_inclination, nominal_radius_mm, grid_mm : float
        Wheel-rail model settings.
    max_samples : int
    random_state : int or numpy.random.Generator

    Attributes
    ----------
    supports : SupportAreas
        Its solves; by default its own. Correctors of one film type and
        kinematics may be given one shared `SupportAreas` (`share_supports`).
    """

    def __init__(self, posterior: dict, film: FilmModel, wheel: str = WHEEL, rail: str = RAIL,
                 rail_inclination: float = RAIL_INCLINATION, nominal_radius_mm: float = NOMINAL_RADIUS_MM, grid_mm: float = GRID_MM,
                 max_samples: int = 2000, random_state=0) -> None:
        from filmcal.correction.moduli import thinned_posterior

        samples = thinned_posterior(posterior, max_samples)
        self.modulus_mpa_ = nominal_modulus_mpa(samples, film.film.poisson)
        self.sigma_mm_ = samples["sigma_mm"]
        self.film = film
        self.settings = dict(wheel=wheel, rail=rail, rail_inclination=rail_inclination,
                             nominal_radius_mm=nominal_radius_mm, grid_mm=grid_mm)
        self.random_state = random_state
        self.supports = SupportAreas([film], [self.modulus_mpa_], self.settings)

    @staticmethod
    def share_supports(correctors: Sequence["WheelRailCorrector"], cache: SupportCache | None = None) -> None:
        """Let correctors of one film type and kinematics share their solves (one per modulus for all).

        Each group of correctors with the same film type, kinematics and
        wheel-rail settings gets one `SupportAreas` over the moduli spanning
        all their posteriors; `cache` (optional) keeps the solved areas.
        """
        groups: dict = {}
        for c in correctors:
            key = (c.film.film, c.film.kinematics, tuple(sorted((k, str(v)) for k, v in c.settings.items())))
            groups.setdefault(key, []).append(c)
        for members in groups.values():
            shared = SupportAreas([c.film for c in members], [c.modulus_mpa_ for c in members], members[0].settings,
                                  cache=cache)
            for c in members:
                c.supports = shared

    def film_area_mm2(self, modulus_mpa: float, offset_mm: float, force_n: float) -> float:
        """The area the calibrated film records at modulus E: the film model's reading of its own solve plus
        the transfer term's shift (`FilmModel.transfer_term`)."""
        from filmcal.wheelrail import solve_wheel_rail

        film, law, _ = self.film.interface(float(modulus_mpa))
        result = solve_wheel_rail(offset_mm, force_n, film=film, roughness=law, **self.settings)
        return self.film.recorded_area_mm2(result) + self.film.transfer_term(float(modulus_mpa), result).shift_mm2

    def area_ratio(self, offset_mm: float, force_n: float) -> tuple[np.ndarray, np.ndarray, dict]:
        """A_0 / A_f(E) for every posterior sample, the transfer term's relative standard deviation of A_f
        there, and the solved support points."""
        solved = self.supports(offset_mm, force_n)
        a0 = solved["area_no_film_mm2"]
        e_grid = np.asarray(solved["modulus_grid_mpa"], dtype=float)
        a_f = np.asarray(solved["area_film_mm2"][self.film.label], dtype=float)
        if not np.all(a_f > 0.0):
            raise empty_imprint(self.film, force_n, offset_mm, "--force-kn")
        rel_std = np.asarray(solved["transfer_std_mm2"][self.film.label], dtype=float) / a_f
        log_e = np.log(self.modulus_mpa_)
        degree = min(2, len(e_grid) - 1)
        if degree > 0:
            ratio = np.exp(np.polyval(np.polyfit(np.log(e_grid), np.log(a0 / a_f), degree), log_e))
            transfer = np.interp(log_e, np.log(e_grid), rel_std)
        else:
            ratio = np.full_like(self.modulus_mpa_, a0 / a_f[0])
            transfer = np.full_like(self.modulus_mpa_, rel_std[0])
        return ratio, transfer, {"area_no_film_mm2": a0, "modulus_grid_mpa": e_grid, "area_film_mm2": a_f}

    def transfer(self, offset_mm: float, force_n: float) -> dict:
        """The transfer term at the posterior median modulus, relative to the calibrated film's area.

        ``shift_rel``: the shift's share of A_f (negative: the calibrated film records less than the springs
        read, so the correction factor grows by about ``-shift_rel``); ``std_rel``: its standard deviation's.
        """
        solved = self.supports(offset_mm, force_n)
        log_e = np.log(solved["modulus_grid_mpa"])
        a_f = np.asarray(solved["area_film_mm2"][self.film.label], dtype=float)
        at = float(np.log(np.median(self.modulus_mpa_)))
        rel = {key: float(np.interp(at, log_e, np.asarray(solved[f"transfer_{key}_mm2"][self.film.label]) / a_f))
               for key in ("shift", "std")}
        return {"shift_rel": rel["shift"], "std_rel": rel["std"]}

    def check_plausible(self, measured_area_mm2: float, offset_mm: float, force_n: float) -> None:
        """Refuse a measured wheel-rail area that no film could print at this offset and load.

        A film enlarges the contact without film A_0 by a factor of about 1.3-1.8
        (MS at most about 1.9); it does not halve it, nor multiply it by four:
        areas outside [A_0 / 2, 4 A_0] are taken as a unit, offset or load error. Every caller (a command,
        a batch row, a served request) meets this rule here.
        """
        a0 = self.supports(offset_mm, force_n)["area_no_film_mm2"]
        lo, hi = 0.5 * a0, 4.0 * a0
        if not lo <= measured_area_mm2 <= hi:
            raise ValueError(f"measured_area_mm2 {measured_area_mm2:g} is implausible at eta = {offset_mm:g} mm "
                             f"and F = {force_n / 1e3:g} kN (contact area without film {a0:.1f} mm2; a film "
                             f"imprint lies within {lo:.1f}-{hi:.1f} mm2): check the units, the offset and the load")

    def outline_model(self, offset_mm: float, force_n: float):
        """The contact outlines with and without film at the posterior median (`wheel_rail_outlines`).

        The outline's shape comes from the linear film at the posterior median: the large-strain law changes
        the area, which the correction carries, more than the shape of its rim.
        """
        from filmcal.contact.laws import FilmLayer
        from filmcal.correction.outline import wheel_rail_outlines

        ft = self.film.film
        film = FilmLayer(float(np.median(self.modulus_mpa_)), ft.poisson, ft.thickness_mm)
        return wheel_rail_outlines(offset_mm, force_n, film, **self.settings)

    def correct(self, measured_area_mm2, offset_mm, force_n, measured_area_std_mm2=0.0, rough=None,
                offset_std_mm=0.0) -> CorrectedArea:
        """The contact area without film behind measured imprint areas (vectorised).

        Parameters
        ----------
        measured_area_mm2 : float or array_like
            Imprint area on the film (mm^2), > 0.
        offset_mm : float or array_like
            Lateral offset eta (mm, the paper's convention).
        force_n : float or array_like
            Wheel load (N), > 0.
        measured_area_std_mm2 : float or array_like
            The user's standard uncertainty of the measured area (mm^2), >= 0.
        rough : RoughGrowth, optional
            The bodies' roughness at this offset and force (`filmcal.correction.roughness`): each sample's
            factor is multiplied by ``g_0 / g_f`` of a draw of the roughness inputs, drawn by their weights
            (one offset and force for every point).
        offset_std_mm : float or array_like
            Standard uncertainty of the offset (mm), >= 0: each sample's factor moves along its slope in
            the offset, the secant of ln(A_0 / A_f) between eta - u and eta + u (two more solved offsets),
            by u times a standard normal draw.
        """
        A, eta, F, u, u_eta = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in
                                                   (measured_area_mm2, offset_mm, force_n, measured_area_std_mm2,
                                                    offset_std_mm)))
        if not np.all(np.isfinite(A)) or np.any(A <= 0):
            raise ValueError("measured_area_mm2 must be finite and > 0")
        if not np.all(np.isfinite(u)) or np.any(u < 0):
            raise ValueError("measured_area_std_mm2 must be finite and >= 0")
        if not np.all(np.isfinite(u_eta)) or np.any(u_eta < 0) or np.any(u_eta > 10.0):
            raise ValueError("offset_std_mm must be finite, >= 0 and at most 10 mm (a ruler reads the offset to "
                             "about 0.5-1 mm)")
        if np.any(u > 2.0 * MAX_RELATIVE_STD * A):
            worst = float(np.max(u / A))
            raise ValueError(f"measured_area_std_mm2 is {100 * worst:.3g} % of the measured area, more than "
                             f"{200 * MAX_RELATIVE_STD:g} % ({100 * MAX_RELATIVE_STD:g} % of its radius): an imprint "
                             "read that loosely leaves the film's own error undecided; check the units")
        rng = np.random.default_rng(self.random_state)
        n = len(self.modulus_mpa_)
        samples = np.empty(A.shape + (n,))
        cache: dict[tuple[float, float], tuple[np.ndarray, np.ndarray]] = {}
        for idx in np.ndindex(A.shape):
            key = (float(eta[idx]), float(F[idx]))
            self.check_plausible(float(A[idx]), *key)
            if key not in cache:
                cache[key] = self.area_ratio(*key)[:2]
            ratio, transfer = cache[key]
            r_m = np.sqrt(A[idx] / np.pi)
            measured = A[idx] + u[idx] * rng.standard_normal(n)
            scatter = 1.0 + 2.0 * self.sigma_mm_ / r_m * rng.standard_normal(n)
            samples[idx] = measured * ratio * scatter / (1.0 + transfer * rng.standard_normal(n))
            if u_eta[idx] > 0:
                shifted = [self.area_ratio(key[0] + sign * float(u_eta[idx]), key[1])[0] for sign in (-1.0, 1.0)]
                slope = (np.log(shifted[1]) - np.log(shifted[0])) / (2.0 * float(u_eta[idx]))
                samples[idx] *= np.exp(slope * float(u_eta[idx]) * rng.standard_normal(n))
        if rough is not None:
            if len(cache) > 1:
                raise ValueError("a roughness growth belongs to one offset and force: correct the points apart")
            samples *= rough.factor[rng.choice(len(rough.factor), size=n, p=rough.weights)]
        samples = np.clip(samples, 0.0, None)
        return _summarise(samples, np.sqrt(samples / np.pi))
