"""Which cells to fill, and how full, on a mode: the optimised layout and the source-style ones.

The optimised layout works on regions, to keep the problem small: the cells are grouped into K
levels of |phi| (level k holds 1 - (k+1)/K < |phi| <= 1 - k/K, rings around an antinode), and
SLSQP chooses for each level the share x_k of its N_k cells that is filled and their fill r_k:

    maximise  J(eta_p(G))   over G in the band [G_lo, G_hi] of antinode accelerations
    eta_p(G) = sum_k N_k x_k <C_eq(f, G |phi|, r_k) phi^2>_k / N / (omega M)
    subject to  sum_k N_k x_k s(r_k) <= n_b,   0 <= x_k <= 1,   r_lo <= r_k <= r_hi

with <.>_k the mean over level k (``quantiles`` quantiles of its |phi|), M and omega the loaded
modal mass and frequency (:mod:`pidpipe.panel.loss`), s(r) the spheres per cell and J the
design's functional: ``peak`` (G a variable within the band), ``band_mean`` (Gauss-Legendre in
G) or ``worst_case`` (the minimum on a grid of G, in epigraph form). Starts: filling the levels
from the antinode outwards at mid fill (and at any further fills given, such as the coupon
design's) until the budget is spent, and ``starts`` seeded
Latin-hypercube points scaled onto the budget. Every feasible end point (and every start) is
rounded to whole cells and judged on all its cells (:func:`pidpipe.panel.loss.band_summary`:
the peak as the band grid's best point); the best is the answer. Rounding to whole cells and
spheres: level k fills c_k = round(x_k N_k) of its cells and spends n_k = floor(c_k s(r_k))
spheres on them as a design is built (:mod:`pidpipe.design.built_cells`): w_k = floor(n_k / c_k)
in each and one more in the first n_k - w_k c_k, each cell at its count's fill (counts held to
the C_eq model's fill domain, :meth:`pidpipe.panel.loss.ModalLoss.sphere_counts`); cells are
taken off the outermost filled level while the budget is exceeded. Within a level the cells are
taken best first by their own contribution C_eq(f, G |phi_i|, r_k) phi_i^2 over the design's
accelerations (the level's largest |phi| first when C_eq grows with G, its middle when C_eq
peaks inside the level).

The source-style layouts fill the coupon design's n_c cells as it is built, w spheres in each
and one more in L of them (:func:`pidpipe.design.built_cells.whole_sphere_cells`, given as one
fill per cell, the fuller first): ``source_uniform`` spreads them evenly over the plate,
``source_antinode`` takes the n_c cells of largest |phi|, the fuller ones where |phi| is
largest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from pidpipe.design.built_cells import split_spheres
from pidpipe.design.optimisation import latin_hypercube
from pidpipe.panel.loss import KINDS, AccelBand, Layout, ModalLoss, band_summary


@dataclass(frozen=True)
class Regions:
    """Levels of |phi|: each cell's level, and each level's cells sorted by falling |phi|."""

    level: np.ndarray          # (n_cells,) int, -1: not in any level (|phi| = 0)
    members: list              # K arrays of cell indices
    count: np.ndarray          # (K,) N_k
    phi2_mean: np.ndarray      # (K,) <phi^2>_k
    samples: np.ndarray        # (K, Q) quantile |phi| of each level (0 where empty)


def make_regions(phi: np.ndarray, levels: int, quantiles: int = 8) -> Regions:
    """Group cells into ``levels`` levels of |phi| (k = 0 at the antinode)."""
    a = np.abs(phi)
    level = np.minimum((levels * (1.0 - a)).astype(int), levels - 1)
    level[a <= 0.0] = -1
    members, count, phi2, samples = [], [], [], []
    q = (np.arange(quantiles) + 0.5) / quantiles
    for k in range(levels):
        cells = np.flatnonzero(level == k)
        cells = cells[np.argsort(-a[cells], kind="stable")]
        members.append(cells)
        count.append(cells.size)
        phi2.append(float(np.mean(a[cells] ** 2)) if cells.size else 0.0)
        samples.append(np.quantile(a[cells], q) if cells.size else np.zeros(quantiles))
    return Regions(level, members, np.array(count), np.array(phi2), np.array(samples))


@dataclass
class LayoutResult:
    """The optimised layout of one design kind on one mode."""

    kind: str
    layout: Layout
    objective: float           # J of the continuous optimum (eta_p, -)
    share: np.ndarray          # (K,) x_k
    fill_pct: np.ndarray       # (K,) r_k
    accel_g: float | None      # peak design's G
    n_starts: int
    n_converged: int
    n_evaluations: int


class _RegionProblem:
    """The scaled problem of module docstring; z = (x_1..x_K, rho_1..rho_K[, g or t]) in [0, 1]."""

    def __init__(self, loss: ModalLoss, predict, regions: Regions, band: AccelBand, kind: str,
                 n_spheres: float):
        self.loss, self.predict, self.regions, self.band, self.kind = loss, predict, regions, band, kind
        self.n_spheres = float(n_spheres)
        self.k = regions.count.size
        self.r_lo, self.r_hi = loss.domain["fill_pct"]
        if kind == "band_mean":
            self.nodes, self.weights = band.quadrature()
        else:
            self.nodes, self.weights = band.grid(), None
        self.extra = kind in ("peak", "worst_case")
        self.scale = 1.0
        self.evaluations = 0

    def unpack(self, z):
        x = np.clip(z[:self.k], 0.0, 1.0)
        r = self.r_lo + np.clip(z[self.k:2 * self.k], 0.0, 1.0) * (self.r_hi - self.r_lo)
        return x, r

    def peak_accel(self, z) -> float:
        return self.band.low + float(np.clip(z[-1], 0, 1)) * (self.band.high - self.band.low)

    def eta(self, z, accel_g: np.ndarray) -> np.ndarray:
        """eta_p at antinode accelerations G (shape (m,)) of the continuous region design z."""
        self.evaluations += 1
        x, r = self.unpack(z)
        reg, loss = self.regions, self.loss
        filled = reg.count * x
        if loss.effective_mass_kg is None:
            per_level = loss.cell_effective_mass_kg(r) * reg.phi2_mean
        else:       # m_eff with |phi|: the mean of m_eff phi^2 over the level's quantiles
            s = reg.samples
            per_level = (loss.cell_effective_mass_kg(np.broadcast_to(r[:, None], s.shape), s) * s**2).mean(axis=1)
        mass = loss.mode.modal_mass_kg + float(np.sum(filled * per_level))
        freq = loss.mode.freq_hz * math.sqrt(loss.mode.modal_mass_kg / mass)
        lo, hi = loss.domain["accel_g"]
        g = accel_g[:, None, None] * reg.samples[None, :, :]               # (m, K, Q)
        fills = np.broadcast_to(r[None, :, None], g.shape)
        c = np.asarray(self.predict(np.full(g.shape, freq), np.clip(g, lo, hi), fills), dtype=float)
        c = np.where(g < lo, 0.0, c) * reg.samples[None, :, :] ** 2
        per_cell = c.mean(axis=2) / loss.n_cells_coupon                   # (m, K)
        return per_cell @ filled / (2.0 * math.pi * freq * mass)

    def objective_value(self, z) -> float:
        if self.kind == "peak":
            return float(self.eta(z, np.array([self.peak_accel(z)]))[0])
        values = self.eta(z, self.nodes)
        return float(self.weights @ values) if self.kind == "band_mean" else float(values.min())

    def objective(self, z) -> float:
        if self.kind == "worst_case":
            return -float(z[-1])
        return -self.objective_value(z) / self.scale

    def budget_margin(self, z) -> float:
        x, r = self.unpack(z)
        used = float(np.sum(self.regions.count * x * self.loss.spheres(r)))
        return (self.n_spheres - used) / self.n_spheres

    def constraints(self) -> list[dict]:
        cons = [{"type": "ineq", "fun": self.budget_margin}]
        if self.kind == "worst_case":
            cons.append({"type": "ineq",
                         "fun": lambda z: (self.eta(z, self.nodes) / self.scale - z[-1])})
        return cons

    def bounds(self) -> list[tuple[float, float]]:
        hi_extra = [(0.0, 10.0)] if self.kind == "worst_case" else [(0.0, 1.0)]
        return [(0.0, 1.0)] * (2 * self.k) + (hi_extra if self.extra else [])

    def onto_budget(self, x: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Scale x down so that the budget holds."""
        used = float(np.sum(self.regions.count * x * self.loss.spheres(r)))
        return x * min(1.0, self.n_spheres / used) if used > 0 else x

    def pack(self, x, r, extra: float = 0.5) -> np.ndarray:
        rho = (r - self.r_lo) / (self.r_hi - self.r_lo) if self.r_hi > self.r_lo else np.zeros_like(r)
        z = np.concatenate([x, rho])
        return np.concatenate([z, [extra]]) if self.extra else z

    def ranked_members(self, z) -> list[np.ndarray]:
        """Each level's cells, best first by their own contribution C_eq(f, G |phi_i|, r_k) phi_i^2
        averaged over the design's accelerations (the peak's G, or the band's nodes)."""
        x, r = self.unpack(z)
        loss = self.loss
        accel = np.array([self.peak_accel(z)]) if self.kind == "peak" else self.nodes
        lo, hi = loss.domain["accel_g"]
        ranked = []
        for k, cells in enumerate(self.regions.members):
            if cells.size == 0 or x[k] <= 0:
                ranked.append(cells)
                continue
            a = np.abs(loss.phi[cells])
            # the contribution on 64 levels of |phi| across the level, interpolated to its cells
            grid = np.linspace(a.min(), a.max(), 64)
            g = accel[:, None] * grid[None, :]
            c = np.asarray(self.predict(np.full(g.shape, loss.mode.freq_hz), np.clip(g, lo, hi),
                                        np.full(g.shape, r[k])), dtype=float)
            value = np.interp(a, grid, np.where(g < lo, 0.0, c).mean(axis=0) * grid**2)
            ranked.append(cells[np.lexsort((-a, -value))])
        return ranked

    def antinode_first(self, fill_pct: float) -> np.ndarray:
        """Levels filled from the antinode outwards at one fill until the budget is spent."""
        left = self.n_spheres
        per = float(self.loss.spheres(fill_pct))
        x = np.zeros(self.k)
        for k in range(self.k):
            if self.regions.count[k] == 0 or left <= 0:
                continue
            take = min(float(self.regions.count[k]), left / per)
            x[k] = take / self.regions.count[k]
            left -= take * per
        return x


