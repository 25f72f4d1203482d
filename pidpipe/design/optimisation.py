"""SLSQP multi-start optimisation of the panel's damping under a particle budget (SPEC.md).

The problem, for one operating environment::

    maximise    F(f, r, G, n_c) = (C_eq(f, G, r) / N) * n_c                 [N*s/m]
    subject to  spheres_per_cell(r) * n_c = n_b,  spheres_per_cell(r) = s_full * r / 100
                f_lo <= f <= f_hi,  G_lo <= G <= G_hi   (the environment's band)
                r_lo <= r <= r_hi                       (the surrogate's fill domain)
                1 <= n_c <= N_panel

C_eq(f, G, r) is the coupon's equivalent damping with all N cells filled at r, so C_eq/N is one
cell's; the cells are independent (docs/explanation/scene.md), so the panel being designed may have more
cells than the coupon, N_panel >= N (``Budget.n_cells_panel``, config ``panel.n_cells``).
``s_full`` is the number of spheres in a cell at r = 100 %: 36 in the source study, 22 in
pidpipe's default "poured capacity" definition.

SLSQP works on the variables scaled to [0, 1] by their bounds and on the objective divided by a
reference value (the best objective among the starting points), so that its tolerances mean the
same thing in every environment. The constraint is written relative to the budget,
``(spheres_per_cell(r) * n_c - n_b) / n_b = 0``; its gradient is exact. The objective's gradient
is a forward difference with SciPy's default step (:func:`forward_difference_jacobian`), its
points predicted in one call of the surrogate instead of one call each: the surrogate's
per-call cost, not its arithmetic, was most of the optimisation's time.

Starting points are a seeded Latin hypercube over (f, G, r), with r drawn inside the fills the
budget allows and n_c = n_b / spheres_per_cell(r), so every start is feasible. Each start's
objective is recorded at every iteration. Converged end points closer than ``cluster_tol`` (in
scaled f, G, r) are one local optimum. The final design rounds n_c to a whole number of cells
(the better of floor and ceil), then re-derives the spheres per cell n_b / n_c and the fill it
implies, checks the fill lies in the domain and reports the total C_eq of its cells as built:
whole spheres, w = floor(n_b / n_c) in each and one more in n_b - w n_c of them, each cell read
at its own sphere count's fill (:mod:`pidpipe.design.built_cells`).

Environments outside the surrogate's domain are refused with
:class:`~pidpipe.errors.DomainError`; ``clip_environment=True`` explicitly narrows the band to
the domain instead, and the result records that it did.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from scipy.optimize import minimize

# The budget and the environment are the config's own types (one definition each).
from pidpipe.config.settings import Budget, Environment  # noqa: F401
from pidpipe.design.built_cells import cells_total, whole_sphere_cells, whole_sphere_counts
from pidpipe.errors import ConfigError, DomainError, PidpipeError

#: Order of the optimisation variables.
VARIABLES: tuple[str, ...] = ("freq_hz", "fill_pct", "accel_g", "n_cells")
#: A start counts as converged when SLSQP succeeds and the budget holds to this relative error.
BUDGET_RTOL = 1e-6
#: Relative step of the forward differences: SciPy's default for SLSQP ("2-point"), sqrt(eps).
FD_RELATIVE_STEP = float(np.sqrt(np.finfo(float).eps))


class BudgetError(PidpipeError):
    """The particle budget cannot be spent within the bounds (too small or too large)."""


class CeqModel(Protocol):
    """What the optimiser needs from a surrogate (:class:`pidpipe.design.surrogate.Surrogate` is one).

    ``domain`` maps ``freq_hz``, ``accel_g``, ``fill_pct`` to (low, high); ``predict(f, G, r)``
    returns the coupon's C_eq in N*s/m and raises DomainError outside the domain.
    """

    domain: dict[str, tuple[float, float]]

    def predict(self, freq_hz, accel_g, fill_pct): ...


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
    """A cluster of converged end points; values are those of its best member (f and G are
    None for the band designs, which have no single point)."""

    freq_hz: float | None
    fill_pct: float
    accel_g: float | None
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
    whole * n_cells can go one each into that many cells. ``freq_hz`` and ``accel_g`` are the
    peak design's point, None for the band designs (whose ``total_ceq_ns_m`` is the band mean
    or the band minimum).
    """

    n_cells: int
    spheres_per_cell: float
    whole_spheres_per_cell: int
    spheres_left_over: int
    fill_pct: float
    freq_hz: float | None
    accel_g: float | None
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
    #: "peak", "band_mean" or "worst_case" (:mod:`pidpipe.design.designs`).
    kind: str = "peak"
    #: The design's total C_eq over the band (a :class:`pidpipe.design.band.BandSummary`).
    band: object = None
    #: Non-empty when the design relies on the G <= 1 regime (:mod:`pidpipe.design.designs`).
    regime_warning: str = ""
    #: Bootstrap intervals and win counts (:mod:`pidpipe.design.bootstrap`), or None.
    uncertainty: dict | None = None

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
    bounds["n_cells"] = (1.0, float(budget.max_cells))
    return {k: bounds[k] for k in VARIABLES}, clipped


