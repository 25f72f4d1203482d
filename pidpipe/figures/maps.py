"""The surrogate's C_eq maps: C_eq(f, r) at fixed G (the source's 2, 5 and 8 g) and C_eq(f, G) at fixed r.

The surfaces are drawn as filled contour maps (f on a log axis, C_eq on a log colour scale
shared by the panels of a figure) rather than 3-D surfaces, whose values cannot be read. DEM
points are marked: filled circles where a fitted row lies on the slice, open circles for the
(f, r) or (f, G) positions of the other fitted rows, red crosses for rows left out of the fit.
A slice outside the surrogate's domain is not extrapolated: its panel is left empty and its
title says so. Every map covers the surrogate's domain only.

Below each map a companion panel shows where the surrogate is uncertain: the spread of the
surrogates refitted to the bootstrap's redrawn tables (:func:`pidpipe.design.bootstrap.
resampled_surrogates`), as the standard deviation over the draws relative to the surrogate's
value, in %. A contour drawn where that spread is large is not a measurement. Without draws
(a table with no SEM) the companion panel says so.

The effective mass has maps of its own beside these (:func:`plot_m_eff_freq_fill`,
:func:`plot_m_eff_freq_accel`): m_eff / bed mass from the m_eff surrogate (a Gaussian process,
:func:`pidpipe.steps.design.fit_m_eff_surrogate`), 1 where the bed rides the wall and about 0
where it flies, on a linear colour scale; under each, the surrogate's own predictive standard
uncertainty of that ratio (:meth:`~pidpipe.design.surrogate.Surrogate.predict_with_uncertainty`),
in % of the bed mass (relative to m_eff it would be meaningless where m_eff is about zero).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure

from pidpipe.design.ceq_table import SEM_COLUMN, UNCERTAIN_RELATIVE_SEM, VALUE_COLUMN
from pidpipe.design.surrogate import Surrogate
from pidpipe.figures.common import (
    AXIS_LABELS,
    CEQ_LABEL,
    COLOUR_FLOOR,
    GRID_POINTS,
    RC_PARAMS,
    SYMBOLS,
    UNITS,
    frequency_ticks,
    save_figure,
)


def plot_ceq_freq_fill(surrogate: Surrogate, accel_levels_g=(2.0, 5.0, 8.0),
                       stem: str | Path | None = None, draws: list[Surrogate] | None = None,
                       note: str = "") -> Figure:
    """C_eq(f, r) maps at fixed base accelerations, each over its uncertainty panel.

    Parameters
    ----------
    surrogate : Surrogate
    accel_levels_g : sequence of float
        One panel per level, g.
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.
    draws : list of Surrogate, optional
        The bootstrap's refitted surrogates, for the uncertainty panels.
    note : str
        Why there are no draws (shown in the uncertainty panels).

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _slice_figure(surrogate, "accel_g", accel_levels_g, ("freq_hz", "fill_pct"), stem,
                         draws, note)


def plot_ceq_freq_accel(surrogate: Surrogate, fill_levels_pct=(25.0, 50.0, 80.0),
                        stem: str | Path | None = None, draws: list[Surrogate] | None = None,
                        note: str = "") -> Figure:
    """C_eq(f, G) maps at fixed fill fractions; see :func:`plot_ceq_freq_fill`."""
    return _slice_figure(surrogate, "fill_pct", fill_levels_pct, ("freq_hz", "accel_g"), stem,
                         draws, note)


