"""Figures of a calibration result (matplotlib, no pyplot state), returned and optionally written as PNG.

`plot_trace`        kept samples of every parameter per walker, with their histogram
`plot_corner`       pairwise scatter plots and marginal histograms of the parameters
`plot_case_intervals`  the paper's Fig. 3 analogue: per-case E ranges and the pooled posterior
`plot_predictive`   measured radius error vs the posterior predictive 90 % intervals, per case
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from filmcal.calibration.posterior import CalibrationResult

__all__ = ["plot_trace", "plot_corner", "plot_case_intervals", "plot_predictive", "case_labels"]

_LOG_SCALE = ("modulus_mpa", "oedometric_modulus_mpa")


def case_labels(sphere_radius_mm: np.ndarray, force_n: np.ndarray) -> list[str]:
    """``R450 / 75 kN`` style labels of the cases."""
    return [f"R{r:g} / {f / 1000.0:g} kN" for r, f in zip(sphere_radius_mm, force_n)]


def _save(fig: Figure, path: str | Path | None, dpi: int) -> Figure:
    """Write ``fig`` as PNG when a path is given; return the figure."""
    if path is not None:
        fig.savefig(Path(path), dpi=dpi)
    return fig


def _varying(result: CalibrationResult) -> list[str]:
    """Parameters worth a panel: not constant, and M only when nu is free (else M is E times a constant)."""
    skip = {"oedometric_modulus_mpa"} if result.poisson_mode == "fixed" else set()
    return [k for k, v in result.samples.items() if k not in skip and np.ptp(np.asarray(v)) > 0]


def plot_trace(result: CalibrationResult, path: str | Path | None = None, dpi: int = 120) -> Figure:
    """Trace of the kept samples of each parameter (one line per walker) and their histogram.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, also written as PNG to ``path`` when given.
    """
    names = _varying(result)
    fig = Figure(figsize=(10, 2.2 * len(names)))
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.5 / len(names), top=1 - 0.45 / len(names), hspace=0.45)
    axes = fig.subplots(len(names), 2, squeeze=False, width_ratios=[3, 1])
    for (ax_t, ax_h), name in zip(axes, names):
        values = np.asarray(result.samples[name])
        ax_t.plot(values.T, lw=0.4, alpha=0.5)
        ax_t.set_ylabel(name)
        ax_h.hist(values.ravel(), bins=50, orientation="horizontal", color="0.4")
        ax_h.set_yticklabels([])
        ax_h.set_ylim(ax_t.get_ylim())
        ax_t.set_title(f"R-hat {result.rhat[name]:.3f}, bulk ESS {result.ess_bulk[name]:.0f}", fontsize=8,
                       loc="left")
        if name in _LOG_SCALE:
            ax_t.set_yscale("log")
            ax_h.set_yscale("log")
    axes[-1, 0].set_xlabel(f"draw (after {result.burn_in} burn-in steps, thinned by {result.thin})")
    fig.suptitle(f"{result.film}: posterior traces ({result.n_walkers} walkers)")
    return _save(fig, path, dpi)


def plot_corner(result: CalibrationResult, path: str | Path | None = None, max_points: int = 4000, dpi: int = 120) -> Figure:
    """Pairwise scatter plots (lower triangle) and marginal histograms (diagonal).

    E and M are shown as log10 values.

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
    flat = {k: np.log10(v) if k in _LOG_SCALE else v for k, v in flat.items()}
    labels = [f"log10 {k}" if k in _LOG_SCALE else k for k in names]
    n = len(names)
    size = next(iter(flat.values())).size
    idx = np.linspace(0, size - 1, min(max_points, size)).round().astype(int)
    fig = Figure(figsize=(2.3 * n + 1, 2.3 * n + 1))
    fig.subplots_adjust(left=0.1, right=0.98, bottom=0.08, top=0.94, wspace=0.3, hspace=0.3)
    grid = fig.add_gridspec(n, n)
    for i, yi in enumerate(names):
        for j, xj in enumerate(names[:i + 1]):
            ax = fig.add_subplot(grid[i, j])
            if i == j:
                ax.hist(flat[xj], bins=50, color="0.4")
                ax.set_yticks([])
            else:
                ax.plot(flat[xj][idx], flat[yi][idx], ".", ms=1.5, alpha=0.3, color="C0")
                if j == 0:
                    ax.set_ylabel(labels[i])
            ax.xaxis.set_major_locator(MaxNLocator(3))
            ax.yaxis.set_major_locator(MaxNLocator(3))
            if i == n - 1:
                ax.set_xlabel(labels[j])
    fig.suptitle(f"{result.film}: posterior ({result.n_data} radii)")
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
    fig = Figure(figsize=(8, 0.45 * len(order) + 1.8), layout="constrained")
    ax = fig.subplots()
    post = result.modulus_mpa
    ax.axvspan(*post["ci90"], color="C0", alpha=0.2, label="pooled posterior 90 %")
    ax.axvline(post["median"], color="C0", label="pooled posterior median")
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
    ax.set_yticks(range(len(order)), [labels[k] for k in order])
    ax.set_xscale("log")
    ax.set_xlim(e_lo, e_hi)
    ax.set_xlabel(f"film Young's modulus E (MPa), nu = {ci.poisson:.3g}")
    ax.set_title(f"{result.film}: E reproducing each case within +/- {ci.tolerance_mm:.3f} mm")
    ax.legend(loc="lower right", fontsize=8)
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
    fig = Figure(figsize=(max(6.0, 0.7 * order.size + 2), 4.2), layout="constrained")
    ax = fig.subplots()
    ax.errorbar(x, mean, yerr=[mean - (pc.lower_mm[order] - hertz), (pc.upper_mm[order] - hertz) - mean],
                fmt="s", color="C0", capsize=4, label=f"posterior predictive mean, {round(100 * pc.level)} %")
    measured = pc.measured_radius_mm[order] - hertz
    outside = pc.outside[order]
    ax.plot(x[~outside], measured[~outside], "o", color="k", label="measured (Table 1)")
    if np.any(outside):
        ax.plot(x[outside], measured[outside], "o", color="C3", label="measured, outside interval")
    ax.set_xticks(x, [case_labels(pc.sphere_radius_mm, pc.force_n)[k] for k in order], rotation=45, ha="right")
    ax.set_ylabel("radius error over Hertz (mm)")
    cov = pc.coverage
    ax.set_title(f"{result.film}: posterior predictive check, coverage {cov:.0%} "
                 f"(nominal {pc.level:.0%}), {int(np.sum(pc.outside))} outside")
    ax.legend(fontsize=8)
    return _save(fig, path, dpi)
