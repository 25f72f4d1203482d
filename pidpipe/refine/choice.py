"""Choose a round's cases: what most reduces the open designs' uncertainty per CPU second.

First, every verifying point that failed (|z| > ``flag_z``) is run again as a verifying case
(``reverify``, pooled with its earlier runs), reason saying which design and |z|. It also gets
a fitted case at the same point (a new case, or an extension when the table has one) while the
surrogate's standard deviation there is at least :data:`FITTED_SHARE` of the verifying runs'
pooled SEM: z's denominator is sqrt(SEM_dem^2 + sigma_s^2), and once sigma_s is the smaller
part a fitted case can no longer move z, while another verifying run still can (an extension
there costs ``EXTEND_FACTOR`` times the one before it, a verifying run the same each time). A
point the surrogate refused (outside its domain, :mod:`pidpipe.refine.predict`) gets the
fitted case only, which widens the domain to it.

Then, greedily, up to ``cases_per_round`` fitted cases in all, among the new-case and extension
candidates of the open designs (:mod:`pidpipe.refine.candidates`): the designs whose interval
does not yet meet the criterion (a design open only because a point fails gets that point's
requests above, not more of its interval's). A candidate's gain is the
reduction of the surrogate's predictive variance of C_eq at its point that one more
observation there brings, for a Gaussian process with the table's SEMs as its noise (exact
for the point itself, the Bayesian update of one value by one more measurement of it):

    new case:   sigma^2 - 1 / (1 / sigma^2 + 1 / s_e^2),  s_e the SEM a new case is expected
                to have: the fitted rows' median relative SEM times the predicted C_eq; with
                sigma^2 and s_e^2 less the variance of the offset its fill's pilot packings
                share, which no case on those packings reduces (:mod:`pidpipe.design.packing_noise`);
    extension:  sigma^2 - 1 / (1 / sigma^2 + (k - 1) / SEM^2),  k the effort factor (the
                extension's runs add k - 1 times the case's precision);

in units of each design's target variance: gain = sum over the open designs it serves of
(n_c / N)^2 * reduction / tau_d^2, with tau_d = interval_fraction * |T_d| / 1.96 the sigma_T at
which the design's interval meets the criterion. The candidate with the largest gain per
planned CPU second is taken (ties: the smaller key, then ``new`` before ``extend``); its
observation is then added to the table as a fantasy (the predicted mean with the expected SEM,
or the extended row with its SEM / sqrt(k) and its packing loads / k; a new case with the
loads of the nearest row on the pilot's packings, :func:`pilot_loads`; at a point the surrogate
refuses, the prediction at the nearest point of its domain) and the surrogate refitted, so that the next pick
sees the variance the first one removes (the "kriging believer" batch). A candidate with no
gain is never taken.

The choice is a function of the fitted table, the designs and the settings only: the same
inputs choose the same cases in the same order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import pandas as pd

from pidpipe.design.ceq_table import SEM_COLUMN, VALUE_COLUMN
from pidpipe.design.packing_noise import (LOADS_COLUMN, SharedPackings, format_loads, parse_loads,
                                          scaled_loads)
from pidpipe.refine.candidates import EXTEND_FACTOR, Request, extend_candidates, new_case_candidates
from pidpipe.refine.intervals import DesignInterval
from pidpipe.refine.predict import predict_or_nan
from pidpipe.refine.table import case_key

#: Relative SEM a new case is expected to have when the table has none to go by.
FALLBACK_RELATIVE_SEM = 0.1

#: A failing verifying point gets a fitted case while the surrogate's standard deviation there
#: is at least this fraction of the verifying runs' pooled SEM (its variance at least a fifth
#: of z's denominator squared).
FITTED_SHARE = 0.5

#: Significant digits of a score compared between candidates (so that rounding noise cannot
#: reorder equal scores).
SCORE_DIGITS = 12


@dataclass(frozen=True)
class Choice:
    """The requests of a round: fitted cases (``new``, ``extend``) and verifying reruns."""

    cases: tuple[Request, ...]
    reverify: tuple[Request, ...]


def expected_relative_sem(fitted: pd.DataFrame) -> float:
    """Median SEM / C_eq of the usable rows (status ok) with both finite and C_eq > 0."""
    v = fitted[VALUE_COLUMN].to_numpy(dtype=float)
    s = fitted[SEM_COLUMN].to_numpy(dtype=float)
    usable = (fitted["status"] == "ok").to_numpy() if "status" in fitted else np.ones(v.size, bool)
    good = usable & np.isfinite(v) & np.isfinite(s) & (v > 0) & (s > 0)
    return float(np.median(s[good] / v[good])) if good.any() else FALLBACK_RELATIVE_SEM


def variance_reduction(std: np.ndarray, added_precision: np.ndarray) -> np.ndarray:
    """sigma^2 - 1 / (1 / sigma^2 + p): the predictive variance one more measurement of
    precision p (1 / SEM^2) removes at its own point; shape of ``std``."""
    var = np.asarray(std, dtype=float) ** 2
    with np.errstate(divide="ignore"):
        after = 1.0 / (1.0 / np.maximum(var, 1e-300) + added_precision)
    return np.where(var > 0, var - after, 0.0)


def fitted_case_helps(point: pd.Series) -> bool:
    """Whether a failing point gets a fitted case (see the module's text): the surrogate's
    standard deviation ``surrogate_std_ns_m`` there is at least :data:`FITTED_SHARE` of the
    verifying runs' pooled SEM ``dem_sem_ns_m``, or either is unknown (a refused point)."""
    std = float(point.get("surrogate_std_ns_m", math.nan))
    sem = float(point.get("dem_sem_ns_m", math.nan))
    if not (math.isfinite(std) and math.isfinite(sem)):
        return True
    return std >= FITTED_SHARE * sem


def choose(fitted: pd.DataFrame, fit: Callable, model, results: list,
           intervals: list[DesignInterval], open_designs: set[str], failing: pd.DataFrame,
           cost: Callable[[Request], float], cases_per_round: int, interval_fraction: float, full_cell_spheres: int) -> Choice:
    """The round's requests (see the module's text).

    Parameters
    ----------
    fitted : pandas.DataFrame
        The table the round fitted (:func:`pidpipe.refine.table.fit_table`).
    fit : callable
        ``fit(table, start=None) -> model``, the surrogate factory; ``start``, a model of a
        table that differs by a few rows, may start its fit (the fantasies' refits, each from
        the model before it).
    model
        ``fit(fitted)``, already made.
    results : list of OptimisationResult
        The round's designs, in the order of ``intervals``.
    intervals : list of DesignInterval
    open_designs : set of str
        ``environment/kind`` of the designs whose interval does not yet meet the criterion.
    failing : pandas.DataFrame
        Verifying points with a DEM value that do not pass: |z| > flag_z, or no surrogate value
        there (:func:`pidpipe.refine.verification.compare` rows).
    cost : callable
        ``cost(request) -> planned engine CPU, s``.
    cases_per_round : int
    interval_fraction : float
    full_cell_spheres : int
    """
    fitted_keys = set(fitted["case_key"])
    reverify, cases = [], []
    for key, part in failing.sort_values(["case_key", "design"]).groupby("case_key", sort=True):
        first = part.iloc[0]
        where = ", ".join(f"{d} {p}" for d, p in zip(part["design"], part["point"]))
        z = np.abs(part["z"].to_numpy(dtype=float))
        reason = (f"verify |z| = {np.nanmax(z):.2f} at {where}" if np.isfinite(z).any()
                  else f"verify point outside the surrogate's domain at {where}")
        point = (float(first["freq_hz"]), float(first["accel_g"]), float(first["fill_pct"]))
        helps = fitted_case_helps(first)
        if np.isfinite(z).any():                        # an outside point needs no rerun
            why = reason if helps else (
                f"{reason}; surrogate std {float(first['surrogate_std_ns_m']):.3g} below "
                f"{FITTED_SHARE:g} x the verifying SEM {float(first['dem_sem_ns_m']):.3g} "
                "N*s/m: verified again, no fitted case")
            reverify.append(Request(*point, action="reverify", reason=why,
                                    designs=tuple(part["design"]), run=int(first["runs"])))
        if len(cases) < cases_per_round and helps:
            if key in fitted_keys:
                row = fitted[fitted["case_key"] == key].iloc[-1]
                cases.append(Request(*point, action="extend", reason=reason, factor=EXTEND_FACTOR,
                                     base=row.to_dict(), designs=tuple(part["design"])))
            else:
                cases.append(Request(*point, action="new", reason=reason,
                                     designs=tuple(part["design"])))
    by_name = {f"{i.environment}/{i.kind}": i for i in intervals}
    open_results = [r for r in results if f"{r.environment.name}/{r.kind}" in open_designs]
    taken = {c.key for c in cases}
    candidates = [c for c in (new_case_candidates(open_results, full_cell_spheres, fitted_keys)
                              + extend_candidates(fitted, open_results, full_cell_spheres))
                  if c.key not in taken]
    relative_sem = expected_relative_sem(fitted)
    table = fitted
    for case in cases:                                   # the verify-driven ones as fantasies
        table = _with_fantasy(table, case, model, relative_sem)
    if cases and candidates:
        model = fit(table, start=model)
    while len(cases) < cases_per_round and candidates:
        gains = _gains(candidates, model, by_name, open_designs, relative_sem, interval_fraction,
                       table)
        costs = np.array([float(cost(c)) for c in candidates])
        scores = np.where(gains > 0, gains / np.maximum(costs, 1e-300), -np.inf)
        order = sorted(range(len(candidates)),
                       key=lambda i: (-_rounded(scores[i]), candidates[i].key,
                                      candidates[i].action))
        best = order[0]
        if not np.isfinite(scores[best]):
            break
        pick = replace(candidates[best], reason=(
            f"{candidates[best].action}: removes {gains[best]:.3g} target variances of "
            f"{', '.join(sorted(set(candidates[best].designs) & open_designs))} for "
            f"{costs[best]:.3g} planned CPU-s"))
        cases.append(pick)
        candidates = [c for c in candidates if c.key != pick.key]
        if len(cases) < cases_per_round and candidates:
            table = _with_fantasy(table, pick, model, relative_sem)
            model = fit(table, start=model)
    return Choice(tuple(cases), tuple(reverify))


def _rounded(score: float) -> float:
    if not math.isfinite(score) or score == 0:
        return score
    return round(score, SCORE_DIGITS - 1 - int(math.floor(math.log10(abs(score)))))


def _gains(candidates: list[Request], model, by_name: dict, open_designs: set[str],
           relative_sem: float, interval_fraction: float, table: pd.DataFrame) -> np.ndarray:
    """Each candidate's gain in target variances of the open designs it serves; shape (n,).

    A new case shakes its fill's pilot packings, whose shared offset (variance ``pool``: the
    sum of its expected loads squared, :func:`pilot_loads`, times the packing errors'
    correlation at its distance from the row they are copied from) it cannot reduce: its gain
    is that of a measurement of the rest, sigma^2 - pool, with its own noise s_e^2 - pool."""
    f = np.array([c.freq_hz for c in candidates])
    g = np.array([c.accel_g for c in candidates])
    r = np.array([c.fill_pct for c in candidates])
    mean, std = predict_or_nan(model, f, g, r)
    precision = np.empty(len(candidates))
    pool = np.zeros(len(candidates))
    shared = SharedPackings.of(table)
    parsed = [parse_loads(text) for text in table[LOADS_COLUMN]] if shared is not None else None
    for i, c in enumerate(candidates):
        if c.action == "extend":
            sem = float(c.base[SEM_COLUMN])
            precision[i] = (c.factor - 1.0) / sem ** 2
            continue
        sem = max(relative_sem * abs(mean[i]), 1e-300)
        if shared is not None and np.isfinite(mean[i]):
            loads, distance = pilot_loads(table, c, float(mean[i]), parsed)
            if distance is not None:
                pool[i] = min(float(shared.correlation(distance))
                              * sum(load**2 for _, load in loads.values()), 0.99 * sem**2)
        precision[i] = 1.0 / (sem**2 - pool[i])
    rest = np.sqrt(np.maximum(np.nan_to_num(std) ** 2 - pool, 0.0))
    reduction = np.nan_to_num(variance_reduction(rest, precision), nan=0.0)
    gains = np.zeros(len(candidates))
    for i, c in enumerate(candidates):
        for name in set(c.designs) & open_designs:
            interval = by_name[name]
            tau = interval.target_std_ns_m(interval_fraction)
            if tau > 0:
                gains[i] += interval.per_cell ** 2 * reduction[i] / tau ** 2
    return gains


def _with_fantasy(table: pd.DataFrame, request: Request, model,
                  relative_sem: float) -> pd.DataFrame:
    """The table with the request's expected observation (see the module's text)."""
    if request.action == "extend":
        out = table.copy()
        where = out["case_key"] == request.key
        out.loc[where, SEM_COLUMN] = out.loc[where, SEM_COLUMN] / math.sqrt(request.factor)
        if LOADS_COLUMN in out.columns:
            out[LOADS_COLUMN] = out[LOADS_COLUMN].astype(object)
            out.loc[where, LOADS_COLUMN] = [
                format_loads(scaled_loads(parse_loads(text), 1.0 / request.factor))
                for text in out.loc[where, LOADS_COLUMN]]
        return out
    point = [request.freq_hz, request.accel_g, request.fill_pct]
    mean, _ = predict_or_nan(model, *point)
    if not np.isfinite(mean[0]):        # refused: the prediction at the nearest point it takes
        domain = getattr(model, "domain", {})
        point = [float(np.clip(v, *domain[k])) if k in domain else v
                 for k, v in zip(("freq_hz", "accel_g", "fill_pct"), point)]
        mean, _ = predict_or_nan(model, *point)
    value = float(mean[0]) if np.isfinite(mean[0]) else float(np.nanmedian(table[VALUE_COLUMN]))
    row = {"freq_hz": request.freq_hz, "accel_g": request.accel_g, "fill_pct": request.fill_pct,
           VALUE_COLUMN: value, SEM_COLUMN: max(relative_sem * abs(value), 1e-300),
           "status": "ok", "case_key": case_key(request.freq_hz, request.accel_g, request.fill_pct)}
    if LOADS_COLUMN in table.columns:
        row[LOADS_COLUMN] = format_loads(pilot_loads(table, request, value)[0])
    return pd.concat([table, pd.DataFrame([row])], ignore_index=True, sort=False)


def pilot_loads(table: pd.DataFrame, request: Request, value: float,
                parsed: list | None = None) -> tuple[dict, float | None]:
    """The loads a new case is expected to have on its fill's pilot packings: the nearest row's
    with loads (same fill first, then in ln f, ln G and r / 100), scaled by the values' ratio;
    and that row's distance from the case in (ln f, ln G) when it is of the same fill (the case
    shares its packings), else None.

    A new case shakes the pilot's packings of its fill, which every other case of that fill
    shakes (seeds of the pilot packings are the same at every fill), so its error shares their
    offsets; a fantasy without them would let the refit average away what one more case on
    those packings cannot. At a fill no row has yet, the loads are another fill's, on packings
    of its own. No loads when no row has any. ``parsed``: the table's loads already parsed."""
    loads = parsed if parsed is not None else [parse_loads(text) for text in table[LOADS_COLUMN]]
    values = table[VALUE_COLUMN].to_numpy(dtype=float)
    usable = np.array([bool(part) for part in loads]) & np.isfinite(values) & (values > 0)
    if not usable.any() or not value > 0:
        return {}, None
    f, g, r = (table[c].to_numpy(dtype=float) for c in ("freq_hz", "accel_g", "fill_pct"))
    other_fill = np.round(r, 3) != round(request.fill_pct, 3)
    condition = np.hypot(np.log(f / request.freq_hz), np.log(g / request.accel_g))
    order = np.lexsort((condition + np.abs(r - request.fill_pct) / 100.0, other_fill))
    nearest = next(i for i in order if usable[i])
    return (scaled_loads(loads[nearest], value / values[nearest]),
            None if other_fill[nearest] else float(condition[nearest]))
