"""Figures of the surrogate and of the optimisation, saved as PNG and PDF.

- :func:`plot_ceq_freq_fill`: C_eq(f, r) maps at fixed G (the source's 2, 5 and 8 g);
- :func:`plot_ceq_freq_accel`: C_eq(f, G) maps at fixed r (the source's 25, 50 and 80 %);
- :func:`plot_convergence`: objective against SLSQP iteration for every start, per environment.

The surfaces are drawn as filled contour maps (f on a log axis, C_eq on a log colour scale
shared by the panels of a figure) rather than 3-D surfaces, whose values cannot be read. DEM
points are marked: filled circles where a fitted row lies on the slice, open circles for the
(f, r) or (f, G) positions of the other fitted rows, red crosses for rows left out of the fit.
A slice outside the surrogate's domain is not extrapolated: its panel is left empty and its
title says so. Every map covers the surrogate's domain only.

Figures are built with :class:`matplotlib.figure.Figure` (Agg canvas), so importing this module
does not change pyplot's backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

from pidpipe.ceq_table import SEM_COLUMN, UNCERTAIN_RELATIVE_SEM, VALUE_COLUMN
from pidpipe.optimisation import OptimisationResult
from pidpipe.surrogate import Surrogate

CEQ_LABEL = r"$C_\mathrm{eq}$ (N·s/m)"
_AXIS_LABELS = {"freq_hz": "frequency f (Hz)", "accel_g": "base acceleration G (g)",
                "fill_pct": "fill fraction r (%)"}
_UNITS = {"freq_hz": "Hz", "accel_g": "g", "fill_pct": "%"}
_SYMBOLS = {"freq_hz": "f", "accel_g": "G", "fill_pct": "r"}
_RC = {"font.size": 11, "axes.titlesize": 11, "axes.labelsize": 11, "legend.fontsize": 9}
#: Colour scale floor, as a fraction of the largest C_eq drawn (values below share one colour).
COLOUR_FLOOR = 1e-3
_GRID_POINTS = 80


def save_figure(figure: Figure, stem: str | Path) -> list[Path]:
    """Save ``figure`` as ``<stem>.png`` (150 dpi) and ``<stem>.pdf``; return the two paths."""
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_suffix(".png"), stem.with_suffix(".pdf")]
    for path in paths:
        figure.savefig(path, dpi=150, bbox_inches="tight")
    return paths


def plot_ceq_freq_fill(surrogate: Surrogate, accel_levels_g=(2.0, 5.0, 8.0),
                       stem: str | Path | None = None) -> Figure:
    """C_eq(f, r) maps at fixed base accelerations.

    Parameters
    ----------
    surrogate : Surrogate
    accel_levels_g : sequence of float
        One panel per level, g.
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _slice_figure(surrogate, "accel_g", accel_levels_g, ("freq_hz", "fill_pct"), stem)


def plot_ceq_freq_accel(surrogate: Surrogate, fill_levels_pct=(25.0, 50.0, 80.0),
                        stem: str | Path | None = None) -> Figure:
    """C_eq(f, G) maps at fixed fill fractions; see :func:`plot_ceq_freq_fill`."""
    return _slice_figure(surrogate, "fill_pct", fill_levels_pct, ("freq_hz", "accel_g"), stem)


def _slice_figure(surrogate: Surrogate, fixed: str, levels, axes_vars: tuple[str, str],
                  stem: str | Path | None) -> Figure:
    """One panel per level of ``fixed``; x and y are ``axes_vars``."""
    import matplotlib as mpl

    with mpl.rc_context(_RC):
        fig = Figure(figsize=(4.6 * len(levels) + 1.2, 4.4), layout="constrained")
        axes = fig.subplots(1, len(levels), sharey=True, squeeze=False)[0]
        maps = [_slice_values(surrogate, fixed, level, axes_vars) for level in levels]
        drawn = [m[2] for m in maps if m is not None]
        norm = _shared_norm(drawn)
        image = None
        for ax, level, slice_map in zip(axes, levels, maps):
            image = _draw_panel(ax, surrogate, fixed, level, axes_vars, slice_map, norm) or image
        axes[0].set_ylabel(_AXIS_LABELS[axes_vars[1]])
        if image is not None:
            bar = fig.colorbar(image, ax=list(axes), label=CEQ_LABEL)
            bar.set_ticks(image.levels[::2], labels=[f"{v:.3g}" for v in image.levels[::2]])
            bar.minorticks_off()
        _figure_legend(fig, axes)
        fig.suptitle(f"Surrogate {surrogate.method} ({surrogate.target} target): "
                     f"C_eq({_SYMBOLS[axes_vars[0]]}, {_SYMBOLS[axes_vars[1]]}) at fixed {_SYMBOLS[fixed]}")
        if stem is not None:
            save_figure(fig, stem)
    return fig


