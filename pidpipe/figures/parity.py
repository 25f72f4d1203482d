"""Parity figure of the grid check: C_eq per cell from the compiled DEM against LIGGGHTS.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from pidpipe.figures.common import CEQ_LABEL, RC_PARAMS, save_figure


def plot_parity(table: pd.DataFrame, stem: str | Path, coverage: float = 2.0) -> list[Path]:
    """C_eq,dem against C_eq,liggghts per case on log axes, with ``coverage`` x SEM error bars.

    Parameters
    ----------
    table : pandas.DataFrame
        The grid check (:func:`pidpipe.studies.grid_check.grid_table`).
    stem : path
        Written as ``<stem>.png`` and ``<stem>.pdf``.
    coverage : float
        Error bars are +- coverage standard errors (the agreement criterion's).

    Returns
    -------
    list of Path
        The PNG and the PDF.

    Notes
    -----
    Cases both solvers passed are circles, filled when they agree within ``coverage`` combined
    SEM; cases flagged (or failed) by either solver are crosses. The diagonal is equality. Error
    bars that would reach below zero on a log axis are cut at the axis.
    """
    import matplotlib

    with matplotlib.rc_context(RC_PARAMS):
        figure = Figure(figsize=(5.6, 5.2))
        ax = figure.subplots()
        finite = table[np.isfinite(table["ceq_cell_liggghts_ns_m"])
                       & np.isfinite(table["ceq_cell_dem_ns_m"])
                       & (table["ceq_cell_liggghts_ns_m"] > 0) & (table["ceq_cell_dem_ns_m"] > 0)]
        groups = (
            ("both ok, agree", finite["both_ok"] & finite["agree"], dict(fmt="o", color="C0")),
            ("both ok, differ", finite["both_ok"] & ~finite["agree"],
             dict(fmt="o", color="C3", mfc="none")),
            ("flagged by a solver", ~finite["both_ok"], dict(fmt="x", color="0.4")),
        )
        for label, mask, style in groups:
            part = finite[mask]
            if part.empty:
                continue
            x, y = part["ceq_cell_liggghts_ns_m"], part["ceq_cell_dem_ns_m"]
            xerr = coverage * part["ceq_cell_liggghts_sem_ns_m"]
            yerr = coverage * part["ceq_cell_dem_sem_ns_m"]
            ax.errorbar(x, y, xerr=[np.minimum(xerr, 0.999 * x), xerr],
                        yerr=[np.minimum(yerr, 0.999 * y), yerr], capsize=2, ms=5, lw=0.8,
                        label=f"{label} ({len(part)})", **style)
        if not finite.empty:
            lo = float(np.min(finite[["ceq_cell_liggghts_ns_m", "ceq_cell_dem_ns_m"]].to_numpy()))
            hi = float(np.max(finite[["ceq_cell_liggghts_ns_m", "ceq_cell_dem_ns_m"]].to_numpy()))
            span = np.array([lo / 2.0, hi * 2.0])
            ax.plot(span, span, color="0.6", lw=0.8, zorder=0, label="equal")
            ax.set_xlim(*span)
            ax.set_ylim(*span)
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_minor_formatter(NullFormatter())    # decade labels only: no overlaps
        ax.set_xlabel(f"LIGGGHTS 3.8: {CEQ_LABEL} per cell")
        ax.set_ylabel(f"compiled DEM: {CEQ_LABEL} per cell")
        ax.set_title(f"Every case of the grid in both solvers (±{coverage:g} SEM)")
        ax.legend(loc="upper left")
        return save_figure(figure, stem)
