"""The optimum's uncertainty: a parametric bootstrap of the C_eq table through surrogate and optimiser.

Each draw redraws every fitted C_eq from a normal distribution with its standard error
(``ceq_coupon_sem_ns_m``; negative draws are set to 0, as dissipation is not negative), the
rows that share packings with the covariance their ``packing_loads`` give
(:mod:`pidpipe.design.packing_noise`), refits
the surrogate with the same method and options, and re-optimises every design of every
environment (:mod:`pidpipe.design.designs`), starting from the main run's local optima plus
``starts`` seeded Latin-hypercube points. The draws give:

- a percentile interval (``confidence``) of each design's fill r, cell count n_c (widened to
  whole cells) and total C_eq (the design's objective);
- how often each of the main run's local optima wins: a draw's optimum belongs to the nearest
  main local optimum in scaled (f, r, G) (peak) or r (band designs), or to none ("elsewhere")
  when it is farther than :data:`WIN_TOLERANCE` from all of them.

The surrogate's leave-one-out error (:func:`loo_rel_error`) is reported next to the intervals,
not folded into them: on DEM data it holds the same noise that the draws already propagate.

Without a finite, non-negative SEM for every fitted row there is nothing to propagate and
:func:`resampled_values` refuses with a :class:`~pidpipe.errors.TableError`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from pidpipe.config.sections import Bootstrap
from pidpipe.design.ceq_table import SEM_COLUMN, VALUE_COLUMN
from pidpipe.design.designs import Search, optimise_design, restart_points
from pidpipe.design.optimisation import Budget, OptimisationResult
from pidpipe.design.packing_noise import SharedPackings
from pidpipe.design.surrogate import Surrogate, cross_validate, refit_values
from pidpipe.errors import PidpipeError, TableError

#: Columns of the draws' table (:func:`bootstrap_designs`).
DRAW_COLUMNS: tuple[str, ...] = ("draw", "environment", "design", "ok", "fill_pct", "n_cells",
                                 "total_ceq_ns_m", "continuous_fill_pct", "band_mean_total_ceq_ns_m",
                                 "band_worst_total_ceq_ns_m", "local_optimum")

#: A draw's optimum farther than this (scaled variables) from every main local optimum is "elsewhere".
WIN_TOLERANCE = 0.1


def has_sem(surrogate: Surrogate) -> bool:
    """Whether every fitted row has a finite, non-negative SEM to redraw it from."""
    if SEM_COLUMN not in surrogate.training.columns:
        return False
    sem = surrogate.training[SEM_COLUMN].to_numpy(dtype=float)
    return bool(np.all(np.isfinite(sem) & (sem >= 0)))


def resampled_values(surrogate: Surrogate, draws: int, seed: int) -> np.ndarray:
    """The fitted C_eq redrawn within their SEMs, N*s/m.

    Returns
    -------
    numpy.ndarray, shape (draws, n_rows)
        Row d is draw d (the same seed gives the same draws), clipped at 0.

    Raises
    ------
    TableError
        A fitted row has no finite, non-negative SEM.
    """
    if not has_sem(surrogate):
        raise TableError(f"the C_eq table has no finite {SEM_COLUMN} in every fitted row: the "
                         f"bootstrap has nothing to propagate (set optimisation.bootstrap.draws: 0)")
    value = surrogate.training[VALUE_COLUMN].to_numpy(dtype=float)
    sem = surrogate.training[SEM_COLUMN].to_numpy(dtype=float)
    noise = np.random.default_rng(seed).standard_normal((draws, value.size))
    shared = SharedPackings.of(surrogate.training)
    if shared is None:
        return np.maximum(value + sem * noise, 0.0)
    covariance = shared.covariance(sem**2)
    scale = np.sqrt(np.diag(covariance))
    outer = np.outer(scale, scale)
    correlation = np.divide(covariance, outer, out=np.eye(value.size), where=outer > 0)
    factor = np.linalg.cholesky(correlation + 1e-12 * np.eye(value.size))
    return np.maximum(value + scale * (noise @ factor.T), 0.0)


def resampled_surrogates(surrogate: Surrogate, draws: int, seed: int):
    """Yield the refitted surrogate of each draw (:func:`resampled_values`)."""
    for values in resampled_values(surrogate, draws, seed):
        yield refit_values(surrogate, values)


def loo_rel_error(surrogate: Surrogate) -> float:
    """RMS relative leave-one-out error of the surrogate's method on its own training rows.

    Leave-one-point-out where the method can refit with a point missing (rbf_thin_plate),
    else leave-one-plane-out; NaN when neither has a fold.
    """
    for scheme in ("point", "plane"):
        cv = cross_validate(surrogate.training, methods=(surrogate.method,),
                            targets=(surrogate.target,), schemes=(scheme,),
                            log_offset_fraction=surrogate.options.get("log_offset_fraction", 1e-3))
        if not cv.empty:
            return float(cv["rms_rel_error"].iloc[0])
    return float("nan")


def loo_from_cross_validation(cv: pd.DataFrame, surrogate: Surrogate) -> float | None:
    """:func:`loo_rel_error` read from a cross-validation table of the surrogate's own table
    (:func:`pidpipe.design.surrogate.cross_validate`, ``results/surrogate_cv.csv``): the
    ``rms_rel_error`` of the surrogate's method and target, leave-one-point-out, else
    leave-one-plane-out. None when the table has no such row, or when the surrogate's log offset
    is not the one the table's folds used (the default): the caller computes it then.

    Parameters
    ----------
    cv : pandas.DataFrame
        Columns ``method``, ``target``, ``scheme``, ``rms_rel_error``.
    surrogate : Surrogate
    """
    from pidpipe.design.surrogate import DEFAULT_LOG_OFFSET_FRACTION

    offset = surrogate.options.get("log_offset_fraction", DEFAULT_LOG_OFFSET_FRACTION)
    if offset != DEFAULT_LOG_OFFSET_FRACTION or not {"method", "target", "scheme",
                                                       "rms_rel_error"} <= set(cv.columns):
        return None
    for scheme in ("point", "plane"):
        rows = cv[(cv["method"] == surrogate.method) & (cv["target"] == surrogate.target)
                  & (cv["scheme"] == scheme)]
        if not rows.empty:
            return float(rows["rms_rel_error"].iloc[0])
    return None


def _cluster_coordinates(result: OptimisationResult, optimum) -> np.ndarray:
    """An optimum's scaled clustering coordinates within the result's bounds."""
    names = ("freq_hz", "fill_pct", "accel_g") if result.kind == "peak" else ("fill_pct",)
    z = []
    for name in names:
        lo, hi = result.bounds[name]
        z.append(0.0 if hi <= lo else (getattr(optimum, name) - lo) / (hi - lo))
    return np.array(z)


def winner(result: OptimisationResult, optimum) -> int:
    """Index of the main local optimum nearest to a draw's optimum, or -1 ("elsewhere")."""
    z = _cluster_coordinates(result, optimum)
    distances = [np.linalg.norm(z - _cluster_coordinates(result, o)) for o in result.local_optima]
    best = int(np.argmin(distances))
    return best if distances[best] <= WIN_TOLERANCE else -1


