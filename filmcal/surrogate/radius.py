"""The radius surrogate: what a calibration sees of the FE model of the Hertzian tests.

The FE model gives, for a film (E, nu) between a sphere of radius R and a
flat under force F, a contact radius and imprint radii (one per imprint model
and film type, `filmcal.contact.imprint`). A Gaussian process emulates one of
them as its excess over the Hertz radius (in log or not, whichever the
evidence prefers), over (log E, nu, log R, log F):

* `SurrogateDomain` -- where it is trained and valid (the prior's support);
* `design_points` -- an optimal Latin hypercube over the domain as FE points;
* `case_design_points` -- FE points along ln E at the data's own (R, F, nu) cases;
* `fit_radius_surrogate`, `validate_radius_surrogate` -- fit and held-out check;
* `SurrogateRadiusModel`, `FERadiusModel` -- the surrogate or the FE model itself
  as the ``predict(E, nu, R, F) -> (mean, std)`` callable of the calibration;
* `CaseTable` -- the surrogate at the data's own (R, F) cases and one nu, splined
  in ln E: what an MCMC over E evaluates, checked against the surrogate itself.
"""
from __future__ import annotations

import math

from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from filmcal.hertz import ELASTIC_LIMIT_MPA, hertz_radius_mm

if TYPE_CHECKING:
    from filmcal.contact.options import ContactOptions
    from filmcal.surrogate.gp import GPSurrogate

__all__ = ["INPUTS", "LOG_INPUTS", "EDGE_COLUMN", "SurrogateDomain", "SurrogateValidation", "design_points",
           "case_design_points", "MODULI_PER_CASE", "MAX_MODULI_PER_CASE", "check_moduli_per_case",
           "option_columns", "radius_excess_mm", "TRANSFORM_RULES", "fit_radius_surrogate", "validate_radius_surrogate",
           "fit_and_validate",
           "SurrogateRadiusModel", "FERadiusModel", "CaseTable", "load_for_prediction"]

INPUTS = ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn")
LOG_INPUTS = ("modulus_mpa", "sphere_radius_mm", "force_kn")
#: The FE output read where the contact pressure falls to zero (the ``edge`` imprint model).
EDGE_COLUMN = "contact_radius_mm"
#: FE runs at each of a dataset's (R, F) cases, at moduli spread over the domain (`case_design_points`): 12
#: puts neighbours 1.43 apart in E over 400-20000 MPa and brings the surrogate's std at the cases down to the
#: FE's own jitter (0.0009 mm for HHS's activation reading), where the Latin hypercube alone leaves 2-4 times
#: that at Table 1's 25 kN cases (`bench/case_runs.py`).
MODULI_PER_CASE = 12
#: Most runs at one case a setting may ask for.
MAX_MODULI_PER_CASE = 100


def check_moduli_per_case(value) -> int:
    """`value` if it is a count of runs at each case (0 to `MAX_MODULI_PER_CASE`), else `InputError`."""
    from filmcal._errors import InputError

    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_MODULI_PER_CASE:
        raise InputError(f"moduli_per_case must be an integer 0-{MAX_MODULI_PER_CASE}, got {value!r}")
    return value


