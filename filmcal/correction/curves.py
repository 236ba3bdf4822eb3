"""Correction curves: the film's effect on the wheel-rail contact area, with credible bands.

For each (offset eta, force F) the wheel-rail model is solved without film and
with the film at three moduli spanning the posteriors of all the film's models
(0.1 % to 99.9 % quantiles, log-spaced); models of one film kinematics differ
only in what they read of a solve (edge, activation contour, capsule), so one
solve per modulus serves them all, and a rough wheel's law is computed once
per modulus for every kinematics. Each solve starts from its neighbour's
pressure (the previous modulus, the bare contact first). For each calibrated
model log(A_film / A_0) is fitted quadratically in log E through the three
moduli, A_film being the area that model records, and evaluated at every
posterior sample; the models' samples are pooled by their weights, giving the
posterior of Delta A = A_film - A_0 and of the ratio A_0 / A_film. A_film is
the area the calibrated film records: the application's reading plus the
transfer term (`FilmModel.transfer_term`), whose standard deviation widens
each sample (relative, interpolated in log E; drawn with a seed of the (force,
offset) cell). The fit's
error is measured by one more solve, between the first two moduli, and
reported beside the bands: the error of a quadratic through three points is
odd about the middle one to leading order, so one check measures both halves.
(Over today's posteriors that error is about 1e-3, the size of the cell-count
noise of the areas themselves.)

Rough bodies enter as growth ratios on these smooth samples, as in a
correction (`filmcal.correction.roughness`): at each cell every draw of the
roughness inputs gives the contact without film's growth g_0 and each model's
g_f (`solve_growths`, at the film's one growth modulus); each posterior sample
is paired with one draw (by the draws' weights), so A_0 becomes A_0 g_0 and
A_film becomes A_film g_f. The rough bands thus hold the roughness law's
uncertainty; the roughness share of the variance of log(A_0 / A_film) and the
Monte-Carlo error of the factor's mean change over the draws are columns
beside them.
"""
from __future__ import annotations

import csv
import math
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from filmcal._io import atomic_open
from filmcal.correction.moduli import modulus_grid
from filmcal.wheelrail.wheelrail import get_wheel_rail_model

__all__ = ["CorrectionCurves", "correction_curves", "CURVE_COLUMNS", "curve_rows", "curve_table", "curve_growths",
           "growth_task", "RoughConfiguration", "write_curves_csv", "read_curves_csv", "wheel_label", "transfer_note"]

#: Solver tolerance of the sweeps: areas within 1e-6 (relative) of the default 1e-9, a fifth faster.
SWEEP_TOL = 1e-6


@dataclass
class CorrectionCurves:
    """Posterior summaries over an (offset, force) grid; arrays of shape (n_forces, n_offsets).

    Attributes
    ----------
    offsets_mm, forces_n : ndarray
    area_no_film_mm2 : ndarray
        The contact without film (rough bodies: the smooth area times the draws' mean growth g_0).
    area_film_median_mm2 : ndarray
    delta_area_median_mm2, delta_area_ci90_mm2 : ndarray (ci90 has a last axis of 2)
        A_film - A_0.
    ratio_median, ratio_ci90 : ndarray
        A_0 / A_film, the factor that corrects a measured area.
    interpolation_error_rel : ndarray
        Largest relative error of the interpolated film area at the check quantiles.
    max_pressure_no_film_mpa : ndarray
        Peak pressure of the smooth contact without film: above the steel's elastic limit the elastic model is
        outside its validity.
    roughness_share : ndarray
        Share of the variance of log(A_0 / A_film) that the roughness draws add (0 for smooth bodies).
    roughness_mc_error_rel : ndarray
        Monte-Carlo standard error of the draws' mean change of the factor, relative (0 for smooth bodies).
    rough : list of CorrectionCurves
        The same curves on each rough configuration asked for (`correction_curves`' ``rough``).
    """

    offsets_mm: np.ndarray
    forces_n: np.ndarray
    area_no_film_mm2: np.ndarray
    area_film_median_mm2: np.ndarray
    delta_area_median_mm2: np.ndarray
    delta_area_ci90_mm2: np.ndarray
    ratio_median: np.ndarray
    ratio_ci90: np.ndarray
    interpolation_error_rel: np.ndarray
    max_pressure_no_film_mpa: np.ndarray
    roughness_share: np.ndarray
    roughness_mc_error_rel: np.ndarray
    rough: list = field(default_factory=list)

    @classmethod
    def empty(cls, offsets: np.ndarray, forces: np.ndarray) -> "CorrectionCurves":
        shape = (len(forces), len(offsets))
        return cls(offsets, forces, *(np.zeros(shape) for _ in range(3)), np.zeros(shape + (2,)), np.zeros(shape),
                   np.zeros(shape + (2,)), *(np.zeros(shape) for _ in range(4)))

    def summarise(self, i: int, j: int, a0, area: np.ndarray) -> None:
        """Fill cell (i, j) from the area without film (per sample or one number) and the film's samples."""
        delta, ratio = area - a0, a0 / area
        self.area_no_film_mm2[i, j] = float(np.mean(a0))
        self.area_film_median_mm2[i, j] = np.median(area)
        self.delta_area_median_mm2[i, j], self.ratio_median[i, j] = np.median(delta), np.median(ratio)
        self.delta_area_ci90_mm2[i, j] = np.quantile(delta, [0.05, 0.95])
        self.ratio_ci90[i, j] = np.quantile(ratio, [0.05, 0.95])


