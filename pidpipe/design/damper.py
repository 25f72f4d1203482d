"""The damper as a structure sees it: an added mass and a dashpot per filled cell, with uncertainties.

A structural model (a finite-element panel, a host oscillator) that carries particle-filled
cells sees, at the first harmonic of its motion x = Re(X e^{i omega t}) at a cell, the force

    F = -(-omega^2 m_eff + i omega C_eq) X = -Z V,   V = i omega X,   Z = C_eq + i omega m_eff,

on the structure, where m_eff (kg) is the in-phase part of the spheres' force as a mass (the whole
bed's mass while it rides on the floor, below 1 g; towards zero when the spheres are airborne)
and C_eq (N s/m) the quadrature part as a dashpot. Both depend on the forcing frequency f (Hz),
on the cell's acceleration amplitude Gamma = omega^2 |X| / g (g) and on the fill r (%), and are
read from two surrogates of the campaign:

- ``results/surrogate.json`` (:data:`CEQ_FILE`): C_eq of the coupon of N cells, N s/m; one
  cell's is C_eq / N;
- ``results/surrogate_m_eff.json`` (:data:`M_EFF_FILE`): m_eff of one cell, kg.

Interface expected of a surrogate
---------------------------------
``domain``: dict with ``freq_hz``, ``accel_g`` and ``fill_pct`` bounds ``(lo, hi)``; and either
``predict_with_uncertainty(freq_hz, accel_g, fill_pct) -> (mean, std)`` (arrays broadcast from
the inputs; std the predictive standard uncertainty in the unit of the mean) or, failing that,
``predict(freq_hz, accel_g, fill_pct) -> mean`` (the spline surrogates of
:mod:`pidpipe.design.surrogate`), whose standard uncertainty is then reported as NaN (unknown,
not zero).

:class:`Damper` refuses a query outside the two surrogates' common domain
(:class:`~pidpipe.errors.DomainError`), unless asked to ``clip`` it to the domain's edge, in
which case :attr:`DamperValues.clipped` marks every clipped point.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from pidpipe.errors import DomainError, TableError
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2

#: The C_eq surrogate's file in a results folder (the campaign's ``fit_surrogate`` output).
CEQ_FILE = "surrogate.json"
#: The m_eff surrogate's file in a results folder.
M_EFF_FILE = "surrogate_m_eff.json"
_AXES = ("freq_hz", "accel_g", "fill_pct")
_UNITS = {"freq_hz": "Hz", "accel_g": "g", "fill_pct": "%"}


def predictive(surrogate) -> Callable:
    """``(freq_hz, accel_g, fill_pct) -> (mean, std)`` arrays of a surrogate (module docstring).

    A surrogate without ``predict_with_uncertainty`` gives its ``predict`` as the mean and a
    std of NaN: its uncertainty is not known from the surrogate alone.
    """
    method = surrogate.predict_with_uncertainty if has_uncertainty(surrogate) else None
    if method is not None:
        def both(freq_hz, accel_g, fill_pct):
            mean, std = method(freq_hz, accel_g, fill_pct)
            return np.asarray(mean, dtype=float), np.asarray(std, dtype=float)
        return both

    def mean_only(freq_hz, accel_g, fill_pct):
        mean = np.asarray(surrogate.predict(freq_hz, accel_g, fill_pct), dtype=float)
        return mean, np.full_like(mean, np.nan)
    return mean_only


def has_uncertainty(surrogate) -> bool:
    """Whether the surrogate gives a predictive standard uncertainty: its ``has_uncertainty``
    (:attr:`pidpipe.design.surrogate.Surrogate.has_uncertainty`: a fitted interpolant has the
    method but no uncertainty), else whether it has ``predict_with_uncertainty`` at all."""
    return bool(getattr(surrogate, "has_uncertainty", hasattr(surrogate, "predict_with_uncertainty")))


@dataclass(frozen=True)
class DamperValues:
    """m_eff and C_eq of ``cells`` filled cells at the query points, with standard uncertainties.

    Attributes
    ----------
    freq_hz, accel_g, fill_pct : ndarray, shape (m,)
        The query points as read (after clipping, when asked), Hz, g and %.
    cells : float
        The filled cells the values are of (both scale with it).
    m_eff_kg, m_eff_sd_kg : ndarray, shape (m,)
        Effective (added) mass of the cells and its standard uncertainty, kg (NaN: unknown).
    ceq_ns_m, ceq_sd_ns_m : ndarray, shape (m,)
        Equivalent dashpot of the cells and its standard uncertainty, N s/m (NaN: unknown).
    clipped : ndarray of bool, shape (m,)
        Points whose f or Gamma lay outside the surrogates' domain and were read at its edge.
    """

    freq_hz: np.ndarray
    accel_g: np.ndarray
    fill_pct: np.ndarray
    cells: float
    m_eff_kg: np.ndarray
    m_eff_sd_kg: np.ndarray
    ceq_ns_m: np.ndarray
    ceq_sd_ns_m: np.ndarray
    clipped: np.ndarray


class Damper:
    """Particle-filled cells as an added mass and a dashpot (module docstring).

    Parameters
    ----------
    ceq_surrogate
        Surrogate of the coupon's C_eq, N s/m (interface: module docstring).
    m_eff_surrogate
        Surrogate of one cell's m_eff, kg.
    coupon_n_cells : int
        N, the coupon's cells (one cell's C_eq is the coupon's / N).
    """

    def __init__(self, ceq_surrogate, m_eff_surrogate, coupon_n_cells: int) -> None:
        if int(coupon_n_cells) < 1:
            raise ValueError(f"coupon_n_cells = {coupon_n_cells}: must be >= 1")
        self.ceq_surrogate = ceq_surrogate
        self.m_eff_surrogate = m_eff_surrogate
        self.coupon_n_cells = int(coupon_n_cells)
        self._ceq = predictive(ceq_surrogate)
        self._m_eff = predictive(m_eff_surrogate)
        self.domain = {axis: (max(ceq_surrogate.domain[axis][0], m_eff_surrogate.domain[axis][0]),
                              min(ceq_surrogate.domain[axis][1], m_eff_surrogate.domain[axis][1]))
                       for axis in _AXES}
        empty = [axis for axis, (lo, hi) in self.domain.items() if lo > hi]
        if empty:
            raise TableError(f"the C_eq and m_eff surrogates' domains do not overlap in {empty}")

    @classmethod
    def from_results(cls, results_dir, coupon_n_cells: int, loader: Callable | None = None
                     ) -> "Damper":
        """The damper of a campaign's results folder.

        Parameters
        ----------
        results_dir : str or Path
            Folder holding :data:`CEQ_FILE` and :data:`M_EFF_FILE`.
        coupon_n_cells : int
            N (config key ``geometry.coupon_n_cells``).
        loader : callable, optional
            ``loader(path) -> surrogate``; default :func:`pidpipe.design.surrogate.load_surrogate`.

        Raises
        ------
        TableError
            A file is missing or cannot be loaded.
        """
        if loader is None:
            from pidpipe.design.surrogate import load_surrogate as loader
        folder = Path(results_dir)
        m_eff_path = folder / M_EFF_FILE
        if not m_eff_path.exists():
            raise TableError(f"{m_eff_path} does not exist: the campaign's cases have no effective "
                             "mass surrogate (tables without m_eff_cell_kg); rerun the design stage "
                             "on records that measure m_eff")
        return cls(loader(folder / CEQ_FILE), loader(m_eff_path), coupon_n_cells)

    def values(self, freq_hz, accel_g, fill_pct, cells: float = 1, clip: bool = False
               ) -> DamperValues:
        """m_eff and C_eq of ``cells`` cells with their standard uncertainties.

        Parameters
        ----------
        freq_hz, accel_g, fill_pct : float or array_like
            f (Hz), Gamma (g) and r (%), broadcast together (flattened to shape (m,)).
        cells : float
            Filled cells (n_c); both values scale with it.
        clip : bool
            Read points outside the domain at its edge (f and Gamma only; r is never clipped)
            and mark them, instead of refusing them.

        Raises
        ------
        DomainError
            A point lies outside the domain (and ``clip`` is False, or r lies outside it).
        """
        f, g, r = (np.ravel(a).astype(float) for a in np.broadcast_arrays(freq_hz, accel_g, fill_pct))
        clipped = np.zeros(f.shape, dtype=bool)
        query = {"freq_hz": f, "accel_g": g, "fill_pct": r}
        for axis, values in query.items():
            lo, hi = self.domain[axis]
            tol = 1e-9 * (hi - lo)
            outside = ~((values >= lo - tol) & (values <= hi + tol))
            if not outside.any():
                continue
            if clip and axis != "fill_pct" and np.all(np.isfinite(values)):
                clipped |= outside
                query[axis] = np.clip(values, lo, hi)
                continue
            bad = values[outside][0]
            raise DomainError(f"{axis} = {bad:g} {_UNITS[axis]} is outside the damper's domain "
                              f"[{lo:g}, {hi:g}] {_UNITS[axis]} (the C_eq and m_eff surrogates' "
                              "common range); the surrogates do not extrapolate")
        f, g, r = query["freq_hz"], query["accel_g"], query["fill_pct"]
        ceq, ceq_sd = self._ceq(f, g, r)
        m_eff, m_eff_sd = self._m_eff(f, g, r)
        per_cell = cells / self.coupon_n_cells
        return DamperValues(freq_hz=f, accel_g=g, fill_pct=r, cells=float(cells),
                            m_eff_kg=cells * np.ravel(m_eff), m_eff_sd_kg=cells * np.ravel(m_eff_sd),
                            ceq_ns_m=per_cell * np.ravel(ceq), ceq_sd_ns_m=per_cell * np.ravel(ceq_sd),
                            clipped=clipped)

    def impedance(self, freq_hz, accel_g, fill_pct, cells: float = 1, clip: bool = False
                  ) -> np.ndarray:
        """The mechanical impedance Z = C_eq + i omega m_eff the cells add, N s/m (complex).

        Sign convention: with the structure's motion at the cells x = Re(X e^{i omega t}) and
        velocity V = i omega X (m/s), the cells' force on the structure is F = -Z V
        = -(-omega^2 m_eff + i omega C_eq) X, N. Add Z to the structure's impedance (or
        i omega Z, :meth:`dynamic_stiffness`, to its dynamic stiffness k - omega^2 m + i omega c)
        at the cells' degree of freedom. Arguments as :meth:`values`; shape (m,).
        """
        v = self.values(freq_hz, accel_g, fill_pct, cells, clip)
        return v.ceq_ns_m + 1j * (2.0 * np.pi * v.freq_hz) * v.m_eff_kg

    def dynamic_stiffness(self, freq_hz, accel_g, fill_pct, cells: float = 1, clip: bool = False
                          ) -> np.ndarray:
        """i omega Z = -omega^2 m_eff + i omega C_eq, N/m (complex): F = -(i omega Z) X.

        Arguments as :meth:`values`; shape (m,).
        """
        v = self.values(freq_hz, accel_g, fill_pct, cells, clip)
        omega = 2.0 * np.pi * v.freq_hz
        return -omega**2 * v.m_eff_kg + 1j * omega * v.ceq_ns_m

    def describe(self) -> str:
        """One line for logs: the domain and whether each surrogate has an uncertainty."""
        bounds = ", ".join(f"{axis} [{lo:g}, {hi:g}] {_UNITS[axis]}"
                           for axis, (lo, hi) in self.domain.items())
        return (f"damper of {self.coupon_n_cells}-cell coupon surrogates on {bounds}; predictive "
                f"std: C_eq {'yes' if has_uncertainty(self.ceq_surrogate) else 'no'}, m_eff "
                f"{'yes' if has_uncertainty(self.m_eff_surrogate) else 'no'}")


def acceleration_g(freq_hz, amplitude_m) -> np.ndarray:
    """Gamma = omega^2 |X| / g of a displacement amplitude |X| (m) at f (Hz), in g."""
    omega = 2.0 * np.pi * np.asarray(freq_hz, dtype=float)
    return omega**2 * np.abs(amplitude_m) / STANDARD_GRAVITY_M_S2