@dataclass(frozen=True)
class SurrogateDomain:
    """The domain over which a radius surrogate is trained and validated.

    The default covers Table 1's experiments (R 300-600 mm, F 25-100 kN) with
    margins, film moduli from 400 MPa (softer films collapse at 100 kN) to
    20000 MPa and Poisson's ratios 0.29-0.37 (thin PET films, the paper's
    range). Sphere radii are discrete levels: each needs its own FE model.
    """

    modulus_mpa: tuple[float, float] = (400.0, 20000.0)
    poisson: tuple[float, float] = (0.29, 0.37)
    radius_levels_mm: tuple[float, ...] = (300.0, 375.0, 450.0, 525.0, 600.0)
    force_kn: tuple[float, float] = (20.0, 110.0)

    def space(self):
        """The `filmcal.doe.DesignSpace` of the domain (log E, nu, discrete R levels, F)."""
        from filmcal.doe import DesignSpace, Parameter

        return DesignSpace((Parameter("modulus_mpa", *self.modulus_mpa, unit="MPa", scale="log"),
                            Parameter("poisson", *self.poisson),
                            Parameter("sphere_radius_mm", levels=tuple(self.radius_levels_mm), unit="mm"),
                            Parameter("force_kn", *self.force_kn, unit="kN")))

    def bounds(self) -> dict[str, tuple[float, float]]:
        """Lower and upper bound of each input."""
        return {"modulus_mpa": self.modulus_mpa, "poisson": self.poisson,
                "sphere_radius_mm": (min(self.radius_levels_mm), max(self.radius_levels_mm)),
                "force_kn": self.force_kn}

    def contains(self, modulus_mpa, poisson, sphere_radius_mm, force_kn) -> np.ndarray:
        """Elementwise: inside the domain (radius within the levels' span)."""
        b = self.bounds()
        inside = np.ones(np.broadcast(modulus_mpa, poisson, sphere_radius_mm, force_kn).shape, bool)
        for name, x in zip(INPUTS, (modulus_mpa, poisson, sphere_radius_mm, force_kn)):
            lo, hi = b[name]
            inside &= (np.asarray(x) >= lo * (1 - 1e-12)) & (np.asarray(x) <= hi * (1 + 1e-12))
        return inside

    def to_dict(self) -> dict:
        return {k: list(v) for k, v in asdict(self).items()}

    def covering(self, sphere_radius_mm, force_kn) -> "SurrogateDomain":
        """This domain, or one extended to cover the data's cases (radii and forces) with margins.

        Inside this domain it is returned unchanged (its runs are reused). Otherwise this domain's radius
        levels stay and new ones continue them to the data's extreme radii at about the same density (1.19
        between neighbours, as Table 1's 300-600 mm in five levels), so that a design augmented from this
        domain's keeps its runs (`design_points` with ``base``); the force range becomes the data's with 10 %
        margins where it reaches beyond; the modulus and Poisson ranges stay. Cases outside the supported
        domain (`check_supported`) are refused first.
        """
        radii = np.asarray(sphere_radius_mm, dtype=float).ravel()
        forces = np.asarray(force_kn, dtype=float).ravel()
        check_supported(radii, forces)
        lo_r, hi_r = min(self.radius_levels_mm), max(self.radius_levels_mm)
        lo_f, hi_f = self.force_kn
        if radii.min() >= lo_r and radii.max() <= hi_r and forces.min() >= lo_f and forces.max() <= hi_f:
            return self
        levels = list(self.radius_levels_mm)
        # this domain's levels stay (its runs are reused by an augmented design); new ones continue them at
        # the same geometric step or finer, out to the data's extreme radius
        step = (hi_r / lo_r) ** (1.0 / max(len(levels) - 1, 1)) if len(levels) > 1 else 1.19
        if radii.min() < lo_r:
            n = max(1, math.ceil(math.log(lo_r / radii.min()) / math.log(step) - 1e-9))
            levels = [float(round(v, 3)) for v in np.geomspace(radii.min(), lo_r, n + 1)[:-1]] + levels
        if radii.max() > hi_r:
            n = max(1, math.ceil(math.log(radii.max() / hi_r) / math.log(step) - 1e-9))
            levels = levels + [float(round(v, 3)) for v in np.geomspace(hi_r, radii.max(), n + 1)[1:]]
        force = (min(lo_f, float(forces.min()) / 1.1), max(hi_f, float(forces.max()) * 1.1))
        return SurrogateDomain(self.modulus_mpa, self.poisson, tuple(levels), force)

    def includes(self, other: "SurrogateDomain") -> bool:
        """True if `other` lies inside this domain with every radius level of its own (its design's points
        are points of this domain's design space)."""
        return (self.modulus_mpa == other.modulus_mpa and self.poisson == other.poisson
                and set(other.radius_levels_mm) <= set(self.radius_levels_mm)
                and self.force_kn[0] <= other.force_kn[0] and other.force_kn[1] <= self.force_kn[1])

    def share_of(self, other: "SurrogateDomain") -> float:
        """The share of this domain's design space that `other` (inside it) covers: its radius levels' share
        times its force range's (E and nu are common)."""
        levels = len(other.radius_levels_mm) / len(self.radius_levels_mm)
        forces = (other.force_kn[1] - other.force_kn[0]) / (self.force_kn[1] - self.force_kn[0])
        return levels * forces


