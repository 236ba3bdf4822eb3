"""Measuring the transfer term: sphere-on-flat in both models at equal film parameters.

At points of a Latin hypercube over (E, nu, R, F), the calibrated model (the
axisymmetric FE, default mesh: the model the posteriors were fitted with) and
the application model (the half-space with the film law of
`FilmModel.interface`, on the wheel-rail grid) solve the same sphere on a flat
with the same film; each imprint model reads both. `fit_transfer` fits the
edge offset of `filmcal.contact.transfer` on one design and checks it on
another (held out); ``scripts/fit-transfer`` writes the shipped fit.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from filmcal.contact.transfer import FEATURES, THICKNESS_STD_MM, ResidualGP, TransferFit, transfer_features

__all__ = ["TRANSFER_DOMAIN", "CORE_DOMAIN", "NEAR_INCOMPRESSIBLE", "THICKNESS_DOMAIN_MM", "THICKNESS_PARTS_MM",
           "THICKNESS_RANGES", "RMS_BOUND_CONFIDENCE", "rms_upper_bound", "transfer_design", "thickness_design",
           "thickness_parts", "measure_transfer", "fit_transfer", "check_transfer", "outside_fit"]

#: Where the transfer is measured and checked: the calibration's supported domain
#: (`filmcal.surrogate.radius.SUPPORTED_RADIUS_MM`, `SUPPORTED_FORCE_KN`, within the steel's elastic limit), with
#: margins: film modulus (MPa, sampled in log), nu, sphere radius (mm, log), force (kN, log).
TRANSFER_DOMAIN = {"modulus_mpa": (400.0, 20000.0), "poisson": (0.25, 0.45), "sphere_radius_mm": (150.0, 1500.0),
                   "force_kn": (9.0, 165.0)}
#: Table 1's region (R 250-600 mm, 20-110 kN; its patches are the size of a wheel-rail patch's), sampled
#: densest (R and F linear): where the paper's calibrations and the wheel-rail corrections read the term.
CORE_DOMAIN = {**TRANSFER_DOMAIN, "sphere_radius_mm": (250.0, 600.0), "force_kn": (20.0, 110.0)}
#: A design point's Hertz peak pressure without film stays below the elastic limit times this margin.
ELASTIC_MARGIN = 1.05

#: Where the transfer varies fastest: films near incompressibility (the continuum film's edge zone scales with
#: 1 - 2 nu). A training design adds a hypercube over this nu range; held out, the level readings' residual
#: there was twice its rms elsewhere (0.0022 against 0.0011-0.0013 mm) with the whole-domain design alone.
NEAR_INCOMPRESSIBLE = (0.42, 0.45)


def transfer_design(n: int, random_state: int, corners: bool = False,
                    poisson: tuple[float, float] | None = None, region: str = "core") -> np.ndarray:
    """``n`` points (E, nu, R, F in kN) of a Latin hypercube, R rounded to 0.1 mm.

    ``region="core"`` samples `CORE_DOMAIN` (R and F linear); ``"whole"`` samples `TRANSFER_DOMAIN` (R and F in
    log) and keeps the first `n` of 6 n hypercube points within the steel's elastic limit (`ELASTIC_MARGIN`):
    a random subset of a hypercube, each point uniform over the region.
    With ``corners`` the region's corners follow (E and nu at their bounds; for ``"whole"`` the (R, F) corners
    of the region cut by the elastic limit): a training design then anchors the residual process where a
    Latin hypercube leaves it to extrapolate (soft films near incompressibility, stiff films at the highest
    pressures). ``poisson`` narrows the hypercube's nu range (e.g. `NEAR_INCOMPRESSIBLE`).
    """
    import itertools

    from scipy.stats import qmc

    from filmcal.hertz import hertz_max_pressure_mpa
    from filmcal.surrogate.radius import ELASTIC_LIMIT_MPA

    if region not in ("core", "whole"):
        raise ValueError(f"region must be 'core' or 'whole', got {region!r}")
    domain = CORE_DOMAIN if region == "core" else TRANSFER_DOMAIN
    (e0, e1), (n0, n1), (r0, r1), (f0, f1) = domain.values()
    if poisson is not None:
        if not n0 <= poisson[0] < poisson[1] <= n1:
            raise ValueError(f"poisson must be a range inside {n0}-{n1}, got {poisson!r}")
        n0, n1 = poisson
    limit = ELASTIC_LIMIT_MPA * ELASTIC_MARGIN

    def elastic(r, f):
        return hertz_max_pressure_mpa(r, 1e3 * np.asarray(f)) <= limit * (1 + 1e-9)

    u = qmc.LatinHypercube(d=4, seed=random_state).random(n if region == "core" else 6 * n)
    e = np.exp(np.log(e0) + u[:, 0] * np.log(e1 / e0))
    nu = n0 + (n1 - n0) * u[:, 1]
    if region == "core":
        r, f = r0 + (r1 - r0) * u[:, 2], f0 + (f1 - f0) * u[:, 3]
    else:
        r, f = np.exp(np.log(r0) + u[:, 2] * np.log(r1 / r0)), np.exp(np.log(f0) + u[:, 3] * np.log(f1 / f0))
        keep = np.flatnonzero(elastic(r, f))[:n]
        if len(keep) < n:
            raise ValueError(f"only {len(keep)} of the hypercube's points lie within the elastic limit")
        e, nu, r, f = e[keep], nu[keep], r[keep], f[keep]
    points = np.column_stack([e, nu, np.round(r, 1), f])
    if corners:
        if region == "core":
            rf = [(r_, f_) for r_ in (r0, r1) for f_ in (f0, f1)]
        else:  # the (R, F) box cut by the elastic limit p ~ (F / R^2)^(1/3)
            p_ref = float(hertz_max_pressure_mpa(r0, 1e3 * f0))
            f_at_r0 = f0 * (limit / p_ref) ** 3  # the largest force on the smallest sphere
            r_at_f1 = r0 * (float(hertz_max_pressure_mpa(r0, 1e3 * f1)) / limit) ** 1.5  # the smallest sphere at F max
            rf = [(r0, f0), (r1, f0), (r1, f1), (min(max(r_at_f1, r0), r1), f1), (r0, min(max(f_at_r0, f0), f1))]
            rf = [(rr, ff) for rr, ff in rf if elastic(np.ceil(rr * 10) / 10, ff)]
        corner_rows = [(e_, nu_, np.ceil(rr * 10) / 10, ff) for e_, nu_ in itertools.product((e0, e1), (n0, n1))
                       for rr, ff in rf]
        points = np.vstack([points, np.array(corner_rows)])
    return points


#: Film thicknesses (mm) the transfer is measured over (`thickness_design`; in log): from the thinnest Prescale
#: sheets to two stacked. The built-in films (0.09 mm) lie inside.
THICKNESS_DOMAIN_MM = (0.04, 0.25)


#: The held-out rows with the thickness drawn are checked in these ranges of it (mm; thirds of ln t over
#: `THICKNESS_DOMAIN_MM`), each a part of its own (`thickness_parts`): the term's std, the largest part's rms, then
#: holds at the range's ends as in its middle (pooled, it was 0.0012-0.0014 mm while the level readings on films of
#: 0.04-0.06 mm were missed by 0.0017-0.0022 mm rms and the edge on films of 0.16-0.25 mm by 0.0017-0.0018 mm).
THICKNESS_PARTS_MM = (0.04, 0.074, 0.136, 0.25)
#: The fit's residual is also measured in this many equal ranges of ln t over the fitted thicknesses
#: (`TransferFit.thickness_rms_mm`), and a film's band is raised to its range's where that is larger than the
#: one std (`TransferFit.std_for`). Over ninths the error grows toward both ends of 0.04-0.25 mm, inside the
#: outer thirds too: the activation readings on films of 0.040-0.049 mm were missed by 0.0025-0.0028 mm held out
#: and the edge on films of 0.17-0.25 mm by 0.0021-0.0028 mm, against a std of 0.0016-0.0019 mm. A range holds
#: about 10 independent held-out points (the three films share each), too few to lower a band on, enough to
#: raise one, to the upper bound of its rms (`RMS_BOUND_CONFIDENCE`). The raised bands are set on the rows they
#: hold: their one check on points of their own is
#: `bench/verification.py --thickness` (films of 0.045, 0.05, 0.15 and 0.23 mm).
THICKNESS_RANGES = 9
#: A range's rms is raised to its upper confidence bound at this level (`rms_upper_bound`).
RMS_BOUND_CONFIDENCE = 0.9


def thickness_parts(rows: list[dict]) -> dict[str, list[dict]]:
    """`rows` split by the film's thickness into the ranges of `THICKNESS_PARTS_MM`, named
    ``"thickness <lo>-<hi> mm"`` (the last range closed)."""
    edges = THICKNESS_PARTS_MM
    parts: dict[str, list[dict]] = {f"thickness {lo:g}-{hi:g} mm": [] for lo, hi in zip(edges[:-1], edges[1:])}
    names = list(parts)
    for r in rows:
        k = int(np.searchsorted(edges[1:-1], float(r["thickness_mm"]), side="right"))
        parts[names[k]].append(r)
    return parts


def thickness_design(n: int, random_state: int, region: str = "core") -> np.ndarray:
    """`transfer_design`'s ``n`` points (E, nu, R, F in kN) with a fifth column, the film's thickness (mm).

    The thicknesses are drawn one in each of ``n`` equal strata of ln t over `THICKNESS_DOMAIN_MM`, in random
    order (seeded by ``random_state + 1000``): the (E, nu, R, F) hypercube stays as it is and the thickness is
    stratified beside it.
    """
    points = transfer_design(n, random_state, region=region)
    rng = np.random.default_rng(random_state + 1000)
    u = (rng.permutation(len(points)) + rng.random(len(points))) / len(points)
    t0, t1 = THICKNESS_DOMAIN_MM
    return np.column_stack([points, np.exp(np.log(t0) + u * np.log(t1 / t0))])


def measure_transfer(points: np.ndarray, films, kinematics=("small", "large"), grid_mm: float | None = None,
                     progress=None, fe_rows: list[dict] | None = None) -> list[dict]:
    """Both models at every point, film type and kinematics; one row per (point, film, kinematics, imprint).

    Parameters
    ----------
    points : ndarray, shape (n, 4) or (n, 5)
        (E MPa, nu, R mm, F kN), e.g. from `transfer_design`, or with the film's thickness (mm) as a fifth
        column (`thickness_design`).
    films : sequence of FilmType
        Their activation pressure is used, and their thickness unless the points give one; nu is the point's.
    kinematics : sequence of str
    grid_mm : float, optional
        The application's cell size (default: the wheel-rail grid).
    progress : callable, optional
        Called with the number of points done.
    fe_rows : list of dict, optional
        Rows measured before (this function's output): where they hold every
        reading of a point's film type and kinematics, the calibrated FE's
        readings are taken from them and only the application is solved again
        (after a change of the application's grid, law or reading; never
        after a change of the FE).

    Returns
    -------
    list of dict
        ``film, kinematics, imprint, modulus_mpa, poisson, sphere_radius_mm, force_kn, thickness_mm,
        level_mpa, fe_radius_mm, applied_radius_mm, applied_max_pressure_mpa, converged``.
    """
    from filmcal.contact.film import FilmModel
    from filmcal.contact.imprint import imprint_models_for
    from filmcal.contact.options import ContactOptions
    from filmcal.fem import Film, get_model
    from filmcal.wheelrail.halfspace import HalfSpaceContactSolver, sphere_on_flat_contact
    from filmcal.wheelrail.settings import GRID_MM

    spacing = GRID_MM if grid_mm is None else float(grid_mm)
    solver = HalfSpaceContactSolver()
    known = {_reading_key(r): (float(r["fe_radius_mm"]), bool(r["converged"])) for r in (fe_rows or ())}
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] not in (4, 5):
        raise ValueError(f"points must have 4 or 5 columns (E, nu, R, F[, t]), got shape {points.shape}")
    rows = []
    for i, (e, nu, radius, force_kn, *thickness) in enumerate(points):
        for kin in kinematics:
            fe_by_thickness: dict = {}  # films of one thickness share the FE solve
            for film in films:
                film = replace(film, thickness_mm=float(thickness[0])) if thickness else film
                ft = replace(film, poisson=float(nu))
                models = [FilmModel(ft, imprint, kin) for imprint in imprint_models_for(ft)]
                keys = [_reading_key({"modulus_mpa": e, "poisson": nu, "sphere_radius_mm": radius,
                                      "force_kn": force_kn, "thickness_mm": film.thickness_mm, "film": film.name,
                                      "kinematics": kin, "imprint": model.imprint}) for model in models]
                if all(k in known for k in keys):
                    fe_readings = [known[k] for k in keys]
                else:
                    if film.thickness_mm not in fe_by_thickness:
                        fe_by_thickness[film.thickness_mm] = get_model(
                            float(radius), film_thickness_mm=film.thickness_mm
                        ).solve(Film(float(e), float(nu)), force_kn * 1e3, ContactOptions(kinematics=kin))
                    fe = fe_by_thickness[film.thickness_mm]
                    fe_readings = [(fe.contact_radius_mm if model.imprint == "edge"
                                    else fe.read_imprint(model.imprint, ft), bool(fe.converged)) for model in models]
                solver_film, solver_law, _ = models[0].interface(float(e))
                applied = sphere_on_flat_contact(float(radius), force_kn * 1e3, film=solver_film, law=solver_law,
                                                 spacing_mm=spacing, solver=solver)
                for model, (fe_radius, converged) in zip(models, fe_readings):
                    rows.append({"film": film.name, "kinematics": kin, "imprint": model.imprint,
                                 "modulus_mpa": float(e), "poisson": float(nu), "sphere_radius_mm": float(radius),
                                 "force_kn": float(force_kn), "thickness_mm": film.thickness_mm,
                                 "level_mpa": film.activation_pressure_mpa,
                                 "fe_radius_mm": float(fe_radius),
                                 "applied_radius_mm": math.sqrt(model.recorded_area_mm2(applied) / math.pi),
                                 "applied_max_pressure_mpa": float(applied.max_pressure_mpa),
                                 "converged": converged})
        if progress is not None:
            progress(i + 1)
    return rows


def _reading_key(row: dict) -> tuple:
    """A row's point, film type, kinematics and imprint model (the point rounded to 9 digits)."""
    return (*(round(float(row[k]), 9) for k in ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn",
                                                "thickness_mm")),
            row["film"], row["kinematics"], row["imprint"])


