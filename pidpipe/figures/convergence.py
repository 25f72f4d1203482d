"""The optimisation's convergence figure: objective against SLSQP iteration for every start, one panel
per design (rows: peak, band_mean, worst_case) and environment (columns).
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from pidpipe.design.optimisation import OptimisationResult
from pidpipe.figures.common import CEQ_LABEL, RC_PARAMS, save_figure

#: What each design's objective is, for titles and axes.
OBJECTIVES = {"peak": "total C_eq at the best point", "band_mean": "band-mean total C_eq",
              "worst_case": "band-minimum total C_eq"}


def plot_convergence(results: list[OptimisationResult], stem: str | Path | None = None) -> Figure:
    """Each design's objective against SLSQP iteration for every start, a panel per design and
    environment.

    Grey: starts that ended elsewhere (or did not converge); blue: starts that reached the
    global optimum; red, thick: the best start. A design whose band reaches G <= 1 says so in
    its title.

    Parameters
    ----------
    results : list of OptimisationResult
        Any designs of any environments (:func:`pidpipe.design.designs.optimise_designs`).
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib as mpl

    environments = list(dict.fromkeys(res.environment.name for res in results)) or [""]
    kinds = list(dict.fromkeys(res.kind for res in results)) or ["peak"]
    with mpl.rc_context(RC_PARAMS):
        fig = Figure(figsize=(5.2 * len(environments), 3.9 * len(kinds)), layout="constrained")
        axes = fig.subplots(len(kinds), len(environments), squeeze=False)
        for res in results:
            _draw_convergence(axes[kinds.index(res.kind)][environments.index(res.environment.name)], res)
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
    regime = "\nWARNING: band reaches G ≤ 1 (contact-model regime)" if res.regime_warning else ""
    ax.set_title(f"{res.environment.name}{clipped}: {res.kind}\nr = {d.fill_pct:.1f} %, "
                 f"n_c = {d.n_cells}, {OBJECTIVES[res.kind]} = {d.total_ceq_ns_m:.3g} N·s/m{regime}",
                 color="C3" if regime else "black")
    ax.set_xlabel("SLSQP iteration")
    ax.set_ylabel(f"{OBJECTIVES[res.kind]}, " + CEQ_LABEL)
    ax.legend(loc="lower right", framealpha=0.8)
