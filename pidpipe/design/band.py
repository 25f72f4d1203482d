"""Designs over the whole band: the (r, n_c) that does best on average, or at the band's worst point.

For one environment with bands f in [f_lo, f_hi] and G in [G_lo, G_hi], a design (r, n_c) that
spends the budget has the total C_eq T(f, G) = (C_eq(f, G, r) / N) * n_c at every point of the
band [N*s/m]. Two designs maximise a functional of T over the band instead of its value at the
band's most favourable point (the ``peak`` design of :mod:`pidpipe.design.optimisation`):

``band_mean``
    maximise  mean_band T = sum_ij w_i w_j T(f_i, G_j), the Gauss-Legendre rule with
    ``quadrature_points`` nodes per axis on [f_lo, f_hi] x [G_lo, G_hi] (f linear, weights
    normalised to 1): the band's average with f and G uniform in their bands.
``worst_case``
    maximise  min_band T, the minimum over an evenly spaced ``grid_points`` x ``grid_points``
    grid of the band, edges and corners included. SLSQP cannot differentiate a minimum, so the
    problem is written in epigraph form: maximise t subject to T(f_k, G_k) >= t at every grid
    point k (and the budget).

Both spend the budget exactly: n_c = n_b / s(r) follows from r, so the SLSQP variables are the
scaled r (and t), bounded by the fills the budget allows; starts are a seeded stratified sample
of those fills. Every design, the peak one included, is then evaluated over its band by
:func:`evaluate_band`: the mean by the quadrature, the worst and best on the grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pidpipe.design.built_cells import at_each_fill, cells_total, whole_sphere_cells
from pidpipe.design.optimisation import (
    Budget,
    CeqModel,
    Environment,
    OptimisationResult,
    environment_bounds,
    feasible_fill_range,
    forward_difference_jacobian,
    latin_hypercube,
    make_design,
    run_starts,
    whole_cell_candidates,
)
from pidpipe.errors import ConfigError

#: The band designs this module solves.
BAND_KINDS: tuple[str, ...] = ("band_mean", "worst_case")


@dataclass(frozen=True)
class BandRule:
    """Where the band is sampled.

    Attributes
    ----------
    quadrature_points : int
        Gauss-Legendre nodes per axis of the band mean (>= 2; n nodes integrate polynomials
        of degree 2n - 1 exactly).
    grid_points : int
        Evenly spaced points per axis, edges included, for the band's minimum and maximum (>= 2).
    """

    quadrature_points: int = 5
    grid_points: int = 7

    def __post_init__(self) -> None:
        if self.quadrature_points < 2 or self.grid_points < 2:
            raise ConfigError(f"band rule needs quadrature_points >= 2 and grid_points >= 2; got {self}")

    def quadrature(self, bounds: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nodes (f Hz, G g) and weights (summing to 1) of the band mean, each shape (n*n,)."""
        x, w = np.polynomial.legendre.leggauss(self.quadrature_points)
        f = _map(x, bounds["freq_hz"])
        g = _map(x, bounds["accel_g"])
        ff, gg = np.meshgrid(f, g, indexing="ij")
        ww = np.outer(w, w) / 4.0
        return ff.ravel(), gg.ravel(), ww.ravel()

    def grid(self, bounds: dict) -> tuple[np.ndarray, np.ndarray]:
        """Grid points (f Hz, G g) of the band's extremes, each shape (n*n,)."""
        f = np.linspace(*bounds["freq_hz"], self.grid_points)
        g = np.linspace(*bounds["accel_g"], self.grid_points)
        ff, gg = np.meshgrid(f, g, indexing="ij")
        return ff.ravel(), gg.ravel()