def _features(rows: list[dict], imprint: str, grid_mm: float) -> np.ndarray:
    col = {k: np.array([r[k] for r in rows], dtype=float) for k in
           ("modulus_mpa", "poisson", "thickness_mm", "applied_radius_mm", "applied_max_pressure_mpa")}
    level = None if imprint == "edge" else np.array([r["level_mpa"] for r in rows], dtype=float)
    return transfer_features(imprint, col["modulus_mpa"], col["poisson"], col["thickness_mm"],
                             col["applied_radius_mm"], col["applied_max_pressure_mpa"], level, grid_mm=grid_mm)


def _target(rows: list[dict]) -> np.ndarray:
    return np.array([(r["fe_radius_mm"] - r["applied_radius_mm"]) / r["thickness_mm"] for r in rows])


def _recorded(row: dict) -> tuple[bool, bool]:
    """Whether the calibrated FE and the application record an imprint at all (a reading of a pressure level
    records nothing where the peak stays below it)."""
    return row["fe_radius_mm"] > 0, row["applied_radius_mm"] > 0


def _groups(rows: list[dict]) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for r in rows:  # a reading that records nothing (the peak below the film's level) has no edge to transfer
        if r["converged"] and _recorded(r) == (True, True):
            out.setdefault(f"{r['imprint']}/{r['kinematics']}", []).append(r)
    return out