#: The supported domain's physical limits: the steel stays elastic (the Hertz peak pressure without film below
#: `filmcal.hertz.ELASTIC_LIMIT_MPA`) and the contact stays small against the modelled bodies (the refined zone,
#: 1.6 times the contact radius, within 0.6 of the 50 mm body).
MAX_CONTACT_RADIUS_MM = 0.6 * 50.0 / 1.6
#: The supported spheres and forces: where the film's transfer from the calibrated FE to the wheel-rail model
#: is measured and checked (`filmcal.correction.transfer.TRANSFER_DOMAIN`, which adds margins to the forces), so that a lab's
#: calibration domain and the application's are one.
SUPPORTED_RADIUS_MM = (150.0, 1500.0)
SUPPORTED_FORCE_KN = (10.0, 150.0)


def check_supported(sphere_radius_mm, force_kn) -> None:
    """Refuse, in one line and before any FE work, cases outside the supported domain (`SUPPORTED_RADIUS_MM`,
    `SUPPORTED_FORCE_KN`, `ELASTIC_LIMIT_MPA`; they keep the contact radius within `MAX_CONTACT_RADIUS_MM`) or
    with non-physical sizes."""
    from filmcal.hertz import hertz_max_pressure_mpa

    radii = np.asarray(sphere_radius_mm, dtype=float).ravel()
    forces = np.asarray(force_kn, dtype=float).ravel()
    if radii.size == 0 or not (np.all(np.isfinite(radii)) and np.all(np.isfinite(forces))) \
            or np.any(radii <= 0) or np.any(forces <= 0):
        raise ValueError("sphere radii and forces must be finite and > 0")
    (r0, r1), (f0, f1) = SUPPORTED_RADIUS_MM, SUPPORTED_FORCE_KN
    outside = np.flatnonzero((radii < r0) | (radii > r1) | (forces < f0) | (forces > f1))
    if outside.size:
        i = int(outside[0])
        raise ValueError(f"the case R {radii[i]:g} mm / {forces[i]:g} kN lies outside the supported spheres of "
                         f"{r0:g}-{r1:g} mm and forces of {f0:g}-{f1:g} kN (where the film's transfer from the "
                         "calibrated FE to the wheel-rail model is measured): leave it out")
    peak = hertz_max_pressure_mpa(radii, 1e3 * forces)
    worst = int(np.argmax(peak))
    if peak[worst] > ELASTIC_LIMIT_MPA:
        raise ValueError(f"the case R {radii[worst]:g} mm / {forces[worst]:g} kN presses the steel to a Hertz peak "
                         f"pressure of {peak[worst]:.0f} MPa, above its elastic limit ({ELASTIC_LIMIT_MPA:g} MPa, "
                         "where the paper stopped): leave it out, or use a larger sphere or a smaller force")


def option_columns(options: "ContactOptions") -> dict:
    """The FE options as design columns of a campaign."""
    return options.as_columns()