def optimise_layout(loss: ModalLoss, predict, regions: Regions, band: AccelBand, kind: str,
                    n_spheres: float, starts: int = 6, seed: int = 17, maxiter: int = 200,
                    antinode_fills: tuple[float, ...] = ()) -> LayoutResult:
    """The optimised region layout of one design kind (module docstring).

    Parameters
    ----------
    loss : ModalLoss
    predict : callable
        C_eq_coupon(f, G, r), N*s/m.
    regions : Regions
    band : AccelBand
        The environment's band of antinode accelerations.
    kind : {"peak", "band_mean", "worst_case"}
    n_spheres : float
        The budget n_b.
    starts, seed : int
        Seeded Latin-hypercube starts besides the antinode-first one.
    antinode_fills : tuple of float
        Further antinode-first starts at these fills (%), e.g. the coupon designs' (the
        ``source_antinode`` layouts), so that the search starts from them too.
    """
    if kind not in KINDS:
        raise ValueError(f"design kind {kind!r} is unknown; one of {', '.join(KINDS)}")
    problem = _RegionProblem(loss, predict, regions, band, kind, n_spheres)
    mid = 0.5 * (problem.r_lo + problem.r_hi)
    x0s = [problem.pack(problem.antinode_first(r), np.full(problem.k, r), 1.0)
           for r in (mid, *(float(np.clip(f, problem.r_lo, problem.r_hi)) for f in antinode_fills))]
    if starts:
        sample = latin_hypercube(starts, 2 * problem.k, seed)
        for row in sample:
            x, rho = row[:problem.k], row[problem.k:]
            r = problem.r_lo + rho * (problem.r_hi - problem.r_lo)
            x0s.append(problem.pack(problem.onto_budget(x, r), r, 0.5))
    problem.scale = max(max(problem.objective_value(z) for z in x0s), 1e-300)
    candidates, converged = [], 0
    for z0 in x0s:
        if kind == "worst_case":
            z0 = z0.copy()
            z0[-1] = problem.objective_value(z0) / problem.scale
        result = minimize(problem.objective, z0, method="SLSQP", bounds=problem.bounds(),
                          constraints=problem.constraints(),
                          options={"maxiter": maxiter, "ftol": 1e-9})
        feasible = problem.budget_margin(result.x) >= -1e-6
        converged += bool(result.success and feasible)
        candidates += [result.x] if feasible else []
    # every feasible end point, and the starts themselves, rounded to whole cells and judged on
    # all their cells (not the levels' quantiles): the best whole-cell layout is the answer
    best = None
    for z in candidates + x0s:
        x, r = problem.unpack(z)
        layout = whole_cell_layout(loss, regions, x, r, n_spheres, members=problem.ranked_members(z))
        exact = band_summary(loss, predict, layout, band)[kind]
        if best is None or exact > best[0]:
            best = (exact, z, layout)
    _, z, layout = best
    x, r = problem.unpack(z)
    return LayoutResult(kind=kind, layout=layout, objective=problem.objective_value(z), share=x,
                        fill_pct=r, accel_g=problem.peak_accel(z) if kind == "peak" else None,
                        n_starts=len(x0s), n_converged=converged, n_evaluations=problem.evaluations)


