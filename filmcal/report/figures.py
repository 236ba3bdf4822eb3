"""Figures (matplotlib figures without pyplot state: no display needed).

Each ``plot_*`` function draws plain data (arrays, the rows of a study's
files) and returns the `matplotlib.figure.Figure`; `plot_pressure_profile`
also writes a PNG for ``filmcal fem --plot``. Report figures are drawn at
most `WIDTH_IN` wide (the text width of an A4 page) so that they print at
their drawn size; axes carry physical units and legends sit outside the data.
"""
from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, MaxNLocator

from filmcal._io import atomic_savefig
from filmcal.calibration.plots import readable_log_axis

__all__ = ["plot_pressure_profile", "plot_pressure_profiles", "plot_hertz_verification",
           "plot_surrogate_at_medians", "plot_preliminary_study", "plot_design", "plot_surrogate_validation",
           "plot_area_curves", "plot_correction_factor", "plot_outlines", "plot_crossval", "REPORT_STYLE",
           "WIDTH_IN"]

Z90 = 1.6448536269514722  # standard normal 95 % quantile: a central 90 % interval is mean +/- Z90 std


#: Text width of an A4 page with 16 mm margins (in): the widest a report figure is drawn.
WIDTH_IN = 6.9
#: Matplotlib settings of the report's figures (sizes in points at the printed size).
REPORT_STYLE = {"font.size": 8.5, "axes.titlesize": 9, "axes.labelsize": 8.5, "xtick.labelsize": 7.5,
                "ytick.labelsize": 7.5, "legend.fontsize": 7.5, "figure.titlesize": 10, "lines.markersize": 4,
                "axes.formatter.useoffset": False}


def signed_offset(value: float) -> str:
    """A signed offset as a table or title shows it: +2, -3, 0 (not +0)."""
    return f"{value:+g}" if value else "0"


def _figure(**kwargs) -> Figure:
    return Figure(layout="constrained", **kwargs)


def _legend_below(fig: Figure, ncol: int = 3) -> None:
    """One legend for the figure, under the axes (outside the data)."""
    fig.legend(loc="outside lower center", ncol=ncol, frameon=False)


def plot_pressure_profile(result, path: str) -> None:
    """Pressure p(r) of an FE result against the Hertz distribution (PNG)."""
    from filmcal.hertz import hertz_pressure_mpa

    fig = _figure(figsize=(6.4, 4.2))
    ax = fig.subplots()
    r = result.r_mm
    rr = np.linspace(0, r[-1], 800)
    ax.plot(rr, hertz_pressure_mpa(rr, result.sphere_radius_mm, result.force_n), "k--", lw=1, label="Hertz, no film")
    label = "FE, no film" if result.film_modulus_mpa is None else (
        f"FE, film E = {result.film_modulus_mpa:g} MPa, nu = {result.film_poisson:g}")
    ax.plot(r, result.pressure_profile_mpa, ".-", ms=3, lw=1, label=label)
    ax.axvline(result.contact_radius_mm, color="C0", lw=0.8, ls=":", label=f"a = {result.contact_radius_mm:.3f} mm")
    ax.axvline(result.hertz_radius_mm, color="k", lw=0.8, ls=":", label=f"a Hertz = {result.hertz_radius_mm:.3f} mm")
    ax.set_xlim(0, 1.25 * max(result.contact_radius_mm, result.hertz_radius_mm))
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("contact pressure (MPa)")
    ax.set_title(f"Sphere R{result.sphere_radius_mm:g} on flat, F = {result.force_n / 1e3:g} kN")
    ax.legend(fontsize=8)
    ax.grid(lw=0.3)
    atomic_savefig(fig, path, dpi=120)


def plot_pressure_profiles(profiles: dict, radius_mm: float, force_n: float) -> Figure:
    """FE pressure profiles (label -> r_mm, pressure_mpa, contact_radius_mm) with the Hertz distribution."""
    from filmcal.hertz import hertz_pressure_mpa, hertz_radius_mm

    fig = _figure(figsize=(WIDTH_IN, 3.7))
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
    ax.set_ylim(bottom=0)
    ax.set_xlabel("distance from the axis r (mm)")
    ax.set_ylabel("contact pressure p (MPa)")
    ax.set_title(f"Sphere R{radius_mm:g} mm on flat, F = {force_n / 1e3:g} kN (dotted: contact edges)")
    ax.grid(lw=0.3)
    _legend_below(fig, ncol=2)
    return fig


