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
from pidpipe.design.designs import Search, optimise_designs
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
                   search: Search, bootstrap: Bootstrap, workers: int = 1) -> Optimum:
    """Optimise every design, then bootstrap them when the table has SEMs and draws > 0.

    Parameters
    ----------
    surrogate : Surrogate
    environments : list of Environment
    budget : Budget
    search : Search
    bootstrap : Bootstrap
    workers : int
        Processes the bootstrap's draws are shared among (the same draws for any number).

    Returns
    -------
    Optimum
        ``note`` says why there are no intervals, if there are none ('' otherwise).
    """
    results = optimise_designs(surrogate, environments, budget, search)
    loo = loo_rel_error(surrogate)
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