def _slice_values(surrogate: Surrogate, fixed: str, level: float, axes_vars: tuple[str, str]):
    """(x grid, y grid, C_eq grid) of one slice, or None when the level is outside the domain."""
    lo, hi = surrogate.domain[fixed]
    if not lo <= level <= hi:
        return None
    x_lo, x_hi = surrogate.domain[axes_vars[0]]
    y_lo, y_hi = surrogate.domain[axes_vars[1]]
    x = np.geomspace(x_lo, x_hi, _GRID_POINTS)  # x is always frequency
    y = np.linspace(y_lo, y_hi, _GRID_POINTS)
    xx, yy = np.meshgrid(x, y)
    query = {axes_vars[0]: xx, axes_vars[1]: yy, fixed: np.full_like(xx, level)}
    values = surrogate.predict(query["freq_hz"], query["accel_g"], query["fill_pct"])
    return xx, yy, values


def _shared_norm(grids: list[np.ndarray]) -> LogNorm | None:
    """A log colour scale over every drawn value, floored at COLOUR_FLOOR of the maximum."""
    if not grids:
        return None
    top = max(float(np.max(g)) for g in grids)
    if top <= 0:
        return LogNorm(1e-3, 1.0)
    positive = [g[g > 0] for g in grids if np.any(g > 0)]
    bottom = max(min(float(p.min()) for p in positive), COLOUR_FLOOR * top)
    if bottom >= top:
        bottom = top / 10.0
    return LogNorm(bottom, top)


def _frequency_ticks(ax, lo: float, hi: float) -> None:
    """Plain-number ticks (1-2-5 series) on a log frequency axis."""
    decades = 10.0 ** np.arange(np.floor(np.log10(lo)), np.ceil(np.log10(hi)) + 1)
    ticks = [v for d in decades for v in (d, 2 * d, 5 * d) if lo * (1 - 1e-9) <= v <= hi * (1 + 1e-9)]
    if len(ticks) < 2:
        ticks = [lo, hi]
    ax.set_xticks(ticks, labels=[f"{v:g}" for v in ticks])
    ax.set_xticks([], minor=True)


def _figure_legend(fig: Figure, axes) -> None:
    """One legend for all panels, below them."""
    handles = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, handle)
    if handles:
        fig.legend(list(handles.values()), list(handles.keys()), loc="outside lower center",
                   ncols=len(handles), frameon=False)


def _draw_panel(ax, surrogate: Surrogate, fixed: str, level: float, axes_vars: tuple[str, str],
                slice_map, norm):
    """Draw one map (or the out-of-domain notice) and the DEM points; return the contour set."""
    unit = _UNITS[fixed]
    ax.set_xscale("log")
    ax.set_xlabel(_AXIS_LABELS[axes_vars[0]])
    x_lo, x_hi = surrogate.domain[axes_vars[0]]
    y_lo, y_hi = surrogate.domain[axes_vars[1]]
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)
    _frequency_ticks(ax, x_lo, x_hi)
    if slice_map is None:
        lo, hi = surrogate.domain[fixed]
        ax.set_title(f"{_SYMBOLS[fixed]} = {level:g} {unit}: outside the surrogate domain\n"
                     f"[{lo:g}, {hi:g}] {unit}, not drawn (no extrapolation)")
        ax.text(0.5, 0.5, "outside the\nsurrogate domain", transform=ax.transAxes,
                ha="center", va="center", color="0.4")
        _mark_points(ax, surrogate, fixed, level, axes_vars)
        return None
    xx, yy, values = slice_map
    levels = np.geomspace(norm.vmin, norm.vmax, 13)
    image = ax.contourf(xx, yy, np.clip(values, norm.vmin, norm.vmax), levels=levels,
                        norm=norm, cmap="viridis")
    ax.set_title(f"{_SYMBOLS[fixed]} = {level:g} {unit}")
    _mark_points(ax, surrogate, fixed, level, axes_vars)
    return image


