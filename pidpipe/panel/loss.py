"""The loss factor that a layout of filled cells adds to one of the plate's modes.

A mode q(t) with shape phi (1 at the antinode) carries filled cells i at positions where phi = phi_i.
A cell moves with the local acceleration G_i = G |phi_i| (G the antinode's, in g) at the mode's
frequency f, and dissipates as a dashpot C_i = C_eq,coupon(f, G_i, r_i) / N (one cell of the
coupon's N, the cells being independent). Projected on the mode, the dashpots give the modal
damping  c_p = sum_i C_i phi_i^2  and the added loss factor

    eta_p = c_p / (omega M),   M = M_plate + sum_i m_eff,i phi_i^2,   omega = omega_0 sqrt(M_plate / M),

M_plate the bare plate's modal mass (:class:`pidpipe.panel.plate.Mode`), m_eff,i the particles'
effective mass in cell i (by default ``effective_mass_fraction`` of the bed's whole mass; pass
``effective_mass_kg`` to use a measured one, such as the m_eff surrogate's,
:class:`pidpipe.panel.mass.SurrogateEffectiveMass`) and f = omega / 2 pi the loaded mode's frequency.

The cells of one fill are summed in narrow bins of |phi| (:data:`PHI_BINS`), so that a layout of
thousands of cells costs a few hundred predictions per acceleration.

The surrogate has no data below its lowest G (1 g on the reference grid, where the spheres start
to lift off): a cell below it counts as C = 0, the bed resting on its floor. Above its highest G
the cell's G is clipped to it and the number of clipped cells is reported. A frequency or fill
outside the domain is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from pidpipe.config.derived import cell_fill_pct
from pidpipe.errors import DomainError
from pidpipe.panel.plate import Mode


#: Bins of |phi| in which a layout's cells of one fill are summed: C_eq is evaluated once per bin,
#: at its phi^2-weighted mean |phi| (an error second order in the bin width 1/512).
PHI_BINS = 512


@dataclass(frozen=True)
class Layout:
    """Filled cells and their fills.

    Attributes
    ----------
    name : str
        ``optimised``, ``source_uniform``, ``source_antinode`` ...
    cells : numpy.ndarray of int, shape (k,)
        Indices into the plate's cells.
    fill_pct : numpy.ndarray, shape (k,)
        Fill r of each filled cell, %.
    """

    name: str
    cells: np.ndarray
    fill_pct: np.ndarray

    def __post_init__(self) -> None:
        cells = np.asarray(self.cells, dtype=int)
        fills = np.broadcast_to(np.asarray(self.fill_pct, dtype=float), cells.shape).copy()
        object.__setattr__(self, "cells", cells)
        object.__setattr__(self, "fill_pct", fills)
        if np.unique(cells).size != cells.size:
            raise ValueError(f"layout {self.name}: a cell is filled twice")


@dataclass
class ModalLoss:
    """One mode's cells and what filling them adds (module docstring).

    Parameters
    ----------
    mode : Mode
    phi : numpy.ndarray, shape (n_cells,)
        The mode shape at every cell (1 at the antinode).
    n_cells_coupon : int
        N of the coupon whose C_eq the model predicts.
    full_cell_spheres : float
        Spheres in a cell at r = 100 %.
    sphere_mass_kg : float
    domain : dict
        The C_eq model's ``freq_hz``, ``accel_g``, ``fill_pct`` bounds.
    effective_mass_fraction : float
        m_eff of a cell as a fraction of its particles' mass (when ``effective_mass_kg`` is None).
    effective_mass_kg : callable, optional
        ``effective_mass_kg(fill_pct, spheres, phi_abs)`` -> kg per cell, arrays of shape (k,)
        (fills %, spheres per cell, the cells' |phi|).
    """

    mode: Mode
    phi: np.ndarray
    n_cells_coupon: int
    full_cell_spheres: float
    sphere_mass_kg: float
    domain: dict
    effective_mass_fraction: float = 1.0
    effective_mass_kg: Callable | None = field(default=None, repr=False)

    def spheres(self, fill_pct) -> np.ndarray:
        """Spheres per cell at fill r: full_cell_spheres r / 100 (not rounded)."""
        return self.full_cell_spheres * np.asarray(fill_pct, dtype=float) / 100.0

    def sphere_counts(self) -> tuple[int, int]:
        """The fewest and most whole spheres a cell may hold: from the count at or below the C_eq
        model's lowest fill to the count at or above its highest (a table at whole-sphere fills
        has both edges at counts; one named by nominal fills, e.g. 25 % of 21 spheres, has its
        nearest counts read at the edge, :meth:`fill_of`, as a coupon design's built cells are,
        :func:`pidpipe.design.built_cells.whole_sphere_cells`).

        Raises
        ------
        DomainError
            The domain holds no whole count."""
        full = int(round(self.full_cell_spheres))
        lo, hi = self.domain["fill_pct"]
        fewest = max(1, int(math.floor(full * lo / 100.0 + 1e-6)))
        most = min(full, int(math.ceil(full * hi / 100.0 - 1e-6)))
        if fewest > most:
            raise DomainError(f"no whole number of spheres (of {full} in a full cell) fills a cell "
                              f"within the C_eq model's fill domain [{lo:g}, {hi:g}] %")
        return fewest, most

    def fill_of(self, spheres) -> np.ndarray:
        """The fill of cells holding ``spheres`` whole spheres, rounded as every C_eq table row's
        fill is (:func:`pidpipe.config.derived.cell_fill_pct`) and held to the C_eq model's fill
        domain (:meth:`sphere_counts`), %; shape of ``spheres``."""
        full = int(round(self.full_cell_spheres))
        fills = np.vectorize(lambda n: cell_fill_pct(int(n), full), otypes=[float])(spheres)
        return np.clip(fills, *self.domain["fill_pct"])

    def cell_effective_mass_kg(self, fill_pct, phi_abs=1.0) -> np.ndarray:
        """m_eff per cell at fill r and |phi| (default 1: at the antinode), kg."""
        spheres = self.spheres(fill_pct)
        if self.effective_mass_kg is not None:
            fills, phi = np.broadcast_arrays(np.asarray(fill_pct, dtype=float),
                                             np.abs(np.asarray(phi_abs, dtype=float)))
            return np.asarray(self.effective_mass_kg(fills, np.broadcast_to(spheres, fills.shape), phi),
                              dtype=float)
        return self.effective_mass_fraction * spheres * self.sphere_mass_kg

    def added_mass_kg(self, layout: Layout) -> float:
        """The particles' whole mass, kg."""
        return float(np.sum(self.spheres(layout.fill_pct)) * self.sphere_mass_kg)

    def modal_mass_kg(self, layout: Layout) -> float:
        """M = M_plate + sum m_eff,i phi_i^2, kg."""
        phi = self.phi[layout.cells]
        return self.mode.modal_mass_kg + float(np.sum(self.cell_effective_mass_kg(layout.fill_pct, phi) * phi**2))

    def state_added_mass_kg(self, layout: Layout, accel_g, freq_hz: float) -> np.ndarray:
        """sum_i m_eff,i phi_i^2 (kg) at antinode accelerations G (shape (m,)) and frequency f:
        read at each G when the effective mass is the m_eff surrogate's
        (:class:`pidpipe.panel.mass.SurrogateEffectiveMass`), else the layout's fixed one."""
        from pidpipe.panel.mass import SurrogateEffectiveMass

        accel = np.atleast_1d(np.asarray(accel_g, dtype=float))
        mass = self.effective_mass_kg
        if not isinstance(mass, SurrogateEffectiveMass) or layout.cells.size == 0:
            return np.full(accel.shape, self.modal_mass_kg(layout) - self.mode.modal_mass_kg)
        levels, fills, weights = self._binned(layout)
        return mass.projected_kg(fills, self.spheres(fills), levels, weights, accel, freq_hz)

    def frequency_hz(self, layout: Layout) -> float:
        """The loaded mode's frequency f_0 sqrt(M_plate / M), Hz."""
        return self.mode.freq_hz * math.sqrt(self.mode.modal_mass_kg / self.modal_mass_kg(layout))

    def check_fills(self, fill_pct) -> None:
        """Refuse fills outside the C_eq model's domain."""
        lo, hi = self.domain["fill_pct"]
        fills = np.asarray(fill_pct, dtype=float)
        if fills.size and (fills.min() < lo - 1e-9 or fills.max() > hi + 1e-9):
            raise DomainError(f"a layout fills cells at {fills.min():g}-{fills.max():g} %, outside the "
                              f"C_eq model's fill domain [{lo:g}, {hi:g}] %")

    def check_frequency(self, freq_hz: float) -> None:
        """Refuse a mode frequency outside the C_eq model's domain."""
        lo, hi = self.domain["freq_hz"]
        if not lo <= freq_hz <= hi:
            raise DomainError(f"mode ({self.mode.m}, {self.mode.n}) at {freq_hz:.4g} Hz is outside the "
                              f"C_eq model's frequency domain [{lo:g}, {hi:g}] Hz")

    def cell_accel_g(self, layout: Layout, accel_g) -> np.ndarray:
        """G_i = G |phi_i| of each filled cell at antinode accelerations G, shape (m, k)."""
        return np.atleast_1d(np.asarray(accel_g, dtype=float))[:, None] * np.abs(self.phi[layout.cells])[None, :]

    def damping_ns_m(self, predict: Callable, layout: Layout, accel_g,
                     freq_hz: float | None = None) -> np.ndarray:
        """c_p = sum_i C_eq,i(f, G_i, r_i) phi_i^2 at antinode accelerations G, N*s/m, shape (m,).

        ``freq_hz`` defaults to the loaded mode's frequency.
        """
        freq = self.frequency_hz(layout) if freq_hz is None else freq_hz
        self.check_frequency(freq)
        self.check_fills(layout.fill_pct)
        accel = np.atleast_1d(np.asarray(accel_g, dtype=float))
        if layout.cells.size == 0:
            return np.zeros(accel.size)
        levels, fills, weights = self._binned(layout)
        g = accel[:, None] * levels[None, :]
        lo, hi = self.domain["accel_g"]
        values = np.asarray(predict(np.full(g.shape, freq), np.clip(g, lo, hi),
                                    np.broadcast_to(fills[None, :], g.shape)), dtype=float)
        values = np.where(g < lo, 0.0, values) / self.n_cells_coupon
        return values @ weights

    def _binned(self, layout: Layout) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The filled cells grouped by fill and by |phi| in :data:`PHI_BINS` bins: each group's
        phi^2-weighted mean |phi|, its fill and its sum of phi^2, each shape (groups,)."""
        a = np.abs(self.phi[layout.cells])
        fill_values, fill_index = np.unique(layout.fill_pct, return_inverse=True)
        key = fill_index * PHI_BINS + np.minimum((a * PHI_BINS).astype(int), PHI_BINS - 1)
        groups, inverse = np.unique(key, return_inverse=True)
        weights = np.bincount(inverse, a**2)
        cubes = np.bincount(inverse, a**3)
        levels = np.divide(cubes, weights, out=np.zeros_like(weights), where=weights > 0)
        return levels, fill_values[groups // PHI_BINS], weights

    def clipped_cells(self, layout: Layout, accel_g: float) -> int:
        """Filled cells whose G lies above the model's domain at antinode acceleration G."""
        return int(np.sum(self.cell_accel_g(layout, accel_g) > self.domain["accel_g"][1]))

    def loss_factor(self, predict: Callable, layout: Layout, accel_g) -> np.ndarray:
        """eta_p = c_p / (omega M) at antinode accelerations G, shape (m,)."""
        omega = 2.0 * math.pi * self.frequency_hz(layout)
        return self.damping_ns_m(predict, layout, accel_g) / (omega * self.modal_mass_kg(layout))