def _slice_figure(surrogate: Surrogate, fixed: str, levels, axes_vars: tuple[str, str],
                  stem: str | Path | None, draws: list[Surrogate] | None = None,
                  note: str = "") -> Figure:
    """One column per level of ``fixed``, the map over its uncertainty; x and y are ``axes_vars``."""
    import matplotlib as mpl

    with mpl.rc_context(RC_PARAMS):
        fig = Figure(figsize=(4.6 * len(levels) + 1.2, 8.6), layout="constrained")
        grid = fig.subplots(2, len(levels), sharex="col", sharey=True, squeeze=False)
        axes, spread_axes = grid[0], grid[1]
        maps = [_slice_values(surrogate, fixed, level, axes_vars) for level in levels]
        drawn = [m[2] for m in maps if m is not None]
        norm = _shared_norm(drawn)
        image = None
        for ax, level, slice_map in zip(axes, levels, maps):
            image = _draw_panel(ax, surrogate, fixed, level, axes_vars, slice_map, norm) or image
        axes[0].set_ylabel(AXIS_LABELS[axes_vars[1]])
        spread_axes[0].set_ylabel(AXIS_LABELS[axes_vars[1]])
        if image is not None:
            bar = fig.colorbar(image, ax=list(axes), label=CEQ_LABEL)
            bar.set_ticks(image.levels[::2], labels=[f"{v:.3g}" for v in image.levels[::2]])
            bar.minorticks_off()
        spread = None
        for ax, level, slice_map in zip(spread_axes, levels, maps):
            spread = _draw_spread(ax, surrogate, fixed, level, axes_vars, slice_map, draws, note) or spread
        if spread is not None:
            fig.colorbar(spread, ax=list(spread_axes),
                         label=f"bootstrap spread of {CEQ_LABEL.split(' (')[0]}: std / value (%)")
        _figure_legend(fig, axes)
        fig.suptitle(f"Surrogate {surrogate.method} ({surrogate.target} target): "
                     f"C_eq({SYMBOLS[axes_vars[0]]}, {SYMBOLS[axes_vars[1]]}) at fixed {SYMBOLS[fixed]}")
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
    x = np.geomspace(x_lo, x_hi, GRID_POINTS)  # x is always frequency
    y = np.linspace(y_lo, y_hi, GRID_POINTS)
    xx, yy = np.meshgrid(x, y)
    query = {axes_vars[0]: xx, axes_vars[1]: yy, fixed: np.full_like(xx, level)}
    values = surrogate.predict(query["freq_hz"], query["accel_g"], query["fill_pct"])
    return xx, yy, values


#: Levels of the uncertainty panels, % (std / value); above the last is one colour.
SPREAD_LEVELS = (0, 1, 2, 3, 5, 7.5, 10, 15, 20, 30, 50)


def relative_spread(surrogate: Surrogate, draws: list[Surrogate], freq_hz: np.ndarray,
                    accel_g: np.ndarray, fill_pct: np.ndarray) -> np.ndarray:
    """Standard deviation of the draws' C_eq relative to the surrogate's, %, same shape as the
    query (the value is floored at COLOUR_FLOOR of its largest, as the colour scale is)."""
    stack = np.stack([d.predict(freq_hz, accel_g, fill_pct) for d in draws])
    value = np.asarray(surrogate.predict(freq_hz, accel_g, fill_pct), dtype=float)
    floor = max(COLOUR_FLOOR * float(np.max(value)), 1e-300)
    return 100.0 * stack.std(axis=0, ddof=1) / np.maximum(value, floor)


def _draw_spread(ax, surrogate: Surrogate, fixed: str, level: float, axes_vars: tuple[str, str],
                 slice_map, draws: list[Surrogate] | None, note: str):
    """The uncertainty panel under one map; return its contour set (None if not drawn)."""
    _frame(ax, surrogate, axes_vars)
    unit = UNITS[fixed]
    if slice_map is None or not draws or len(draws) < 2:
        why = "outside the surrogate domain" if slice_map is None else (note or "no bootstrap draws")
        ax.set_title(f"{SYMBOLS[fixed]} = {level:g} {unit}: uncertainty not drawn", fontsize=9)
        ax.text(0.5, 0.5, why, transform=ax.transAxes, ha="center", va="center", color="0.4",
                wrap=True)
        _mark_points(ax, surrogate, fixed, level, axes_vars)
        return None
    xx, yy, _ = slice_map
    query = {axes_vars[0]: xx, axes_vars[1]: yy, fixed: np.full_like(xx, level)}
    spread = relative_spread(surrogate, draws, query["freq_hz"], query["accel_g"], query["fill_pct"])
    image = ax.contourf(xx, yy, np.clip(spread, 0, SPREAD_LEVELS[-1]), levels=SPREAD_LEVELS,
                        cmap="magma_r", extend="max")
    ax.set_title(f"{SYMBOLS[fixed]} = {level:g} {unit}: spread of {len(draws)} bootstrap refits "
                 f"(median {np.median(spread):.1f} %)", fontsize=9)
    _mark_points(ax, surrogate, fixed, level, axes_vars)
    return image


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


