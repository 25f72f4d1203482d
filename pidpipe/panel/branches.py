"""The consistent amplitudes of a mode whose dashpot (and mass) follow its own amplitude, and the
one a frequency sweep reaches.

At a forcing frequency Omega the steady antinode amplitude x = |q| (m) solves x = A(x), with

    A(x) = F_0 / |k - (M + M_a(G)) Omega^2 + i Omega (c_s + c_p(G))|,   G = x Omega^2 / g,

M_a the particles' added modal mass (0 when it is held fixed in M) and c_p their dashpot. Where
c_p falls with G (C_eq above 2-3 g) up to three amplitudes are consistent: the response curve
folds. The residual r(x) = x - A(x) is negative as x -> 0 (A(0) > 0); its roots are found as
:func:`pidpipe.loop.equivalent.solve_point` finds them (sign changes on the same log grid,
refined by Brent's method), and every root is returned, not only the largest.

Which root a structure sits on depends on where it comes from. The amplitude relaxes towards
A(x): it grows where A(x) > x (r < 0) and decays where A(x) < x (r > 0), the energy balance of
a cycle reduced to the amplitude (slowly varying amplitude and phase). So a root where r crosses
from - to + (increasing x) is stable, one where it crosses from + to - (the middle branch of a
fold, a saddle) is unstable, and a state started at amplitude x_s reaches the adjacent root in
the direction of A(x_s) - x_s: the smallest root above x_s if r(x_s) < 0, the largest below it
if r(x_s) > 0 -- always a stable one. A sweep in frequency (:func:`sweep_order`) starts each
frequency from the amplitude reached at the one before (the first from rest, x = 0), so it
follows a branch until the branch ends at a fold and then jumps to the other: up and down
sweeps over a fold differ (a hysteresis loop). With a single root every rule gives it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import brentq

#: The branch rules: continued from the previous frequency, up or down in frequency, or the
#: largest consistent amplitude at every frequency (:func:`pidpipe.loop.equivalent.solve_point`'s).
SWEEPS: tuple[str, ...] = ("up", "down", "largest")


@dataclass(frozen=True)
class Amplitudes:
    """The consistent amplitudes at one frequency.

    Attributes
    ----------
    roots_m : ndarray, shape (n,)
        The roots of r(x) = x - A(x), ascending, m (at least one).
    stable : ndarray of bool, shape (n,)
        Whether r crosses from - to + there (module docstring).
    """

    roots_m: np.ndarray
    stable: np.ndarray

    @property
    def count(self) -> int:
        """The number of consistent amplitudes."""
        return int(self.roots_m.size)


def consistent_amplitudes(residual: Callable[[np.ndarray], np.ndarray], grid_m: np.ndarray
                          ) -> Amplitudes:
    """Every root of ``residual`` (r(x) = x - A(x), vectorised) found on ``grid_m`` (ascending,
    m): the sign changes between grid points refined by Brent's method, plus the grid's last
    point if r vanishes there. With no sign change (the dashpot so large that the amplitude lies
    below the grid), the grid's first point."""
    grid = np.asarray(grid_m, dtype=float)
    gap = np.asarray(residual(grid), dtype=float)
    scale = float(grid[-1])
    roots, stable = [], []
    for i in np.flatnonzero(np.sign(gap[:-1]) * np.sign(gap[1:]) < 0):
        roots.append(brentq(lambda x: float(residual(np.array([x]))[0]), grid[i], grid[i + 1],
                            xtol=1e-14 * scale, rtol=1e-12))
        stable.append(bool(gap[i] < 0 < gap[i + 1]))
    if gap[-1] == 0:
        roots.append(scale)
        stable.append(True)
    if not roots:
        roots, stable = [float(grid[0])], [True]
    return Amplitudes(roots_m=np.asarray(roots, dtype=float), stable=np.asarray(stable, dtype=bool))


def reached_amplitude(amplitudes: Amplitudes, residual: Callable[[np.ndarray], np.ndarray],
                      start_m: float | None) -> float:
    """The root reached from amplitude ``start_m`` (m; None: the largest root, the old rule)
    by relaxing towards A(x) (module docstring)."""
    roots = amplitudes.roots_m
    if start_m is None:
        return float(roots[-1])
    start = max(float(start_m), 0.0)
    gap = float(residual(np.array([start]))[0]) if start > 0 else -1.0
    if gap < 0:
        above = roots[roots >= start]
        return float(above[0] if above.size else roots[-1])
    if gap > 0:
        below = roots[roots <= start]
        return float(below[-1] if below.size else roots[0])
    return float(roots[np.argmin(np.abs(roots - start))])


def sweep_order(freqs_hz, sweep: str) -> np.ndarray:
    """The indices of ``freqs_hz`` in the order a sweep visits them: ascending for ``up`` (and
    ``largest``, whose points are independent), descending for ``down``."""
    if sweep not in SWEEPS:
        raise ValueError(f"sweep = {sweep!r} is not one of {', '.join(SWEEPS)}")
    order = np.argsort(np.asarray(freqs_hz, dtype=float), kind="stable")
    return order[::-1] if sweep == "down" else order