def _thinned(samples, max_samples: int) -> np.ndarray:
    e = np.asarray(samples, dtype=float).ravel()
    if len(e) > max_samples:
        e = e[np.linspace(0, len(e) - 1, max_samples).round().astype(int)]
    if not np.all(np.isfinite(e)) or np.any(e <= 0):
        raise ValueError("modulus_samples_mpa must be finite and > 0")
    return e


def _pooled(components, max_samples: int) -> tuple[list, np.ndarray]:
    """The components with thinned samples, and how many samples of each the weighted pool takes."""
    parts = [(model, _thinned(samples, max_samples), float(w)) for model, samples, w in components]
    weights = np.array([w for _, _, w in parts])
    if not len(parts) or np.any(weights < 0) or not np.all(np.isfinite(weights)) or weights.sum() <= 0:
        raise ValueError("components need non-negative finite weights, not all zero")
    weights = weights / weights.sum()
    n_pool = max(len(e) for _, e, _ in parts)
    counts = np.floor(weights * n_pool).astype(int)
    counts[np.argsort(-(weights * n_pool - counts), kind="stable")[:n_pool - counts.sum()]] += 1
    return parts, counts


def correction_curves(components, offsets_mm, forces_n, *, rough=(), max_samples: int = 4000,
                      **wheel_rail) -> CorrectionCurves:
    """Posterior correction curves over offsets and forces, of one film model or a mixture of models.

    Parameters
    ----------
    components : sequence of (FilmModel, modulus samples, weight)
        Calibrated film models (`filmcal.contact.film.FilmModel`: film type,
        imprint model, kinematics), each with its posterior samples of E and
        its weight in the mixture (e.g. stacking weights; normalised here).
        Each model's film area is what that model records; the bands pool
        the models' samples by weight, so they are as wide as the spread
        between models that the data cannot tell apart.
    offsets_mm, forces_n : array_like
        The grid (lateral offsets eta in mm, forces in N).
    rough : sequence of mappings
        Rough configurations, each the growths of its draws at every cell: ``{(force_n, offset_mm):
        {model label: RoughGrowth}}`` (`curve_growths`); the result's ``rough`` holds their curves, made from
        the same posterior samples as the smooth ones.
    max_samples : int
        Posterior samples used per model.
    **wheel_rail
        Wheel-rail settings of `filmcal.wheelrail.get_wheel_rail_model` (wheel, rail,
        rail_inclination, nominal_radius_mm, grid_mm); the sweep solves to the
        tolerance `SWEEP_TOL`.
    """
    parts, counts = _pooled(components, max_samples)
    offsets = np.atleast_1d(np.asarray(offsets_mm, dtype=float))
    forces = np.atleast_1d(np.asarray(forces_n, dtype=float))
    out = CorrectionCurves.empty(offsets, forces)
    out.rough = [CorrectionCurves.empty(offsets, forces) for _ in rough]

    # Models of one film type and kinematics read the same contact: one solve per modulus serves them all.
    groups: dict = {}
    for k, (model, e, _) in enumerate(parts):
        if counts[k] > 0:
            groups.setdefault((model.film, model.kinematics), []).append(k)
    nodes, checks = modulus_grid([parts[k][1] for members in groups.values() for k in members])
    moduli = np.sort(np.concatenate([nodes, checks]))
    wheel_rail_model = get_wheel_rail_model(**wheel_rail, tol=SWEEP_TOL)
    interfaces = {(key, m): parts[members[0]][0].interface(float(m))
                  for key, members in groups.items() for m in moduli}

    for i, force in enumerate(forces):
        for j, eta in enumerate(offsets):
            # the transfer spread's draws: seeded by the cell, so a cell's band does not depend on the others
            rng = np.random.default_rng([int(round(force)), int(round(1e3 * eta)) + 10**7])
            bare = wheel_rail_model.solve(eta, force)
            a0 = float(bare.area_mm2)
            out.max_pressure_no_film_mpa[i, j] = bare.max_pressure_mpa
            pooled, labels = [], []
            for key, members in groups.items():
                recorded, spread, previous = {}, {}, bare
                for m in moduli:  # each solve starts from its neighbour's pressure
                    film, law, _ = interfaces[key, m]
                    previous = wheel_rail_model.solve(eta, force, film=film, roughness=law, initial=previous)
                    terms = [parts[k][0].transfer_term(float(m), previous) for k in members]
                    recorded[m] = [parts[k][0].recorded_area_mm2(previous) + t.shift_mm2
                                   for k, t in zip(members, terms)]
                    for k, r in zip(members, recorded[m]):
                        if not r > 0.0:
                            from filmcal.correction.wheelrail import empty_imprint

                            raise empty_imprint(parts[k][0], force, eta, "--forces-kn", previous.max_pressure_mpa)
                    spread[m] = [t.std_mm2 / r for t, r in zip(terms, recorded[m])]
                at_nodes = np.log(np.array([recorded[m] for m in nodes]) / a0)
                at_checks = np.log(np.array([recorded[m] for m in checks]) / a0) if len(checks) else None
                degree = min(2, len(nodes) - 1)
                for col, k in enumerate(members):
                    e = parts[k][1]
                    coef = np.polyfit(np.log(nodes), at_nodes[:, col], degree) if degree else at_nodes[:1, col]
                    area = a0 * np.exp(np.polyval(coef, np.log(e)))
                    rel_std = np.interp(np.log(e), np.log(moduli), [spread[m][col] for m in moduli])
                    area = area * (1.0 + rel_std * rng.standard_normal(len(area)))
                    if len(nodes) > 1:
                        out.interpolation_error_rel[i, j] = max(out.interpolation_error_rel[i, j], float(np.max(
                            np.abs(np.exp(np.polyval(coef, np.log(checks)) - at_checks[:, col]) - 1.0))))
                    pooled.append(area[np.linspace(0, len(area) - 1, counts[k]).round().astype(int)])
                    labels.append(parts[k][0].label)
            area = np.concatenate(pooled)
            out.summarise(i, j, a0, area)
            for r, growths in enumerate(rough):
                _rough_cell(out.rough[r], i, j, a0, pooled, labels, growths[float(force), float(eta)], force, eta)
            for curves in out.rough:
                curves.interpolation_error_rel[i, j] = out.interpolation_error_rel[i, j]
                curves.max_pressure_no_film_mpa[i, j] = out.max_pressure_no_film_mpa[i, j]
    return out