def _figure_legend(fig: Figure, axes) -> None:
    """One legend for all panels, below them."""
    handles = {}
    for ax in axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, handle)
    if handles:
        fig.legend(list(handles.values()), list(handles.keys()), loc="outside lower center",
                   ncols=min(len(handles), 4), frameon=False)


def _frame(ax, surrogate: Surrogate, axes_vars: tuple[str, str]) -> None:
    """Log frequency axis, labels and limits: the surrogate's domain."""
    ax.set_xscale("log")
    ax.set_xlabel(AXIS_LABELS[axes_vars[0]])
    x_lo, x_hi = surrogate.domain[axes_vars[0]]
    y_lo, y_hi = surrogate.domain[axes_vars[1]]
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)
    frequency_ticks(ax, x_lo, x_hi)


def _draw_panel(ax, surrogate: Surrogate, fixed: str, level: float, axes_vars: tuple[str, str],
                slice_map, norm):
    """Draw one map (or the out-of-domain notice) and the DEM points; return the contour set."""
    unit = UNITS[fixed]
    _frame(ax, surrogate, axes_vars)
    if slice_map is None:
        lo, hi = surrogate.domain[fixed]
        ax.set_title(f"{SYMBOLS[fixed]} = {level:g} {unit}: outside the surrogate domain\n"
                     f"[{lo:g}, {hi:g}] {unit}, not drawn (no extrapolation)")
        ax.text(0.5, 0.5, "outside the\nsurrogate domain", transform=ax.transAxes,
                ha="center", va="center", color="0.4")
        _mark_points(ax, surrogate, fixed, level, axes_vars)
        return None
    xx, yy, values = slice_map
    levels = np.geomspace(norm.vmin, norm.vmax, 13)
    image = ax.contourf(xx, yy, np.clip(values, norm.vmin, norm.vmax), levels=levels,
                        norm=norm, cmap="viridis")
    ax.set_title(f"{SYMBOLS[fixed]} = {level:g} {unit}")
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
    if np.any(on) and "regime" in rows.columns:
        regimes = rows["regime"].astype("string").fillna("").to_numpy()
        for name, marker in REGIME_MARKERS.items():
            mine = on & (regimes == name)
            if np.any(mine):
                ax.scatter(x[mine], y[mine], s=44, marker=marker, color="black",
                           edgecolors="white", linewidths=0.8, clip_on=False, zorder=4,
                           label=f"DEM on the slice: {name.replace('_', ' ')}")
        unknown = on & ~np.isin(regimes, list(REGIME_MARKERS))
        if np.any(unknown):
            ax.scatter(x[unknown], y[unknown], s=34, color="black", edgecolors="white",
                       linewidths=0.8, clip_on=False, zorder=4, label="DEM points on the slice")
    elif np.any(on):
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


#: Marker of each regime (:mod:`pidpipe.measurement.regime`; ``impacting`` is the regime decided
#: from G alone when the motion was not sampled).
REGIME_MARKERS = {"no_lift_off": "v", "bouncing_bed": "o", "period_doubling": "D",
                  "lid_impacts": "^", "fluidised": "*", "irregular": "s", "impacting": "P"}


