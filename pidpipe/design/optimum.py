"""The optimisation stage on one surrogate: every design of every environment, with its bootstrap.

This is what both the workflow's ``optimise_environments`` rule and ``pidpipe optimise`` run.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import pandas as pd

from pidpipe.design.bootstrap import (
    DRAW_COLUMNS,
    Bootstrap,
    bootstrap_designs,
    has_sem,
    loo_rel_error,
)
from pidpipe.design.designs import DESIGN_KINDS, Search, optimise_design, optimise_designs
from pidpipe.design.optimisation import Budget, Environment, OptimisationResult
from pidpipe.design.surrogate import Surrogate

logger = logging.getLogger("pidpipe.campaign")


@dataclass
class Optimum:
    """The designs (three per environment, in order), the bootstrap's draws and what was skipped."""

    results: list[OptimisationResult]
    draws: pd.DataFrame
    note: str


def optimise_panel(surrogate: Surrogate, environments: list[Environment], budget: Budget,
                   search: Search, bootstrap: Bootstrap, workers: int = 1,
                   loo: float | None = None) -> Optimum:
    """Optimise every design, then bootstrap them when the table has SEMs and draws > 0.

    Parameters
    ----------
    surrogate : Surrogate
    environments : list of Environment
    budget : Budget
    search : Search
    bootstrap : Bootstrap
    workers : int
        Processes the work is shared among: the designs and the leave-one-out error, then the
        bootstrap's draws (forked; each design and draw is computed as alone, so the results are
        the same for any number).
    loo : float, optional
        The surrogate's leave-one-out RMS relative error when it is known already (the
        workflow's cross-validation, :func:`pidpipe.design.bootstrap.loo_from_cross_validation`);
        computed here otherwise (a GP refitted per fold: the longest part of this stage).

    Returns
    -------
    Optimum
        ``note`` says why there are no intervals, if there are none ('' otherwise).
    """
    results, loo = _designs_and_loo(surrogate, environments, budget, search, workers, loo)
    draws = pd.DataFrame(columns=list(DRAW_COLUMNS))
    note = ""
    if bootstrap.draws == 0:
        note = "bootstrap off (optimisation.bootstrap.draws = 0): no intervals"
    elif not has_sem(surrogate):
        note = ("the table has no ceq_coupon_sem_ns_m for every fitted row: no bootstrap, no "
                "intervals")
    else:
        draws = bootstrap_designs(surrogate, results, budget, search, bootstrap, loo=loo,
                                  workers=workers)
    if note:
        logger.warning(note)
        for res in results:
            res.uncertainty = {"draws": 0, "used": 0,
                               "surrogate_loo_rel_error": loo if math.isfinite(loo) else None}
    return Optimum(results=results, draws=draws, note=note)


def _designs_and_loo(surrogate: Surrogate, environments: list[Environment], budget: Budget,
                     search: Search, workers: int,
                     loo: float | None = None) -> tuple[list[OptimisationResult], float]:
    """:func:`~pidpipe.design.designs.optimise_designs` and :func:`~pidpipe.design.bootstrap.loo_rel_error`
    (unless ``loo`` is given), shared among ``workers`` forked processes: the leave-one-out
    error first, then the designs, each one task (independent of the others, so each result is
    the one computed alone)."""
    if workers <= 1:
        return (optimise_designs(surrogate, environments, budget, search),
                loo_rel_error(surrogate) if loo is None else loo)
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    tasks = [(env, kind) for env in environments for kind in DESIGN_KINDS]
    with ProcessPoolExecutor(max_workers=int(workers), initializer=_share,
                             initargs=((surrogate, budget, search),),
                             mp_context=multiprocessing.get_context("fork")) as pool:
        computed = pool.submit(_loo) if loo is None else None
        results = list(pool.map(_design, tasks))
        return results, computed.result() if computed is not None else loo


_PANEL: tuple = ()
"""The surrogate, budget and search of the running panel (set in each worker by :func:`_share`)."""


def _share(panel: tuple) -> None:
    global _PANEL
    _PANEL = panel


def _loo() -> float:
    return loo_rel_error(_PANEL[0])


def _design(task: tuple) -> OptimisationResult:
    surrogate, budget, search = _PANEL
    environment, kind = task
    return optimise_design(surrogate, environment, budget, kind, search)
