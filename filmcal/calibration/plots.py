"""Figures of a calibration result (matplotlib, no pyplot state), returned and optionally written as PNG.

`plot_trace`        kept samples of every parameter per walker, with their histogram
`plot_corner`       pairwise scatter plots and marginal histograms of the parameters
`plot_case_intervals`  the paper's Fig. 3 analogue: per-case E ranges and the pooled posterior
`plot_predictive`   measured radius error vs the posterior predictive 90 % intervals, per case

Parameters are labelled as an engineer reads them (``E (MPa)``, not the
variable name; see `parameter_label`), in physical units, and every figure
fits the width of an A4 page (6.9 in) so that it prints at its drawn size.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
from matplotlib.axis import Axis
from matplotlib.figure import Figure
from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator, NullFormatter, NullLocator

from filmcal._io import atomic_savefig
from filmcal.calibration.posterior import CalibrationResult

__all__ = ["plot_trace", "plot_corner", "plot_case_intervals", "plot_predictive", "case_labels", "parameter_label",
           "readable_log_axis", "PARAMETER_LABELS"]

#: Printed names of the sampled parameters.
PARAMETER_LABELS = {
    "modulus_mpa": "film Young's modulus E (MPa)",
    "oedometric_modulus_mpa": "film oedometric modulus M (MPa)",
    "poisson": "film Poisson's ratio ν (-)",
    "sigma_mm": "scatter of the measured radius σ (mm)",
    "case_sigma_mm": "scatter between cases σ_case (mm)",
}
_SHORT_LABELS = {"modulus_mpa": "E (MPa)", "oedometric_modulus_mpa": "M (MPa)", "poisson": "ν",
                 "sigma_mm": "σ (mm)", "case_sigma_mm": "σ_case (mm)"}
_WIDTH_IN = 6.9  # text width of an A4 page with 16 mm margins


def parameter_label(name: str, short: bool = False) -> str:
    """The printed name of a posterior parameter (``modulus_mpa`` -> ``film Young's modulus E (MPa)``).

    Per-load discrepancies ``delta_50kn_mm`` read ``model discrepancy at 50 kN (mm)``
    (``δ 50 kN (mm)`` when `short`); unknown names are returned as they are.
    """
    table = _SHORT_LABELS if short else PARAMETER_LABELS
    if name in table:
        return table[name]
    m = re.fullmatch(r"delta_([0-9.]+)kn(?:_mm)?", name)
    if m:
        return f"δ {m.group(1)} kN (mm)" if short else f"model discrepancy at {m.group(1)} kN (mm)"
    return name


def _nice_log_ticks(lo: float, hi: float) -> list[float]:
    """1-2-5 ticks inside [lo, hi]; thinned to 1-3 per decade (or 1 per decade) when the span is wide."""
    decades = np.log10(hi / lo)
    mantissas = (1, 2, 5) if decades <= 2.5 else ((1, 3) if decades <= 4 else (1,))
    if decades < 0.5:
        return list(MaxNLocator(4).tick_values(lo, hi))
    ticks = [m * 10.0**k for k in range(int(np.floor(np.log10(lo))) - 1, int(np.ceil(np.log10(hi))) + 1)
             for m in mantissas]
    return [t for t in ticks if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)]


def readable_log_axis(axis: Axis, lo: float, hi: float, max_ticks: int = 8) -> None:
    """Log-scaled axis from `lo` to `hi` with plain-number 1-2-5 ticks and no minor labels.

    Avoids matplotlib's crowded ``2x10^3`` minor labels: ticks read ``500``,
    ``1000``, ``2000``, ``5000`` (fewer per decade when the span is wide, and
    every other one until at most `max_ticks` remain, for narrow panels).
    """
    ax = axis.axes
    (ax.set_xscale if axis is ax.xaxis else ax.set_yscale)("log")
    (ax.set_xlim if axis is ax.xaxis else ax.set_ylim)(lo, hi)
    ticks = _nice_log_ticks(lo, hi)
    while len(ticks) > max(max_ticks, 2):
        ticks = ticks[::2]
    axis.set_major_locator(FixedLocator(ticks))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())
    if np.log10(hi / lo) < 0.5:
        axis.set_minor_locator(NullLocator())


def case_labels(sphere_radius_mm: np.ndarray, force_n: np.ndarray) -> list[str]:
    """``R450 / 75 kN`` style labels of the cases."""
    return [f"R{r:g} / {f / 1000.0:g} kN" for r, f in zip(sphere_radius_mm, force_n)]


def _save(fig: Figure, path: str | Path | None, dpi: int) -> Figure:
    """Write ``fig`` (whole or not at all) when a path is given, as PNG unless its suffix says otherwise;
    return the figure."""
    if path is not None:
        atomic_savefig(fig, path, dpi=dpi)
    return fig


def _varying(result: CalibrationResult) -> list[str]:
    """Parameters worth a panel: not constant, and M only when nu is free (else M is E times a constant)."""
    skip = {"oedometric_modulus_mpa"} if result.poisson_mode == "fixed" else set()
    return [k for k, v in result.samples.items() if k not in skip and np.ptp(np.asarray(v)) > 0]


def _num(value: float) -> str:
    """A number for a label: whole numbers from 100 up, else three significant digits (never ``1e+03``)."""
    return f"{value:.0f}" if abs(value) >= 100 else f"{value:.3g}"


def _plain_numbers(axis: Axis) -> None:
    """Tick labels as plain numbers (no offset or scientific notation)."""
    axis.set_major_locator(MaxNLocator(4))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.4g}"))


def plot_trace(result: CalibrationResult, path: str | Path | None = None, dpi: int = 120) -> Figure:
    """Trace of the kept samples of each parameter (one line per walker) and their histogram.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, also written as PNG to ``path`` when given.
    """
    names = _varying(result)
    fig = Figure(figsize=(_WIDTH_IN, min(1.75 * len(names) + 0.7, 9.0)), layout="constrained")
    axes = fig.subplots(len(names), 2, squeeze=False, width_ratios=[3.2, 1], sharey="row")
    for (ax_t, ax_h), name in zip(axes, names):
        values = np.asarray(result.samples[name])
        ax_t.plot(values.T, lw=0.4, alpha=0.5)
        ax_t.set_ylabel(parameter_label(name, short=True))
        _plain_numbers(ax_t.yaxis)
        ax_t.set_title(f"{parameter_label(name)}: R-hat {result.rhat.get(name, np.nan):.3f}, bulk ESS "
                       f"{result.ess_bulk.get(name, np.nan):.0f}, tail ESS {result.ess_tail.get(name, np.nan):.0f}",
                       fontsize=8, loc="left")
        ax_h.hist(values.ravel(), bins=40, orientation="horizontal", color="0.45")
        ax_h.set_xlabel("kept draws", fontsize=7.5)
        ax_h.tick_params(labelleft=False, labelsize=7)
        ax_h.xaxis.set_major_locator(MaxNLocator(3))
    axes[-1, 0].set_xlabel(f"draw per walker (after {result.burn_in} burn-in steps, every {result.thin}th step)")
    fig.suptitle(f"{result.film}: posterior traces of {result.n_walkers} walkers", fontsize=10)
    return _save(fig, path, dpi)


def plot_corner(result: CalibrationResult, path: str | Path | None = None, max_points: int = 4000, dpi: int = 120) -> Figure:
    """Pairwise scatter plots (lower triangle) and labelled marginal histograms (diagonal), in physical units.

    Parameters
    ----------
    result : CalibrationResult
    path : str or Path
    max_points : int, default 4000
        Samples drawn per scatter plot (evenly spaced).

    Returns
    -------
    matplotlib.figure.Figure
        The figure, also written as PNG to ``path`` when given.
    """
    names = _varying(result)
    flat = {k: np.asarray(result.samples[k]).ravel() for k in names}
    n = len(names)
    size = next(iter(flat.values())).size
    idx = np.linspace(0, size - 1, min(max_points, size)).round().astype(int)
    side = min(_WIDTH_IN, 2.0 * n + 1.2)
    fig = Figure(figsize=(side, side), layout="constrained")
    axes = fig.subplots(n, n, squeeze=False)
    for i, yi in enumerate(names):
        for j, xj in enumerate(names):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
            if i == j:
                v = flat[xj]
                lo, med, hi = np.quantile(v, [0.05, 0.5, 0.95])
                ax.hist(v, bins=40, color="0.45")
                for q in (lo, hi):
                    ax.axvline(q, color="C3", lw=0.8, ls="--")
                ax.axvline(med, color="C3", lw=1.0)
                sep = "\n" if n > 3 else " "
                ax.set_title(f"{parameter_label(xj, short=True)}\n{_num(med)}{sep}[{_num(lo)}, {_num(hi)}]",
                             fontsize=8 if n <= 3 else 6.5)
                ax.set_yticks([])
            else:
                ax.plot(flat[xj][idx], flat[yi][idx], ".", ms=1.5, alpha=0.3, color="C0")
                _plain_numbers(ax.yaxis)
                if j == 0:
                    ax.set_ylabel(parameter_label(yi, short=True))
                else:
                    ax.tick_params(labelleft=False)
            _plain_numbers(ax.xaxis)
            ax.tick_params(labelsize=7)
            ax.tick_params(axis="x", labelrotation=30)
            if i == n - 1:
                ax.set_xlabel(parameter_label(xj, short=True))
            else:
                ax.tick_params(labelbottom=False)
    for i in range(1, n):
        for j in range(i):
            axes[i, j].sharex(axes[j, j])
    fig.suptitle(f"{result.film}: posterior from {result.n_data} measured radii (diagonal: median [5 %, 95 %])",
                 fontsize=9)
    return _save(fig, path, dpi)


def plot_case_intervals(result: CalibrationResult, path: str | Path | None = None, dpi: int = 120) -> Figure:
    """The paper's Fig. 3 analogue: for each (R, F) case, the E range reproducing it alone.

    Bars span the E for which the model radius is within +/- the posterior
    median sigma of the measurement (arrows where the range leaves the prior);
    dots mark the E reproducing it exactly. The vertical line and band are the
    pooled posterior median and 90 % interval of E.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, also written as PNG to ``path`` when given.
    """
    ci = result.case_intervals
    e_lo, e_hi = ci.modulus_range_mpa
    order = np.lexsort((ci.sphere_radius_mm, ci.force_n))
    labels = case_labels(ci.sphere_radius_mm, ci.force_n)
    fig = Figure(figsize=(_WIDTH_IN, 0.3 * len(order) + 1.9), layout="constrained")
    ax = fig.subplots()
    post = result.modulus_mpa
    ax.axvspan(*post["ci90"], color="C0", alpha=0.2, label="pooled posterior, 90 % credible interval")
    ax.axvline(post["median"], color="C0", label="pooled posterior median")
    ax.plot([], [], color="k", lw=2.5, label=f"E reproducing the case within ±{ci.tolerance_mm:.3f} mm")
    ax.plot([], [], "o", color="C3", ms=5, label="E reproducing the case exactly")
    for row, k in enumerate(order):
        lo = max(ci.lower_mpa[k], e_lo)
        hi = min(ci.upper_mpa[k], e_hi)
        ax.plot([lo, hi], [row, row], color="k", lw=2.5, solid_capstyle="butt")
        if ci.lower_mpa[k] < e_lo:
            ax.plot(e_lo, row, "<", color="k")
        if ci.upper_mpa[k] > e_hi:
            ax.plot(e_hi, row, ">", color="k")
        if e_lo <= ci.modulus_mpa[k] <= e_hi:
            ax.plot(ci.modulus_mpa[k], row, "o", color="C3", ms=5)
    ax.set_yticks(range(len(order)), [labels[k] for k in order], fontsize=7.5)
    ax.set_ylim(-0.7, len(order) - 0.3)
    readable_log_axis(ax.xaxis, e_lo, e_hi)
    ax.set_xlabel(f"film Young's modulus E (MPa), ν = {ci.poisson:.3g}")
    ax.set_title(f"{result.film}: E reproducing each case alone", fontsize=9)
    ax.grid(axis="x", lw=0.3)
    fig.legend(loc="outside lower center", ncol=2, fontsize=7.5, frameon=False)
    return _save(fig, path, dpi)


def plot_predictive(result: CalibrationResult, path: str | Path | None = None, dpi: int = 120) -> Figure:
    """Measured radius error vs the posterior predictive mean and 90 % interval, per case.

    Errors are radii minus the Hertz radius (Table 1's quantity). Cases
    outside their interval are drawn in red.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, also written as PNG to ``path`` when given.
    """
    pc = result.predictive
    order = np.lexsort((pc.sphere_radius_mm, pc.force_n))
    x = np.arange(order.size)
    hertz = pc.hertz_radius_mm[order]
    mean = pc.mean_mm[order] - hertz
    fig = Figure(figsize=(_WIDTH_IN, 3.6), layout="constrained")
    ax = fig.subplots()
    ax.errorbar(x, mean, yerr=[mean - (pc.lower_mm[order] - hertz), (pc.upper_mm[order] - hertz) - mean],
                fmt="s", ms=4, color="C0", capsize=3,
                label=f"posterior predictive mean and {round(100 * pc.level)} % interval")
    measured = pc.measured_radius_mm[order] - hertz
    outside = pc.outside[order]
    ax.plot(x[~outside], measured[~outside], "o", color="k", ms=4, label="measured (Table 1), inside")
    if np.any(outside):
        ax.plot(x[outside], measured[outside], "o", color="C3", ms=5, label="measured, outside the interval")
    ax.set_xticks(x, [case_labels(pc.sphere_radius_mm, pc.force_n)[k] for k in order], rotation=40, ha="right",
                  fontsize=7.5)
    ax.set_ylabel("radius with film − Hertz radius (mm)")
    ax.grid(axis="y", lw=0.3)
    ax.set_title(f"{result.film}: {int(np.sum(~pc.outside))} of {pc.outside.size} cases inside their "
                 f"{pc.level:.0%} predictive interval", fontsize=9)
    fig.legend(loc="outside lower center", ncol=3, fontsize=7.5, frameon=False)
    return _save(fig, path, dpi)
