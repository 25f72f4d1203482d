"""Each design's convergence over the refinement's rounds: total C_eq and its 95 % band.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from pidpipe.figures.common import RC_PARAMS
from pidpipe.files import write_atomic

#: Column order of the panels.
DESIGN_ORDER: tuple[str, ...] = ("peak", "band_mean", "worst_case")


def plot_refine(rounds: pd.DataFrame, stem: str | Path, interval_fraction: float | None = None,
                flag_z: float = 2.0) -> list[Path]:
    """Total C_eq of each design against the round, with its 95 % interval.

    Parameters
    ----------
    rounds : pandas.DataFrame
        ``results/refine/rounds.csv`` (:data:`pidpipe.refine.outputs.ROUND_COLUMNS`): one row
        per round and design, with ``environment``, ``design``, ``round``,
        ``total_ceq_ns_m``, ``total_ceq_lo_ns_m``, ``total_ceq_hi_ns_m`` (N*s/m),
        ``cumulative_cpu_s`` (s) and ``verify_worst_abs_z``.
    stem : path
        Written (atomically) as ``<stem>.png`` and ``<stem>.pdf``.
    interval_fraction : float, optional
        The criterion: dashed lines at +- this fraction of the last round's value.
    flag_z : float
        ``verify.flag_z``: a worst |z| above it is drawn red.

    Returns
    -------
    list of Path
        The PNG and the PDF.

    Notes
    -----
    One row of panels per environment, one column per design kind. The band is the surrogate's
    95 % interval of the design's total C_eq; the top axis is the planned engine CPU spent by
    the end of the round (first and last round). Rounds whose design was verified show its
    worst |z| next to the point.
    """
    import matplotlib

    environments = list(dict.fromkeys(rounds["environment"]))
    kinds = [k for k in DESIGN_ORDER if k in set(rounds["design"])] + sorted(
        set(rounds["design"]) - set(DESIGN_ORDER))
    with matplotlib.rc_context(RC_PARAMS):
        figure = Figure(figsize=(3.4 * len(kinds), 2.8 * len(environments) + 0.6))
        axes = np.atleast_2d(figure.subplots(len(environments), len(kinds), squeeze=False))
        for i, env in enumerate(environments):
            for j, kind in enumerate(kinds):
                ax = axes[i, j]
                part = rounds[(rounds["environment"] == env) & (rounds["design"] == kind)]
                part = part.sort_values("round")
                _panel(ax, part, interval_fraction, flag_z, top_label=(i == 0))
                ax.set_title(f"{env}: {kind}", pad=22 if i == 0 else 14)
                if j == 0:
                    ax.set_ylabel("total $C_\\mathrm{eq}$ (N·s/m)")
                if i == len(environments) - 1:
                    ax.set_xlabel("round")
        figure.suptitle("Designs over the refinement's rounds (band: 95 % interval; numbers: "
                        f"verify's worst |z|, red above {flag_z:g}; dashed: the criterion)")
        figure.tight_layout()
        stem = Path(stem)
        return [write_atomic(stem.with_suffix(suffix), lambda tmp, s=suffix: figure.savefig(
            tmp, format=s[1:], dpi=150, bbox_inches="tight")) for suffix in (".png", ".pdf")]


def _panel(ax, part: pd.DataFrame, interval_fraction: float | None, flag_z: float,
           top_label: bool) -> None:
    """One design's value, band, criterion and worst |z| against the round."""
    x = part["round"].to_numpy(dtype=float)
    y = part["total_ceq_ns_m"].to_numpy(dtype=float)
    ax.fill_between(x, part["total_ceq_lo_ns_m"], part["total_ceq_hi_ns_m"], color="C0",
                    alpha=0.25, lw=0, label="95 % interval")
    ax.plot(x, y, "o-", color="C0", ms=4, label="surrogate")
    if interval_fraction is not None and y.size:
        for sign in (-1, 1):
            ax.axhline(y[-1] * (1 + sign * interval_fraction), color="0.4", ls="--", lw=0.8)
    for xi, yi, z in zip(x, y, part["verify_worst_abs_z"].to_numpy(dtype=float)):
        if np.isfinite(z):
            ax.annotate(f"{z:.1f}", (xi, yi), textcoords="offset points", xytext=(0, 6),
                        ha="center", fontsize=7, color="C3" if z > flag_z else "k")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if x.size:
        top = ax.secondary_xaxis("top", functions=(_identity, _identity))
        top.set_xticks(x[[0, -1]] if x.size > 1 else x)
        cpu = part["cumulative_cpu_s"].to_numpy(dtype=float)
        top.set_xticklabels([f"{cpu[0]:.0f} s", f"{cpu[-1]:.0f} s"][: min(2, x.size)],
                            fontsize=7)
        if top_label:
            top.set_xlabel("planned engine CPU spent", fontsize=7, labelpad=2)


def _identity(values):
    return values