def design_points(domain: SurrogateDomain, samples: int, seed: int, options: "ContactOptions",
                  base: SurrogateDomain | None = None) -> list[dict]:
    """An optimal Latin hypercube over the domain as FE campaign points (inputs + FE options).

    With `base` (a domain that `domain` extends, `SurrogateDomain.includes`), the design is the base
    domain's design of `samples` points, unchanged (its runs are reused), followed by
    `augmented_samples` points in the extension: each new radius level gets as many as a base level
    holds, the rest go to forces beyond the base range; each point is chosen in turn as the farthest, in
    the extended space's unit cube, from every point so far (greedy maximin over 200 random candidates
    per point), so the extension is sampled about as densely as the base domain.
    """
    from filmcal.doe import latin_design

    cols = option_columns(options)
    points = latin_design((base or domain).space(), samples, seed=seed).points
    if base is not None:
        if not domain.includes(base):
            raise ValueError("design_points: the base domain must lie inside the domain, with its radius levels")
        points = np.vstack([points, _fill_extension(domain, base, points, augmented_samples(domain, base, samples),
                                                    seed)])
    return [dict(zip(INPUTS, map(float, row)), **cols) for row in points]


def case_design_points(domain: SurrogateDomain, cases, moduli_per_case: int, options: "ContactOptions"
                       ) -> list[dict]:
    """FE campaign points at a dataset's own cases: at each ``(sphere_radius_mm, force_kn, poisson)``,
    `moduli_per_case` moduli spaced geometrically over the domain's modulus range (its ends included).

    A calibration asks the surrogate only at its data's cases, along ln E (`CaseTable`); a Latin hypercube
    leaves cases near the domain's corners (the smallest sphere at the lowest force) between its points,
    where the surrogate's std reaches the data's scatter and down-weights those cases. Runs on the cases'
    lines make the surrogate exact there to the FE's jitter, at every modulus the prior allows.
    """
    cols = option_columns(options)
    moduli = np.geomspace(*domain.modulus_mpa, int(moduli_per_case)) if moduli_per_case > 0 else np.array([])
    return [dict(zip(INPUTS, (float(e), float(nu), float(r), float(f))), **cols)
            for r, f, nu in cases for e in moduli]


def _fill_extension(domain: SurrogateDomain, base: SurrogateDomain, existing: np.ndarray, k: int,
                    seed: int) -> np.ndarray:
    """`k` points of `domain` outside `base` (physical): each new radius level gets as many as a base level
    holds, the rest go to the base levels' forces beyond the base range; within each group every point is
    the farthest, in the unit cube, from all points so far (greedy maximin over random candidates)."""
    space = domain.space()
    rng = np.random.default_rng([seed, 0x5eed])
    new_levels = [r for r in domain.radius_levels_mm if r not in base.radius_levels_mm]
    per_level = len(existing) / len(base.radius_levels_mm)
    counts = {r: int(round(per_level)) for r in new_levels}
    centre = math.exp(np.mean(np.log(base.radius_levels_mm)))
    while sum(counts.values()) > k:  # fewer points than the levels want: those nearest the base give up first
        counts[min(counts, key=lambda r: (counts[r] == 0, abs(math.log(r / centre))))] -= 1
    groups = [(r, n) for r, n in counts.items() if n > 0] + [(None, k - sum(counts.values()))]
    chosen_all = [np.asarray(existing, dtype=float)]
    for level, n in groups:
        if n <= 0:
            continue
        candidates = space.to_physical(rng.random((200 * n, space.d)))
        if level is not None:
            candidates[:, 2] = level
        else:
            candidates = candidates[np.isin(candidates[:, 2], base.radius_levels_mm)
                                    & ((candidates[:, 3] < base.force_kn[0]) | (candidates[:, 3] > base.force_kn[1]))]
            if len(candidates) < n:  # no force extension: the rest go to the new levels too
                candidates = space.to_physical(rng.random((200 * n, space.d)))
                candidates = candidates[~np.isin(candidates[:, 2], base.radius_levels_mm)]
        unit = space.to_unit(candidates)
        nearest = np.min(np.linalg.norm(unit[:, None, :] - space.to_unit(np.vstack(chosen_all))[None, :, :], axis=2),
                         axis=1)
        picked = []
        for _ in range(n):
            i = int(np.argmax(nearest))
            picked.append(i)
            nearest = np.minimum(nearest, np.linalg.norm(unit - unit[i], axis=1))
            nearest[picked] = -1.0
        chosen_all.append(candidates[picked])
    return np.vstack(chosen_all[1:])


