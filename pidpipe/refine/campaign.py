"""The loop bound to its files: resume from the table it wrote, write every round as it ends.

:func:`refine_files` is the one function a workflow step calls: it starts from the loop's table
when there is one (a campaign killed between or within rounds resumes there), else from the
grid's C_eq table; it saves the table after every change and ``rounds.csv`` after every round
(:mod:`pidpipe.refine.outputs`), and at the end writes ``summary.json`` (what stopped the loop,
what is open, each design's interval), ``verify_points.csv`` (the last round's verifying points)
and the convergence figure (:func:`pidpipe.figures.refine.plot_refine`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

import pandas as pd

from pidpipe.config.refine import RefineSettings
from pidpipe.design.ceq_table import read_ceq_table
from pidpipe.design.designs import Search
from pidpipe.design.optimisation import Budget, Environment
from pidpipe.figures.refine import plot_refine
from pidpipe.refine.loop import Outcome, refine
from pidpipe.refine.outputs import (read_table, write_rounds, write_summary, write_table,
                                     write_verify_points)
from pidpipe.refine.table import with_grid


def refine_files(grid_table: str | Path, out_dir: str | Path, fit: Callable, measure: Callable,
                 verify: Callable, cost: Callable, environments: list[Environment],
                 budget: Budget, search: Search, settings: RefineSettings,
                 flag_z: float, on_round: Callable | None = None,
                 mapper: Callable = map) -> Outcome:
    """Run (or resume) the loop and write its files under ``out_dir``.

    Parameters
    ----------
    grid_table : path
        The grid's C_eq table (``results/ceq_table.csv``). When ``out_dir`` has a table of the
        loop's, the loop resumes from it; if its grid rows are not the grid table's (the
        campaign was rerun or its grid changed), they are replaced by the grid table's and the
        loop's own rows are kept (:func:`pidpipe.refine.table.with_grid`).
    out_dir : path
        ``results/refine/state``: ``ceq_table.csv`` (the loop's table), ``rounds.csv``,
        ``summary.json``, ``verify_points.csv``, ``convergence.png`` and ``.pdf``.
    fit, measure, verify, cost, environments, budget, search, settings, flag_z
        As :func:`pidpipe.refine.loop.refine`.
    on_round : callable, optional
        ``on_round(record)`` after each round, once ``rounds.csv`` has it (to print it).
    mapper : callable
        As :func:`pidpipe.refine.loop.refine`.
    """
    out = Path(out_dir)
    table_path, rounds_path = out / "ceq_table.csv", out / "rounds.csv"
    grid = read_ceq_table(grid_table)
    table = with_grid(read_table(table_path), grid) if table_path.is_file() else grid
    outcome = refine(table, fit, measure, verify, cost, environments, budget, search, settings,
                     flag_z, save=lambda t: write_table(t, table_path),
                     on_round=lambda record: _round_done(record, rounds_path, on_round),
                     mapper=mapper)
    write_table(outcome.table, table_path)
    write_summary(outcome, out / "summary.json", pd.read_csv(rounds_path))
    write_verify_points(outcome.rounds[-1].comparison, out / "verify_points.csv")
    plot_refine(pd.read_csv(rounds_path), out / "convergence", settings.interval_fraction, flag_z)
    return outcome


def _round_done(record, rounds_path: Path, on_round: Callable | None) -> None:
    """Write the round into rounds.csv, then hand it to ``on_round``."""
    write_rounds([record], rounds_path)
    if on_round is not None:
        on_round(record)
