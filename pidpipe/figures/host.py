"""The host-coupled check's figure: amplitude and loss factor against forcing frequency.

One column per force level. Top row: the host's displacement amplitude |X| (um) for the coupled
host (markers, error bars one standard error over the measured cycles; hollow where the point
was not steady), the two dashpot models and, when there is an m_eff surrogate, the damper model
(c) with the spheres' effective mass (lines, shaded one standard deviation over the redrawn
surrogates; crosses where the host's Gamma lay outside the surrogate's G range and C_eq was read
at its edge). Bottom row:
the loss factor eta (energy dissipated per cycle over 2 pi x the peak strain energy) of each.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from pidpipe.figures.common import RC_PARAMS

_STYLE = {"coupled": ("C3", "coupled DEM (a)"),
          "equivalent": ("C0", "dashpot C_eq, mass m_h + m_p (b)"),
          "equivalent_bare_mass": ("C2", "dashpot C_eq, mass m_h (b')"),
          "equivalent_mass": ("C1", "damper: C_eq and m_eff(f, Γ), mass m_h + n_c m_eff (c)")}


def plot_host(curves: pd.DataFrame) -> Figure:
    """The figure of a curves table (:func:`pidpipe.loop.host.curves_table`'s columns).

    Parameters
    ----------
    curves : pandas.DataFrame
        Columns ``model, level, force_n, freq_hz, amplitude_m, amplitude_unc_m, loss_factor,
        loss_factor_unc, steady, surrogate_clipped``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib as mpl

    levels = sorted(curves["level"].unique())
    with mpl.rc_context(RC_PARAMS):
        fig = Figure(figsize=(4.6 * len(levels), 7.2), layout="constrained")
        axes = fig.subplots(2, len(levels), squeeze=False, sharex="col")
        for column, level in enumerate(levels):
            mine = curves[curves["level"] == level]
            top, bottom = axes[0, column], axes[1, column]
            for model, (colour, label) in _STYLE.items():
                curve = mine[mine["model"] == model].sort_values("freq_hz")
                if curve.empty:
                    continue
                _draw(top, curve, "amplitude_m", "amplitude_unc_m", 1e6, colour, label, model)
                _draw(bottom, curve, "loss_factor", "loss_factor_unc", 1.0, colour, label, model)
            top.set_title(f"F0 = {mine['force_n'].iloc[0]:g} N")
            top.set_ylabel("host amplitude |X| (µm)")
            bottom.set_ylabel("loss factor η (–)")
            bottom.set_xlabel("forcing frequency f (Hz)")
            top.grid(alpha=0.3)
            bottom.grid(alpha=0.3)
        axes[0, 0].legend(loc="upper left", fontsize=8)
    return fig


def _draw(ax, curve: pd.DataFrame, column: str, unc: str, scale: float, colour: str, label: str,
          model: str) -> None:
    f = curve["freq_hz"].to_numpy()
    y = curve[column].to_numpy() * scale
    e = np.nan_to_num(curve[unc].to_numpy() * scale)
    if model == "coupled":
        steady = curve["steady"].astype(bool).to_numpy()
        ax.errorbar(f[steady], y[steady], yerr=e[steady], fmt="o", ms=5, color=colour,
                    capsize=3, label=label, zorder=3)
        if (~steady).any():
            ax.errorbar(f[~steady], y[~steady], yerr=e[~steady], fmt="o", ms=5, color=colour,
                        mfc="white", capsize=3, label="coupled, not steady", zorder=3)
        return
    clipped = curve["surrogate_clipped"].astype(bool).to_numpy()
    ax.plot(f, y, "-", color=colour, label=label, lw=1.6)
    if clipped.any():
        ax.plot(f[clipped], y[clipped], color=colour, lw=0, marker="x", ms=5,
                label=("dashpot: Γ outside the surrogate's G range, C_eq at its edge"
                       if model == "equivalent" else "_nolegend_"))
    ax.fill_between(f, y - e, y + e, color=colour, alpha=0.2, lw=0)