def augmented_samples(domain: SurrogateDomain, base: SurrogateDomain, samples: int) -> int:
    """Points added to a base design of `samples` points so that the extended domain is as densely sampled:
    ``samples * (1 / share - 1)`` (`SurrogateDomain.share_of`), at least one."""
    return max(1, int(round(samples * (1.0 / domain.share_of(base) - 1.0))))


def radius_excess_mm(X: dict, radius_mm: np.ndarray) -> np.ndarray:
    """Radius minus the Hertz radius of the same (R, F): the film's enlargement."""
    return np.asarray(radius_mm, float) - hertz_radius_mm(X["sphere_radius_mm"], np.asarray(X["force_kn"]) * 1e3)


#: How a radius surrogate's output transform is chosen: by the evidence of the excesses ("evidence"), or log
#: while every excess is positive ("sign": the rule of the surrogates a study recorded without a rule, made
#: before the evidence chose; kept to refit such a surrogate as it was made).
TRANSFORM_RULES = ("evidence", "sign")


def fit_radius_surrogate(X: dict, radius_mm: np.ndarray, domain: SurrogateDomain, random_state: int = 0,
                         n_restarts: int = 8, transform_rule: str = "evidence") -> "GPSurrogate":
    """GP of the radius excess over Hertz over (log E, nu, log R, log F), in log or not by the evidence.

    With ``transform_rule="evidence"`` the output transform is ``"auto"``
    (`GPSurrogate`): the log and the standardised excess are both fitted and
    the one whose evidence of the excesses is larger is kept. An edge
    reading's excess spans a decade and keeps its log; a level reading of a
    stiff film (HHS's activation contour) comes close to zero or inside the
    Hertz radius, where a log stretches the small excesses and the standardised
    excess predicts 2-3 times better (bench/output_transform.py). Non-positive
    excesses are fitted standardised. ``"sign"`` takes the log whenever every
    excess is positive (`TRANSFORM_RULES`).
    """
    from filmcal.surrogate.gp import GPSurrogate

    if transform_rule not in TRANSFORM_RULES:
        raise ValueError(f"transform_rule must be one of {', '.join(TRANSFORM_RULES)}; got {transform_rule!r}")
    y = radius_excess_mm(X, radius_mm)
    transform = "auto" if transform_rule == "evidence" else "log" if np.all(y > 0) else "standardize"
    return GPSurrogate(list(INPUTS), output="radius_excess_mm", log_inputs=list(LOG_INPUTS),
                       output_transform=transform, input_bounds=domain.bounds(), n_restarts=n_restarts,
                       random_state=random_state).fit(X, y)


@dataclass
class SurrogateValidation:
    """Held-out accuracy of a radius surrogate, in radius and in area.

    ``details["points"]`` holds the held-out inputs with the FE radius and the
    surrogate's mean and predictive std (incl. FE noise) at each.
    """

    n: int
    radius_rms_error_mm: float
    radius_max_error_mm: float
    area_rms_relative_error: float
    area_max_relative_error: float
    coverage90: float
    q2: float
    details: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "details"}


def validate_radius_surrogate(surrogate: "GPSurrogate", X: dict, radius_mm: np.ndarray) -> SurrogateValidation:
    """Accuracy on held-out FE runs; intervals include the fitted FE noise (a new FE run's jitter)."""
    from filmcal.surrogate.validation import validate

    v = validate(surrogate, X, radius_excess_mm(X, radius_mm), noise=True)
    excess, std = surrogate.predict(X, return_std=True, noise=True)
    mean = excess + hertz_radius_mm(X["sphere_radius_mm"], np.asarray(X["force_kn"]) * 1e3)
    area_rel = (mean / radius_mm) ** 2 - 1.0
    err = mean - radius_mm
    points = {**{k: np.asarray(X[k], dtype=float) for k in INPUTS}, "radius_fe_mm": np.asarray(radius_mm, float),
              "radius_mean_mm": mean, "radius_std_mm": std}
    return SurrogateValidation(int(len(radius_mm)), float(np.sqrt(np.mean(err**2))), float(np.max(np.abs(err))),
                               float(np.sqrt(np.mean(area_rel**2))), float(np.max(np.abs(area_rel))),
                               float(v.coverage90), float(v.q2), {"excess": v.__dict__, "points": points})


