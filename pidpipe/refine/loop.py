"""The refinement loop, engine-free: rounds of fit, optimise, verify, choose, run.

Round N (:func:`refine`):

1. fit the surrogate to the table of rounds < N (:func:`pidpipe.refine.table.fit_table`);
2. optimise every design (:func:`pidpipe.design.designs.optimise_designs`);
3. take each design's 95 % interval of its total C_eq (:mod:`pidpipe.refine.intervals`);
4. verify the designs whose interval meets ``refine.interval_fraction``: their points without a
   verifying run are run (``verify``), and every point's |z| computed
   (:mod:`pidpipe.refine.verification`);
5. stop when every design's interval meets the criterion and every one of its points passes
   (``criterion met``), or at ``refine.max_rounds`` (``max rounds reached``);
6. choose the round's cases (:mod:`pidpipe.refine.choice`: reruns of the failing verifying
   points, and cases for the designs whose interval is still wide), keep those that fit in what
   is left of ``refine.max_cpu_s`` (planned CPU, in the order chosen), and run them; when none
   fits, stop (``cpu budget spent``), and when there is nothing to choose (``nothing left to run``).

The table is the loop's only state, and it is append-only: every row says its round, its
action and its planned CPU (:mod:`pidpipe.refine.table`). Every decision of round N depends on
rows of rounds < N, and on the verifying runs of round N, which are themselves decided from
those rows; so a loop restarted from the table it saved (after a round, or within one) decides
the same round again, finds the rows it has, and asks the engine only for the missing ones. The
engine's planned CPU comes from ``cost`` (not the measured CPU), so a loaded machine does not
change what the loop does.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pandas as pd

from pidpipe.config.refine import RefineSettings
from pidpipe.design.ceq_table import SEM_COLUMN, VALUE_COLUMN
from pidpipe.design.designs import Search, optimise_designs
from pidpipe.design.optimisation import Budget, Environment, OptimisationResult
from pidpipe.refine.candidates import Request, design_name, verify_points
from pidpipe.refine.choice import choose
from pidpipe.refine.intervals import DesignInterval, design_intervals
from pidpipe.refine.table import (
    VERIFY_SOURCE,
    append_rows,
    as_stored,
    fit_table,
    last_round,
    round_source,
    rows_of_round,
    spent_cpu_s,
    start_table,
    verify_rows,
)
from pidpipe.refine.verification import compare, worst_abs_z

#: Why the loop stopped.
CRITERION_MET = "criterion met"
BUDGET_SPENT = "cpu budget spent"
MAX_ROUNDS = "max rounds reached"
NOTHING_TO_RUN = "nothing left to run"


@dataclass
class RoundRecord:
    """What one round found and did.

    ``engine_cpu_s`` is the planned CPU of the rows the round added, ``cumulative_cpu_s`` that of
    every row the loop has added up to the round's end, s; ``worst_z`` maps each design to its
    points' largest |z| (NaN when not verified in the round).
    """

    round: int
    intervals: list[DesignInterval]
    worst_z: dict[str, float]
    open: list[str]
    cases_added: int = 0
    cases_extended: int = 0
    verify_cases: int = 0
    engine_cpu_s: float = 0.0
    cumulative_cpu_s: float = 0.0
    comparison: pd.DataFrame = field(default_factory=pd.DataFrame, repr=False)


@dataclass
class Outcome:
    """The loop's end: why it stopped, what is still open, the rounds run, the final table."""

    stopped_by: str
    open: list[str]
    rounds: list[RoundRecord]
    table: pd.DataFrame
    results: list[OptimisationResult]
    intervals: list[DesignInterval]
    model: object = None


