"""Parity figure of the designs' check: the DEM's C_eq of each verifying case against the surrogate's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from pidpipe.figures.common import CEQ_LABEL, RC_PARAMS, save_figure

#: Marker of each design kind: band_mean large and open, so that a case the peak design shares
#: (drawn small and filled) shows inside it.
_MARKERS = {"band_mean": "o", "peak": "s"}
_MARKER_STYLE = {"band_mean": dict(ms=9, mfc="none", mew=1.2), "peak": dict(ms=4)}
_COLOURS = {"band_mean": "C0", "peak": "C2"}

#: Log axes only when the values span more than this ratio (else few decade ticks show).
LOG_SPAN = 20.0


def plot_verify(table: pd.DataFrame, stem: str | Path, flag_z: float = 2.0) -> list[Path]:
    """C_eq of the coupon, DEM against surrogate, one point per distinct (design, case).

    Parameters
    ----------
    table : pandas.DataFrame
        The verification table (``results/verify.csv``): ``design``, ``case_id``,
        ``ceq_coupon_surrogate_ns_m``, ``surrogate_u_ns_m``, ``ceq_coupon_dem_ns_m``,
        ``ceq_coupon_dem_sem_ns_m`` (N*s/m), ``surrogate_off`` and ``engine``.
    stem : path
        Written as ``<stem>.png`` and ``<stem>.pdf``.
    flag_z : float
        The flagging threshold, for the legend.

    Returns
    -------
    list of Path
        The PNG and the PDF.

    Notes
    -----
    Error bars are +- one standard uncertainty (DEM: its SEM; surrogate: u_s). Cases where the
    surrogate is off (|z| > flag_z) are drawn red. Log axes when the values span more than
    :data:`LOG_SPAN` (bars that would reach below zero cut at the axis), else linear from 0;
    the diagonal is equality.
    """
    import matplotlib

    with matplotlib.rc_context(RC_PARAMS):
        figure = Figure(figsize=(5.8, 5.2))
        ax = figure.subplots()
        x_all, y_all = table["ceq_coupon_surrogate_ns_m"], table["ceq_coupon_dem_ns_m"]
        shown = table[np.isfinite(x_all) & np.isfinite(y_all) & (x_all > 0) & (y_all > 0)]
        for design, part in shown.groupby("design", sort=False):
            for off in (False, True):
                rows = part[part["surrogate_off"].astype(bool) == off]
                if rows.empty:
                    continue
                x, y = rows["ceq_coupon_surrogate_ns_m"], rows["ceq_coupon_dem_ns_m"]
                xerr, yerr = rows["surrogate_u_ns_m"].fillna(0.0), rows["ceq_coupon_dem_sem_ns_m"]
                style = dict(color="C3" if off else _COLOURS.get(design, "C1"),
                             **_MARKER_STYLE.get(design, {}))
                label = f"{design}" + (f", off (|z| > {flag_z:g})" if off else "") + f" ({len(rows)})"
                ax.errorbar(x, y, xerr=[np.minimum(xerr, 0.999 * x), xerr],
                            yerr=[np.minimum(yerr, 0.999 * y), yerr], capsize=2, lw=0.8,
                            fmt=_MARKERS.get(design, "^"), label=label, **style)
        if not shown.empty:
            values = shown[["ceq_coupon_surrogate_ns_m", "ceq_coupon_dem_ns_m"]].to_numpy(dtype=float)
            span = np.array([values.min() / 1.5, values.max() * 1.5])
            if values.max() / values.min() > LOG_SPAN:
                ax.set_xscale("log")
                ax.set_yscale("log")
                for axis in (ax.xaxis, ax.yaxis):
                    axis.set_minor_formatter(NullFormatter())
            else:
                span = np.array([0.0, values.max() * 1.3])
            ax.plot(span, span, color="0.6", lw=0.8, zorder=0, label="equal")
            ax.set_xlim(*span)
            ax.set_ylim(*span)
        engines = ", ".join(sorted(set(table["engine"].dropna().astype(str)) - {""})) or "?"
        ax.set_xlabel(f"surrogate: coupon {CEQ_LABEL}")
        ax.set_ylabel(f"DEM ({engines}): coupon {CEQ_LABEL}")
        ax.set_title("Designs checked by DEM at their band's corners and centre (±1 u)")
        ax.legend(loc="upper left")
        return save_figure(figure, stem)