def _rough_cell(curves: CorrectionCurves, i: int, j: int, a0: float, pooled: list, labels: list,
                growths: dict, force: float, eta: float) -> None:
    """One cell of a rough configuration: each smooth sample paired with one draw's growths."""
    first = growths[labels[0]]
    n = len(first.weights)
    # the draws' pairing: its own seed of the cell, so the smooth samples (and bands) stay those of the smooth curves
    rng = np.random.default_rng([int(round(force)), int(round(1e3 * eta)) + 10**7, 1])
    areas, nominal, factors = [], [], []
    for area, label in zip(pooled, labels):
        g = growths[label]
        d = rng.choice(n, size=len(area), p=g.weights)
        areas.append(area * g.film[d])
        nominal.append(a0 * g.no_film[d])
        factors.append(g.factor)
    area, rough_a0 = np.concatenate(areas), np.concatenate(nominal)
    curves.summarise(i, j, rough_a0, area)
    curves.area_no_film_mm2[i, j] = a0 * float(np.sum(first.weights * first.no_film))
    # shares of the relative spread: the variance of log(A0 / A), which a common scale factor leaves alone
    var_rough = float(np.var(np.log(rough_a0 / area)))
    var_smooth = float(np.var(np.log(a0 / np.concatenate(pooled))))
    curves.roughness_share[i, j] = max(0.0, 1.0 - var_smooth / var_rough) if var_rough > 0 else 0.0
    # the Monte-Carlo error of the draws' mean factor change, the models mixed by their shares of the pool
    shares = np.array([len(a) for a in pooled], dtype=float)
    h = np.sum(shares[:, None] * np.array(factors), axis=0) / shares.sum()
    w = first.weights / first.weights.sum()
    mean = float(np.sum(w * h))
    sd = float(np.sqrt(np.sum(w * (h - mean) ** 2)))
    # one draw has no spread to estimate its error from: not known, rather than zero
    curves.roughness_mc_error_rel[i, j] = (sd * math.sqrt(first.weight_square_sum()) / mean if len(w) > 1
                                           else math.nan)


