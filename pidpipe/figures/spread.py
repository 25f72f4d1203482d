"""The optimum's spread: every bootstrap draw's design (fill r, objective) per environment.

One panel per environment. Each design (peak, band_mean, worst_case) has its own colour: small
dots are the draws' whole-cell designs, the large marker is the design on the table itself with
its percentile intervals of r and of the objective as error bars. The legend gives each design's
interval of n_c and how often each local optimum won. A design whose band reaches G <= 1 says
so in the panel's title.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from pidpipe.design.optimisation import OptimisationResult
from pidpipe.figures.common import AXIS_LABELS, CEQ_LABEL, RC_PARAMS, save_figure

_COLOURS = {"peak": "C3", "band_mean": "C0", "worst_case": "C2"}


def plot_optimum_spread(results: list[OptimisationResult], draws: pd.DataFrame,
                        stem: str | Path | None = None, note: str = "") -> Figure:
    """The bootstrap's designs and intervals, one panel per environment.

    Parameters
    ----------
    results : list of OptimisationResult
        With ``uncertainty`` from :func:`pidpipe.design.bootstrap.bootstrap_designs` (or None).
    draws : pandas.DataFrame
        The draws' table (columns of :data:`pidpipe.design.bootstrap.DRAW_COLUMNS`); may be empty.
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.
    note : str
        Shown when there are no draws (why there is no bootstrap).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib as mpl

    environments = list(dict.fromkeys(res.environment.name for res in results)) or [""]
    with mpl.rc_context(RC_PARAMS):
        fig = Figure(figsize=(5.4 * len(environments), 4.8), layout="constrained")
        axes = fig.subplots(1, len(environments), squeeze=False)[0]
        for ax, env in zip(axes, environments):
            mine = [res for res in results if res.environment.name == env]
            _draw_environment(ax, mine, draws, note)
        if stem is not None:
            save_figure(fig, stem)
    return fig


def _draw_environment(ax, results: list[OptimisationResult], draws: pd.DataFrame, note: str) -> None:
    """One environment's panel."""
    for res in results:
        colour = _COLOURS.get(res.kind, "0.3")
        mine = draws[(draws["environment"] == res.environment.name) & (draws["design"] == res.kind)
                     & draws["ok"].astype(bool)] if len(draws) else draws
        if len(mine):
            ax.scatter(mine["fill_pct"], mine["total_ceq_ns_m"], s=9, alpha=0.35, color=colour,
                       linewidths=0)
        d, u = res.design, res.uncertainty or {}
        intervals = u.get("intervals", {})
        xerr = _error_bar(d.fill_pct, intervals.get("fill_pct"))
        yerr = _error_bar(d.total_ceq_ns_m, intervals.get("total_ceq_ns_m"))
        label = f"{res.kind}: r = {d.fill_pct:.1f} %, n_c = {d.n_cells}"
        if "n_cells" in intervals:
            lo, hi = intervals["n_cells"]
            label += f" [{lo:.0f}, {hi:.0f}]"
        if u.get("used"):
            label += f"\nwins: {u['wins_text']}"
        ax.errorbar([d.fill_pct], [d.total_ceq_ns_m], xerr=xerr, yerr=yerr, fmt="o", ms=8,
                    color=colour, markeredgecolor="black", capsize=4, zorder=4, label=label)
    res = results[0]
    u = res.uncertainty or {}
    if u.get("used"):
        what = (f"{u['used']} bootstrap draws; bars: {100 * u['confidence']:g} % intervals")
        loo = u.get("surrogate_loo_rel_error")
        if loo is not None:
            what += f"\nsurrogate leave-one-out error {100 * loo:.1f} % RMS (not in the bars)"
    else:
        what = note or "no bootstrap"
    title = f"{res.environment.name}\n{what}"
    if res.regime_warning:
        title += "\nWARNING: band reaches G ≤ 1 (contact-model regime)"
    ax.set_title(title, color="C3" if res.regime_warning else "black", fontsize=9)
    ax.set_xlabel(AXIS_LABELS["fill_pct"] + " of the whole-cell design")
    ax.set_ylabel("design's objective (peak / band mean / band minimum), " + CEQ_LABEL)
    ax.legend(loc="best", fontsize=7, framealpha=0.85)


def _error_bar(value: float, interval) -> np.ndarray | None:
    """Asymmetric error bar (2, 1) from an interval [lo, hi], or None."""
    if not interval:
        return None
    lo, hi = interval
    return np.array([[max(value - lo, 0.0)], [max(hi - value, 0.0)]])
