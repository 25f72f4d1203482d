"""The three designs of every environment, their band evaluation and regime, and their tables.

For each environment (:class:`~pidpipe.design.optimisation.Environment`):

``peak``
    the best point of the band: (f, G, r, n_c) maximising the total C_eq (SPEC.md, the source's);
``band_mean``
    the (r, n_c) maximising the band-averaged total C_eq (:mod:`pidpipe.design.band`);
``worst_case``
    the (r, n_c) maximising the band's minimum total C_eq.

Each design's whole-cell (r, n_c) is then evaluated over its band (mean, worst, best). A design
whose band reaches G <= 1 carries :data:`REGIME_WARNING`: there the spheres never leave the
floor and C_eq is contact damping in persistent contacts, which depends on the contact model.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from pidpipe.design.band import BandRule, evaluate_band, optimise_band_design
from pidpipe.design.optimisation import (
    Budget,
    CeqModel,
    Environment,
    OptimisationResult,
    optimise_environment,
)

#: The designs, in the order of every table.
DESIGN_KINDS: tuple[str, ...] = ("peak", "band_mean", "worst_case")

#: Said next to the numbers of a design whose band reaches G <= 1.
REGIME_WARNING = ("band reaches G <= 1: there the spheres never leave the floor and C_eq is contact "
                  "damping in persistent contacts, which depends on the contact model (E x 0.1 "
                  "moved C_eq at 1000 Hz / 1 g by 145 %)")


@dataclass(frozen=True)
class Search:
    """How the designs are searched: SLSQP starts, their seed, the band rule, clipping."""

    starts: int = 40
    seed: int = 7
    rule: BandRule = BandRule()
    clip_environment: bool = False
    cluster_tol: float = 0.02
    maxiter: int = 200


def regime_warning(bounds: dict) -> str:
    """:data:`REGIME_WARNING` when the acceleration band reaches G <= 1, else ''."""
    return REGIME_WARNING if bounds["accel_g"][0] <= 1.0 else ""


def optimise_design(model: CeqModel, environment: Environment, budget: Budget, kind: str,
                    search: Search, initial: np.ndarray | None = None, seed: int | None = None,
                    starts: int | None = None) -> OptimisationResult:
    """One design of one environment, evaluated over its band.

    Parameters
    ----------
    model, environment, budget
        As :func:`pidpipe.design.optimisation.optimise_environment`.
    kind : str
        One of :data:`DESIGN_KINDS`.
    search : Search
    initial : numpy.ndarray, optional
        Starting points run first: (f, r, G, n_c) rows for ``peak``, fills (%) for the others.
    seed, starts : int, optional
        Override ``search.seed`` and ``search.starts`` (the bootstrap's draws).
    """
    options = dict(starts=search.starts if starts is None else starts,
                   seed=search.seed if seed is None else seed,
                   clip_environment=search.clip_environment, cluster_tol=search.cluster_tol,
                   maxiter=search.maxiter)
    if kind == "peak":
        result = optimise_environment(model, environment, budget, initial_points=initial, **options)
    else:
        result = optimise_band_design(model, environment, budget, kind, rule=search.rule,
                                      initial_fills=initial, **options)
    result.band = evaluate_band(model, result.bounds, budget, result.design.n_cells, search.rule)
    result.regime_warning = regime_warning(result.bounds)
    return result


def optimise_designs(model: CeqModel, environments: list[Environment], budget: Budget,
                     search: Search = Search(), mapper: Callable = map) -> list[OptimisationResult]:
    """Every design (:data:`DESIGN_KINDS`) of every environment, environment by environment.

    ``mapper(function, items)`` runs the designs, each independent of the others: the builtin
    ``map`` here, or a pool's ``map`` (e.g. the refinement loop's worker processes); the
    results are the same, in the same order."""
    tasks = [(env, kind) for env in environments for kind in DESIGN_KINDS]
    return list(mapper(partial(_design_task, model, budget, search), tasks))


def _design_task(model: CeqModel, budget: Budget, search: Search,
                 task: tuple[Environment, str]) -> OptimisationResult:
    """One (environment, kind) of :func:`optimise_designs` (a picklable task)."""
    environment, kind = task
    return optimise_design(model, environment, budget, kind, search)


def restart_points(result: OptimisationResult) -> np.ndarray:
    """The result's local optima as starting points of the same design (for the bootstrap)."""
    if result.kind == "peak":
        return np.array([[o.freq_hz, o.fill_pct, o.accel_g, o.n_cells] for o in result.local_optima])
    return np.array([o.fill_pct for o in result.local_optima])