CURVE_COLUMNS = ("film", "wheel", "force_kn", "offset_mm", "area_no_film_mm2", "area_film_median_mm2",
                 "delta_area_median_mm2", "delta_area_lo_mm2", "delta_area_hi_mm2", "ratio_median", "ratio_lo",
                 "ratio_hi", "interpolation_error_rel", "max_pressure_no_film_mpa", "roughness_share",
                 "roughness_mc_error_rel")


def wheel_label(roughness=None) -> str:
    """The ``wheel`` column of curve rows: ``smooth``, ``rough Ra <x> um``, the rough bodies' Ra, or ``rough,
    measured law``."""
    from filmcal.contact.roughness import Roughness

    if roughness is None:
        return "smooth"
    if isinstance(roughness, (int, float)):
        return f"rough Ra {roughness:g} um"
    if isinstance(roughness, Roughness):
        ra = roughness.describe()
        parts = [f"{body} Ra {ra[f'{body}_ra_um']:.3g} um" for body in ("wheel", "rail") if ra[f"{body}_ra_um"]]
        return "rough " + ", ".join(parts)
    return "rough, measured law"


def _rows(film: str, wheel: str, c: CorrectionCurves) -> list[list]:
    return [[film, wheel, force / 1e3, eta, c.area_no_film_mm2[i, j], c.area_film_median_mm2[i, j],
             c.delta_area_median_mm2[i, j], *c.delta_area_ci90_mm2[i, j], c.ratio_median[i, j], *c.ratio_ci90[i, j],
             c.interpolation_error_rel[i, j], c.max_pressure_no_film_mpa[i, j], c.roughness_share[i, j],
             c.roughness_mc_error_rel[i, j]]
            for i, force in enumerate(c.forces_n) for j, eta in enumerate(c.offsets_mm)]


@contextmanager
def _at_cell(offset_mm: float, force_kn: float):
    """A cell the model cannot solve (a soft film spreading a flange contact past the profiles' ends) is the
    grid's fault, said as such with the cell: an `InputError`, not a failed task (an internal error)."""
    from filmcal._errors import InputError

    try:
        yield
    except InputError:
        raise
    except ValueError as exc:
        raise InputError(f"the cell eta {offset_mm:+g} mm, {force_kn:g} kN cannot be solved: {exc}; leave it out "
                         "of --offsets-mm or --forces-kn") from None


