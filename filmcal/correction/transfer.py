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

from filmcal.contact.transfer import FEATURES, ResidualGP, TransferFit, transfer_features

__all__ = ["TRANSFER_DOMAIN", "NEAR_INCOMPRESSIBLE", "transfer_design", "measure_transfer", "fit_transfer", "check_transfer"]

#: Where the transfer is measured: film modulus (MPa, sampled in log), nu, sphere radius (mm), force (kN).
TRANSFER_DOMAIN = {"modulus_mpa": (400.0, 20000.0), "poisson": (0.25, 0.45), "sphere_radius_mm": (250.0, 600.0),
                   "force_kn": (20.0, 110.0)}


#: Where the transfer varies fastest: films near incompressibility (the continuum film's edge zone scales with
#: 1 - 2 nu). A training design adds a hypercube over this nu range; held out, the level readings' residual
#: there was twice its rms elsewhere (0.0022 against 0.0011-0.0013 mm) with the whole-domain design alone.
NEAR_INCOMPRESSIBLE = (0.42, 0.45)


def transfer_design(n: int, random_state: int, corners: bool = False,
                    poisson: tuple[float, float] | None = None) -> np.ndarray:
    """``n`` points (E, nu, R, F in kN) of a Latin hypercube over `TRANSFER_DOMAIN`, R rounded to 0.1 mm.

    With ``corners`` the domain's 16 corners follow: a training design then anchors the residual
    process where a Latin hypercube leaves it to extrapolate (soft films near incompressibility, stiff
    films at the highest pressures). ``poisson`` narrows the hypercube's nu range (e.g.
    `NEAR_INCOMPRESSIBLE`).
    """
    import itertools

    from scipy.stats import qmc

    u = qmc.LatinHypercube(d=4, seed=random_state).random(n)
    if corners:
        u = np.vstack([u, np.array(list(itertools.product((0.0, 1.0), repeat=4)))])
    (e0, e1), (n0, n1), (r0, r1), (f0, f1) = TRANSFER_DOMAIN.values()
    if poisson is not None:
        if not n0 <= poisson[0] < poisson[1] <= n1:
            raise ValueError(f"poisson must be a range inside {n0}-{n1}, got {poisson!r}")
        n0, n1 = poisson
    e = np.exp(np.log(e0) + u[:, 0] * np.log(e1 / e0))
    return np.column_stack([e, n0 + (n1 - n0) * u[:, 1], np.round(r0 + (r1 - r0) * u[:, 2], 1),
                            f0 + (f1 - f0) * u[:, 3]])


