"""Figures (matplotlib figures without pyplot state: no display needed).

Each ``plot_*`` function draws plain data (arrays, the rows of a study's
files) and returns the `matplotlib.figure.Figure`; `plot_pressure_profile`
also writes a PNG for ``filmcal fem --plot``.
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

__all__ = ["plot_pressure_profile", "plot_pressure_profiles", "plot_hertz_verification",
           "plot_surrogate_at_medians", "plot_preliminary_study", "plot_design", "plot_surrogate_validation",
           "plot_area_curves", "plot_correction_factor", "plot_outlines", "plot_crossval"]

Z90 = 1.6448536269514722  # standard normal 95 % quantile: a central 90 % interval is mean +/- Z90 std


def _figure(**kwargs) -> Figure:
    return Figure(layout="constrained", **kwargs)


def plot_pressure_profile(result, path: str) -> None:
    """Pressure p(r) of an FE result against the Hertz distribution (PNG)."""
    from filmcal.hertz import hertz_pressure_mpa

    fig = _figure(figsize=(6.4, 4.2))
    ax = fig.subplots()
    r = result.r_mm
    rr = np.linspace(0, r[-1], 800)
    ax.plot(rr, hertz_pressure_mpa(rr, result.radius_mm, result.force_n), "k--", lw=1, label="Hertz, no film")
    label = "FE, no film" if result.film_modulus_mpa is None else (
        f"FE, film E = {result.film_modulus_mpa:g} MPa, nu = {result.film_poisson:g}")
    ax.plot(r, result.pressure_mpa, ".-", ms=3, lw=1, label=label)
    ax.axvline(result.contact_radius_mm, color="C0", lw=0.8, ls=":", label=f"a = {result.contact_radius_mm:.3f} mm")
    ax.axvline(result.hertz_radius_mm, color="k", lw=0.8, ls=":", label=f"a Hertz = {result.hertz_radius_mm:.3f} mm")
    ax.set_xlim(0, 1.25 * max(result.contact_radius_mm, result.hertz_radius_mm))
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("contact pressure (MPa)")
    ax.set_title(f"Sphere R{result.radius_mm:g} on flat, F = {result.force_n / 1e3:g} kN")
    ax.legend(fontsize=8)
    ax.grid(lw=0.3)
    fig.savefig(path, dpi=120)


def plot_pressure_profiles(profiles: dict, radius_mm: float, force_n: float) -> Figure:
    """FE pressure profiles (label -> r_mm, pressure_mpa, contact_radius_mm) with the Hertz distribution."""
    from filmcal.hertz import hertz_pressure_mpa, hertz_radius_mm

    fig = _figure(figsize=(7.5, 4.3))
    ax = fig.subplots()
    a_h = float(hertz_radius_mm(radius_mm, force_n))
    a_max = max([a_h] + [p["contact_radius_mm"] for p in profiles.values()])
    rr = np.linspace(0, 1.3 * a_max, 800)
    ax.plot(rr, hertz_pressure_mpa(rr, radius_mm, force_n), "k--", lw=1.2, label=f"Hertz, a = {a_h:.3f} mm")
    for k, (label, p) in enumerate(profiles.items()):
        line = ax.plot(p["r_mm"], p["pressure_mpa"], ".-", ms=2.5, lw=0.9, color=f"C{k}",
                       label=f"FE, {label}: a = {p['contact_radius_mm']:.3f} mm")[0]
        ax.axvline(p["contact_radius_mm"], color=line.get_color(), lw=0.7, ls=":")
    ax.set_xlim(0, 1.3 * a_max)
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("contact pressure (MPa)")
    ax.set_title(f"Sphere R{radius_mm:g} on flat, F = {force_n / 1e3:g} kN", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(lw=0.3)
    return fig


def _case_labels(rows: list[dict]) -> list[str]:
    return [f"R{r['radius_mm']:g}\n{r['force_n'] / 1e3:g} kN" for r in rows]


def plot_hertz_verification(rows: list[dict]) -> Figure:
    """Relative error of the FE contact radius (no film) against Hertz, per (R, F) case."""
    fig = _figure(figsize=(8, 3.4))
    ax = fig.subplots()
    err = np.array([100 * (r["fe_radius_mm"] / r["hertz_radius_mm"] - 1) for r in rows])
    x = np.arange(len(rows))
    ax.bar(x, err, color="C0")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x, _case_labels(rows), fontsize=8)
    ax.set_ylabel("a(FE) / a(Hertz) - 1 (%)")
    ax.set_title(f"FE without film against Hertz: largest |error| {np.abs(err).max():.3f} %", fontsize=10)
    ax.grid(axis="y", lw=0.3)
    return fig


def plot_surrogate_at_medians(films: dict) -> Figure:
    """FE radius against the surrogate's 90 % interval at each film's posterior median, per case."""
    fig = _figure(figsize=(9, 3.8))
    ax = fig.subplots()
    for k, (film, d) in enumerate(films.items()):
        rows = d["cases"]
        x = np.arange(len(rows)) + (k - (len(films) - 1) / 2) * 0.22
        diff = np.array([1e3 * (r["surrogate_mean_mm"] - r["fe_radius_mm"]) for r in rows])
        half = np.array([1e3 * Z90 * r["surrogate_std_mm"] for r in rows])
        ax.errorbar(x, diff, yerr=half, fmt="o", ms=4, capsize=2, color=f"C{k}",
                    label=f"{film}, E = {d['modulus_mpa']:.0f} MPa")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(np.arange(len(rows)), _case_labels(rows), fontsize=8)
    ax.set_ylabel("surrogate - FE radius (um)")
    ax.set_title("Surrogate mean and 90 % interval against a new FE solve at the posterior medians", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(axis="y", lw=0.3)
    return fig


def plot_preliminary_study(model, cases=((300.0, 25e3), (600.0, 100e3)), poissons=(0.29, 0.33, 0.37),
                           modulus_range_mpa=(400.0, 20000.0)) -> Figure:
    """The paper's Fig. 2 in kind: contact area over E for several nu, and over the oedometric modulus M.

    ``model.predict(E, nu, R, F) -> (mean radius, std)``; bands are 90 % intervals.
    """
    from filmcal.elastic import oedometric_modulus_mpa

    e = np.geomspace(*modulus_range_mpa, 120)
    fig = _figure(figsize=(10, 3.8 * len(cases)))
    axes = fig.subplots(len(cases), 2, squeeze=False)
    for (ax_e, ax_m), (r, f) in zip(axes, cases):
        for k, nu in enumerate(poissons):
            mean, std = model.predict(e, nu, r, f)
            area, half = np.pi * mean**2, 2 * np.pi * mean * Z90 * std
            for ax, x in ((ax_e, e), (ax_m, oedometric_modulus_mpa(e, nu))):
                ax.plot(x, area, color=f"C{k}", lw=1.2, label=f"nu = {nu:g}")
                ax.fill_between(x, area - half, area + half, color=f"C{k}", alpha=0.25, lw=0)
        for ax, name in ((ax_e, "film Young's modulus E (MPa)"), (ax_m, "film oedometric modulus M (MPa)")):
            ax.set_xscale("log")
            ax.set_xlabel(name)
            ax.set_ylabel("contact area (mm$^2$)")
            ax.set_title(f"R{r:g}, {f / 1e3:g} kN", fontsize=10)
            ax.grid(lw=0.3, which="both")
            ax.legend(fontsize=8)
    return fig


def plot_design(names: list[str], train_unit: np.ndarray, test_unit: np.ndarray) -> Figure:
    """Pairwise projections of the training and held-out designs in the unit cube."""
    d = len(names)
    fig = _figure(figsize=(8.5, 8.5))
    axes = fig.subplots(d, d, squeeze=False)
    for i in range(d):
        for j in range(d):
            ax = axes[i, j]
            if i == j:
                ax.hist(train_unit[:, i], bins=10, range=(0, 1), color="C0", alpha=0.7)
            else:
                ax.plot(train_unit[:, j], train_unit[:, i], ".", ms=3, color="C0", label="training")
                ax.plot(test_unit[:, j], test_unit[:, i], "x", ms=3, color="C1", label="held out")
                ax.set_ylim(0, 1)
            ax.set_xlim(0, 1)
            ax.tick_params(labelsize=6)
            if i == d - 1:
                ax.set_xlabel(names[j], fontsize=8)
            if j == 0:
                ax.set_ylabel(names[i], fontsize=8)
    axes[0, 1].legend(fontsize=7, loc="upper right")
    return fig


def plot_surrogate_validation(points: dict) -> Figure:
    """Held-out FE radius excess over Hertz against the surrogate's mean with its 90 % interval."""
    from filmcal.hertz import hertz_radius_mm

    a_h = hertz_radius_mm(np.asarray(points["radius_mm"]), 1e3 * np.asarray(points["force_kn"]))
    fe = np.asarray(points["radius_fe_mm"]) - a_h
    mean = np.asarray(points["radius_mean_mm"]) - a_h
    std = np.asarray(points["radius_std_mm"])
    fig = _figure(figsize=(10, 4.2))
    ax, ax_z = fig.subplots(1, 2, width_ratios=[1.4, 1])
    ax.errorbar(fe, mean, yerr=Z90 * std, fmt="o", ms=3, lw=0.8, capsize=1.5)
    lim = [min(fe.min(), mean.min()), max(fe.max(), mean.max())]
    ax.plot(lim, lim, "k--", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("FE radius excess a - a(Hertz) (mm)")
    ax.set_ylabel("surrogate (mean, 90 % interval) (mm)")
    ax.grid(lw=0.3, which="both")
    z = (fe - mean) / std
    ax_z.hist(z, bins=15, density=True, color="0.5")
    zz = np.linspace(-4, 4, 200)
    ax_z.plot(zz, np.exp(-zz**2 / 2) / np.sqrt(2 * np.pi), "k-", lw=1, label="N(0, 1)")
    ax_z.set_xlabel("(FE - mean) / std")
    ax_z.set_title(f"{np.mean(np.abs(z) <= Z90):.0%} inside the 90 % interval", fontsize=10)
    ax_z.legend(fontsize=8)
    return fig


def _by(rows: list[dict], **match) -> list[dict]:
    return sorted((r for r in rows if all(r[k] == v for k, v in match.items())), key=lambda r: r["offset_mm"])


def _wheels(rows: list[dict]) -> list[str]:
    return list(dict.fromkeys(r["wheel"] for r in rows))


def plot_area_curves(rows: list[dict], film: str) -> Figure:
    """The paper's Fig. 6 in kind: area with and without film over the offset, per load, with 90 % bands."""
    forces = sorted({r["force_kn"] for r in rows})
    fig = _figure(figsize=(5.2 * len(forces), 4.2))
    axes = np.atleast_1d(fig.subplots(1, len(forces), squeeze=False)[0])
    for ax, force in zip(axes, forces):
        for k, wheel in enumerate(_wheels(rows)):
            sel = _by(rows, force_kn=force, wheel=wheel)
            eta = np.array([r["offset_mm"] for r in sel])
            a0 = np.array([r["area_no_film_mm2"] for r in sel])
            lo = a0 + np.array([r["delta_area_lo_mm2"] for r in sel])
            hi = a0 + np.array([r["delta_area_hi_mm2"] for r in sel])
            med = np.array([r["area_film_median_mm2"] for r in sel])
            if k == 0:
                ax.plot(eta, a0, "ko-", ms=4, lw=1.2, label="no film")
            ax.plot(eta, med, "s--", ms=4, lw=1.2, color=f"C{k + 1}", label=f"{film} film, {wheel} wheel")
            ax.fill_between(eta, lo, hi, color=f"C{k + 1}", alpha=0.25, lw=0)
        ax.set_xlabel("lateral offset eta (mm)")
        ax.set_ylabel("contact area A (mm$^2$)")
        ax.set_title(f"S1002 on 60E2, F = {force:g} kN", fontsize=10)
        ax.grid(lw=0.3)
        ax.legend(fontsize=8)
    return fig


def plot_correction_factor(rows_by_film: dict) -> Figure:
    """Correction factor A(no film) / A(film) over the offset with 90 % bands, per load; smooth wheel solid."""
    all_rows = [r for rows in rows_by_film.values() for r in rows]
    forces = sorted({r["force_kn"] for r in all_rows})
    fig = _figure(figsize=(5.2 * len(forces), 4.2))
    axes = np.atleast_1d(fig.subplots(1, len(forces), squeeze=False)[0])
    for ax, force in zip(axes, forces):
        err = 0.0
        for k, (film, rows) in enumerate(rows_by_film.items()):
            for wheel, style in zip(_wheels(rows), ("o-", "^:")):
                sel = _by(rows, force_kn=force, wheel=wheel)
                eta = np.array([r["offset_mm"] for r in sel])
                ax.plot(eta, [r["ratio_median"] for r in sel], style, ms=3.5, lw=1.1, color=f"C{k}",
                        label=f"{film}, {wheel}")
                ax.fill_between(eta, [r["ratio_lo"] for r in sel], [r["ratio_hi"] for r in sel], color=f"C{k}",
                                alpha=0.2, lw=0)
                err = max(err, max(r["interpolation_error_rel"] for r in sel))
        ax.set_xlabel("lateral offset eta (mm)")
        ax.set_ylabel("A(no film) / A(film)")
        ax.set_title(f"F = {force:g} kN (propagation error <= {100 * err:.3f} % of A)", fontsize=10)
        ax.grid(lw=0.3)
        ax.legend(fontsize=7)
    return fig


def plot_outlines(outlines: dict, film: str) -> Figure:
    """The paper's Fig. 7 in kind: contact outlines without (solid) and with film (dashed), per offset."""
    cases = outlines["cases"]
    ncol = min(5, len(cases))
    nrow = int(np.ceil(len(cases) / ncol))
    fig = _figure(figsize=(2.3 * ncol, 3.0 * nrow))
    axes = np.atleast_2d(fig.subplots(nrow, ncol, sharex=True, sharey=True, squeeze=False))
    rings = [np.asarray(ring) for c in cases for key in ("no film", film) for ring in c[key]["outline_mm"]]
    y_lo = min(r[:, 1].min() for r in rings) - 1.5
    y_hi = max(r[:, 1].max() for r in rings) + 1.5
    x_hi = max(np.abs(r[:, 0]).max() for r in rings) + 1.0
    for ax, case in zip(axes.flat, cases):
        for key, style, color in (("no film", "-", "k"), (film, "--", "C1")):
            for k, ring in enumerate(case[key]["outline_mm"]):
                ring = np.asarray(ring)
                ax.plot(ring[:, 1], ring[:, 0], style, color=color, lw=1.1,
                        label=(f"{key}" if key == "no film" else f"{film} film") if k == 0 else None)
        ax.set_title(f"eta = {case['offset_mm']:+g} mm\nA = {case['no film']['area_mm2']:.0f} / "
                     f"{case[film]['area_mm2']:.0f} mm$^2$", fontsize=8)
        ax.set_xlim(y_lo, y_hi)
        ax.set_ylim(-x_hi, x_hi)
        ax.set_aspect("equal")
        ax.grid(lw=0.3)
        ax.tick_params(labelsize=7)
    for ax in axes.flat[len(cases):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("y (mm), field side ->", fontsize=8)
    for ax in axes[:, 0]:
        ax.set_ylabel("x (mm), along the rail", fontsize=8)
    axes.flat[0].legend(fontsize=7, loc="lower left")
    return fig


def plot_crossval(results: dict) -> Figure:
    """Leave-one-case-out: each held-out case's corrected area (90 % interval) relative to the Hertz area."""
    fig = _figure(figsize=(9, 3.9))
    ax = fig.subplots()
    for k, (film, cv) in enumerate(results.items()):
        n = len(cv.hertz_area_mm2)
        x = np.arange(n) + (k - (len(results) - 1) / 2) * 0.22
        rel = 100 * (cv.area_mm2 / cv.hertz_area_mm2 - 1)
        lo = 100 * (cv.area_ci90_mm2[:, 0] / cv.hertz_area_mm2 - 1)
        hi = 100 * (cv.area_ci90_mm2[:, 1] / cv.hertz_area_mm2 - 1)
        ax.errorbar(x, rel, yerr=[rel - lo, hi - rel], fmt="o", ms=4, capsize=2, color=f"C{k}",
                    label=f"{film}: {cv.hits}/{n} inside")
        out = ~cv.inside
        ax.plot(x[out], rel[out], "x", color="red", ms=9)
    ax.axhline(0, color="k", lw=0.8)
    labels = [f"R{r:g}\n{f / 1e3:g} kN" for r, f in zip(cv.sphere_radius_mm, cv.force_n)]
    ax.set_xticks(np.arange(len(labels)), labels, fontsize=8)
    ax.set_ylabel("corrected area / Hertz area - 1 (%)")
    ax.set_title("Each case corrected by a calibration without it (90 % intervals; x: Hertz area outside)",
                 fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(axis="y", lw=0.3)
    return fig