# --------------------------------------------------------------------------------------------
# Tables and files

#: Bootstrap columns of :func:`results_frame` (NaN without a bootstrap).
INTERVAL_COLUMNS: tuple[str, ...] = ("fill_pct", "n_cells", "total_ceq_ns_m")


def results_frame(results: list[OptimisationResult]) -> pd.DataFrame:
    """One row per (environment, design): the whole-cell design, its band, its intervals.

    ``total_ceq_ns_m`` is what the design maximises (peak: at its f and G; band_mean: the band
    mean; worst_case: the band minimum), ``band_*`` the design's total over the band; ``freq_hz``
    and ``accel_g`` are the peak design's point (empty for the band designs); ``*_lo`` and
    ``*_hi`` the bootstrap's percentile interval (``bootstrap_confidence``).
    """
    rows = []
    for res in results:
        d, o, band = res.design, res.optimum, res.band
        row = {
            "environment": res.environment.name, "design": res.kind,
            "freq_band_hz": f"{res.bounds['freq_hz'][0]:g}-{res.bounds['freq_hz'][1]:g}",
            "accel_band_g": f"{res.bounds['accel_g'][0]:g}-{res.bounds['accel_g'][1]:g}",
            "clipped": res.clipped,
            "n_budget_spheres": res.budget.n_spheres,
            "full_cell_spheres": res.budget.full_cell_spheres,
            "n_cells_panel": res.budget.max_cells,
            "n_cells": d.n_cells, "fill_pct": d.fill_pct, "spheres_per_cell": d.spheres_per_cell,
            "whole_spheres_per_cell": d.whole_spheres_per_cell,
            "spheres_left_over": d.spheres_left_over,
            "freq_hz": d.freq_hz, "accel_g": d.accel_g,
            "ceq_per_cell_ns_m": d.ceq_per_cell_ns_m, "total_ceq_ns_m": d.total_ceq_ns_m,
        }
        if band is not None:
            row.update({"band_" + k: v for k, v in asdict(band).items()})
        row.update({
            "continuous_n_cells": o.n_cells, "continuous_fill_pct": o.fill_pct,
            "continuous_total_ceq_ns_m": o.total_ceq_ns_m,
            "n_starts": len(res.starts), "n_converged": res.n_converged,
            "n_local_optima": len(res.local_optima), "starts_at_optimum": o.n_starts,
        })
        row.update(_uncertainty_columns(res.uncertainty))
        row["regime_warning"] = res.regime_warning
        rows.append(row)
    return pd.DataFrame(rows)


def _uncertainty_columns(uncertainty: dict | None) -> dict:
    """The bootstrap's columns of one row (NaN when there was none)."""
    u = uncertainty or {}
    columns = {}
    for name in INTERVAL_COLUMNS:
        lo, hi = u.get("intervals", {}).get(name, (np.nan, np.nan))
        columns[f"{name}_lo"], columns[f"{name}_hi"] = lo, hi
    columns["bootstrap_draws"] = u.get("draws", 0)
    columns["bootstrap_used"] = u.get("used", 0)
    columns["bootstrap_confidence"] = u.get("confidence", np.nan)
    columns["optimum_wins"] = u.get("wins_text", "")
    loo = u.get("surrogate_loo_rel_error")
    columns["surrogate_loo_rel_error"] = np.nan if loo is None else loo
    return columns


