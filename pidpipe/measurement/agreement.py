"""How far a DEM value of few cells lies from a prediction, judged by its degrees of freedom.

A DEM value whose SEM is the spread of a few cells (``dof`` = cells - 1) is compared with a
prediction whose standard uncertainty is taken as exact (a Gaussian process's posterior):

    t = (C_dem - C_s) / sqrt(SEM^2 + u_s^2),
    nu = (SEM^2 + u_s^2)^2 / (SEM^4 / dof)        (Welch-Satterthwaite),
    z = Phi^-1(F_nu(t)),

z being the standard normal score with the same tail probability as t under Student's t of nu
degrees of freedom (z = t when nu is infinite). A flag on |z| then means the same two-sided
probability whatever the cells: a 7-cell value passes up to |t| = 2.52 where a normal judgement
stops at 2. The refinement loop's verification (:mod:`pidpipe.refine.verification`) and the
verify step (:mod:`pidpipe.loop.verify`) both judge so.
"""

from __future__ import annotations

import numpy as np
from scipy import stats


def normal_score(t, dem_sem, dem_dof, surrogate_std) -> np.ndarray:
    """z of t (see the module's text): the normal score of equal tail probability under
    Student's t of the Welch-Satterthwaite degrees of freedom; shape of the inputs.

    Parameters
    ----------
    t : array_like
        (C_dem - C_s) / sqrt(SEM^2 + u_s^2), dimensionless.
    dem_sem : array_like
        The DEM value's SEM (any unit, the same as ``surrogate_std``).
    dem_dof : array_like
        Its degrees of freedom (cells - 1; inf when unknown).
    surrogate_std : array_like
        The prediction's standard uncertainty, the unit of ``dem_sem``.
    """
    t, dem_sem, dem_dof, surrogate_std = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (t, dem_sem, dem_dof, surrogate_std)))
    with np.errstate(divide="ignore", invalid="ignore"):
        nu = (dem_sem**2 + surrogate_std**2) ** 2 / (dem_sem**4 / dem_dof)
    finite = np.isfinite(t) & np.isfinite(nu) & (nu > 0)
    z = np.array(t, dtype=float, copy=True)
    if finite.any():
        tail = stats.t.sf(np.abs(t[finite]), nu[finite])
        z[finite] = np.sign(t[finite]) * stats.norm.isf(tail)
    return z