def refine(table: pd.DataFrame, fit: Callable, measure: Callable, verify: Callable,
           cost: Callable[[Request], float], environments: list[Environment], budget: Budget,
           search: Search, settings: RefineSettings, flag_z: float,
           save: Callable[[pd.DataFrame], None] | None = None,
           on_round: Callable[[RoundRecord], None] | None = None,
           mapper: Callable = map) -> Outcome:
    """Run the loop (see the module's text) from ``table`` until a stop.

    Parameters
    ----------
    table : pandas.DataFrame
        The grid's C_eq table (rows of ``results/ceq_table.csv``), or a table the loop saved.
    fit : callable
        ``fit(table, start=None) -> model`` (``start``: a model of a table a few rows apart,
        which may start the fit; the choice's fantasies pass it); the model has ``domain``,
        ``predict(f, G, r)`` and
        ``predict_with_uncertainty(f, G, r) -> (mean, std)`` (coupon C_eq, N*s/m; arrays of
        the inputs' shape; std the latent function's, without the noise), optionally
        ``predict_joint(f, G, r) -> (mean, covariance)``; it fits the rows the project's fit
        policy keeps (:mod:`pidpipe.design.fit_policy`: status ``ok``, and rows flagged for
        precision only, each with its SEM as its noise), as
        :func:`pidpipe.design.surrogate.fit_surrogate` with ``method="gp"`` does. It may refuse
        points outside its domain (:class:`~pidpipe.errors.DomainError`).
    measure : callable
        ``measure(cases, more) -> rows``: runs the new cases (each a
        :class:`~pidpipe.refine.candidates.Request`) and extends the
        existing ones (``more``, each with the row it extends as ``base`` and the effort factor)
        and returns one row per request, in order (f, G, r, C_eq, SEM, status, anything else).
    verify : callable
        ``verify(points) -> rows``: runs verifying cases (requests), one row per point with
        its DEM C_eq and SEM.
    cost : callable
        ``cost(request) -> planned engine CPU, s``.
    environments, budget, search
        As :func:`pidpipe.design.designs.optimise_designs`.
    settings : RefineSettings
    flag_z : float
        ``verify.flag_z``.
    save : callable, optional
        ``save(table)`` after every change of the table (to write it atomically).
    on_round : callable, optional
        ``on_round(record)`` after each round.
    mapper : callable
        ``mapper(function, items)``, how a round's designs are optimised
        (:func:`pidpipe.design.designs.optimise_designs`): the builtin ``map``, or a pool's.
    """
    table = as_stored(start_table(table))
    spheres = int(round(budget.full_cell_spheres))
    rounds: list[RoundRecord] = []
    round_index = max(1, last_round(table))
    while True:
        fitted = fit_table(table, round_index)
        model = fit(fitted)
        results = optimise_designs(model, environments, budget, search, mapper)
        intervals = design_intervals(model, results, search.rule)
        met = {f"{i.environment}/{i.kind}": i.within(settings.interval_fraction) for i in intervals}
        points = verify_points([r for r in results if met[design_name(r)]], spheres)
        first_runs = _verify_requests(points, table, round_index)
        before = _cpu_before(table, round_index)
        verify_cost = sum(float(cost(q)) for q in first_runs)
        if before + verify_cost > settings.max_cpu_s:
            # the budget cannot pay for the new points; the points earlier rounds verified (a
            # design whose fill and band did not move) are still compared and reported
            comparison = compare(points, verify_rows(table, round_index), model, flag_z)
            worst = {design_name(r): worst_abs_z(comparison, design_name(r)) for r in results}
            record = RoundRecord(round_index, intervals, worst, _open_lines(
                intervals, met, comparison, settings, flag_z), cumulative_cpu_s=before,
                comparison=comparison)
            return _finish(BUDGET_SPENT, record, rounds, table, results, intervals, model, on_round)
        table = _run(table, first_runs, round_index, verify, None, cost, save)
        comparison = compare(points, verify_rows(table, round_index), model, flag_z)
        worst = {design_name(r): worst_abs_z(comparison, design_name(r)) for r in results}
        open_lines = _open_lines(intervals, met, comparison, settings, flag_z)
        record = RoundRecord(round_index, intervals, worst, open_lines, comparison=comparison)
        if not open_lines:
            return _finish(CRITERION_MET, _account(record, table, round_index), rounds, table,
                           results, intervals, model, on_round)
        if round_index >= settings.max_rounds:
            return _finish(MAX_ROUNDS, _account(record, table, round_index), rounds, table,
                           results, intervals, model, on_round)
        wide = {name for name, within in met.items() if not within}
        failing = comparison[~comparison["passes"].astype(bool)
                             & np.isfinite(comparison["dem_ns_m"].to_numpy(dtype=float))]
        choice = choose(fitted, fit, model, results, intervals, wide, failing, cost,
                        settings.cases_per_round, settings.interval_fraction, spheres)
        wanted = list(choice.cases) + list(choice.reverify)
        left = settings.max_cpu_s - before - verify_cost
        kept = []
        for request in wanted:
            planned = float(cost(request))
            if planned <= left:
                kept.append(request)
                left -= planned
        if not kept:
            reason = BUDGET_SPENT if wanted else NOTHING_TO_RUN
            return _finish(reason, _account(record, table, round_index), rounds, table, results,
                           intervals, model, on_round)
        table = _run(table, kept, round_index, verify, measure, cost, save)
        record = _account(record, table, round_index)
        rounds.append(record)
        if on_round is not None:
            on_round(record)
        round_index += 1


def _verify_requests(points: pd.DataFrame, table: pd.DataFrame, round_index: int) -> list[Request]:
    """The round's first verifying runs: points (one per key) with no verifying run before the
    round, in key order. Those the table already has for this round are among them (they are
    found, not run, by :func:`_run`), so that their planned CPU is counted the same way."""
    earlier = table[(table["source"] == VERIFY_SOURCE) & (table["refine_round"] < round_index)]
    have = set(earlier["case_key"])
    requests = []
    for key, part in points.groupby("case_key", sort=True):
        if key in have:
            continue
        first = part.iloc[0]
        where = ", ".join(f"{d} {p}" for d, p in zip(part["design"], part["point"]))
        requests.append(Request(float(first["freq_hz"]), float(first["accel_g"]),
                                float(first["fill_pct"]), "verify", reason=f"verifies {where}",
                                designs=tuple(part["design"])))
    return requests