def _case_labels(rows: list[dict]) -> list[str]:
    return [f"R{r['sphere_radius_mm']:g}\n{r['force_n'] / 1e3:g} kN" for r in rows]


def plot_hertz_verification(rows: list[dict]) -> Figure:
    """Relative error of the FE contact radius (no film) against Hertz, per (R, F) case."""
    fig = _figure(figsize=(WIDTH_IN, 2.9))
    ax = fig.subplots()
    err = np.array([100 * (r["fe_radius_mm"] / r["hertz_radius_mm"] - 1) for r in rows])
    x = np.arange(len(rows))
    ax.bar(x, err, color="C0")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(x, _case_labels(rows), fontsize=7)
    ax.set_xlabel("sphere radius R (mm) and load F (kN) of the Table 1 case")
    ax.set_ylabel("FE radius / Hertz radius − 1 (%)")
    ax.set_title(f"FE without film against Hertz: largest |error| {np.abs(err).max():.3f} %")
    ax.grid(axis="y", lw=0.3)
    return fig


def plot_surrogate_at_medians(films: dict) -> Figure:
    """FE radius against the surrogate's 90 % interval at each film's posterior median, per case."""
    fig = _figure(figsize=(WIDTH_IN, 3.3))
    ax = fig.subplots()
    rows: list[dict] = []
    for k, (film, d) in enumerate(films.items()):
        rows = d["cases"]
        x = np.arange(len(rows)) + (k - (len(films) - 1) / 2) * 0.22
        diff = np.array([1e3 * (r["surrogate_mean_mm"] - r["fe_radius_mm"]) for r in rows])
        half = np.array([1e3 * Z90 * r["surrogate_std_mm"] for r in rows])
        ax.errorbar(x, diff, yerr=half, fmt="o", ms=3.5, capsize=2, color=f"C{k}",
                    label=f"{film} at E = {d['modulus_mpa']:.0f} MPa")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(np.arange(len(rows)), _case_labels(rows), fontsize=7)
    ax.set_ylabel("surrogate − FE contact radius (µm)")
    ax.set_title("Surrogate mean and its 90 % interval against a new FE solve")
    ax.grid(axis="y", lw=0.3)
    _legend_below(fig)
    return fig


def plot_preliminary_study(model, cases=((300.0, 25e3), (600.0, 100e3)), poissons=(0.29, 0.33, 0.37),
                           modulus_range_mpa=(400.0, 20000.0)) -> Figure:
    """The paper's Fig. 2 in kind: contact area over E for several nu, and over the oedometric modulus M.

    ``model.predict(E, nu, R, F) -> (mean radius, std)``; bands are 90 % intervals.
    """
    from filmcal.elastic import oedometric_modulus_mpa

    e = np.geomspace(*modulus_range_mpa, 120)
    fig = _figure(figsize=(WIDTH_IN, 2.7 * len(cases) + 0.5))
    axes = fig.subplots(len(cases), 2, squeeze=False)
    m_all = [oedometric_modulus_mpa(e, nu) for nu in poissons]
    m_range = (min(m.min() for m in m_all), max(m.max() for m in m_all))
    for (ax_e, ax_m), (r, f) in zip(axes, cases):
        for k, nu in enumerate(poissons):
            mean, std = model.predict(e, nu, r, f)
            area, half = np.pi * mean**2, 2 * np.pi * mean * Z90 * std
            for ax, x in ((ax_e, e), (ax_m, m_all[k])):
                ax.plot(x, area, color=f"C{k}", lw=1.2, label=f"ν = {nu:g}" if ax is ax_e and r == cases[0][0]
                        else None)
                ax.fill_between(x, area - half, area + half, color=f"C{k}", alpha=0.25, lw=0)
        for ax, name, rng in ((ax_e, "film Young's modulus E (MPa)", modulus_range_mpa),
                              (ax_m, "film oedometric modulus M (MPa)", m_range)):
            readable_log_axis(ax.xaxis, *rng)
            ax.set_xlabel(name)
            ax.set_ylabel("contact area (mm²)")
            ax.set_title(f"sphere R{r:g} mm, F = {f / 1e3:g} kN")
            ax.grid(lw=0.3, which="major")
    _legend_below(fig)
    return fig