def history_frame(results: list[OptimisationResult]) -> pd.DataFrame:
    """Long table of objective (N*s/m) against iteration for every start of every design;
    ``at_optimum`` marks the starts that ended in the global optimum's cluster."""
    rows = []
    for res in results:
        best = set(res.optimum.start_indices)
        for run in res.starts:
            for it, value in enumerate(run.history_ns_m):
                rows.append({"environment": res.environment.name, "design": res.kind,
                             "start": run.index, "iteration": it, "total_ceq_ns_m": value,
                             "converged": run.converged, "at_optimum": run.index in best})
    return pd.DataFrame(rows)


def format_designs(results: list[OptimisationResult]) -> str:
    """The designs as a plain-text table (for the command line and the log)."""
    table = results_frame(results)
    lines = []
    for env, rows in table.groupby("environment", sort=False):
        first = rows.iloc[0]
        lines.append(f"{env}  (f {first['freq_band_hz']} Hz, G {first['accel_band_g']} g; "
                     f"{first['n_budget_spheres']} spheres, at most {first['n_cells_panel']} cells)")
        lines.append(f"  {'design':<11}{'r %':>20}{'n_c':>18}{'objective':>28}"
                     f"{'band mean':>11}{'worst':>10}{'best':>10}  N*s/m")
        for _, row in rows.iterrows():
            lines.append(f"  {row['design']:<11}{_with_interval(row, 'fill_pct', '.1f'):>20}"
                         f"{_with_interval(row, 'n_cells', '.0f'):>18}"
                         f"{_with_interval(row, 'total_ceq_ns_m', '.4g'):>28}"
                         f"{row['band_mean_total_ceq_ns_m']:>11.4g}"
                         f"{row['band_worst_total_ceq_ns_m']:>10.4g}"
                         f"{row['band_best_total_ceq_ns_m']:>10.4g}"
                         + (f"  at {row['freq_hz']:g} Hz, {row['accel_g']:g} g"
                            if row["design"] == "peak" else ""))
        if first["regime_warning"]:
            lines.append(f"  warning: {first['regime_warning']}")
        if first["bootstrap_used"]:
            lines.append(f"  [lo, hi]: {100 * first['bootstrap_confidence']:g} % bootstrap interval of "
                         f"{first['bootstrap_used']} draws; surrogate leave-one-out error "
                         f"{100 * first['surrogate_loo_rel_error']:.1f} % RMS (not in the intervals)")
            for _, row in rows.iterrows():
                lines.append(f"  {row['design']} local optima, share of the draws they win: "
                             f"{row['optimum_wins']}")
    return "\n".join(lines)


def _with_interval(row, name: str, spec: str) -> str:
    """``value [lo, hi]``, or the value alone without a bootstrap."""
    text = format(row[name], spec)
    lo, hi = row[f"{name}_lo"], row[f"{name}_hi"]
    if np.isfinite(lo) and np.isfinite(hi):
        text += f" [{lo:{spec}}, {hi:{spec}}]"
    return text


def write_results_csv(results: list[OptimisationResult], path: str | Path) -> None:
    """Write :func:`results_frame` as CSV."""
    results_frame(results).to_csv(path, index=False)


def write_history_csv(results: list[OptimisationResult], path: str | Path) -> None:
    """Write :func:`history_frame` as CSV."""
    history_frame(results).to_csv(path, index=False)


def write_results_json(results: list[OptimisationResult], path: str | Path) -> None:
    """Write every result in full (starts, histories, band, bootstrap) as JSON."""
    document = [asdict(res) for res in results]
    Path(path).write_text(json.dumps(document, indent=1, default=_json_default))


def _json_default(value):
    """JSON encoder for numpy scalars and arrays."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")