def _cpu_before(table: pd.DataFrame, round_index: int) -> float:
    """Planned CPU of the rows of rounds < N, s."""
    return spent_cpu_s(table[table["refine_round"] < round_index])


def _run(table: pd.DataFrame, requests: list[Request], round_index: int, verify: Callable,
         measure: Callable | None, cost: Callable, save) -> pd.DataFrame:
    """Run the requests the table does not have for this round, append their rows, save."""
    missing = []
    for request in requests:
        have = rows_of_round(table, round_index, request.action)
        if request.key not in set(have["case_key"]):
            missing.append(request)
    if not missing:
        return table
    checks = [q for q in missing if q.action in ("verify", "reverify")]
    cases = [q for q in missing if q.action == "new"]
    more = [q for q in missing if q.action == "extend"]
    parts = []
    if checks:
        parts.append((checks, verify(checks)))
    if cases or more:
        parts.append((cases + more, measure(cases, more)))
    for done, rows in parts:
        table = as_stored(append_rows(table, _tag(rows, done, round_index, cost)))
        if save is not None:
            save(table)
    return table


def _tag(rows: pd.DataFrame, requests: list[Request], round_index: int,
         cost: Callable) -> pd.DataFrame:
    """The engine's rows with the request's coordinates and the loop's columns."""
    rows = pd.DataFrame(rows).reset_index(drop=True).copy()
    if len(rows) != len(requests):
        raise ValueError(f"the engine returned {len(rows)} row(s) for {len(requests)} request(s)")
    for column in (VALUE_COLUMN, SEM_COLUMN):
        if column not in rows.columns:
            raise ValueError(f"the engine's rows have no {column} column")
    rows["freq_hz"] = [q.freq_hz for q in requests]
    rows["accel_g"] = [q.accel_g for q in requests]
    rows["fill_pct"] = [q.fill_pct for q in requests]
    if "status" not in rows.columns:
        rows["status"] = "ok"
    rows["case_key"] = [q.key for q in requests]
    rows["source"] = [VERIFY_SOURCE if q.action in ("verify", "reverify")
                      else round_source(round_index) for q in requests]
    rows["reason"] = [q.reason for q in requests]
    rows["refine_round"] = round_index
    rows["action"] = [q.action for q in requests]
    rows["planned_cpu_s"] = [float(cost(q)) for q in requests]
    return rows


def _account(record: RoundRecord, table: pd.DataFrame, round_index: int) -> RoundRecord:
    """The record with the round's cases and CPU counted from the table."""
    mine = table[table["refine_round"] == round_index]
    record.cases_added = int((mine["action"] == "new").sum())
    record.cases_extended = int((mine["action"] == "extend").sum())
    record.verify_cases = int(mine["action"].isin(["verify", "reverify"]).sum())
    record.engine_cpu_s = spent_cpu_s(mine)
    record.cumulative_cpu_s = spent_cpu_s(table[table["refine_round"] <= round_index])
    return record


def _open_lines(intervals: list[DesignInterval], met: dict, comparison: pd.DataFrame,
                settings: RefineSettings, flag_z: float) -> list[str]:
    """One line per open design: its interval, and its failing points."""
    lines = []
    for interval in intervals:
        name = f"{interval.environment}/{interval.kind}"
        if not met[name]:
            lines.append(f"{name}: 95 % interval +-{100 * interval.half_width_fraction:.1f} % of "
                         f"{interval.total_ceq_ns_m:.4g} N*s/m, wider than "
                         f"+-{100 * settings.interval_fraction:g} % (not yet verified)")
            continue
        mine = comparison[comparison["design"] == name]
        bad = mine[~mine["passes"].astype(bool)]
        unrun = mine[~np.isfinite(mine["dem_ns_m"].to_numpy(dtype=float))] \
            if "dem_ns_m" in mine.columns else mine
        if mine.empty or len(unrun) == len(mine):
            lines.append(f"{name}: not verified")
        elif not unrun.empty:
            lines.append(f"{name}: not verified at {', '.join(unrun['point'])}")
        elif not bad.empty:
            shown = ", ".join(_point_text(p, z, dem) for p, z, dem in
                              zip(bad["point"], bad["z"], bad["dem_ns_m"]))
            lines.append(f"{name}: verify fails (|z| > {flag_z:g}) at {shown}")
    return lines


def _point_text(point: str, z: float, dem: float) -> str:
    """A failing point in an open line."""
    if np.isfinite(z):
        return f"{point} |z| = {abs(z):.2f}"
    return f"{point} no DEM value" if not np.isfinite(dem) else f"{point} no surrogate value"


def _finish(reason: str, record: RoundRecord, rounds: list, table, results, intervals, model,
            on_round) -> Outcome:
    rounds.append(record)
    if on_round is not None:
        on_round(record)
    return Outcome(stopped_by=reason, open=record.open, rounds=rounds, table=table,
                   results=results, intervals=intervals, model=model)