def plot_design(labels: list[str], train: np.ndarray, test: np.ndarray, log_scale: list[bool] | None = None,
                levels: list[tuple[float, ...] | None] | None = None) -> Figure:
    """Pairwise projections of the training and held-out designs in physical units, with marginal histograms.

    Parameters
    ----------
    labels : list of str
        Printed name and unit of each column (``film Young's modulus E (MPa)``).
    train, test : ndarray of shape (n, len(labels))
        Design points in physical units.
    log_scale : list of bool, optional
        Columns drawn on a log axis (with log-width histogram bins).
    levels : list of tuple or None, optional
        Discrete levels of a column (one histogram bar per level).
    """
    d = len(labels)
    log_scale = log_scale or [False] * d
    levels = levels or [None] * d
    both = np.vstack([train, test])
    lims = []
    for k in range(d):
        lo, hi = both[:, k].min(), both[:, k].max()
        if log_scale[k]:
            lims.append((lo / 1.15, hi * 1.15))
        else:
            pad = 0.06 * (hi - lo) if hi > lo else 1.0
            lims.append((lo - pad, hi + pad))
    fig = _figure(figsize=(WIDTH_IN, WIDTH_IN))
    axes = fig.subplots(d, d, squeeze=False)
    for i in range(d):
        for j in range(d):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
            if i == j:
                if levels[i] is not None:
                    lv = np.asarray(levels[i], float)
                    step = np.min(np.diff(lv)) if lv.size > 1 else 1.0
                    bins = np.concatenate([lv - step / 2, [lv[-1] + step / 2]])
                elif log_scale[i]:
                    bins = np.geomspace(both[:, i].min(), both[:, i].max(), 9)
                else:
                    bins = np.linspace(both[:, i].min(), both[:, i].max(), 9)
                ax.hist([train[:, i], test[:, i]], bins=bins, stacked=True, color=["C0", "C1"],
                        label=["training runs", "held-out runs"])
                ax.yaxis.tick_right()
                ax.yaxis.set_label_position("right")
                ax.set_ylabel("runs per bin", fontsize=7)
                ax.yaxis.set_major_locator(MaxNLocator(3, integer=True))
            else:
                ax.plot(train[:, j], train[:, i], ".", ms=3, color="C0")
                ax.plot(test[:, j], test[:, i], "x", ms=3.5, color="C1")
                if log_scale[i]:
                    readable_log_axis(ax.yaxis, *lims[i], max_ticks=4)
                else:
                    ax.set_ylim(*lims[i])
                    ax.yaxis.set_major_locator(MaxNLocator(4))
                if j == 0:
                    ax.set_ylabel(labels[i], fontsize=7.5)
                else:
                    ax.tick_params(labelleft=False)
            if log_scale[j]:
                readable_log_axis(ax.xaxis, *lims[j], max_ticks=3)
            else:
                ax.set_xlim(*lims[j])
                ax.xaxis.set_major_locator(MaxNLocator(4))
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.tick_params(labelsize=6.5)
            if i == d - 1:
                ax.set_xlabel(labels[j], fontsize=7.5)
                ax.tick_params(axis="x", labelrotation=35)
            else:
                ax.tick_params(labelbottom=False)
    handles, names = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, names, loc="upper right", bbox_to_anchor=(0.98, 0.97), frameon=False,
               title=f"{len(train)} training (dots), {len(test)} held out (crosses)", title_fontsize=7.5)
    return fig