@dataclass(frozen=True)
class AccelBand:
    """Where a band of antinode accelerations [G_lo, G_hi] (g) is sampled.

    ``quadrature_points`` Gauss-Legendre nodes give the band mean (G uniform in the band),
    ``grid_points`` evenly spaced points, edges included, its worst and best.
    """

    low: float
    high: float
    quadrature_points: int = 5
    grid_points: int = 7

    def quadrature(self) -> tuple[np.ndarray, np.ndarray]:
        """Nodes (g) and weights (summing to 1), each shape (q,)."""
        x, w = np.polynomial.legendre.leggauss(self.quadrature_points)
        return 0.5 * (self.low + self.high) + 0.5 * (self.high - self.low) * x, w / 2.0

    def grid(self) -> np.ndarray:
        """Evenly spaced G (g), edges included, shape (p,)."""
        return np.linspace(self.low, self.high, self.grid_points)


#: The designs on a mode, as the coupon designs: peak (best G of the band), band mean, worst case.
KINDS: tuple[str, ...] = ("peak", "band_mean", "worst_case")


def band_summary(loss: ModalLoss, predict: Callable, layout: Layout, band: AccelBand) -> dict:
    """eta_p of a layout over the band: ``band_mean``, ``worst_case`` and ``peak`` (grid max),
    with the G (g) of the worst and best point."""
    nodes, weights = band.quadrature()
    grid = band.grid()
    on_grid = loss.loss_factor(predict, layout, grid)
    worst, best = int(np.argmin(on_grid)), int(np.argmax(on_grid))
    return {"band_mean": float(weights @ loss.loss_factor(predict, layout, nodes)),
            "worst_case": float(on_grid[worst]), "peak": float(on_grid[best]),
            "worst_accel_g": float(grid[worst]), "peak_accel_g": float(grid[best])}