def feasible_fill_range(bounds: dict[str, tuple[float, float]], budget: Budget) -> tuple[float, float]:
    """Fills r (%) at which the budget can be spent exactly with 1 <= n_c <= N_panel.

    r * n_c = 100 n_b / s_full, so n_c <= N_panel needs r >= 100 n_b / (s_full N_panel) and n_c >= 1 needs
    r <= 100 n_b / s_full; intersected with the fill bounds.

    Raises
    ------
    BudgetError
        The intersection is empty; the message says which side fails and by how much.
    """
    r_lo, r_hi = bounds["fill_pct"]
    product = 100.0 * budget.n_spheres / budget.full_cell_spheres  # r * n_c, %*cells
    n_max = budget.max_cells
    one_cell_min = float(budget.spheres_per_cell(r_lo))
    if product < r_lo:
        raise BudgetError(
            f"budget of {budget.n_spheres} spheres is less than one cell at the lowest fill "
            f"{r_lo:g} % ({one_cell_min:g} spheres with {budget.full_cell_spheres:g} spheres at "
            f"100 %); raise the budget or extend the fill grid downwards")
    if product / n_max > r_hi:
        most = float(budget.spheres_per_cell(r_hi)) * n_max
        raise BudgetError(
            f"budget of {budget.n_spheres} spheres cannot be spent: all {n_max} cells "
            f"{'of the panel ' if budget.n_cells_panel is not None else ''}at the "
            f"highest fill {r_hi:g} % hold only {most:g} spheres; lower the budget, raise "
            f"panel.n_cells, or extend the fill grid upwards")
    return max(r_lo, product / n_max), min(r_hi, product)


# --------------------------------------------------------------------------------------------
# Gradients


def forward_difference_jacobian(values_at, z: np.ndarray, fixed: np.ndarray,
                                columns=None) -> np.ndarray:
    """Forward-difference derivatives at z in [0, 1]^d, every point evaluated in one call.

    The step is SciPy's for SLSQP without a gradient: h = sqrt(eps) max(1, |z_j|), taken
    backwards where z_j + h would pass the upper bound 1, and divided by the step actually
    made, (z_j + h) - z_j.

    Parameters
    ----------
    values_at : callable
        Maps points, shape (m, d), to values, shape (m,) or (m, p).
    z : numpy.ndarray, shape (d,)
        Where to differentiate (scaled variables).
    fixed : numpy.ndarray of bool, shape (d,)
        Variables held fixed: their derivative is 0 and they are not stepped.
    columns : sequence of int, optional
        The variables to differentiate (default: every one not fixed); the others' derivative
        is left 0, for the caller to fill in exactly.

    Returns
    -------
    numpy.ndarray
        Shape (d,) for scalar values, (p, d) for vector values.
    """
    z = np.asarray(z, dtype=float)
    free = [j for j in (range(z.size) if columns is None else columns) if not fixed[j]]
    points = np.repeat(z[None, :], len(free) + 1, axis=0)
    for row, j in enumerate(free, start=1):
        h = FD_RELATIVE_STEP * max(1.0, abs(z[j]))
        points[row, j] = z[j] + h if z[j] + h <= 1.0 else z[j] - h
    values = np.asarray(values_at(points), dtype=float)
    jac = np.zeros(values.shape[1:] + (z.size,))
    for row, j in enumerate(free, start=1):
        jac[..., j] = (values[row] - values[0]) / (points[row, j] - z[j])
    return jac