def plot_surrogate_validation(points: dict) -> Figure:
    """Held-out FE runs against the surrogate: parity of the radius excess over Hertz, errors, standardised errors.

    The parity panel is on log axes (the excess spans a decade and more); the
    error panel shows surrogate minus FE in micrometres with the surrogate's 90 %
    interval, where the bars are visible; the histogram compares the
    standardised errors with the standard normal density.
    """
    from filmcal.hertz import hertz_radius_mm

    a_h = hertz_radius_mm(np.asarray(points["sphere_radius_mm"]), 1e3 * np.asarray(points["force_kn"]))
    fe = np.asarray(points["radius_fe_mm"]) - a_h
    mean = np.asarray(points["radius_mean_mm"]) - a_h
    std = np.asarray(points["radius_std_mm"])
    fig = _figure(figsize=(WIDTH_IN, 5.6))
    grid = fig.add_gridspec(2, 2)
    ax = fig.add_subplot(grid[0, 0])
    ax_d = fig.add_subplot(grid[0, 1])
    ax_z = fig.add_subplot(grid[1, :])
    lo, hi = min(fe.min(), mean.min()) / 1.2, max(fe.max(), mean.max()) * 1.2
    ax.plot([lo, hi], [lo, hi], "k--", lw=0.8, label="surrogate = FE")
    ax.errorbar(fe, mean, yerr=Z90 * std, fmt="o", ms=3, lw=1.0, capsize=2, color="C0",
                label="surrogate mean, 90 % interval")
    readable_log_axis(ax.xaxis, lo, hi)
    readable_log_axis(ax.yaxis, lo, hi)
    ax.set_xlabel("FE: radius with film − Hertz radius (mm)")
    ax.set_ylabel("surrogate: same (mm)")
    ax.set_title(f"Parity, {fe.size} held-out FE runs")
    ax.grid(lw=0.3)
    ax.legend(loc="upper left", fontsize=6.5, frameon=False)
    diff_um = 1e3 * (mean - fe)
    ax_d.errorbar(fe, diff_um, yerr=1e3 * Z90 * std, fmt="o", ms=3, lw=1.0, capsize=2, color="C0")
    ax_d.axhline(0, color="k", lw=0.8)
    readable_log_axis(ax_d.xaxis, lo, hi)
    ax_d.set_xlabel("FE: radius with film − Hertz radius (mm)")
    ax_d.set_ylabel("surrogate − FE radius (µm)")
    ax_d.set_title("Error with the surrogate's 90 % interval")
    ax_d.grid(lw=0.3)
    z = (fe - mean) / std
    ax_z.hist(z, bins=np.linspace(-4, 4, 17), density=True, color="0.55", label="held-out runs")
    zz = np.linspace(-4, 4, 200)
    ax_z.plot(zz, np.exp(-zz**2 / 2) / np.sqrt(2 * np.pi), "k-", lw=1, label="standard normal N(0, 1)")
    for q in (-Z90, Z90):
        ax_z.axvline(q, color="C3", lw=0.8, ls="--")
    ax_z.set_xlabel("standardised error (FE − surrogate mean) / surrogate std (dashed: ±1.645, the 90 % limits)")
    ax_z.set_ylabel("density")
    ax_z.set_title(f"{np.mean(np.abs(z) <= Z90):.0%} of the held-out runs inside the 90 % interval")
    ax_z.legend(loc="upper left", frameon=False)
    return fig


def _by(rows: list[dict], **match) -> list[dict]:
    return sorted((r for r in rows if all(r[k] == v for k, v in match.items())), key=lambda r: r["offset_mm"])


def _wheels(rows: list[dict]) -> list[str]:
    return list(dict.fromkeys(r["wheel"] for r in rows))


def _wheel_name(wheel: str) -> str:
    return wheel if "wheel" in wheel else f"{wheel} wheel"


def plot_area_curves(rows: list[dict], film: str) -> Figure:
    """The paper's Fig. 6 in kind: area with and without film over the offset, per load, with 90 % bands."""
    forces = sorted({r["force_kn"] for r in rows})
    fig = _figure(figsize=(WIDTH_IN, 3.4))
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
                ax.plot(eta, a0, "ko-", ms=3.5, lw=1.2, label="no film" if force == forces[0] else None)
            ax.plot(eta, med, "s--", ms=3.5, lw=1.2, color=f"C{k + 1}",
                    label=f"{film} film, {_wheel_name(wheel)}: median, 90 % band" if force == forces[0] else None)
            ax.fill_between(eta, lo, hi, color=f"C{k + 1}", alpha=0.25, lw=0)
        ax.set_xlabel("lateral offset η (mm)")
        ax.set_ylabel("contact area A (mm²)")
        ax.set_title(f"S1002 on 60E2, F = {force:g} kN")
        ax.grid(lw=0.3)
    _legend_below(fig, ncol=2)
    return fig