def _broadcast(modulus_mpa, poisson, sphere_radius_mm, force_n):
    return np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (modulus_mpa, poisson, sphere_radius_mm, force_n)))


def fit_and_validate(train: tuple[dict, np.ndarray], test: tuple[dict, np.ndarray], domain: SurrogateDomain,
                     random_state: int = 0, transform_rule: str = "evidence"
                     ) -> tuple["SurrogateRadiusModel", SurrogateValidation]:
    """Fit a radius surrogate on ``train = (X, radius_mm)`` (`fit_radius_surrogate`) and check it on the
    held-out ``test``.

    Returns
    -------
    (SurrogateRadiusModel, SurrogateValidation)
    """
    surrogate = fit_radius_surrogate(*train, domain, random_state=random_state, transform_rule=transform_rule)
    return SurrogateRadiusModel(surrogate, domain), validate_radius_surrogate(surrogate, *test)


class SurrogateRadiusModel:
    """A radius surrogate seen by the calibration: ``predict(E, nu, R, F) -> (mean, std)``.

    The std includes the FE model's numerical jitter (the GP's fitted noise).
    Points outside the surrogate's domain get a NaN mean.
    """

    def __init__(self, surrogate: "GPSurrogate", domain: SurrogateDomain | None = None) -> None:
        self.surrogate = surrogate
        self.domain = domain or SurrogateDomain()

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        e, nu, r, f = _broadcast(modulus_mpa, poisson, sphere_radius_mm, force_n)
        shape = e.shape
        X = {"modulus_mpa": e.ravel(), "poisson": nu.ravel(), "sphere_radius_mm": r.ravel(), "force_kn": f.ravel() / 1e3}
        mean, std = self.surrogate.predict(X, return_std=True, noise=True)
        mean = mean + hertz_radius_mm(X["sphere_radius_mm"], f.ravel())
        inside = self.domain.contains(*(X[n] for n in INPUTS))
        mean = np.where(inside, mean, np.nan)
        return mean.reshape(shape), std.reshape(shape)

    def restricted_to(self, cases, poisson: float, modulus_range_mpa: tuple[float, float]) -> "CaseTable":
        """This surrogate at known (R, F) cases and one nu, splined in ln E (`CaseTable`)."""
        return CaseTable(self, cases, poisson, modulus_range_mpa)


