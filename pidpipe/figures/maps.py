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
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import LogNorm
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
                   ncols=len(handles), frameon=False)


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