def bootstrap_designs(surrogate: Surrogate, results: list[OptimisationResult], budget: Budget,
                      search: Search, settings: Bootstrap,
                      loo: float = float("nan"), workers: int = 1) -> pd.DataFrame:
    """Re-optimise every design on every draw; store the intervals in each result.

    Parameters
    ----------
    surrogate : Surrogate
        The surrogate the results were optimised on (its training rows and SEMs are redrawn).
    results : list of OptimisationResult
        From :func:`pidpipe.design.designs.optimise_designs`; each gets ``uncertainty`` set.
    budget : Budget
    search : Search
        The main run's search (band rule, clipping, tolerances).
    settings : Bootstrap
    loo : float
        The surrogate's leave-one-out relative error (:func:`loo_rel_error`), reported with the
        intervals; NaN if not computed.
    workers : int
        Processes that share the draws (forked; each draw is seeded on its own, so the table is
        the same for any number).

    Returns
    -------
    pandas.DataFrame
        One row per (draw, environment, design): ``fill_pct``, ``n_cells``, ``total_ceq_ns_m``
        (the design's objective) of the whole-cell design, ``continuous_fill_pct`` of the
        continuous optimum, ``band_mean_total_ceq_ns_m``, ``band_worst_total_ceq_ns_m``,
        ``local_optimum`` (index into the main result's local optima, -1 elsewhere) and
        ``ok`` (False where the draw's optimisation failed; its values are NaN).
    """
    values = resampled_values(surrogate, settings.draws, settings.seed)
    job = (surrogate, results, budget, search, settings, values)
    if workers > 1 and settings.draws > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=int(workers), initializer=_share, initargs=(job,),
                                 mp_context=multiprocessing.get_context("fork")) as pool:
            per_draw = list(pool.map(_draw_rows, range(settings.draws),
                                     chunksize=max(1, settings.draws // (4 * int(workers)))))
    else:
        _share(job)
        per_draw = [_draw_rows(draw) for draw in range(settings.draws)]
    draws = pd.DataFrame([row for rows in per_draw for row in rows], columns=list(DRAW_COLUMNS))
    for res in results:
        mine = draws[(draws["environment"] == res.environment.name) & (draws["design"] == res.kind)]
        res.uncertainty = summarise(res, mine, settings, loo)
    return draws


_JOB: tuple = ()
"""What every draw of the running bootstrap reads (set in each worker by :func:`_share`)."""


def _share(job: tuple) -> None:
    global _JOB
    _JOB = job


def _draw_rows(draw: int) -> list[dict]:
    """Every design re-optimised on draw ``draw``'s refitted surrogate (one row each)."""
    surrogate, results, budget, search, settings, values = _JOB
    model = refit_values(surrogate, values[draw])
    return [_one_draw(model, res, budget, search, settings, draw) for res in results]


def _one_draw(model: Surrogate, res: OptimisationResult, budget: Budget, search: Search,
              settings: Bootstrap, draw: int) -> dict:
    """One design re-optimised on one draw's surrogate (a failed draw is kept, marked)."""
    row = {"draw": draw, "environment": res.environment.name, "design": res.kind}
    try:
        again = optimise_design(model, res.environment, budget, res.kind, search,
                                initial=restart_points(res), seed=settings.seed + 1 + draw,
                                starts=settings.starts)
    except PidpipeError:
        return {**row, "ok": False, "fill_pct": np.nan, "n_cells": np.nan, "total_ceq_ns_m": np.nan,
                "continuous_fill_pct": np.nan,
                "band_mean_total_ceq_ns_m": np.nan, "band_worst_total_ceq_ns_m": np.nan,
                "local_optimum": -1}
    return {**row, "ok": True, "fill_pct": again.design.fill_pct, "n_cells": again.design.n_cells,
            "total_ceq_ns_m": again.design.total_ceq_ns_m,
            "continuous_fill_pct": again.optimum.fill_pct,
            "band_mean_total_ceq_ns_m": again.band.mean_total_ceq_ns_m,
            "band_worst_total_ceq_ns_m": again.band.worst_total_ceq_ns_m,
            "local_optimum": winner(res, again.optimum)}


def summarise(result: OptimisationResult, draws: pd.DataFrame, settings: Bootstrap,
              loo: float) -> dict:
    """Intervals and win fractions of one design from its draws (rows of :func:`bootstrap_designs`).

    Returns
    -------
    dict
        ``draws``, ``used`` (draws whose optimisation converged), ``confidence``,
        ``intervals`` {name: [lo, hi]} for fill_pct (%), n_cells (whole cells) and
        total_ceq_ns_m (N*s/m), ``wins`` (one entry per main local optimum and one for
        "elsewhere": its r and the fraction of used draws it won), ``wins_text`` and
        ``surrogate_loo_rel_error``.
    """
    ok = draws[draws["ok"]]
    tail = 0.5 * (1.0 - settings.confidence)
    intervals = {}
    if len(ok):
        for name in ("fill_pct", "n_cells", "total_ceq_ns_m"):
            lo, hi = np.quantile(ok[name].to_numpy(dtype=float), [tail, 1.0 - tail])
            if name == "n_cells":
                lo, hi = np.floor(lo), np.ceil(hi)
            intervals[name] = [float(lo), float(hi)]
    counts = ok["local_optimum"].value_counts().to_dict()
    used = max(len(ok), 1)
    wins = [{"local_optimum": i, "fill_pct": o.fill_pct, "fraction": counts.get(i, 0) / used}
            for i, o in enumerate(result.local_optima)]
    wins.append({"local_optimum": -1, "fill_pct": None, "fraction": counts.get(-1, 0) / used})
    text = "; ".join(f"r {w['fill_pct']:.1f} %: {w['fraction']:.2f}" for w in wins[:-1])
    text += f"; elsewhere: {wins[-1]['fraction']:.2f}"
    return {"draws": int(len(draws)), "used": int(len(ok)), "confidence": settings.confidence,
            "seed": settings.seed, "intervals": intervals, "wins": wins, "wins_text": text,
            "surrogate_loo_rel_error": None if not np.isfinite(loo) else loo}