def whole_cell_layout(loss: ModalLoss, regions: Regions, share: np.ndarray, fill_pct: np.ndarray,
                      n_spheres: float, name: str = "optimised", members: list | None = None) -> Layout:
    """Level k fills round(x_k N_k) of its cells, the first of ``members[k]`` (default: those
    of largest |phi|), built at whole spheres (see the module's text); cells come off the
    outermost filled level while the budget is exceeded."""
    members = regions.members if members is None else members
    counts = np.floor(share * regions.count + 0.5).astype(int)
    fewest, most = loss.sphere_counts()
    cells, spheres = [], []
    for k in np.flatnonzero(counts):
        c = int(counts[k])
        whole, left = split_spheres(math.floor(c * float(loss.spheres(fill_pct[k])) + 1e-9), c)
        per = np.clip(np.r_[np.full(left, whole + 1), np.full(c - left, whole)], fewest, most)
        cells.append(members[k][:c])
        spheres.append(per)
    cells = np.concatenate(cells) if cells else np.empty(0, int)
    spheres = np.concatenate(spheres) if spheres else np.empty(0, int)
    kept = cells.size
    while kept and spheres[:kept].sum() > n_spheres:
        kept -= 1
    return Layout(name, cells[:kept], loss.fill_of(spheres[:kept]))