def measure_transfer(points: np.ndarray, films, kinematics=("small", "large"), grid_mm: float | None = None,
                     progress=None) -> list[dict]:
    """Both models at every point, film type and kinematics; one row per (point, film, kinematics, imprint).

    Parameters
    ----------
    points : ndarray, shape (n, 4)
        (E MPa, nu, R mm, F kN), e.g. from `transfer_design`.
    films : sequence of FilmType
        Their thickness and activation pressure are used; nu is the point's.
    kinematics : sequence of str
    grid_mm : float, optional
        The application's cell size (default: the wheel-rail grid).
    progress : callable, optional
        Called with the number of points done.

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
    rows = []
    for i, (e, nu, radius, force_kn) in enumerate(np.asarray(points, dtype=float)):
        for kin in kinematics:
            fe_by_thickness: dict = {}  # films of one thickness share the FE solve
            for film in films:
                if film.thickness_mm not in fe_by_thickness:
                    fe_by_thickness[film.thickness_mm] = get_model(float(radius), film_thickness_mm=film.thickness_mm) \
                        .solve(Film(float(e), float(nu)), force_kn * 1e3, ContactOptions(kinematics=kin))
                fe = fe_by_thickness[film.thickness_mm]
                ft = replace(film, poisson=float(nu))
                models = [FilmModel(ft, imprint, kin) for imprint in imprint_models_for(ft)]
                solver_film, solver_law, _ = models[0].interface(float(e))
                applied = sphere_on_flat_contact(float(radius), force_kn * 1e3, film=solver_film, law=solver_law,
                                                 spacing_mm=spacing, solver=solver)
                for model in models:
                    fe_radius = fe.contact_radius_mm if model.imprint == "edge" else fe.read_imprint(model.imprint, ft)
                    rows.append({"film": film.name, "kinematics": kin, "imprint": model.imprint,
                                 "modulus_mpa": float(e), "poisson": float(nu), "sphere_radius_mm": float(radius),
                                 "force_kn": float(force_kn), "thickness_mm": film.thickness_mm,
                                 "level_mpa": film.activation_pressure_mpa,
                                 "fe_radius_mm": float(fe_radius),
                                 "applied_radius_mm": math.sqrt(model.recorded_area_mm2(applied) / math.pi),
                                 "applied_max_pressure_mpa": float(applied.max_pressure_mpa),
                                 "converged": bool(fe.converged)})
        if progress is not None:
            progress(i + 1)
    return rows


def _features(rows: list[dict], imprint: str) -> np.ndarray:
    col = {k: np.array([r[k] for r in rows], dtype=float) for k in
           ("modulus_mpa", "poisson", "thickness_mm", "applied_radius_mm", "applied_max_pressure_mpa")}
    level = None if imprint == "edge" else np.array([r["level_mpa"] for r in rows], dtype=float)
    return transfer_features(imprint, col["modulus_mpa"], col["poisson"], col["thickness_mm"],
                             col["applied_radius_mm"], col["applied_max_pressure_mpa"], level)


def _target(rows: list[dict]) -> np.ndarray:
    return np.array([(r["fe_radius_mm"] - r["applied_radius_mm"]) / r["thickness_mm"] for r in rows])


def _groups(rows: list[dict]) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for r in rows:
        if r["converged"]:
            out.setdefault(f"{r['imprint']}/{r['kinematics']}", []).append(r)
    return out


def check_transfer(fit: TransferFit, rows: list[dict]) -> dict[str, dict]:
    """Residuals (mm) of rows against a fit, per ``imprint/kinematics``, without and with the term.

    Returns ``{key: {"n", "raw_mean_mm", "raw_max_mm", "mean_mm", "rms_mm", "max_mm"}}`` (max: of |.|).
    """
    out = {}
    for key, group in _groups(rows).items():
        imprint = key.split("/")[0]
        t = np.array([r["thickness_mm"] for r in group])
        raw = _target(group) * t
        fitted = fit.shift_mm(imprint, key.split("/")[1], _features(group, imprint))[0] * t
        res = raw - fitted
        out[key] = {"n": len(group), "raw_mean_mm": float(raw.mean()), "raw_max_mm": float(np.abs(raw).max()),
                    "mean_mm": float(res.mean()), "rms_mm": float(np.sqrt(np.mean(res**2))),
                    "max_mm": float(np.abs(res).max())}
    return out


#: Features the residual process sees (nu, x, y), for the imprint models that read a pressure level.
GP_INPUTS = (FEATURES.index("nu"), FEATURES.index("x"), FEATURES.index("y"))


def _residual_gp(X: np.ndarray, residual: np.ndarray) -> ResidualGP:
    """A Gaussian process on the polynomial's residual (d / t), kernel and noise by maximum likelihood."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    Z = X[:, list(GP_INPUTS)]
    center, scale = Z.mean(axis=0), Z.std(axis=0)
    kernel = ConstantKernel(1.0, (1e-3, 1e3)) * RBF(np.ones(len(GP_INPUTS)), (1e-2, 1e2)) \
        + WhiteKernel(1e-2, (1e-6, 1.0))
    y_mean, y_std = float(np.mean(residual)), float(np.std(residual)) or 1.0
    gp = GaussianProcessRegressor(kernel, n_restarts_optimizer=3, random_state=0)
    with warnings.catch_warnings():
        # a length scale at its upper bound means the residual does not vary along that input
        warnings.simplefilter("ignore", ConvergenceWarning)
        gp.fit((Z - center) / scale, (residual - y_mean) / y_std)
    k = gp.kernel_.k1  # ConstantKernel * RBF; the white noise has no cross-covariance
    return ResidualGP(GP_INPUTS, center, scale, np.atleast_1d(k.k2.length_scale).astype(float),
                      float(k.k1.constant_value), np.asarray(gp.X_train_, dtype=float),
                      np.asarray(gp.alpha_, dtype=float).ravel() * y_std, y_mean)


def fit_transfer(train: list[dict], held_out: list[dict], grid_mm: float, provenance: dict | None = None) -> TransferFit:
    """Least-squares fit of d / t per (imprint, kinematics) on `train`; its std from `held_out`.

    The activation and capsule models get a Gaussian process on the polynomial's residual
    (`filmcal.contact.transfer.ResidualGP`). The term's standard deviation is the larger of the training
    and held-out root-mean-square residuals.
    """
    coefficients, std, gps = {}, {}, {}
    for key, group in _groups(train).items():
        imprint = key.split("/")[0]
        X = _features(group, imprint)
        used = np.flatnonzero(np.ptp(X, axis=0) > 0)  # the edge model has no level feature
        used = np.union1d(used, [0])
        beta = np.zeros(len(FEATURES))
        beta[used] = np.linalg.lstsq(X[:, used], _target(group), rcond=None)[0]
        coefficients[key] = [float(b) for b in beta]
        if imprint != "edge":
            gps[key] = _residual_gp(X, _target(group) - X @ beta)
    fit = TransferFit(coefficients, {k: 0.0 for k in coefficients}, dict(TRANSFER_DOMAIN), float(grid_mm), {}, gps)
    on_train, on_held_out = check_transfer(fit, train), check_transfer(fit, held_out)
    std = {k: max(on_train[k]["rms_mm"], on_held_out.get(k, on_train[k])["rms_mm"]) for k in coefficients}
    prov = dict(provenance or {})
    prov.update(train=on_train, held_out=on_held_out)
    return TransferFit(coefficients, std, dict(TRANSFER_DOMAIN), float(grid_mm), prov, gps)