def curve_rows(film: str, components, offsets_mm, forces_kn, rough=(), **wheel_rail) -> list[list]:
    """Correction curves of one film as CSV rows (`CURVE_COLUMNS`): the smooth wheel's, then each rough one's.

    Parameters
    ----------
    film : str
        Film type (the rows' label).
    components : sequence of (FilmModel, modulus samples, weight)
        The film's calibrated models, as `correction_curves` takes them.
    offsets_mm, forces_kn : sequence of float
        The grid: lateral offsets eta (mm) and loads (kN).
    rough : sequence of (label, growths)
        Rough configurations: the rows' ``wheel`` label (`wheel_label`) and the growths of its draws at each
        cell, keyed by (force in N, offset) (`curve_growths`).
    **wheel_rail
        Passed on to `correction_curves` (profiles, inclination, ...).
    """
    with _at_cell(offsets_mm[0], forces_kn[0]) if len(offsets_mm) == len(forces_kn) == 1 else nullcontext():
        c = correction_curves(components, offsets_mm, np.asarray(forces_kn, dtype=float) * 1e3,
                              rough=[g for _, g in rough], **wheel_rail)
    return _rows(film, "smooth", c) + [row for (label, _), r in zip(rough, c.rough) for row in _rows(film, label, r)]


@dataclass(frozen=True)
class RoughConfiguration:
    """Rough bodies of a set of curves: each body's Ra (a draw's synthetic surface) or measured surface, and
    the draws of the roughness inputs; or a measured film-wheel law (``law``: taken as it is, one draw, the
    contact without film smooth).

    Attributes
    ----------
    wheel, rail : float, RoughSurface or None
    draws : tuple of RoughnessInputs
        The draws (repeats of a resampled set count as their weight; each distinct draw is solved once).
    law : InterfaceLaw or None
    """

    wheel: object = None
    rail: object = None
    draws: tuple = ()
    law: object = None

    @property
    def label(self) -> str:
        if self.law is not None:
            return wheel_label(self.law)
        if not isinstance(self.wheel, (int, float)) or self.rail is not None:
            return wheel_label(self.draws[0].bodies(self.wheel, self.rail))
        return wheel_label(float(self.wheel))

    def distinct(self) -> list:
        return [None] if self.law is not None else list(dict.fromkeys(self.draws))


def growth_task(models, draws, laws, offset_mm: float, force_n: float, wheel_rail: dict) -> dict:
    """The growths of every distinct draw at one cell (a task for `filmcal._parallel.run_tasks`).

    ``models``: ``[(film name, FilmModel, modulus_mpa)]``; ``draws``: the distinct draws (None: a measured
    law); ``laws``: each draw's laws (`filmcal.correction.roughness.draw_laws`), each given as the law or as
    the path of its file (`filmcal.contact.rough_law_file`; read once per process). The smooth solves are
    shared by the draws (`filmcal.correction.roughness.solve_growths`). Returns ``{draw: (g_0, [g_f per
    model])}``.
    """
    from filmcal.correction.roughness import solve_growths

    solver = get_wheel_rail_model(**wheel_rail, tol=SWEEP_TOL)
    given = [(None if d is None else d.reading_level, {k: _law(v) for k, v in laws[d].items()}) for d in draws]
    with _at_cell(offset_mm, force_n / 1e3):
        return dict(zip(draws, solve_growths(models, given, offset_mm, force_n, solver)))


_LOADED: dict = {}


def _law(law):
    """A law, or the law read from its file (kept: a worker reads each file once)."""
    if not isinstance(law, (str, Path)):
        return law
    from filmcal.contact.rough_law_file import load_rough_law

    key = str(law)
    if key not in _LOADED:
        _LOADED[key] = load_rough_law(key)
        while len(_LOADED) > 64:
            _LOADED.pop(next(iter(_LOADED)))
    return _LOADED[key]


def curve_growths(models, configuration: RoughConfiguration, solved: dict) -> dict:
    """The growths of every cell as `correction_curves` takes them, for one film's ``models`` (``[(position,
    (film name, FilmModel, modulus_mpa))]``, each position into the solved lists), from ``solved``
    (``{cell: output of `growth_task`}``, cells keyed by (force_n, offset_mm), over all films' models)."""
    from filmcal.correction.roughness import RoughGrowth

    draws = [None] if configuration.law is not None else list(configuration.draws)
    w = np.full(len(draws), 1.0 / len(draws))
    return {cell: {model.label: RoughGrowth(np.array([by_draw[d][1][k] for d in draws]),
                                            np.array([by_draw[d][0] for d in draws]), w, draws)
                   for k, (_, model, _) in models}
            for cell, by_draw in solved.items()}


