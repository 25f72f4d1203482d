"""SLSQP multi-start optimisation of the panel's damping under a particle budget (SPEC.md).

The problem, for one operating environment::

    maximise    F(f, r, G, n_c) = (C_eq(f, G, r) / N) * n_c                 [N*s/m]
    subject to  spheres_per_cell(r) * n_c = n_b,  spheres_per_cell(r) = s_full * r / 100
                f_lo <= f <= f_hi,  G_lo <= G <= G_hi   (the environment's band)
                r_lo <= r <= r_hi                       (the surrogate's fill domain)
                1 <= n_c <= N

C_eq(f, G, r) is the coupon's equivalent damping with all N cells filled at r, so C_eq/N is one
cell's. ``s_full`` is the number of spheres in a cell at r = 100 %: 36 in the source study, 22 in
pidpipe's default "poured capacity" definition.

SLSQP works on the variables scaled to [0, 1] by their bounds and on the objective divided by a
reference value (the best objective among the starting points), so that its tolerances mean the
same thing in every environment. The constraint is written relative to the budget,
``(spheres_per_cell(r) * n_c - n_b) / n_b = 0``.

Starting points are a seeded Latin hypercube over (f, G, r), with r drawn inside the fills the
budget allows and n_c = n_b / spheres_per_cell(r), so every start is feasible. Each start's
objective is recorded at every iteration. Converged end points closer than ``cluster_tol`` (in
scaled f, G, r) are one local optimum. The final design rounds n_c to a whole number of cells
(the better of floor and ceil), then re-derives the spheres per cell n_b / n_c and the fill it
implies, checks the fill lies in the domain and reports the total C_eq there.

Environments outside the surrogate's domain are refused with
:class:`~pidpipe.errors.DomainError`; ``clip_environment=True`` explicitly narrows the band to
the domain instead, and the result records that it did.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np
import pandas as pd
from scipy.optimize import minimize
from scipy.stats import qmc

from pidpipe.errors import ConfigError, DomainError, PidpipeError

#: Order of the optimisation variables.
VARIABLES: tuple[str, ...] = ("freq_hz", "fill_pct", "accel_g", "n_cells")
#: A start counts as converged when SLSQP succeeds and the budget holds to this relative error.
BUDGET_RTOL = 1e-6


class BudgetError(PidpipeError):
    """The particle budget cannot be spent within the bounds (too small or too large)."""


class CeqModel(Protocol):
    """What the optimiser needs from a surrogate (:class:`pidpipe.design.surrogate.Surrogate` is one).

    ``domain`` maps ``freq_hz``, ``accel_g``, ``fill_pct`` to (low, high); ``predict(f, G, r)``
    returns the coupon's C_eq in N*s/m and raises DomainError outside the domain.
    """

    domain: dict[str, tuple[float, float]]

    def predict(self, freq_hz, accel_g, fill_pct): ...


@dataclass(frozen=True)
class Environment:
    """An operating environment: frequency band (Hz) and base-acceleration band (g)."""

    name: str
    freq_hz: tuple[float, float]
    accel_g: tuple[float, float]

    def __post_init__(self) -> None:
        for key, unit in (("freq_hz", "Hz"), ("accel_g", "g")):
            lo, hi = getattr(self, key)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
                raise ConfigError(f"environment {self.name!r}: {key} band [{lo}, {hi}] {unit} "
                                  f"must be finite with 0 < low <= high")


@dataclass(frozen=True)
class Budget:
    """The particle budget and the cell counts.

    Attributes
    ----------
    n_spheres : int
        n_b, spheres available for the panel.
    full_cell_spheres : float
        Spheres in one cell at r = 100 % (``pidpipe.config.full_cell_spheres``: 36 in the
        source's definition, 21 in the default poured-capacity one).
    n_cells_coupon : int
        N, cells of the coupon whose C_eq the surrogate predicts, and the most cells to fill.
    """

    n_spheres: int
    full_cell_spheres: float
    n_cells_coupon: int

    def __post_init__(self) -> None:
        if not (self.n_spheres >= 1 and self.full_cell_spheres > 0 and self.n_cells_coupon >= 1):
            raise ConfigError(f"budget needs n_spheres >= 1, full_cell_spheres > 0 and "
                              f"n_cells_coupon >= 1; got {self}")

    def spheres_per_cell(self, fill_pct):
        """Spheres in one cell at fill r (%): full_cell_spheres * r / 100 (not rounded)."""
        return self.full_cell_spheres * np.asarray(fill_pct, dtype=float) / 100.0


@dataclass
class StartRun:
    """One SLSQP run. Objectives are total C_eq of the filled cells, N*s/m."""

    index: int
    start: dict[str, float]
    final: dict[str, float]
    objective_ns_m: float
    history_ns_m: list[float]
    success: bool
    converged: bool
    message: str
    n_iterations: int
    budget_residual_spheres: float


@dataclass
class LocalOptimum:
    """A cluster of converged end points; values are those of its best member."""

    freq_hz: float
    fill_pct: float
    accel_g: float
    n_cells: float
    total_ceq_ns_m: float
    n_starts: int
    start_indices: list[int]


@dataclass
class Design:
    """The answer with a whole number of filled cells.

    ``spheres_per_cell`` = n_b / n_cells is what the budget implies (not a whole number in
    general); ``fill_pct`` is the fill it corresponds to, at which ``total_ceq_ns_m`` is
    evaluated. ``whole_spheres_per_cell`` = floor of it; ``spheres_left_over`` = n_b -
    whole * n_cells can go one each into that many cells.
    """

    n_cells: int
    spheres_per_cell: float
    whole_spheres_per_cell: int
    spheres_left_over: int
    fill_pct: float
    freq_hz: float
    accel_g: float
    ceq_per_cell_ns_m: float
    total_ceq_ns_m: float
    budget_residual_spheres: float


@dataclass
class OptimisationResult:
    """Everything the optimisation of one environment found."""

    environment: Environment
    budget: Budget
    bounds: dict[str, tuple[float, float]]
    clipped: bool
    seed: int
    optimum: LocalOptimum
    local_optima: list[LocalOptimum]
    design: Design
    starts: list[StartRun] = field(repr=False)

    @property
    def n_converged(self) -> int:
        """How many starts converged to a feasible point."""
        return sum(run.converged for run in self.starts)


# --------------------------------------------------------------------------------------------
# Bounds and feasibility


def environment_bounds(model: CeqModel, environment: Environment, budget: Budget,
                       clip_environment: bool = False) -> tuple[dict[str, tuple[float, float]], bool]:
    """Bounds of (f, r, G, n_c) for one environment.

    Parameters
    ----------
    model : CeqModel
        Supplies the domain.
    environment : Environment
    budget : Budget
    clip_environment : bool
        Narrow a band that leaves the domain to its part inside, instead of refusing.

    Returns
    -------
    bounds : dict of str -> (float, float)
        For each of :data:`VARIABLES` (Hz, %, g, cells).
    clipped : bool
        Whether a band was narrowed.

    Raises
    ------
    DomainError
        A band leaves the domain (and ``clip_environment`` is False) or does not overlap it.
    """
    bounds: dict[str, tuple[float, float]] = {}
    clipped = False
    for key, unit in (("freq_hz", "Hz"), ("accel_g", "g")):
        lo, hi = getattr(environment, key)
        d_lo, d_hi = model.domain[key]
        inside = lo >= d_lo and hi <= d_hi
        if not inside and (not clip_environment or hi < d_lo or lo > d_hi):
            what = "does not overlap" if (hi < d_lo or lo > d_hi) else "leaves"
            raise DomainError(
                f"environment {environment.name!r}: {key} band [{lo:g}, {hi:g}] {unit} {what} the "
                f"surrogate's domain [{d_lo:g}, {d_hi:g}] {unit}; extend the C_eq grid"
                + ("" if what == "does not overlap" else ", or clip the environment explicitly")
            )
        clipped = clipped or not inside
        bounds[key] = (max(lo, d_lo), min(hi, d_hi))
    bounds["fill_pct"] = tuple(float(v) for v in model.domain["fill_pct"])
    bounds["n_cells"] = (1.0, float(budget.n_cells_coupon))
    return {k: bounds[k] for k in VARIABLES}, clipped


def feasible_fill_range(bounds: dict[str, tuple[float, float]], budget: Budget) -> tuple[float, float]:
    """Fills r (%) at which the budget can be spent exactly with 1 <= n_c <= N.

    r * n_c = 100 n_b / s_full, so n_c <= N needs r >= 100 n_b / (s_full N) and n_c >= 1 needs
    r <= 100 n_b / s_full; intersected with the fill bounds.

    Raises
    ------
    BudgetError
        The intersection is empty; the message says which side fails and by how much.
    """
    r_lo, r_hi = bounds["fill_pct"]
    product = 100.0 * budget.n_spheres / budget.full_cell_spheres  # r * n_c, %*cells
    n_max = budget.n_cells_coupon
    one_cell_min = float(budget.spheres_per_cell(r_lo))
    if product < r_lo:
        raise BudgetError(
            f"budget of {budget.n_spheres} spheres is less than one cell at the lowest fill "
            f"{r_lo:g} % ({one_cell_min:g} spheres with {budget.full_cell_spheres:g} spheres at "
            f"100 %); raise the budget or extend the fill grid downwards")
    if product / n_max > r_hi:
        most = float(budget.spheres_per_cell(r_hi)) * n_max
        raise BudgetError(
            f"budget of {budget.n_spheres} spheres cannot be spent: all {n_max} cells at the "
            f"highest fill {r_hi:g} % hold only {most:g} spheres; lower the budget, or extend "
            f"the fill grid upwards")
    return max(r_lo, product / n_max), min(r_hi, product)


# --------------------------------------------------------------------------------------------
# The problem in scaled variables


class _Problem:
    """Objective and constraint of one environment in scaled variables z in [0, 1]^4."""

    def __init__(self, model: CeqModel, bounds: dict[str, tuple[float, float]], budget: Budget):
        self.model, self.budget = model, budget
        self.lo = np.array([bounds[k][0] for k in VARIABLES])
        self.hi = np.array([bounds[k][1] for k in VARIABLES])
        span = self.hi - self.lo
        self.span = np.where(span > 0, span, 1.0)  # a fixed variable keeps z = 0
        self.fixed = span <= 0
        self.scale = 1.0

    def to_x(self, z: np.ndarray) -> np.ndarray:
        """Scaled -> physical (f Hz, r %, G g, n_c), clipped to the bounds (SLSQP may step a
        rounding error outside them)."""
        x = self.lo + np.where(self.fixed, 0.0, z) * self.span
        return np.clip(x, self.lo, self.hi)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Physical -> scaled."""
        return np.where(self.fixed, 0.0, (np.asarray(x, dtype=float) - self.lo) / self.span)

    def total_ceq(self, x: np.ndarray) -> float:
        """(C_eq(f, G, r) / N) * n_c, N*s/m."""
        f, r, g, n_c = x
        return float(self.model.predict(f, g, r)) / self.budget.n_cells_coupon * n_c

    def objective(self, z: np.ndarray) -> float:
        """-total C_eq / scale (SLSQP minimises)."""
        return -self.total_ceq(self.to_x(z)) / self.scale

    def budget_residual(self, x: np.ndarray) -> float:
        """spheres_per_cell(r) * n_c - n_b, spheres."""
        return float(self.budget.spheres_per_cell(x[1])) * x[3] - self.budget.n_spheres

    def constraint(self, z: np.ndarray) -> float:
        """Budget residual relative to n_b (0 when the budget is spent exactly)."""
        return self.budget_residual(self.to_x(z)) / self.budget.n_spheres


def starting_points(bounds: dict[str, tuple[float, float]], budget: Budget, n_starts: int,
                    seed: int) -> np.ndarray:
    """Feasible starting points: a seeded Latin hypercube over (f, G, r).

    f is drawn uniformly in ln f, G and r uniformly; r only within :func:`feasible_fill_range`;
    n_c = n_b / spheres_per_cell(r) then spends the budget exactly.

    Returns
    -------
    numpy.ndarray, shape (n_starts, 4)
        Physical (f Hz, r %, G g, n_c) per row.
    """
    r_lo, r_hi = feasible_fill_range(bounds, budget)
    sample = qmc.LatinHypercube(d=3, rng=np.random.default_rng(seed)).random(n_starts)
    f_lo, f_hi = np.log(bounds["freq_hz"][0]), np.log(bounds["freq_hz"][1])
    g_lo, g_hi = bounds["accel_g"]
    f = np.exp(f_lo + sample[:, 0] * (f_hi - f_lo))
    g = g_lo + sample[:, 1] * (g_hi - g_lo)
    r = r_lo + sample[:, 2] * (r_hi - r_lo)
    n_c = np.clip(budget.n_spheres / budget.spheres_per_cell(r), *bounds["n_cells"])
    return np.column_stack([f, r, g, n_c])


def _run_start(problem: _Problem, index: int, x0: np.ndarray, maxiter: int) -> StartRun:
    """One SLSQP run from x0, recording the objective (N*s/m) at each iteration."""
    history = [problem.total_ceq(x0)]

    def record(zk: np.ndarray) -> None:
        history.append(problem.total_ceq(problem.to_x(zk)))

    result = minimize(
        problem.objective, problem.to_z(x0), method="SLSQP",
        bounds=[(0.0, 0.0) if fixed else (0.0, 1.0) for fixed in problem.fixed],
        constraints=[{"type": "eq", "fun": problem.constraint}],
        callback=record, options={"maxiter": maxiter, "ftol": 1e-10},
    )
    x = problem.to_x(result.x)
    residual = problem.budget_residual(x)
    feasible = abs(residual) <= BUDGET_RTOL * problem.budget.n_spheres
    return StartRun(
        index=index, start=dict(zip(VARIABLES, map(float, x0))), final=dict(zip(VARIABLES, map(float, x))),
        objective_ns_m=float(problem.total_ceq(x)), history_ns_m=[float(v) for v in history], success=bool(result.success),
        converged=bool(result.success) and feasible, message=str(result.message),
        n_iterations=int(result.nit), budget_residual_spheres=residual,
    )


def cluster_optima(runs: list[StartRun], problem: _Problem, tol: float) -> list[LocalOptimum]:
    """Group converged end points within ``tol`` of each other in scaled (f, r, G).

    Returns
    -------
    list of LocalOptimum
        Best first.
    """
    converged = sorted((run for run in runs if run.converged), key=lambda run: -run.objective_ns_m)
    clusters: list[tuple[np.ndarray, list[StartRun]]] = []
    for run in converged:
        z = problem.to_z(np.array([run.final[k] for k in VARIABLES]))[:3]
        for centre, members in clusters:
            if np.linalg.norm(z - centre) <= tol:
                members.append(run)
                break
        else:
            clusters.append((z, [run]))
    optima = []
    for _, members in clusters:
        best = members[0]
        optima.append(LocalOptimum(
            freq_hz=float(best.final["freq_hz"]), fill_pct=float(best.final["fill_pct"]),
            accel_g=float(best.final["accel_g"]), n_cells=float(best.final["n_cells"]),
            total_ceq_ns_m=float(best.objective_ns_m), n_starts=len(members),
            start_indices=[m.index for m in members]))
    return optima


def whole_cell_design(problem: _Problem, optimum: LocalOptimum) -> Design:
    """Round n_c to a whole number of cells and re-derive the fill from the budget.

    Both floor and ceil of n_c are tried; a candidate is kept if the fill it implies,
    100 * (n_b / n_c) / s_full, lies within the fill bounds; the better one wins.

    Raises
    ------
    BudgetError
        Neither whole number of cells gives a fill within the bounds.
    """
    budget = problem.budget
    r_lo, r_hi = problem.lo[1], problem.hi[1]
    candidates = {int(np.clip(math.floor(optimum.n_cells), 1, budget.n_cells_coupon)),
                  int(np.clip(math.ceil(optimum.n_cells), 1, budget.n_cells_coupon))}
    designs = []
    for n_cells in sorted(candidates):
        per_cell = budget.n_spheres / n_cells
        fill = 100.0 * per_cell / budget.full_cell_spheres
        if not (r_lo - 1e-9 <= fill <= r_hi + 1e-9):
            continue
        fill = float(np.clip(fill, r_lo, r_hi))
        ceq_cell = float(problem.model.predict(optimum.freq_hz, optimum.accel_g, fill)) / budget.n_cells_coupon
        whole = math.floor(per_cell + 1e-9)
        designs.append(Design(
            n_cells=n_cells, spheres_per_cell=per_cell, whole_spheres_per_cell=whole,
            spheres_left_over=int(budget.n_spheres - whole * n_cells), fill_pct=fill,
            freq_hz=optimum.freq_hz, accel_g=optimum.accel_g, ceq_per_cell_ns_m=ceq_cell,
            total_ceq_ns_m=ceq_cell * n_cells,
            budget_residual_spheres=float(budget.spheres_per_cell(fill)) * n_cells - budget.n_spheres))
    if not designs:
        raise BudgetError(f"no whole number of cells near n_c = {optimum.n_cells:.3f} spends the "
                          f"budget of {budget.n_spheres} spheres at a fill within "
                          f"[{r_lo:g}, {r_hi:g}] %")
    return max(designs, key=lambda d: d.total_ceq_ns_m)


# --------------------------------------------------------------------------------------------
# Entry points


def optimise_environment(model: CeqModel, environment: Environment, budget: Budget,
                         starts: int = 40, seed: int = 7, clip_environment: bool = False,
                         cluster_tol: float = 0.02, maxiter: int = 200) -> OptimisationResult:
    """Maximise the panel's total C_eq in one environment from many SLSQP starts.

    Parameters
    ----------
    model : CeqModel
        The C_eq surrogate (coupon, N*s/m).
    environment : Environment
    budget : Budget
    starts : int
        Number of starting points (>= 1).
    seed : int
        Seed of the starting points; the same seed gives the same result.
    clip_environment : bool
        Narrow bands that leave the surrogate's domain instead of refusing them.
    cluster_tol : float
        Distance in scaled (f, r, G) below which two end points are the same local optimum.
    maxiter : int
        SLSQP's iteration limit per start.

    Returns
    -------
    OptimisationResult

    Raises
    ------
    DomainError
        The environment leaves the surrogate's domain (see ``clip_environment``).
    BudgetError
        The budget cannot be spent within the bounds.
    PidpipeError
        No start converged to a feasible point.
    """
    if starts < 1:
        raise ConfigError(f"starts must be >= 1, got {starts}")
    bounds, clipped = environment_bounds(model, environment, budget, clip_environment)
    problem = _Problem(model, bounds, budget)
    x0s = starting_points(bounds, budget, starts, seed)
    initial = [problem.total_ceq(x0) for x0 in x0s]
    problem.scale = max(max(abs(v) for v in initial), 1e-300)
    runs = [_run_start(problem, i, x0, maxiter) for i, x0 in enumerate(x0s)]
    optima = cluster_optima(runs, problem, cluster_tol)
    if not optima:
        messages = sorted({run.message for run in runs})
        raise PidpipeError(f"environment {environment.name!r}: SLSQP converged to a feasible point "
                           f"from none of {starts} starts ({'; '.join(messages)})")
    return OptimisationResult(
        environment=environment, budget=budget, bounds=bounds, clipped=clipped, seed=seed,
        optimum=optima[0], local_optima=optima, design=whole_cell_design(problem, optima[0]),
        starts=runs)


def optimise_environments(model: CeqModel, environments: list[Environment], budget: Budget,
                          **options) -> list[OptimisationResult]:
    """:func:`optimise_environment` for each environment, same options and seed."""
    return [optimise_environment(model, env, budget, **options) for env in environments]


# --------------------------------------------------------------------------------------------
# Output


def results_frame(results: list[OptimisationResult]) -> pd.DataFrame:
    """One row per environment: the whole-cell design, the continuous optimum and counts."""
    rows = []
    for res in results:
        d, o = res.design, res.optimum
        rows.append({
            "environment": res.environment.name,
            "freq_band_hz": f"{res.bounds['freq_hz'][0]:g}-{res.bounds['freq_hz'][1]:g}",
            "accel_band_g": f"{res.bounds['accel_g'][0]:g}-{res.bounds['accel_g'][1]:g}",
            "clipped": res.clipped,
            "n_budget_spheres": res.budget.n_spheres,
            "full_cell_spheres": res.budget.full_cell_spheres,
            "n_cells": d.n_cells, "fill_pct": d.fill_pct, "spheres_per_cell": d.spheres_per_cell,
            "whole_spheres_per_cell": d.whole_spheres_per_cell,
            "spheres_left_over": d.spheres_left_over,
            "freq_hz": d.freq_hz, "accel_g": d.accel_g,
            "ceq_per_cell_ns_m": d.ceq_per_cell_ns_m, "total_ceq_ns_m": d.total_ceq_ns_m,
            "continuous_n_cells": o.n_cells, "continuous_fill_pct": o.fill_pct,
            "continuous_total_ceq_ns_m": o.total_ceq_ns_m,
            "n_starts": len(res.starts), "n_converged": res.n_converged,
            "n_local_optima": len(res.local_optima), "starts_at_optimum": o.n_starts,
        })
    return pd.DataFrame(rows)


def history_frame(results: list[OptimisationResult]) -> pd.DataFrame:
    """Long table of objective (N*s/m) against iteration for every start of every environment;
    ``at_optimum`` marks the starts that ended in the global optimum's cluster."""
    rows = []
    for res in results:
        best = set(res.optimum.start_indices)
        for run in res.starts:
            for it, value in enumerate(run.history_ns_m):
                rows.append({"environment": res.environment.name, "start": run.index,
                             "iteration": it, "total_ceq_ns_m": value,
                             "converged": run.converged, "at_optimum": run.index in best})
    return pd.DataFrame(rows)


def write_results_csv(results: list[OptimisationResult], path: str | Path) -> None:
    """Write :func:`results_frame` as CSV."""
    results_frame(results).to_csv(path, index=False)


def write_history_csv(results: list[OptimisationResult], path: str | Path) -> None:
    """Write :func:`history_frame` as CSV."""
    history_frame(results).to_csv(path, index=False)


def write_results_json(results: list[OptimisationResult], path: str | Path) -> None:
    """Write every result in full (starts and their histories included) as JSON."""
    document = [asdict(res) for res in results]
    Path(path).write_text(json.dumps(document, indent=1, default=_json_default))


def _json_default(value):
    """JSON encoder for numpy scalars and arrays."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")