def _map(x: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """Gauss-Legendre nodes on [-1, 1] -> the band [lo, hi]."""
    lo, hi = band
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * x


@dataclass
class BandSummary:
    """A design's total C_eq (N*s/m) over its environment's band.

    ``mean_total_ceq_ns_m`` by the quadrature; ``worst_*`` and ``best_*`` the smallest and
    largest on the grid and where (f Hz, G g) they are.
    """

    mean_total_ceq_ns_m: float
    worst_total_ceq_ns_m: float
    worst_freq_hz: float
    worst_accel_g: float
    best_total_ceq_ns_m: float
    best_freq_hz: float
    best_accel_g: float


def evaluate_band(model: CeqModel, bounds: dict, budget: Budget, n_cells: int,
                  rule: BandRule) -> BandSummary:
    """Total C_eq of n_c filled cells over the band, the cells as built: mean, worst and best.

    Parameters
    ----------
    model : CeqModel
    bounds : dict
        ``freq_hz`` and ``accel_g`` bands (from :func:`environment_bounds`), and ``fill_pct``
        (the surrogate's fill domain, %) to which the cells' fills are held.
    budget : Budget
    n_cells : int
        The design's filled cells; the budget's spheres fill them with whole spheres
        (:func:`pidpipe.design.built_cells.whole_sphere_cells`).
    rule : BandRule
    """
    cells = whole_sphere_cells(budget, n_cells, bounds.get("fill_pct"))
    f, g, w = rule.quadrature(bounds)
    mean = float(np.sum(w * cells_total(model, f, g, cells, budget.n_cells_coupon)))
    f, g = rule.grid(bounds)
    values = cells_total(model, f, g, cells, budget.n_cells_coupon)
    lo, hi = int(np.argmin(values)), int(np.argmax(values))
    return BandSummary(mean_total_ceq_ns_m=mean, worst_total_ceq_ns_m=float(values[lo]),
                       worst_freq_hz=float(f[lo]), worst_accel_g=float(g[lo]),
                       best_total_ceq_ns_m=float(values[hi]), best_freq_hz=float(f[hi]),
                       best_accel_g=float(g[hi]))


class _BandProblem:
    """A band design in scaled variables z = (r) or (r, t) in [0, 1].

    n_c is not a variable: it is the count that spends the budget at r, n_c = n_b / s(r), so the
    budget holds exactly and r is bounded by the fills the budget allows (1 <= n_c <= N_panel).
    (With n_c as a variable and the budget as an equality, SLSQP crept along the curved
    constraint for up to 138 iterations on a 1-D problem.) Same interface as
    :class:`pidpipe.design.optimisation._Problem`, so the same SLSQP runs, clustering and
    histories apply.
    """

    cluster_slice = slice(0, 1)  # r
    #: SLSQP's tolerance on the scaled objective. With the peak design's 1e-10, 28 of 160
    #: worst-case runs on bootstrap surrogates ended in SLSQP's exit 8 (positive directional
    #: derivative) at the optimum: below what finite differences of the grid minimum resolve.
    #: With 1e-8 none did.
    ftol = 1e-8

    def __init__(self, model: CeqModel, bounds: dict, budget: Budget, kind: str, rule: BandRule):
        self.model, self.budget, self.kind = model, budget, kind
        self.variables = ("fill_pct",) + (("t_ns_m",) if kind == "worst_case" else ())
        self.nodes = rule.quadrature(bounds) if kind == "band_mean" else rule.grid(bounds)
        r_lo, r_hi = feasible_fill_range(bounds, budget)
        self.lo = np.array([r_lo, 0.0][:len(self.variables)])
        self.hi = np.array([r_hi, 1.0][:len(self.variables)])
        self.scale = 1.0
        self._update_span()

    def _update_span(self) -> None:
        span = self.hi - self.lo
        self.span = np.where(span > 0, span, 1.0)
        self.fixed = span <= 0

    def set_scale(self, scale: float) -> None:
        """The objective's reference value, N*s/m; t is bounded by [0, 10 scale]."""
        self.scale = scale
        if self.kind == "worst_case":
            self.hi[1] = 10.0 * scale
            self._update_span()

    def to_x(self, z: np.ndarray) -> np.ndarray:
        x = self.lo + np.where(self.fixed, 0.0, z) * self.span
        return np.clip(x, self.lo, self.hi)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        return np.where(self.fixed, 0.0, (np.asarray(x, dtype=float) - self.lo) / self.span)

    def n_cells(self, fill_pct: float) -> float:
        """The cells that spend the budget at fill r, n_b / s(r)."""
        return float(self.budget.n_spheres / self.budget.spheres_per_cell(fill_pct))

    def named(self, x: np.ndarray) -> dict[str, float]:
        """Physical x by name, with the n_c it implies."""
        return {"fill_pct": float(x[0]), "n_cells": self.n_cells(x[0]),
                **({"t_ns_m": float(x[1])} if self.kind == "worst_case" else {})}

    def band_totals_of(self, fills: np.ndarray, n_cells: np.ndarray) -> np.ndarray:
        """T at every band node (quadrature or grid) for each fill r (%) and its n_c, in one
        prediction; shape (m, n*n), N*s/m."""
        values = np.asarray(self.model.predict(*at_each_fill(self.nodes[0], self.nodes[1], fills)),
                            dtype=float)
        return values.reshape(fills.size, -1) / self.budget.n_cells_coupon * n_cells[:, None]

    def band_totals(self, fill_pct: float, n_cells: float) -> np.ndarray:
        """T at every band node of n_c cells at fill r, N*s/m, shape (n*n,)."""
        return self.band_totals_of(np.array([fill_pct], dtype=float),
                                   np.array([n_cells], dtype=float))[0]

    def band_totals_at(self, zs: np.ndarray) -> np.ndarray:
        """:meth:`band_totals_of` at the fill (and the n_c that spends the budget there) of
        each row of ``zs``; shape (m, n*n), N*s/m."""
        fills = self.to_x(zs)[:, 0]
        return self.band_totals_of(fills, self.budget.n_spheres / self.budget.spheres_per_cell(fills))

    def band_objective(self, totals: np.ndarray) -> np.ndarray:
        """The band mean (quadrature), or the band minimum (grid), of totals over the last axis."""
        if self.kind == "band_mean":
            return np.sum(self.nodes[2] * totals, axis=-1)
        return np.min(totals, axis=-1)

    def objective_at(self, fill_pct: float, n_cells: float) -> float:
        """The band mean, or the band minimum, of n_c cells at fill r, N*s/m."""
        return float(self.band_objective(self.band_totals(fill_pct, n_cells)))

    def total_ceq(self, x: np.ndarray) -> float:
        """The design's objective at x, N*s/m."""
        return self.objective_at(x[0], self.n_cells(x[0]))

    def objective(self, z: np.ndarray) -> float:
        x = self.to_x(z)
        value = x[1] if self.kind == "worst_case" else self.total_ceq(x)
        return -value / self.scale

    def objective_gradient(self, z: np.ndarray) -> np.ndarray:
        """d objective / dz: exact for worst_case (-t / scale), forward differences of the
        band mean (:func:`~pidpipe.design.optimisation.forward_difference_jacobian`)."""
        if self.kind == "worst_case":
            return np.where(self.fixed, 0.0, np.array([0.0, -self.span[1] / self.scale]))

        def objectives(zs):
            return -self.band_objective(self.band_totals_at(zs)) / self.scale

        return forward_difference_jacobian(objectives, z, self.fixed)

    def budget_residual(self, x: np.ndarray) -> float:
        return float(self.budget.spheres_per_cell(x[0])) * self.n_cells(x[0]) - self.budget.n_spheres

    def constraints(self) -> list[dict]:
        """worst_case: T(f_k, G_k) - t >= 0 at every grid point, relative to the scale."""
        if self.kind != "worst_case":
            return []

        def margin(z: np.ndarray) -> np.ndarray:
            x = self.to_x(z)
            return (self.band_totals(x[0], self.n_cells(x[0])) - x[1]) / self.scale

        def margin_jacobian(z: np.ndarray) -> np.ndarray:
            # d/dr by forward differences of the totals; d/dt = -span_t / scale exactly
            jac = forward_difference_jacobian(lambda zs: self.band_totals_at(zs) / self.scale,
                                              z, self.fixed, columns=[0])
            if not self.fixed[1]:
                jac[:, 1] = -self.span[1] / self.scale
            return jac

        return [{"type": "ineq", "fun": margin, "jac": margin_jacobian}]

    def start(self, fill_pct: float) -> np.ndarray:
        """The start at fill r (and, for worst_case, t = the band minimum there)."""
        if self.kind == "worst_case":
            return np.array([fill_pct, self.total_ceq(np.array([fill_pct, 0.0]))])
        return np.array([fill_pct])


def band_starting_fills(bounds: dict, budget: Budget, n_starts: int, seed: int) -> np.ndarray:
    """Seeded stratified fills r (%), one per start, within the fills the budget allows."""
    r_lo, r_hi = feasible_fill_range(bounds, budget)
    if n_starts == 0:
        return np.empty(0)
    sample = latin_hypercube(n_starts, 1, seed)[:, 0]
    return r_lo + sample * (r_hi - r_lo)


def optimise_band_design(model: CeqModel, environment: Environment, budget: Budget, kind: str,
                         rule: BandRule = BandRule(), starts: int = 40, seed: int = 7,
                         clip_environment: bool = False, cluster_tol: float = 0.02,
                         maxiter: int = 200,
                         initial_fills: np.ndarray | None = None) -> OptimisationResult:
    """Multi-start SLSQP of a band design (``band_mean`` or ``worst_case``) in one environment.

    Parameters are those of :func:`pidpipe.design.optimisation.optimise_environment`, plus

    kind : {"band_mean", "worst_case"}
    rule : BandRule
    initial_fills : numpy.ndarray, shape (m,), optional
        Fills (%) started from before the ``starts`` stratified ones (the bootstrap's).

    Returns
    -------
    OptimisationResult
        ``kind`` set; its optimum and design have no single f and G (None); the design's
        ``total_ceq_ns_m`` is the objective (band mean or band minimum) at the whole-cell design.

    Raises
    ------
    DomainError, BudgetError, PidpipeError
        As :func:`pidpipe.design.optimisation.optimise_environment`.
    """
    if kind not in BAND_KINDS:
        raise ConfigError(f"band design {kind!r} is unknown; choose one of {', '.join(BAND_KINDS)}")
    given = np.empty(0) if initial_fills is None else np.atleast_1d(np.asarray(initial_fills, float))
    if starts < 0 or starts + given.size < 1:
        raise ConfigError(f"starts must be >= 1, got {starts}")
    bounds, clipped = environment_bounds(model, environment, budget, clip_environment)
    problem = _BandProblem(model, bounds, budget, kind, rule)
    fills = np.concatenate([np.clip(given, problem.lo[0], problem.hi[0]),
                            band_starting_fills(bounds, budget, starts, seed)])
    x0s = [problem.start(r) for r in fills]
    problem.set_scale(max(max(abs(problem.total_ceq(x0)) for x0 in x0s), 1e-300))
    x0s = [problem.start(r) for r in fills]  # t within its new bounds
    runs, optima = run_starts(problem, x0s, maxiter, cluster_tol,
                              f"environment {environment.name!r}, design {kind}")
    return OptimisationResult(
        environment=environment, budget=budget, bounds=bounds, clipped=clipped, seed=seed,
        optimum=optima[0], local_optima=optima, design=_whole_cell_band_design(problem, optima[0]),
        starts=runs, kind=kind)


def _whole_cell_band_design(problem: _BandProblem, optimum):
    """The better whole number of cells next to the optimum's n_c, by the band objective of its
    cells as built (:mod:`pidpipe.design.built_cells`)."""
    budget = problem.budget
    designs = []
    bounds = (problem.lo[0], problem.hi[0])
    for n_cells, per_cell, fill in whole_cell_candidates(budget, optimum.n_cells, bounds):
        totals = sum(problem.band_totals(cell_fill, float(count))
                     for cell_fill, count in whole_sphere_cells(budget, n_cells, bounds))
        total = float(problem.band_objective(totals))
        designs.append(make_design(budget, n_cells, per_cell, fill, total, None, None))
    return max(designs, key=lambda d: d.total_ceq_ns_m)