# --------------------------------------------------------------------------------------------
# The problem in scaled variables


class _Problem:
    """Objective and constraint of one environment in scaled variables z in [0, 1]^4."""

    variables = VARIABLES
    cluster_slice = slice(0, 3)  # f, r, G
    ftol = 1e-10  # SLSQP's tolerance on the scaled objective

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

    def total_ceqs(self, xs: np.ndarray) -> np.ndarray:
        """(C_eq(f, G, r) / N) * n_c at each row (f, r, G, n_c) of ``xs`` (m, 4), in one
        prediction; shape (m,), N*s/m."""
        f, r, g, n_c = np.asarray(xs, dtype=float).T
        return np.asarray(self.model.predict(f, g, r), dtype=float) / self.budget.n_cells_coupon * n_c

    def total_ceq(self, x: np.ndarray) -> float:
        """(C_eq(f, G, r) / N) * n_c at one x, N*s/m."""
        return float(self.total_ceqs(np.atleast_2d(x))[0])

    def objective(self, z: np.ndarray) -> float:
        """-total C_eq / scale (SLSQP minimises)."""
        return -self.total_ceq(self.to_x(z)) / self.scale

    def objectives(self, zs: np.ndarray) -> np.ndarray:
        """:meth:`objective` at each row of ``zs`` (m, 4), in one prediction; shape (m,)."""
        return -self.total_ceqs(self.to_x(zs)) / self.scale

    def objective_gradient(self, z: np.ndarray) -> np.ndarray:
        """d objective / dz, shape (4,): forward differences (:func:`forward_difference_jacobian`)."""
        return forward_difference_jacobian(self.objectives, z, self.fixed)

    def budget_residual(self, x: np.ndarray) -> float:
        """spheres_per_cell(r) * n_c - n_b, spheres."""
        return float(self.budget.spheres_per_cell(x[1])) * x[3] - self.budget.n_spheres

    def constraint(self, z: np.ndarray) -> float:
        """Budget residual relative to n_b (0 when the budget is spent exactly)."""
        return self.budget_residual(self.to_x(z)) / self.budget.n_spheres

    def constraint_gradient(self, z: np.ndarray) -> np.ndarray:
        """d :meth:`constraint` / dz, exact, shape (4,): s_full/100 (n_c dr/dz_r + r dn_c/dz_n) / n_b."""
        _, r, _, n_c = self.to_x(z)
        per_percent = self.budget.full_cell_spheres / 100.0 / self.budget.n_spheres
        grad = np.zeros(len(VARIABLES))
        grad[1] = per_percent * n_c * self.span[1]
        grad[3] = per_percent * r * self.span[3]
        return np.where(self.fixed, 0.0, grad)

    def constraints(self) -> list[dict]:
        """SLSQP's constraints: the budget, spent exactly."""
        return [{"type": "eq", "fun": self.constraint, "jac": self.constraint_gradient}]

    def named(self, x: np.ndarray) -> dict[str, float]:
        """Physical x by variable name."""
        return dict(zip(VARIABLES, map(float, x)))


def latin_hypercube(n: int, d: int, seed: int) -> np.ndarray:
    """``n`` seeded Latin-hypercube points in the unit cube of ``d`` dimensions, shape (n, d).

    The multistarts' sampler (``scipy.stats.qmc.LatinHypercube``). ``scipy.stats`` is
    imported here, not with this module: its import costs a job more than a CPU-second, and
    most jobs that import the optimiser's module sample nothing.
    """
    from scipy.stats import qmc

    return qmc.LatinHypercube(d=d, rng=np.random.default_rng(seed)).random(n)


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
    if n_starts == 0:
        return np.empty((0, len(VARIABLES)))
    sample = latin_hypercube(n_starts, 3, seed)
    f_lo, f_hi = np.log(bounds["freq_hz"][0]), np.log(bounds["freq_hz"][1])
    g_lo, g_hi = bounds["accel_g"]
    f = np.exp(f_lo + sample[:, 0] * (f_hi - f_lo))
    g = g_lo + sample[:, 1] * (g_hi - g_lo)
    r = r_lo + sample[:, 2] * (r_hi - r_lo)
    n_c = np.clip(budget.n_spheres / budget.spheres_per_cell(r), *bounds["n_cells"])
    return np.column_stack([f, r, g, n_c])


