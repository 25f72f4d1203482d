"""The fidelity study's figure: C_eq error against CPU time for every variant and case.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from pidpipe.figures.common import RC_PARAMS, save_figure

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
        :data:`pidpipe.studies.fidelity.TABLE_COLUMNS`.
    summary : pandas.DataFrame
        :data:`pidpipe.studies.fidelity.SUMMARY_COLUMNS`.
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
    with mpl.rc_context(RC_PARAMS):
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