def _mark_points(ax, surrogate: Surrogate, fixed: str, level: float,
                 axes_vars: tuple[str, str]) -> None:
    """DEM rows: filled on the slice, open elsewhere (projected), red x if left out of the fit."""
    rows = surrogate.training
    on = np.isclose(rows[fixed].to_numpy(dtype=float), level)
    x, y = rows[axes_vars[0]].to_numpy(dtype=float), rows[axes_vars[1]].to_numpy(dtype=float)
    if np.any(~on):
        ax.scatter(x[~on], y[~on], s=18, facecolors="white", edgecolors="black", linewidths=0.8,
                   clip_on=False, zorder=3, label="DEM points off the slice (projected)")
    if np.any(on):
        ax.scatter(x[on], y[on], s=34, color="black", edgecolors="white", linewidths=0.8,
                   clip_on=False, zorder=4, label="DEM points on the slice")
    uncertain = _uncertain_rows(rows)
    if np.any(uncertain):
        ax.scatter(x[uncertain], y[uncertain], s=95, facecolors="none", edgecolors="C1",
                   linewidths=1.6, clip_on=False, zorder=4,
                   label=f"DEM C_eq uncertain (SEM > {100 * UNCERTAIN_RELATIVE_SEM:g} %)")
    if "accel_g" in axes_vars and rows["accel_g"].min() <= 1.0:
        ax.axhline(1.0, color="C1", linestyle="--", linewidth=1.2, zorder=3,
                   label="G = 1: at and below it the spheres never leave the floor")
    left_out = [r for r in surrogate.excluded
                if all(r.get(k) is not None for k in (fixed,) + axes_vars)]
    if left_out:
        ax.scatter([r[axes_vars[0]] for r in left_out], [r[axes_vars[1]] for r in left_out],
                   marker="x", s=44, color="red", clip_on=False, zorder=5,
                   label="DEM cases left out of the fit (status not ok; projected)")


def _uncertain_rows(rows) -> np.ndarray:
    """Training rows whose C_eq standard error exceeds UNCERTAIN_RELATIVE_SEM of the value."""
    if SEM_COLUMN not in rows.columns:
        return np.zeros(len(rows), dtype=bool)
    value = rows[VALUE_COLUMN].to_numpy(dtype=float)
    sem = rows[SEM_COLUMN].to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (value <= 0.0) | (sem > UNCERTAIN_RELATIVE_SEM * value)


def plot_convergence(results: list[OptimisationResult], stem: str | Path | None = None) -> Figure:
    """Total C_eq against SLSQP iteration for every start, one panel per environment.

    Grey: starts that ended elsewhere (or did not converge); blue: starts that reached the
    global optimum; red, thick: the best start.

    Parameters
    ----------
    results : list of OptimisationResult
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib as mpl

    with mpl.rc_context(_RC):
        fig = Figure(figsize=(4.8 * max(len(results), 1), 4.2), layout="constrained")
        axes = fig.subplots(1, max(len(results), 1), squeeze=False)[0]
        for ax, res in zip(axes, results):
            _draw_convergence(ax, res)
        if stem is not None:
            save_figure(fig, stem)
    return fig


def _draw_convergence(ax, res: OptimisationResult) -> None:
    """One environment's convergence panel."""
    at_optimum = set(res.optimum.start_indices)
    best = res.optimum.start_indices[0]
    for run in res.starts:
        if run.index == best:
            continue
        colour, alpha = ("C0", 0.7) if run.index in at_optimum else ("0.6", 0.6)
        ax.plot(run.history_ns_m, color=colour, alpha=alpha, linewidth=0.9)
    best_run = next(run for run in res.starts if run.index == best)
    ax.plot(best_run.history_ns_m, color="C3", linewidth=2.4,
            label=f"best start (#{best}); {res.optimum.n_starts}/{len(res.starts)} starts reach it")
    ax.plot([], [], color="C0", label="other starts reaching the global optimum")
    ax.plot([], [], color="0.6", label="starts ending elsewhere")
    d = res.design
    clipped = " (band clipped to domain)" if res.clipped else ""
    ax.set_title(f"{res.environment.name}{clipped}\nr = {d.fill_pct:.1f} %, n_c = {d.n_cells}, "
                 f"total C_eq = {d.total_ceq_ns_m:.3g} N·s/m")
    ax.set_xlabel("SLSQP iteration")
    ax.set_ylabel("total " + CEQ_LABEL + " of filled cells")
    ax.legend(loc="lower right", framealpha=0.8)


# --------------------------------------------------------------------------------------------
# The fidelity study