def uniform_layout(n_total: int, n_filled: int, fill_pct, name: str = "source_uniform") -> Layout:
    """n_filled cells spread evenly over the plate (every n_total / n_filled-th cell, column by
    column), at ``fill_pct`` (%: one fill, or one per cell, given to the cells in that order)."""
    n_filled = int(min(max(n_filled, 0), n_total))
    cells = np.unique(np.floor((np.arange(n_filled) + 0.5) * n_total / max(n_filled, 1)).astype(int))
    return Layout(name, cells, np.broadcast_to(np.asarray(fill_pct, dtype=float), cells.shape))


def antinode_layout(phi: np.ndarray, n_filled: int, fill_pct,
                    name: str = "source_antinode") -> Layout:
    """The n_filled cells of largest |phi| at ``fill_pct`` (%: one fill, or one per cell, given
    to the cells from the largest |phi| down)."""
    order = np.argsort(-np.abs(phi), kind="stable")[:int(max(n_filled, 0))]
    fills = np.broadcast_to(np.asarray(fill_pct, dtype=float), order.shape)
    ranked = np.argsort(order, kind="stable")
    return Layout(name, order[ranked], fills[ranked])


def built_fills(cells: list[tuple[float, int]]) -> np.ndarray:
    """One fill per cell of a design built at whole spheres, the fuller cells first, %.

    ``cells``: (fill %, cells) pairs, :func:`pidpipe.design.built_cells.whole_sphere_cells`."""
    ordered = sorted(cells, key=lambda pair: -pair[0])
    return np.concatenate([np.full(count, fill) for fill, count in ordered]) if ordered else np.empty(0)