def curve_table(film: str, components, offsets_mm, forces_kn, rough=(), workers=None, store=None,
                laws_started=None) -> list[list]:
    """Correction curves of one film, smooth and on rough bodies, as CSV rows (`CURVE_COLUMNS`), in parallel.

    The rows are those of `curve_rows` (loads, then offsets within a load; the smooth wheel, then each rough
    configuration) wherever the work runs: for each rough configuration one task per law to solve
    (`rough_law_files`), and one per load and offset (`growth_task`: every draw's rough solves there), then one
    task per load and offset (the curves).

    Parameters
    ----------
    film, components, offsets_mm, forces_kn
        As `curve_rows` takes them: the film type, its calibrated models and the grid (mm, kN).
    rough : sequence of RoughConfiguration
    workers : int or filmcal._parallel.Executor, optional
        Local worker processes (default: all cores; 1: everything in this process), or the executor to run
        on (a `filmcal._parallel.DaskExecutor`: a Dask cluster).
    store : optional
        Where the rough laws are read back and kept as each is solved (`rough_law_files`), such as a study's
        `filmcal.study.core.StudyRoughLaws`; without one they are solved into a temporary folder.
    laws_started : callable, optional
        ``laws_started(configuration, solving, found)`` before each rough configuration's laws are solved: how
        many are solved, how many the store had.
    """
    import tempfile

    from filmcal._parallel import run_tasks
    from filmcal.correction.roughness import growth_modulus_mpa

    modulus = growth_modulus_mpa(components)
    models = [(film, model, modulus) for model, _, _ in components]
    films = {film: (components[0][0].film, modulus)}
    cells = [(1e3 * float(force), float(eta)) for force in forces_kn for eta in offsets_mm]
    growths = []
    with tempfile.TemporaryDirectory(prefix="filmcal-laws-") as tmp:
        for r, configuration in enumerate(rough):
            draws = configuration.distinct()
            started = None if laws_started is None else (
                lambda solving, found, c=configuration: laws_started(c, solving, found))
            paths = rough_law_files(configuration, films, workers, Path(tmp) / str(r), store, started)
            solved: dict = {}
            run_tasks({cell: (growth_task, (models, draws, paths, cell[1], cell[0], {})) for cell in cells}, workers,
                      lambda key, value, k, solved=solved: solved.update({key: value}))
            growths.append(curve_growths(list(enumerate(models)), configuration, solved))
    rows: dict = {}
    run_tasks({(force, eta): (curve_rows, (film, components, (eta,), (force,),
                                           [(c.label, {(1e3 * float(force), float(eta)):
                                                       growths[r][1e3 * float(force), float(eta)]})
                                            for r, c in enumerate(rough)]))
               for force in forces_kn for eta in offsets_mm}, workers, lambda key, value, k: rows.update({key: value}))
    n = len(rough) + 1
    return [row for w in range(n) for force in forces_kn for eta in offsets_mm
            for row in rows[force, eta][w::n]]