_VARIANT_MARKERS = ("o", "s", "D", "^", "v", "<", ">", "P", "X", "h", "p", "d", "8", "H")
_VARIANT_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
                    "tab:pink", "tab:gray", "tab:olive", "tab:cyan", "navy", "darkgoldenrod",
                    "darkgreen", "maroon")
#: Largest error drawn on a case panel, %: points beyond are pinned to the edge and labelled.
FIDELITY_ERROR_CLIP_PCT = 100.0


def plot_fidelity(table, summary, error_target: float, stem: str | Path | None = None) -> Figure:
    """Error in C_eq against CPU time, one panel per case, and a summary panel per variant.

    Case panels: each variant's error against the reference, (C_var / C_ref - 1) in %, with one
    standard error as the bar, against the run's LIGGGHTS CPU time (s, log axis). Filled
    markers: status ok; open markers: the run was flagged or failed (not in the summary). The
    reference sits at 0 (black star), its bar its own relative standard error. The shaded band
    is ±``error_target``. A case whose reference run is not steady is greyed and titled so.
    Errors beyond ±:data:`FIDELITY_ERROR_CLIP_PCT` are pinned to the edge (triangle) and
    labelled with their value.

    Summary panel: median |error| over the steady cases (bar: the standard error of the
    case(s) it comes from) against the variant's total CPU time relative to the baseline;
    filled markers meet the error target (summary column ``meets_target``), open ones do not.

    Parameters
    ----------
    table : pandas.DataFrame
        :data:`pidpipe.fidelity_study.TABLE_COLUMNS`.
    summary : pandas.DataFrame
        :data:`pidpipe.fidelity_study.SUMMARY_COLUMNS`.
    error_target : float
        Fraction of C_eq.
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib as mpl
    from matplotlib.lines import Line2D

    variants = [v for v in dict.fromkeys(table["variant"]) if v != "reference"]
    styles = {v: (_VARIANT_MARKERS[i % len(_VARIANT_MARKERS)],
                  _VARIANT_COLOURS[i % len(_VARIANT_COLOURS)]) for i, v in enumerate(variants)}
    cases = list(dict.fromkeys(table["case_id"]))
    layout = _case_layout(table, cases)
    n_rows, n_cols = len(layout), len(layout[0])
    with mpl.rc_context(_RC):
        fig = Figure(figsize=(3.4 * n_cols + 5.0, 3.3 * n_rows + 1.6), layout="constrained")
        grid = fig.add_gridspec(n_rows, n_cols + 1, width_ratios=[1.0] * n_cols + [1.45])
        for i, row in enumerate(layout):
            for j, case_id in enumerate(row):
                if case_id is None:
                    continue
                ax = fig.add_subplot(grid[i, j])
                _draw_fidelity_case(ax, table[table["case_id"] == case_id], styles,
                                    100.0 * error_target)
                if i == n_rows - 1 or layout[min(i + 1, n_rows - 1)][j] is None:
                    ax.set_xlabel("LIGGGHTS CPU time (s)")
                if j == 0:
                    ax.set_ylabel(r"error in $C_\mathrm{eq}$ vs reference (%)")
        _draw_fidelity_summary(fig.add_subplot(grid[:, n_cols]), summary, styles,
                               100.0 * error_target)
        handles = [Line2D([], [], marker="*", color="black", linestyle="none",
                                    markersize=11, label="reference (bar: its own SEM)")]
        labels = dict(zip(table["variant"], table["label"]))
        handles += [Line2D([], [], marker=styles[v][0], color=styles[v][1],
                                     linestyle="none", markersize=7, label=f"{v}: {labels[v]}")
                    for v in variants]
        handles.append(Line2D([], [], marker="o", markerfacecolor="none", color="0.3",
                                        linestyle="none", label="open: run flagged or failed"))
        fig.legend(handles=handles, loc="outside lower center", ncols=min(5, len(handles)),
                   frameon=False)
        fig.suptitle(r"Fidelity study: error in the cell's $C_\mathrm{eq}$ against a "
                     "high-fidelity reference, and its CPU cost (bars: one standard error)")
        if stem is not None:
            save_figure(fig, stem)
    return fig


def _case_layout(table, cases: list[str]) -> list[list]:
    """Case ids in rows of fill and columns of (f, G) when they form such a grid, else in rows
    of five."""
    first = table.drop_duplicates("case_id").set_index("case_id")
    pairs = list(dict.fromkeys((first.at[c, "freq_hz"], first.at[c, "accel_g"]) for c in cases))
    fills = sorted(set(first.loc[cases, "fill_pct"]))
    by_key = {(first.at[c, "freq_hz"], first.at[c, "accel_g"], first.at[c, "fill_pct"]): c
              for c in cases}
    if len(pairs) * len(fills) == len(cases) and len(pairs) <= 6:
        return [[by_key.get((f, g, r)) for f, g in pairs] for r in fills]
    n_cols = min(5, len(cases))
    padded = cases + [None] * (-len(cases) % n_cols)
    return [padded[k:k + n_cols] for k in range(0, len(padded), n_cols)]


def _draw_fidelity_case(ax, rows, styles: dict, target_pct: float) -> None:
    """One case's panel of the fidelity figure."""
    first = rows.iloc[0]
    ax.set_xscale("log")
    ax.axhspan(-target_pct, target_pct, color="tab:green", alpha=0.12, linewidth=0)
    ax.axhline(0.0, color="0.4", linewidth=0.8)
    error = 100.0 * rows["error_rel"].to_numpy(dtype=float)
    sem = 100.0 * rows["error_rel_sem"].to_numpy(dtype=float)
    finite = np.isfinite(error)
    reach = np.where(np.isfinite(sem), np.abs(error) + sem, np.abs(error))[finite]
    limit = min(max(float(reach.max()) * 1.1 if reach.size else 0.0, 2.0 * target_pct),
                FIDELITY_ERROR_CLIP_PCT)
    for row, e, s in zip(rows.itertuples(), error, sem):
        if not np.isfinite(e) or not np.isfinite(row.cpu_time_s):
            continue
        if row.variant == "reference":
            ax.errorbar(row.cpu_time_s, 0.0, yerr=s, marker="*", color="black", markersize=11,
                        capsize=2, zorder=4)
            continue
        marker, colour = styles[row.variant]
        face = colour if row.status == "ok" else "none"
        shown = float(np.clip(e, -limit, limit))
        if shown != e:
            marker = "^" if e > 0 else "v"
            ax.annotate(f"{e:+.0f} %", (row.cpu_time_s, shown), textcoords="offset points",
                        xytext=(4, -10 if e > 0 else 4), fontsize=7, color=colour)
            s = 0.0
        ax.errorbar(row.cpu_time_s, shown, yerr=s if np.isfinite(s) else None, marker=marker,
                    color=colour, markerfacecolor=face, markersize=6, capsize=2, linestyle="none",
                    zorder=3)
    ax.set_ylim(-limit * 1.05, limit * 1.05)
    title = (f"{first.freq_hz:g} Hz, {first.accel_g:g} g, {first.fill_pct:g} % "
             f"({first.n_spheres:.0f} spheres)" if np.isfinite(first.n_spheres)
             else f"{first.freq_hz:g} Hz, {first.accel_g:g} g, {first.fill_pct:g} %")
    if first.reference_status != "ok":
        ax.set_facecolor("0.92")
        title += f"\nreference {first.reference_flags or first.reference_status}: not summarised"
        ax.set_title(title, color="tab:red", fontsize=9)
    else:
        ax.set_title(title)


def _draw_fidelity_summary(ax, summary, styles: dict, target_pct: float) -> None:
    """The summary panel: median |error| over steady cases against relative CPU time."""
    ax.set_xscale("log")
    ax.axhline(target_pct, color="tab:green", linestyle="--", linewidth=1.0,
               label=f"target {target_pct:g} %")
    for row in summary.itertuples():
        if row.variant not in styles or not np.isfinite(row.median_abs_error):
            continue
        marker, colour = styles[row.variant]
        ax.errorbar(row.cpu_rel_baseline, 100.0 * row.median_abs_error,
                    yerr=100.0 * row.median_abs_error_sem, marker=marker, color=colour,
                    markerfacecolor=colour if str(row.meets_target) == "True" else "white",
                    markersize=8, capsize=3, linestyle="none")
    ax.plot([], [], marker="o", color="0.3", linestyle="none", label="filled: meets the target")
    ax.plot([], [], marker="o", color="0.3", markerfacecolor="white", linestyle="none",
            label="open: does not")
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("total CPU time / baseline variant's")
    ax.set_ylabel(r"median |error| in $C_\mathrm{eq}$ over steady cases (%)")
    ax.set_title("Summary per variant (steady cases only)")
    ax.legend(loc="upper left", framealpha=0.8)