def _run_start(problem, index: int, x0: np.ndarray, maxiter: int) -> StartRun:
    """One SLSQP run from x0, recording the objective (N*s/m) at each iteration.

    ``problem`` is a :class:`_Problem` or another problem with the same interface
    (``to_x``, ``to_z``, ``fixed``, ``ftol``, ``objective``, ``objective_gradient``,
    ``constraints``, ``named``, ``total_ceq``, ``budget_residual``, ``budget``), such as the band
    designs' of :mod:`pidpipe.design.band`.
    """
    history = [problem.total_ceq(x0)]

    def record(zk: np.ndarray) -> None:
        history.append(problem.total_ceq(problem.to_x(zk)))

    result = minimize(
        problem.objective, problem.to_z(x0), method="SLSQP", jac=problem.objective_gradient,
        bounds=[(0.0, 0.0) if fixed else (0.0, 1.0) for fixed in problem.fixed],
        constraints=problem.constraints(),
        callback=record, options={"maxiter": maxiter, "ftol": problem.ftol},
    )
    x = problem.to_x(result.x)
    residual = problem.budget_residual(x)
    feasible = abs(residual) <= BUDGET_RTOL * problem.budget.n_spheres
    return StartRun(
        index=index, start=problem.named(x0), final=problem.named(x),
        objective_ns_m=float(problem.total_ceq(x)), history_ns_m=[float(v) for v in history], success=bool(result.success),
        converged=bool(result.success) and feasible, message=str(result.message),
        n_iterations=int(result.nit), budget_residual_spheres=residual,
    )


def cluster_optima(runs: list[StartRun], problem, tol: float) -> list[LocalOptimum]:
    """Group converged end points within ``tol`` of each other in the problem's scaled
    clustering variables (f, r, G for the peak design; r for the band designs).

    Returns
    -------
    list of LocalOptimum
        Best first.
    """
    converged = sorted((run for run in runs if run.converged), key=lambda run: -run.objective_ns_m)
    clusters: list[tuple[np.ndarray, list[StartRun]]] = []
    for run in converged:
        z = problem.to_z(np.array([run.final[k] for k in problem.variables]))[problem.cluster_slice]
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
            freq_hz=best.final.get("freq_hz"), fill_pct=float(best.final["fill_pct"]),
            accel_g=best.final.get("accel_g"), n_cells=float(best.final["n_cells"]),
            total_ceq_ns_m=float(best.objective_ns_m), n_starts=len(members),
            start_indices=[m.index for m in members]))
    return optima


def run_starts(problem, x0s, maxiter: int, cluster_tol: float,
               what: str) -> tuple[list[StartRun], list[LocalOptimum]]:
    """SLSQP from every starting point, then the local optima (best first).

    Raises
    ------
    PidpipeError
        No start converged to a feasible point (``what`` names the problem).
    """
    runs = [_run_start(problem, i, x0, maxiter) for i, x0 in enumerate(x0s)]
    optima = cluster_optima(runs, problem, cluster_tol)
    if not optima:
        messages = sorted({run.message for run in runs})
        raise PidpipeError(f"{what}: SLSQP converged to a feasible point from none of {len(runs)} "
                           f"starts ({'; '.join(messages)})")
    return runs, optima


def whole_cell_candidates(budget: Budget, n_cells: float,
                          fill_bounds: tuple[float, float]) -> list[tuple[int, float, float]]:
    """The whole numbers of cells next to a continuous n_c that spend the budget in the bounds.

    Both floor and ceil of n_c (within 1 ... N_panel) are tried; a candidate is kept if the fill
    it implies, 100 * (n_b / n_c) / s_full, lies within ``fill_bounds`` (%).

    Returns
    -------
    list of (int, float, float)
        (cells, spheres per cell, fill %) of each kept candidate; never empty.

    Raises
    ------
    BudgetError
        Neither whole number of cells gives a fill within the bounds.
    """
    r_lo, r_hi = fill_bounds
    candidates = {int(np.clip(math.floor(n_cells), 1, budget.max_cells)),
                  int(np.clip(math.ceil(n_cells), 1, budget.max_cells))}
    kept = []
    for cells in sorted(candidates):
        per_cell = budget.n_spheres / cells
        fill = 100.0 * per_cell / budget.full_cell_spheres
        if r_lo - 1e-9 <= fill <= r_hi + 1e-9:
            kept.append((cells, per_cell, float(np.clip(fill, r_lo, r_hi))))
    if not kept:
        raise BudgetError(f"no whole number of cells near n_c = {n_cells:.3f} spends the "
                          f"budget of {budget.n_spheres} spheres at a fill within "
                          f"[{r_lo:g}, {r_hi:g}] %")
    return kept