def _residuals_mm(fit: TransferFit, key: str, group: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """The rows' d (mm) and what remains of it after the fit's term."""
    imprint, kinematics = key.split("/")
    t = np.array([r["thickness_mm"] for r in group])
    raw = _target(group) * t
    return raw, raw - fit.shift_ratio(imprint, kinematics, _features(group, imprint, fit.grid_mm)) * t


def check_transfer(fit: TransferFit, rows: list[dict]) -> dict[str, dict]:
    """Residuals (mm) of rows against a fit, per ``imprint/kinematics``, without and with the term.

    Returns ``{key: {"n", "raw_mean_mm", "raw_max_mm", "mean_mm", "rms_mm", "max_mm", "one_sided",
    "not_converged"}}`` (max: of |.|; ``one_sided``: rows where one model records an imprint and the other
    none, at a peak pressure within a hair of the film's level; they have no edge offset and are counted, not
    fitted; ``not_converged``: rows whose calibrated FE did not converge, left out and counted).
    """
    one_sided: dict[str, int] = {}
    not_converged: dict[str, int] = {}
    for r in rows:
        key = f"{r['imprint']}/{r['kinematics']}"
        if not r["converged"]:
            not_converged[key] = not_converged.get(key, 0) + 1
        elif sum(_recorded(r)) == 1:
            one_sided[key] = one_sided.get(key, 0) + 1
    out = {}
    for key, group in _groups(rows).items():
        raw, res = _residuals_mm(fit, key, group)
        out[key] = {"n": len(group), "raw_mean_mm": float(raw.mean()), "raw_max_mm": float(np.abs(raw).max()),
                    "mean_mm": float(res.mean()), "rms_mm": float(np.sqrt(np.mean(res**2))),
                    "max_mm": float(np.abs(res).max()), "one_sided": one_sided.get(key, 0),
                    "not_converged": not_converged.get(key, 0)}
    return out


#: Features the residual process sees (nu, x, y, z, w), for the imprint models that read a pressure level.
GP_INPUTS = tuple(FEATURES.index(n) for n in ("nu", "x", "y", "z", "w"))


#: The residual process's kernel is fitted on at most this many rows (a random subset); the process then
#: conditions on every row with that kernel. Maximum likelihood costs O(n^3) per step: on the 2400 rows of a
#: whole-domain design it took tens of minutes, and 1000 rows fix five length scales as well.
GP_KERNEL_ROWS = 1000


def _residual_gp(X: np.ndarray, residual: np.ndarray) -> ResidualGP:
    """A Gaussian process on the polynomial's residual (d / t), kernel and noise by maximum likelihood
    (on `GP_KERNEL_ROWS` rows at most), conditioned on every row."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    inputs = tuple(i for i in GP_INPUTS if np.ptp(X[:, i]) > 0)  # an input that does not vary carries nothing
    Z = X[:, list(inputs)]
    center, scale = Z.mean(axis=0), Z.std(axis=0)
    kernel = ConstantKernel(1.0, (1e-3, 1e3)) * RBF(np.ones(len(inputs)), (1e-2, 1e2)) \
        + WhiteKernel(1e-2, (1e-6, 1.0))
    y_mean, y_std = float(np.mean(residual)), float(np.std(residual)) or 1.0
    gp = GaussianProcessRegressor(kernel, n_restarts_optimizer=3, random_state=0)
    Zs, ys = (Z - center) / scale, (residual - y_mean) / y_std
    with warnings.catch_warnings():
        # a length scale at its upper bound means the residual does not vary along that input
        warnings.simplefilter("ignore", ConvergenceWarning)
        if len(ys) > GP_KERNEL_ROWS:
            subset = np.random.default_rng(0).choice(len(ys), GP_KERNEL_ROWS, replace=False)
            kernel = gp.fit(Zs[subset], ys[subset]).kernel_
            gp = GaussianProcessRegressor(kernel, optimizer=None)
        gp.fit(Zs, ys)
    k = gp.kernel_.k1  # ConstantKernel * RBF; the white noise has no cross-covariance
    return ResidualGP(inputs, center, scale, np.atleast_1d(k.k2.length_scale).astype(float),
                      float(k.k1.constant_value), np.asarray(gp.X_train_, dtype=float),
                      np.asarray(gp.alpha_, dtype=float).ravel() * y_std, y_mean)


#: The imprint models whose transfer carries a Gaussian process on the polynomial's residual.
RESIDUAL_GP_MODELS = ("activation", "capsule")


def fit_transfer(train: list[dict], held_out: dict[str, list[dict]], grid_mm: float,
                 provenance: dict | None = None, thickness_mm: tuple[float, float] | None = None) -> TransferFit:
    """Least-squares fit of d / t per (imprint, kinematics) on `train`; its std from the `held_out` parts.

    The activation and capsule models get a Gaussian process on the polynomial's residual
    (`filmcal.contact.transfer.ResidualGP`). The term's standard deviation is the largest of the training
    root-mean-square residual and that of each held-out part (e.g. ``{"core": ..., "whole": ...}``: Table 1's
    region and the whole domain), so that it holds in each; where the training or the held-out rows of a range
    of thickness (`THICKNESS_RANGES`) are missed by more, films of that range carry theirs
    (`TransferFit.thickness_rms_mm`). The provenance records every part's check
    (``held_out_<part>``) and that of all held-out rows together (``held_out``). ``thickness_mm`` is the range
    of film thicknesses the design sampled (the fit's ``domain["thickness_mm"]``; default: the training rows'
    smallest and largest).
    """
    coefficients, gps = {}, {}
    for key, group in _groups(train).items():
        imprint = key.split("/")[0]
        X = _features(group, imprint, grid_mm)
        used = np.flatnonzero(np.ptp(X, axis=0) > 0)  # the edge model has no level feature
        used = np.union1d(used, [0])
        beta = np.zeros(len(FEATURES))
        beta[used] = np.linalg.lstsq(X[:, used], _target(group), rcond=None)[0]
        coefficients[key] = [float(b) for b in beta]
        if imprint in RESIDUAL_GP_MODELS:
            gps[key] = _residual_gp(X, _target(group) - X @ beta)
    t = [float(r["thickness_mm"]) for r in train]
    domain = {**TRANSFER_DOMAIN, "thickness_mm": tuple(thickness_mm) if thickness_mm is not None else (min(t), max(t))}
    fit = TransferFit(coefficients, {k: 0.0 for k in coefficients}, domain, float(grid_mm), {}, gps)
    checks = {"train": check_transfer(fit, train),
              "held_out": check_transfer(fit, [r for part in held_out.values() for r in part])}
    checks.update({f"held_out_{name}": check_transfer(fit, part) for name, part in held_out.items()})
    std = {k: max(c[k]["rms_mm"] for c in checks.values() if k in c) for k in coefficients}
    prov = dict(provenance or {})
    prov.update(checks)
    fit = TransferFit(coefficients, std, domain, float(grid_mm), prov, gps)
    return replace(fit, thickness_rms_mm=_thickness_rms(fit, [train, *held_out.values()]))


def _thickness_rms(fit: TransferFit, row_sets: list[list[dict]]) -> dict:
    """`TransferFit.thickness_rms_mm`: over `THICKNESS_RANGES` equal ranges of ln t across the fit's
    thicknesses, per key, the largest of each row set's root-mean-square residual in each, raised to its upper
    bound at `RMS_BOUND_CONFIDENCE` from its number of points (0 where none), over the films off the built-in
    films' thickness (`filmcal.contact.transfer.on_film_line`: the many rows on it would dilute those of films
    drawn beside them, and the one std is measured on them). Empty when the fit was made on one thickness."""
    from filmcal.contact.transfer import on_film_line, thickness_range

    t0, t1 = fit.domain["thickness_mm"]
    if not t1 > t0:
        return {}
    edges = np.exp(np.linspace(np.log(t0), np.log(t1), THICKNESS_RANGES + 1))
    edges[[0, -1]] = t0, t1
    out: dict = {"edges_mm": [float(e) for e in edges]}
    for key in fit.coefficients:
        rms = np.zeros(THICKNESS_RANGES)
        for rows in row_sets:
            group = [r for r in _groups(rows).get(key, []) if not on_film_line(r["thickness_mm"])]
            if not group:
                continue
            _, res = _residuals_mm(fit, key, group)
            k = thickness_range(edges, np.array([r["thickness_mm"] for r in group]))
            for i in range(THICKNESS_RANGES):
                if np.any(k == i):
                    n_points = len({_point(group[j]) for j in np.flatnonzero(k == i)})
                    bound = rms_upper_bound(float(np.sqrt(np.mean(res[k == i] ** 2))), n_points)
                    rms[i] = max(rms[i], bound)
        out[key] = [float(x) for x in rms]
    return out


def _point(row: dict) -> tuple:
    """The point of the domain a row was measured at (the films MS, HS and HHS share each)."""
    return tuple(float(row[k]) for k in ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn", "thickness_mm"))


def rms_upper_bound(rms_mm: float, n_points: int, confidence: float | None = None) -> float:
    """The one-sided upper confidence bound of a root-mean-square residual measured on `n_points` independent
    points: ``rms sqrt(n / chi2_{1 - confidence}(n))`` (the residuals taken as normal with mean zero).

    A range of ln t holds about ten held-out points; their rms is then uncertain by about a quarter, and
    read as it is, it left the level readings' bands on films held out at other thicknesses too narrow by up
    to half (`bench/verification.py --thickness`). At 90 % ten points raise it by 1.43, fifty by 1.17.
    """
    from scipy.stats import chi2

    confidence = RMS_BOUND_CONFIDENCE if confidence is None else confidence
    if not (0.0 < confidence < 1.0):
        raise ValueError(f"confidence must lie in (0, 1), got {confidence!r}")
    if n_points < 1:
        raise ValueError(f"n_points must be >= 1, got {n_points!r}")
    return float(rms_mm * math.sqrt(n_points / chi2.ppf(1.0 - confidence, n_points)))


def outside_fit(fit: TransferFit, film, imprint: str, radius_mm: float, max_pressure_mpa: float,
                modulus_mpa=None) -> list[str]:
    """What of a film and its contact lies beyond what the fit was made on (empty when nothing).

    The fit's design is a box over (E, nu, R, F, film thickness) for the fitted films' activation pressures
    (`transfer_design`, `thickness_design`). Checked, each as a
    box: the contact's equivalent radius against the Hertz radii of the design's spheres and forces
    (`hertz_radius_range_mm`); the film's thickness, its Poisson's ratio and, when given, the central 90 % of its
    modulus against the fit's `domain` (beyond its thicknesses the band carries `THICKNESS_STD_MM` more);
    for a level reading, its activation pressure against the contact's peak, against the fitted films' over the
    design's Hertz peaks (218-1312 MPa: capped at the steel's elastic limit, as the design was). Each reason is
    a phrase naming the value and the fitted range.

    Parameters
    ----------
    fit : TransferFit
    film : FilmType
    imprint : str
    radius_mm, max_pressure_mpa : float
        The contact without film: its equivalent radius and peak pressure.
    modulus_mpa : array_like, optional
        The film's modulus samples (MPa) at its own Poisson's ratio (`nominal_modulus_mpa`).
    """
    from filmcal.films import BUILTIN_FILMS
    from filmcal.hertz import hertz_max_pressure_mpa
    from filmcal.surrogate.radius import ELASTIC_LIMIT_MPA

    fitted = [BUILTIN_FILMS[n] for n in fit.provenance.get("films", ()) if n in BUILTIN_FILMS] \
        or list(BUILTIN_FILMS.values())  # their activation pressures
    (r0, r1), (f0, f1) = fit.domain["sphere_radius_mm"], fit.domain["force_kn"]
    lo, hi = fit.hertz_radius_range_mm()
    reasons = []
    if not lo * (1 - 1e-9) <= radius_mm <= hi * (1 + 1e-9):
        reasons.append(f"the contact without film is {'smaller' if radius_mm < lo else 'larger'} than any the fit was "
                       f"made on: its equivalent radius is {radius_mm:.2f} mm, theirs {lo:.2f}-{hi:.2f} mm (spheres "
                       f"of {r0:g}-{r1:g} mm at {f0:g}-{f1:g} kN)")
    if not fit.fits_thickness(film.thickness_mm):
        t0, t1 = fit.domain["thickness_mm"]
        reasons.append(f"the film is {film.thickness_mm:g} mm thick and the fit was made on films of {t0:g}-{t1:g} mm"
                       f": the {imprint} reading's band carries {THICKNESS_STD_MM[imprint]:.4f} mm more for it, in "
                       "quadrature")
    nu0, nu1 = fit.domain["poisson"]
    if not nu0 <= film.poisson <= nu1:
        reasons.append(f"the film's Poisson's ratio {film.poisson:g} lies outside the fitted {nu0:g}-{nu1:g}")
    if modulus_mpa is not None:
        e0, e1 = fit.domain["modulus_mpa"]
        q0, q1 = np.quantile(np.asarray(modulus_mpa, dtype=float), [0.05, 0.95])
        if q0 < e0 * (1 - 1e-9) or q1 > e1 * (1 + 1e-9):
            reasons.append(f"the film's modulus at its Poisson's ratio of {film.poisson:g}, 90 % within "
                           f"{q0:.0f}-{q1:.0f} MPa, lies beyond the fitted {e0:g}-{e1:g} MPa")
    level = getattr(film, "activation_pressure_mpa", None)
    levels = [f.activation_pressure_mpa for f in fitted if f.activation_pressure_mpa is not None]
    if imprint != "edge" and level is not None and levels:
        p_lo = float(hertz_max_pressure_mpa(r1, 1e3 * f0))
        p_hi = min(float(hertz_max_pressure_mpa(r0, 1e3 * f1)), ELASTIC_LIMIT_MPA * ELASTIC_MARGIN)
        ratio, (ratio0, ratio1) = level / max_pressure_mpa, (min(levels) / p_hi, max(levels) / p_lo)
        if not ratio0 * (1 - 1e-9) <= ratio <= ratio1 * (1 + 1e-9):
            reasons.append(f"the film's activation pressure against the contact's peak, {level:g} of "
                           f"{max_pressure_mpa:.0f} MPa ({ratio:.3g}), lies outside the fitted "
                           f"{ratio0:.3g}-{ratio1:.3g} (activation pressures {min(levels):g}-{max(levels):g} MPa "
                           f"at peaks of {p_lo:.0f}-{p_hi:.0f} MPa)")
    return reasons
