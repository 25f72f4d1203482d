"""Parity figure of the designs' check: the DEM's C_eq and m_eff of each verifying case against
the surrogates'.
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

M_EFF_LABEL = r"one cell's $m_\mathrm{eff}$ (kg)"

#: The columns of each panel: (value, its standard uncertainty) for the surrogate (x) and the
#: DEM (y), the z-score and the off flag.
_CEQ = dict(x="ceq_coupon_surrogate_ns_m", xu="surrogate_u_ns_m", y="ceq_coupon_dem_ns_m",
            yu="ceq_coupon_dem_sem_ns_m", z="z_combined", off="surrogate_off")
_M_EFF = dict(x="m_eff_surrogate_kg", xu="m_eff_surrogate_u_kg", y="m_eff_dem_kg",
              yu="m_eff_dem_sem_kg", z="z_m_eff", off="m_eff_off")


def plot_verify(table: pd.DataFrame, stem: str | Path, flag_z: float = 2.0) -> list[Path]:
    """DEM against surrogate, one point per distinct (design, case): the coupon's C_eq (left)
    and one cell's effective mass m_eff (right).

    Parameters
    ----------
    table : pandas.DataFrame
        The verification table (``results/verify.csv``): ``design``, ``case_id``,
        ``ceq_coupon_surrogate_ns_m``, ``surrogate_u_ns_m``, ``ceq_coupon_dem_ns_m``,
        ``ceq_coupon_dem_sem_ns_m`` (N*s/m), ``surrogate_off`` and ``engine``; optionally
        ``z_combined``, and the m_eff columns ``m_eff_surrogate_kg``, ``m_eff_surrogate_u_kg``,
        ``m_eff_dem_kg``, ``m_eff_dem_sem_kg`` (kg), ``z_m_eff`` and ``m_eff_off`` (absent or
        NaN: the m_eff panel says that m_eff was not compared).
    stem : path
        Written as ``<stem>.png`` and ``<stem>.pdf``.
    flag_z : float
        The flagging threshold on |z|, for the legends and the panels' worst-|z| line.

    Returns
    -------
    list of Path
        The PNG and the PDF.

    Notes
    -----
    Error bars are +- one standard uncertainty (DEM: its SEM; surrogate: its predictive standard
    uncertainty). Cases where the surrogate is off (|z| > flag_z) are drawn red, and each panel
    states its worst |z| against flag_z. C_eq: log axes when the values span more than
    :data:`LOG_SPAN` (bars that would reach below zero cut at the axis), else linear from 0.
    m_eff: linear axes (an airborne bed's m_eff is near zero or negative). The diagonal is
    equality.
    """
    import matplotlib

    with matplotlib.rc_context(RC_PARAMS):
        figure = Figure(figsize=(11.6, 5.4), layout="constrained")
        ax_ceq, ax_m = figure.subplots(1, 2)
        engines = ", ".join(sorted(set(table["engine"].dropna().astype(str)) - {""})) or "?"
        _ceq_panel(ax_ceq, table, flag_z, engines)
        _m_eff_panel(ax_m, table, flag_z, engines)
        figure.suptitle("Designs checked by DEM at their band's corners and centre (±1 u)")
        return save_figure(figure, stem)


def _ceq_panel(ax, table: pd.DataFrame, flag_z: float, engines: str) -> None:
    x_all, y_all = table[_CEQ["x"]], table[_CEQ["y"]]
    shown = table[np.isfinite(x_all) & np.isfinite(y_all) & (x_all > 0) & (y_all > 0)]
    _points(ax, shown, _CEQ, flag_z, positive=True)
    if not shown.empty:
        values = shown[[_CEQ["x"], _CEQ["y"]]].to_numpy(dtype=float)
        span = np.array([values.min() / 1.5, values.max() * 1.5])
        if values.max() / values.min() > LOG_SPAN:
            ax.set_xscale("log")
            ax.set_yscale("log")
            for axis in (ax.xaxis, ax.yaxis):
                axis.set_minor_formatter(NullFormatter())
        else:
            span = np.array([0.0, values.max() * 1.3])
        _equality(ax, span)
    ax.set_xlabel(f"surrogate: coupon {CEQ_LABEL}")
    ax.set_ylabel(f"DEM ({engines}): coupon {CEQ_LABEL}")
    ax.set_title(r"coupon $C_\mathrm{eq}$")
    _worst_z(ax, shown, _CEQ["z"], flag_z)
    ax.legend(loc="upper left")


def _m_eff_panel(ax, table: pd.DataFrame, flag_z: float, engines: str) -> None:
    ax.set_xlabel(f"surrogate: {M_EFF_LABEL}")
    ax.set_ylabel(f"DEM ({engines}): {M_EFF_LABEL}")
    ax.set_title(r"one cell's effective mass $m_\mathrm{eff}$")
    if all(column in table for column in (_M_EFF["x"], _M_EFF["y"])):
        shown = table[np.isfinite(table[_M_EFF["x"]]) & np.isfinite(table[_M_EFF["y"]])]
    else:
        shown = table.iloc[:0]
    if shown.empty:
        ax.text(0.5, 0.5, "m_eff not compared\n(no m_eff surrogate or no harmonics)",
                transform=ax.transAxes, ha="center", va="center", color="0.4")
        return
    _points(ax, shown, _M_EFF, flag_z, positive=False)
    x, y = shown[_M_EFF["x"]].to_numpy(float), shown[_M_EFF["y"]].to_numpy(float)
    xu = shown[_M_EFF["xu"]].fillna(0.0).to_numpy(float)
    yu = shown[_M_EFF["yu"]].fillna(0.0).to_numpy(float)
    lo, hi = min((x - xu).min(), (y - yu).min(), 0.0), max((x + xu).max(), (y + yu).max())
    pad = 0.1 * (hi - lo) if hi > lo else max(abs(hi), 1e-9)
    _equality(ax, np.array([lo - pad, hi + pad]))
    ax.ticklabel_format(axis="both", style="sci", scilimits=(-3, 3), useMathText=True)
    _worst_z(ax, shown, _M_EFF["z"], flag_z)
    ax.legend(loc="upper left")


def _points(ax, shown: pd.DataFrame, columns: dict, flag_z: float, positive: bool) -> None:
    """One error-bar series per design and off flag (off: red, and named in the legend)."""
    off_column = shown[columns["off"]] if columns["off"] in shown else pd.Series(False, shown.index)
    off_flags = off_column.fillna(False).astype(bool)
    for design, part in shown.groupby("design", sort=False):
        for off in (False, True):
            rows = part[off_flags.loc[part.index] == off]
            if rows.empty:
                continue
            x, y = rows[columns["x"]], rows[columns["y"]]
            xerr, yerr = rows[columns["xu"]].fillna(0.0), rows[columns["yu"]].fillna(0.0)
            if positive:          # on log axes a bar below zero is cut at the axis
                xerr_pair, yerr_pair = ([np.minimum(xerr, 0.999 * x), xerr],
                                        [np.minimum(yerr, 0.999 * y), yerr])
            else:
                xerr_pair, yerr_pair = xerr, yerr
            style = dict(color="C3" if off else _COLOURS.get(design, "C1"),
                         **_MARKER_STYLE.get(design, {}))
            label = f"{design}" + (f", off (|z| > {flag_z:g})" if off else "") + f" ({len(rows)})"
            ax.errorbar(x, y, xerr=xerr_pair, yerr=yerr_pair, capsize=2, lw=0.8,
                        fmt=_MARKERS.get(design, "^"), label=label, **style)


def _equality(ax, span: np.ndarray) -> None:
    ax.plot(span, span, color="0.6", lw=0.8, zorder=0, label="equal")
    ax.set_xlim(*span)
    ax.set_ylim(*span)


def _worst_z(ax, shown: pd.DataFrame, column: str, flag_z: float) -> None:
    """The panel's worst |z| against the threshold, bottom right."""
    if column not in shown:
        return
    z = np.abs(shown[column].to_numpy(dtype=float))
    z = z[np.isfinite(z)]
    if z.size == 0:
        return
    worst = z.max()
    ax.text(0.97, 0.03, f"worst |z| {worst:.2f} ({'above' if worst > flag_z else 'within'} "
            f"the threshold {flag_z:g})", transform=ax.transAxes, ha="right", va="bottom",
            color="C3" if worst > flag_z else "0.2")