def rough_law_files(configuration: RoughConfiguration, films: dict, workers, folder: Path | None, store=None,
                    started=None) -> dict:
    """Each distinct draw's laws (`filmcal.correction.roughness.draw_laws`) as `growth_task` takes them: ``{draw:
    {film name or None: the law's file, "waviness": ...}}``, one task per distinct law to solve (the draws of a
    measured map share its law without film).

    With a ``store`` (``kept(bodies, film, modulus_mpa)`` -> the file of a law it has, or None; ``add(bodies,
    film, modulus_mpa, law)`` -> the file it kept the law in, or None), a law it has is read from there and each
    one solved is kept there as it arrives, so an interrupted run solves only the others again; the rest go to
    files in ``folder`` (None: the tasks get them themselves). On a Dask cluster, whose workers may not see this
    file system, the tasks get the laws themselves. ``started(solving, found)``, when given, is called before
    the solves with the number of laws to solve and of laws the store had."""
    from filmcal._parallel import DaskExecutor, run_tasks
    from filmcal.contact.rough_law_file import load_rough_law, save_rough_law
    from filmcal.correction.roughness import draw_bodies, draw_laws

    remote = isinstance(workers, DaskExecutor)
    out: dict = {}
    tasks: dict = {}
    found = 0
    loaded: dict = {}  # the laws read from the store for a cluster's tasks, by file
    users: dict = {}  # each distinct law: its bodies, film and modulus, and the (draw, name) that use it
    for d in configuration.distinct():
        if d is None:  # a measured law, taken as it is
            out[d] = draw_laws(None, films, law=configuration.law)
            continue
        bodies, wavy = draw_bodies(d, wheel=configuration.wheel, rail=configuration.rail)
        out[d] = {"waviness": wavy}
        micro = bodies.wheel is not None or bodies.rail is not None
        for name in [*films, None]:
            film, modulus = films[name] if name is not None else (None, None)
            path = store.kept(bodies, film, modulus) if store is not None and micro else None
            if not micro:  # smooth, or all waviness: no law
                out[d][name] = None
            elif path is not None:
                if remote and path not in loaded:  # a law the draws share is read once
                    loaded[path] = load_rough_law(path)
                out[d][name] = loaded[path] if remote else str(path)
                found += 1
            else:
                key = (name, *(None if s is None else s.fingerprint() for s in (bodies.wheel, bodies.rail)),
                       None if name is None else float(bodies.film_hardness_mpa))
                users.setdefault(key, (bodies, film, modulus, []))[3].append((d, name))
                tasks[key] = ((bodies.steel_law, ()) if name is None else
                              (bodies.film_law, (float(modulus), film.poisson, film.thickness_mm)))

    def keep(key, law, k):
        bodies, film, modulus, where = users[key]
        path = None if store is None or law is None else store.add(bodies, film, modulus, law)
        if path is None and law is not None and not remote and folder is not None:
            folder.mkdir(parents=True, exist_ok=True)
            path = save_rough_law(law, folder / f"{k}.npz")
        for d, name in where:
            out[d][name] = law if remote or path is None else str(path)

    if started is not None:
        started(len(tasks), found)
    run_tasks(tasks, workers, keep)
    return out


def transfer_note(rows: list[list], components) -> str | None:
    """What `filmcal correct` warns of a cell whose film transfer is extrapolated
    (`filmcal.correction.transfer.outside_fit`), said once for the cells of `rows` (`curve_rows`) it holds at;
    None when it holds at none. ``components`` as `correction_curves` takes them."""
    from filmcal.contact.transfer import load_transfer_fit
    from filmcal.correction.transfer import outside_fit

    area, peak = CURVE_COLUMNS.index("area_no_film_mm2"), CURVE_COLUMNS.index("max_pressure_no_film_mpa")
    contacts = {(r[2], r[3]): (math.sqrt(r[area] / math.pi), r[peak]) for r in rows}  # a cell's rows share it
    cells = {}
    for cell, (radius, p) in contacts.items():
        reasons = [x for fm, modulus, _ in components
                   for x in outside_fit(load_transfer_fit(), fm.film, fm.imprint, radius, p, modulus)]
        if reasons:
            cells[cell] = list(dict.fromkeys(reasons))
    if not cells:
        return None
    (force, offset), reasons = next(iter(cells.items()))
    return (f"the film's transfer to the wheel-rail model is extrapolated at {len(cells)} of {len(contacts)} (load, "
            f"offset) cells (at {force:g} kN, eta {offset:+g} mm: {'; '.join(reasons)}): there the transfer term, "
            "and so the curves and their bands, are extrapolated")


def write_curves_csv(path: str | Path, rows: list[list]) -> Path:
    """Write curve rows with the `CURVE_COLUMNS` header, whole or not at all."""
    path = Path(path)
    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CURVE_COLUMNS)
        w.writerows(rows)
    return path


def read_curves_csv(path: str | Path) -> list[dict]:
    """Rows of a ``curves-<film>.csv`` with numbers as floats."""
    with open(path, newline="") as fh:
        return [{k: (v if k in ("film", "wheel") else float(v)) for k, v in row.items()} for row in csv.DictReader(fh)]