class CaseTable:
    """A radius model at known (R, F) cases and one nu, as cubic splines in ln E.

    A calibration with nu fixed asks its model for the same few cases at ever
    new moduli; along ln E the surrogate's mean and std are smooth, so they are
    tabulated per case on a geometric grid of E and splined. The grid doubles
    until the splines agree with the model at every midpoint within `tol_mm`
    (mean and std); `max_error_mm` is that check's largest difference. Points
    off the cases, at another nu or outside the grid are passed to the model.

    Parameters
    ----------
    model
        ``predict(modulus_mpa, poisson, sphere_radius_mm, force_n) -> (mean_mm, std_mm)``.
    cases : iterable of (float, float)
        (sphere_radius_mm, force_n) pairs.
    poisson : float
    modulus_range_mpa : (float, float)
        Where the table is made (the prior's range of E).
    tol_mm : float
        Largest spline error accepted at the midpoints.
    """

    def __init__(self, model, cases, poisson: float, modulus_range_mpa: tuple[float, float], *,
                 tol_mm: float = 1e-5, n_start: int = 129, n_max: int = 4097) -> None:
        from scipy.interpolate import CubicSpline

        self.model = model
        self.cases = sorted({(float(r), float(f)) for r, f in cases})
        self.poisson = float(poisson)
        lo, hi = (float(v) for v in modulus_range_mpa)
        if not (0.0 < lo < hi) or not self.cases:
            raise ValueError(f"need cases and 0 < low < high moduli, got {len(self.cases)} cases, {lo!r}, {hi!r}")
        R = np.array([c[0] for c in self.cases])
        F = np.array([c[1] for c in self.cases])
        n = n_start
        while True:
            log_e = np.linspace(np.log(lo), np.log(hi), n)
            mean, std = self._model_grid(np.exp(log_e), R, F)
            splines = [CubicSpline(log_e, mean, axis=1), CubicSpline(log_e, std, axis=1)]
            mid = 0.5 * (log_e[1:] + log_e[:-1])
            check = self._model_grid(np.exp(mid), R, F)
            errors = [np.abs(spline(mid) - exact) for spline, exact in zip(splines, check)]
            finite = [e[np.isfinite(e)] for e in errors]
            self.max_error_mm = max(float(e.max(initial=0.0)) for e in finite)
            if self.max_error_mm <= tol_mm or 2 * n - 1 > n_max:
                break
            n = 2 * n - 1
        self.log_modulus_mpa = log_e
        self._defined = np.all(np.isfinite(mean), axis=1)  # a case the model leaves undefined goes to the model
        # mean (first rows) and std (the rest) in one spline: the same coefficients, column by column, and one
        # evaluation per sampler step
        self._both = CubicSpline(log_e, np.concatenate([mean, std]), axis=1)

    def _model_grid(self, moduli: np.ndarray, R: np.ndarray, F: np.ndarray):
        E, Rg = np.meshgrid(moduli, R)
        _, Fg = np.meshgrid(moduli, F)
        mean, std = self.model.predict(E, np.full(E.shape, self.poisson), Rg, Fg)
        return np.asarray(mean, dtype=float).reshape(E.shape), np.asarray(std, dtype=float).reshape(E.shape)

    def case_index(self, sphere_radius_mm, force_n) -> np.ndarray:
        """Index of each (R, F) among `cases` (-1 where it is none of them)."""
        r, f = np.broadcast_arrays(np.asarray(sphere_radius_mm, dtype=float), np.asarray(force_n, dtype=float))
        case = np.full(r.shape, -1)
        for k, (rc, fc) in enumerate(self.cases):
            case[(r == rc) & (f == fc)] = k
        return case

    def predict_cases(self, modulus_mpa: np.ndarray, poisson: np.ndarray, case: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
        """Mean and std of shape (k, n) at k moduli and the n points of known `case` indices (`case_index`).

        What a sampler asks for at every step: the splines are evaluated once per modulus, not once per
        modulus and point; the same numbers as `predict` (points it cannot tabulate go there).
        """
        e = np.atleast_1d(np.asarray(modulus_mpa, dtype=float))
        nu = np.asarray(poisson, dtype=float)
        case = np.asarray(case)
        if case.ndim != 1 or not np.all((case >= 0) & (case < len(self.cases))):
            raise ValueError("case indices must be those of the table's cases (case_index >= 0)")
        with np.errstate(divide="ignore", invalid="ignore"):
            log_e = np.log(e)
        if (case.size and np.all(self._defined[case])
                and np.all(np.abs(nu - self.poisson) <= 1e-12)
                and e.size and self.log_modulus_mpa[0] <= log_e.min() and log_e.max() <= self.log_modulus_mpa[-1]):
            both = self._both(log_e)
            return both[case].T, np.maximum(both[len(self.cases) + case].T, 0.0)
        nu = np.broadcast_to(nu, e.shape)
        R, F = (np.array([c[j] for c in self.cases])[case] for j in (0, 1))
        n = case.size
        mean, std = self.predict(np.repeat(e, n), np.repeat(nu, n), np.tile(R, e.size), np.tile(F, e.size))
        return mean.reshape(e.size, n), std.reshape(e.size, n)

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        e, nu, r, f = _broadcast(modulus_mpa, poisson, sphere_radius_mm, force_n)
        shape = e.shape
        e, nu, r, f = e.ravel(), nu.ravel(), r.ravel(), f.ravel()
        case = self.case_index(r, f)
        with np.errstate(divide="ignore", invalid="ignore"):
            log_e = np.log(e)
        use = ((case >= 0) & self._defined[case] & (np.abs(nu - self.poisson) <= 1e-12)
               & (log_e >= self.log_modulus_mpa[0]) & (log_e <= self.log_modulus_mpa[-1]))
        mean, std = np.empty(e.shape), np.empty(e.shape)
        if use.any():
            k, columns = case[use], np.arange(int(use.sum()))
            both = self._both(log_e[use])
            mean[use], std[use] = both[k, columns], both[len(self.cases) + k, columns]
        if not use.all():
            mean[~use], std[~use] = self.model.predict(e[~use], nu[~use], r[~use], f[~use])
        return mean.reshape(shape), np.maximum(std, 0.0).reshape(shape)


class FERadiusModel:
    """The FE model itself seen by the calibration (FE in the loop): std = 0.

    Slow per call compared with a surrogate; meant for deterministic checks
    (e.g. inverting each case) rather than for MCMC.

    Parameters
    ----------
    options : ContactOptions, optional
        FE options (default: frictionless sphere, film tied to the flat, small strain).
    output : str
        Which FE reading is the radius: ``contact_radius_mm`` (the edge) or an
        imprint reading ``radius_<model>_<film>_mm`` of `filmcal.fem.evaluate_point`.
    films : sequence of FilmType, optional
        Film types whose imprint readings `output` may name.
    """

    def __init__(self, options: "ContactOptions | None" = None, output: str = EDGE_COLUMN, films=()) -> None:
        from filmcal.contact.options import ContactOptions

        from filmcal.fem import imprint_columns

        self.options = options or ContactOptions()
        self.output = output
        self.films = tuple(films)
        known = [EDGE_COLUMN] + [key for _, _, key in imprint_columns(self.films)]
        if output not in known:  # a name the FE does not return would answer NaN after every solve
            raise ValueError(f"output {output!r} is not a reading of the FE for these films; known: "
                             f"{', '.join(known)} (an imprint reading needs its film in films=)")

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        from filmcal.fem import evaluate_point

        e, nu, r, f = _broadcast(modulus_mpa, poisson, sphere_radius_mm, force_n)
        out = np.empty(e.shape)
        for idx in np.ndindex(e.shape):
            point = {"modulus_mpa": float(e[idx]), "poisson": float(nu[idx]), "sphere_radius_mm": float(r[idx]),
                     "force_kn": float(f[idx]) / 1e3, **option_columns(self.options)}
            res = evaluate_point(point, films=self.films) if self.films else evaluate_point(point)
            out[idx] = float(res.get(self.output, np.nan)) if res.get("converged", True) else np.nan
        return out, np.zeros(e.shape)


def load_for_prediction(path: str | Path):
    """A saved surrogate for prediction: numpy alone (`load_saved_surrogate`), else the full reader.

    When numpy's factorisation does not reproduce the stored log marginal
    likelihood (a nearly singular kernel matrix, or a damaged file), the
    files go to `filmcal.surrogate.io.load_surrogate` (scikit-learn and scipy,
    as the fit computed it), which returns the `GPSurrogate` or refuses the
    files with its own message.
    """
    from filmcal.surrogate.saved import load_saved_surrogate

    try:
        return load_saved_surrogate(path)
    except ValueError as exc:
        if "log marginal likelihood" not in str(exc):
            raise
    from filmcal.surrogate.io import load_surrogate

    return load_surrogate(path)