def plot_correction_factor(rows_by_film: dict) -> Figure:
    """Correction factor A(no film) / A(film) over the offset with 90 % bands, per load; smooth wheel solid."""
    all_rows = [r for rows in rows_by_film.values() for r in rows]
    forces = sorted({r["force_kn"] for r in all_rows})
    fig = _figure(figsize=(WIDTH_IN, 3.8 if len(forces) > 1 else 4.2))
    axes = np.atleast_1d(fig.subplots(1, len(forces), squeeze=False)[0])
    for ax, force in zip(axes, forces):
        err = 0.0
        for k, (film, rows) in enumerate(rows_by_film.items()):
            for wheel, style in zip(_wheels(rows), ("o-", "^:")):
                sel = _by(rows, force_kn=force, wheel=wheel)
                eta = np.array([r["offset_mm"] for r in sel])
                ax.plot(eta, [r["ratio_median"] for r in sel], style, ms=3.5, lw=1.1, color=f"C{k}",
                        label=f"{film}, {_wheel_name(wheel)}" if force == forces[0] else None)
                ax.fill_between(eta, [r["ratio_lo"] for r in sel], [r["ratio_hi"] for r in sel], color=f"C{k}",
                                alpha=0.2, lw=0)
                err = max(err, max(r["interpolation_error_rel"] for r in sel))
        ax.set_xlabel("lateral offset η (mm)")
        ax.set_ylabel("correction factor A(no film) / A(film)")
        ax.set_title(f"F = {force:g} kN (propagation error ≤ {100 * err:.2f} % of A)")
        ax.grid(lw=0.3)
    _legend_below(fig, ncol=3)
    return fig


def plot_outlines(outlines: dict, film: str) -> Figure:
    """The paper's Fig. 7 in kind: contact outlines without (solid) and with film (dashed), per offset."""
    cases = outlines["cases"]
    ncol = min(5, len(cases))
    nrow = int(np.ceil(len(cases) / ncol))
    fig = _figure(figsize=(min(WIDTH_IN, 1.45 * ncol + 0.6), 2.7 * nrow + 0.4))
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
        ax.set_title(f"η = {signed_offset(case['offset_mm'])} mm\nA = {case['no film']['area_mm2']:.0f} / "
                     f"{case[film]['area_mm2']:.0f} mm²", fontsize=7.5)
        ax.set_xlim(y_lo, y_hi)
        ax.set_ylim(-x_hi, x_hi)
        ax.set_aspect("equal")
        ax.grid(lw=0.3)
        ax.tick_params(labelsize=6.5)
    for ax in axes.flat[len(cases):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("y (mm), field side →", fontsize=7)
    for ax in axes[:, 0]:
        ax.set_ylabel("x along the rail (mm)", fontsize=7)
    handles, names = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="outside lower center", ncol=2, frameon=False)
    return fig


def plot_crossval(results: dict) -> Figure:
    """Leave-one-case-out: each held-out case's corrected area (90 % interval) relative to the Hertz area."""
    fig = _figure(figsize=(WIDTH_IN, 3.5))
    ax = fig.subplots()
    cv = None
    for k, (film, cv) in enumerate(results.items()):
        n = len(cv.hertz_area_mm2)
        x = np.arange(n) + (k - (len(results) - 1) / 2) * 0.22
        rel = 100 * (cv.area_mm2 / cv.hertz_area_mm2 - 1)
        lo = 100 * (cv.area_ci90_mm2[:, 0] / cv.hertz_area_mm2 - 1)
        hi = 100 * (cv.area_ci90_mm2[:, 1] / cv.hertz_area_mm2 - 1)
        ax.errorbar(x, rel, yerr=[rel - lo, hi - rel], fmt="o", ms=3.5, capsize=2, color=f"C{k}",
                    label=f"{film}: {cv.hits} of {n} inside")
        out = ~cv.inside
        ax.plot(x[out], rel[out], "x", color="red", ms=8, label="Hertz area outside the interval" if k == 0 else None)
    ax.axhline(0, color="k", lw=0.8)
    labels = [f"R{r:g}\n{f / 1e3:g} kN" for r, f in zip(cv.sphere_radius_mm, cv.force_n)]
    ax.set_xticks(np.arange(len(labels)), labels, fontsize=7)
    ax.set_ylabel("corrected area / Hertz area − 1 (%)")
    ax.set_title("Each case corrected by a calibration without it (90 % intervals)")
    ax.grid(axis="y", lw=0.3)
    _legend_below(fig, ncol=4)
    return fig