def make_design(budget: Budget, n_cells: int, per_cell: float, fill: float, total_ns_m: float,
                freq_hz: float | None, accel_g: float | None) -> Design:
    """A :class:`Design` of ``n_cells`` cells at ``fill`` whose total C_eq is ``total_ns_m``."""
    whole, left = whole_sphere_counts(budget, n_cells)
    return Design(
        n_cells=n_cells, spheres_per_cell=per_cell, whole_spheres_per_cell=whole,
        spheres_left_over=left, fill_pct=fill,
        freq_hz=freq_hz, accel_g=accel_g, ceq_per_cell_ns_m=total_ns_m / n_cells,
        total_ceq_ns_m=total_ns_m,
        budget_residual_spheres=float(budget.spheres_per_cell(fill)) * n_cells - budget.n_spheres)


def whole_cell_design(problem: _Problem, optimum: LocalOptimum) -> Design:
    """Round n_c to a whole number of cells and re-derive the fill from the budget.

    Of the candidates of :func:`whole_cell_candidates` the better one, by the total C_eq at
    the optimum's f and G of its cells as built (whole spheres,
    :mod:`pidpipe.design.built_cells`), wins.

    Raises
    ------
    BudgetError
        Neither whole number of cells gives a fill within the bounds.
    """
    budget = problem.budget
    r_lo, r_hi = problem.lo[1], problem.hi[1]
    designs = []
    for n_cells, per_cell, fill in whole_cell_candidates(budget, optimum.n_cells, (r_lo, r_hi)):
        cells = whole_sphere_cells(budget, n_cells, (r_lo, r_hi))
        total = float(cells_total(problem.model, [optimum.freq_hz], [optimum.accel_g], cells,
                                  budget.n_cells_coupon)[0])
        designs.append(make_design(budget, n_cells, per_cell, fill, total,
                                   optimum.freq_hz, optimum.accel_g))
    return max(designs, key=lambda d: d.total_ceq_ns_m)


# --------------------------------------------------------------------------------------------
# Entry points


def optimise_environment(model: CeqModel, environment: Environment, budget: Budget,
                         starts: int = 40, seed: int = 7, clip_environment: bool = False,
                         cluster_tol: float = 0.02, maxiter: int = 200,
                         initial_points: np.ndarray | None = None) -> OptimisationResult:
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
    initial_points : numpy.ndarray, shape (m, 4), optional
        Physical (f, r, G, n_c) starting points run before the ``starts`` Latin-hypercube ones
        (the bootstrap starts from the main run's local optima); ``starts`` may then be 0.

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
    given = np.empty((0, len(VARIABLES))) if initial_points is None else np.atleast_2d(initial_points)
    if starts < 0 or starts + len(given) < 1:
        raise ConfigError(f"starts must be >= 1, got {starts}")
    bounds, clipped = environment_bounds(model, environment, budget, clip_environment)
    problem = _Problem(model, bounds, budget)
    x0s = np.vstack([given, starting_points(bounds, budget, starts, seed)])
    initial = [problem.total_ceq(x0) for x0 in x0s]
    problem.scale = max(max(abs(v) for v in initial), 1e-300)
    runs, optima = run_starts(problem, x0s, maxiter, cluster_tol, f"environment {environment.name!r}")
    return OptimisationResult(
        environment=environment, budget=budget, bounds=bounds, clipped=clipped, seed=seed,
        optimum=optima[0], local_optima=optima, design=whole_cell_design(problem, optima[0]),
        starts=runs)


def optimise_environments(model: CeqModel, environments: list[Environment], budget: Budget,
                          **options) -> list[OptimisationResult]:
    """:func:`optimise_environment` for each environment, same options and seed."""
    return [optimise_environment(model, env, budget, **options) for env in environments]