def _uncertain_rows(rows) -> np.ndarray:
    """Training rows whose C_eq standard error exceeds UNCERTAIN_RELATIVE_SEM of the value."""
    if SEM_COLUMN not in rows.columns:
        return np.zeros(len(rows), dtype=bool)
    value = rows[VALUE_COLUMN].to_numpy(dtype=float)
    sem = rows[SEM_COLUMN].to_numpy(dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (value <= 0.0) | (sem > UNCERTAIN_RELATIVE_SEM * value)


# --------------------------------------------------------------------------------------------
# The effective mass

#: Colour bar label of the m_eff maps.
M_EFF_RATIO_LABEL = r"$m_\mathrm{eff}$ / bed mass (-)"
#: Levels of the m_eff uncertainty panels, % of the bed mass; above the last is one colour.
M_EFF_SD_LEVELS = (0, 1, 2, 3, 5, 7.5, 10, 15, 20, 30, 50)


def plot_m_eff_freq_fill(surrogate: Surrogate, bed_mass_kg, accel_levels_g=(1.0, 2.0, 5.0),
                         stem: str | Path | None = None) -> Figure:
    """m_eff / bed mass (f, r) maps at fixed base accelerations, each over its uncertainty.

    Parameters
    ----------
    surrogate : Surrogate
        The m_eff surrogate (one cell's m_eff, kg); ``gp`` for the uncertainty panels.
    bed_mass_kg : callable
        ``bed_mass_kg(fill_pct) -> kg``, array in, array out of the same shape: one cell's
        spheres' mass at a fill (:func:`bed_mass_of_fill`).
    accel_levels_g : sequence of float
        One column per level, g. The defaults straddle lift-off (1 g) and the 1-5 g transition,
        where m_eff changes; above it m_eff is about zero everywhere.
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _m_eff_figure(surrogate, bed_mass_kg, "accel_g", accel_levels_g,
                         ("freq_hz", "fill_pct"), stem)


def plot_m_eff_freq_accel(surrogate: Surrogate, bed_mass_kg, fill_levels_pct=(25.0, 50.0, 80.0),
                          stem: str | Path | None = None) -> Figure:
    """m_eff / bed mass (f, G) maps at fixed fills (the C_eq maps' levels); see
    :func:`plot_m_eff_freq_fill`."""
    return _m_eff_figure(surrogate, bed_mass_kg, "fill_pct", fill_levels_pct,
                         ("freq_hz", "accel_g"), stem)


def bed_mass_of_fill(fill_pct, bed_mass_kg):
    """One cell's bed mass at any fill, from the table's fills: ``(fill_pct, bed_mass_kg)`` ->
    a callable, linear between the fills (a cell holds round(r N_full / 100) spheres, so this is
    within half a sphere's mass of the poured bed between grid fills and exact on them).

    Parameters
    ----------
    fill_pct, bed_mass_kg : array_like, shape (n,)
        The table's rows (NaN masses are ignored; repeated fills averaged), % and kg.

    Returns
    -------
    callable
        ``f(fill_pct) -> kg``, array in, array out (held constant beyond the table's fills).

    Raises
    ------
    ValueError
        No finite bed mass.
    """
    fill = np.asarray(fill_pct, dtype=float)
    mass = np.asarray(bed_mass_kg, dtype=float)
    keep = np.isfinite(fill) & np.isfinite(mass) & (mass > 0)
    if not np.any(keep):
        raise ValueError("the table has no bed mass (bed_mass_kg) to divide m_eff by")
    levels = np.unique(fill[keep])
    means = np.array([mass[keep][fill[keep] == level].mean() for level in levels])
    return lambda r: np.interp(np.asarray(r, dtype=float), levels, means)


def m_eff_ratio_grid(surrogate: Surrogate, bed_mass_kg, freq_hz: np.ndarray, accel_g: np.ndarray,
                     fill_pct: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """m_eff / bed mass and its standard uncertainty at the query points (same shape).

    Returns
    -------
    ratio : ndarray
    sd : ndarray or None
        The GP's predictive standard uncertainty of m_eff (without the cases' excess scatter:
        the response's own) over the bed mass; None for a surrogate without one.
    """
    mass = bed_mass_kg(fill_pct)
    if surrogate.has_uncertainty:
        value, sd = surrogate.predict_with_uncertainty(freq_hz, accel_g, fill_pct)
        return np.asarray(value) / mass, np.asarray(sd) / mass
    return np.asarray(surrogate.predict(freq_hz, accel_g, fill_pct)) / mass, None


def _m_eff_figure(surrogate: Surrogate, bed_mass_kg, fixed: str, levels,
                  axes_vars: tuple[str, str], stem: str | Path | None) -> Figure:
    """One column per level of ``fixed``: m_eff / bed mass over its uncertainty."""
    import matplotlib as mpl

    with mpl.rc_context(RC_PARAMS):
        fig = Figure(figsize=(4.6 * len(levels) + 1.2, 8.6), layout="constrained")
        grid = fig.subplots(2, len(levels), sharex="col", sharey=True, squeeze=False)
        axes, sd_axes = grid[0], grid[1]
        maps = []
        for level in levels:
            slice_map = _slice_grid(surrogate, fixed, level, axes_vars)
            if slice_map is not None:
                xx, yy, query = slice_map
                slice_map = (xx, yy, *m_eff_ratio_grid(surrogate, bed_mass_kg, query["freq_hz"],
                                                       query["accel_g"], query["fill_pct"]))
            maps.append(slice_map)
        drawn = [m[2] for m in maps if m is not None]
        norm = Normalize(min(0.0, *(float(g.min()) for g in drawn)),
                         max(1.0, *(float(g.max()) for g in drawn))) if drawn else None
        image = sd_image = None
        for ax, sd_ax, level, slice_map in zip(axes, sd_axes, levels, maps):
            _frame(ax, surrogate, axes_vars)
            _frame(sd_ax, surrogate, axes_vars)
            unit = UNITS[fixed]
            if slice_map is None:
                lo, hi = surrogate.domain[fixed]
                for target in (ax, sd_ax):
                    target.set_title(f"{SYMBOLS[fixed]} = {level:g} {unit}: outside the surrogate "
                                     f"domain\n[{lo:g}, {hi:g}] {unit}, not drawn", fontsize=9)
                    _mark_points(target, surrogate, fixed, level, axes_vars)
                continue
            xx, yy, ratio, sd = slice_map
            image = ax.contourf(xx, yy, ratio, levels=np.linspace(norm.vmin, norm.vmax, 13),
                                norm=norm, cmap="viridis")
            ax.set_title(f"{SYMBOLS[fixed]} = {level:g} {unit}")
            _mark_points(ax, surrogate, fixed, level, axes_vars)
            if sd is None:
                sd_ax.set_title(f"{SYMBOLS[fixed]} = {level:g} {unit}: uncertainty not drawn",
                                fontsize=9)
                sd_ax.text(0.5, 0.5, f"surrogate {surrogate.method} has no predictive "
                           "uncertainty", transform=sd_ax.transAxes, ha="center", va="center",
                           color="0.4", wrap=True)
            else:
                percent = 100.0 * sd
                sd_image = sd_ax.contourf(xx, yy, np.clip(percent, 0, M_EFF_SD_LEVELS[-1]),
                                          levels=M_EFF_SD_LEVELS, cmap="magma_r", extend="max")
                sd_ax.set_title(f"{SYMBOLS[fixed]} = {level:g} {unit}: predictive std "
                                f"(median {np.median(percent):.1f} % of the bed)", fontsize=9)
            _mark_points(sd_ax, surrogate, fixed, level, axes_vars)
        axes[0].set_ylabel(AXIS_LABELS[axes_vars[1]])
        sd_axes[0].set_ylabel(AXIS_LABELS[axes_vars[1]])
        if image is not None:
            fig.colorbar(image, ax=list(axes), label=M_EFF_RATIO_LABEL)
        if sd_image is not None:
            fig.colorbar(sd_image, ax=list(sd_axes),
                         label=r"standard uncertainty of $m_\mathrm{eff}$ / bed mass (% of the bed)")
        _figure_legend(fig, axes)
        fig.suptitle(f"Effective mass, surrogate {surrogate.method} ({surrogate.target} target): "
                     f"m_eff / bed mass ({SYMBOLS[axes_vars[0]]}, {SYMBOLS[axes_vars[1]]}) at "
                     f"fixed {SYMBOLS[fixed]}")
        if stem is not None:
            save_figure(fig, stem)
    return fig


def _slice_grid(surrogate: Surrogate, fixed: str, level: float, axes_vars: tuple[str, str]):
    """(x grid, y grid, query dict of the three coordinates) of one slice over the surrogate's
    domain, or None when the level is outside it."""
    lo, hi = surrogate.domain[fixed]
    if not lo <= level <= hi:
        return None
    x = np.geomspace(*surrogate.domain[axes_vars[0]], GRID_POINTS)  # x is always frequency
    y = np.linspace(*surrogate.domain[axes_vars[1]], GRID_POINTS)
    xx, yy = np.meshgrid(x, y)
    return xx, yy, {axes_vars[0]: xx, axes_vars[1]: yy, fixed: np.full_like(xx, level)}
