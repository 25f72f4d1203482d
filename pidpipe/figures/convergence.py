"""The optimisation's convergence figure: objective against SLSQP iteration for every start, per environment.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from pidpipe.design.optimisation import OptimisationResult
from pidpipe.figures.common import CEQ_LABEL, RC_PARAMS, save_figure


def plot_convergence(results: list[OptimisationResult], stem: str | Path | None = None) -> Figure:
    """Total C_eq against SLSQP iteration for every start, one panel per environment.

    Grey: starts that ended elsewhere (or did not converge); blue: starts that reached the
    global optimum; red, thick: the best start.

    Parameters
    ----------
    results : list of OptimisationResult
    stem : str or Path, optional
        If given, save as ``<stem>.png`` and ``<stem>.pdf``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib as mpl

    with mpl.rc_context(RC_PARAMS):
        fig = Figure(figsize=(4.8 * max(len(results), 1), 4.2), layout="constrained")
        axes = fig.subplots(1, max(len(results), 1), squeeze=False)[0]
        for ax, res in zip(axes, results):
            _draw_convergence(ax, res)
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
    ax.set_title(f"{res.environment.name}{clipped}\nr = {d.fill_pct:.1f} %, n_c = {d.n_cells}, "
                 f"total C_eq = {d.total_ceq_ns_m:.3g} N·s/m")
    ax.set_xlabel("SLSQP iteration")
    ax.set_ylabel("total " + CEQ_LABEL + " of filled cells")
    ax.legend(loc="lower right", framealpha=0.8)
