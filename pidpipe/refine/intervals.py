"""Each design's 95 % interval of its total C_eq, from the surrogate's predictive uncertainty.

A design (:mod:`pidpipe.design.designs`) fills n_c cells with whole spheres: n_k cells at the
fill r_k of each sphere count k it holds (:func:`pidpipe.design.built_cells.whole_sphere_cells`:
one count, or two neighbouring ones). Its total C_eq is T = J[sum_k (n_k / N) C(., ., r_k)],
a linear functional a^T C of the coupon's C_eq at a set of points, with J the design's
functional over the band:

``peak``
    at the design's point (f*, G*): the points (f*, G*, r_k), weights a_k = n_k / N.
``band_mean``
    sum_i w_i over the band's Gauss-Legendre nodes: the points (f_i, G_i, r_k), weights
    a_ik = w_i n_k / N.
``worst_case``
    min_i over the band's grid of the built cells' total: the points (f_i*, G_i*, r_k) of the
    grid point i* that is the minimum, weights n_k / N (the minimum's own uncertainty when it
    does not change place).

With a model that offers ``predict_joint(f, G, r) -> (mean, covariance)`` the variance is
a^T Sigma a (the GP drawn jointly over the points: ``joint``); otherwise sigma_T = sum |a| sigma,
the value for fully correlated points, an upper bound of the true standard deviation
(Cauchy-Schwarz: a^T Sigma a <= (sum |a| sigma)^2 for any correlation), so the interval is
conservative (``correlated bound``). A peak or worst-case design of one sphere count has one
point, and sigma_T = a sigma exactly (``point``, ``minimum point``).

The interval is T +- 1.96 sigma_T (normal predictive distribution). It is the interval of the
design's value as the surrogate predicts it at the design found; it does not hold the
uncertainty of where the optimum lies (at an optimum the objective is flat to first order, so a
nearby design gives nearly the same value).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pidpipe.design.band import BandRule
from pidpipe.design.built_cells import at_each_fill, cells_weights, whole_sphere_cells
from pidpipe.design.optimisation import OptimisationResult

#: Normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054


@dataclass(frozen=True)
class DesignInterval:
    """A design's total C_eq (N*s/m) and its 95 % interval from the surrogate.

    ``method`` says how sigma was formed (``point``, ``joint``, ``correlated bound``,
    ``minimum point``); ``freq_hz`` and ``accel_g`` are the peak design's point (NaN for the
    band designs).
    """

    environment: str
    kind: str
    fill_pct: float
    n_cells: int
    n_cells_coupon: int
    freq_hz: float
    accel_g: float
    total_ceq_ns_m: float
    std_ns_m: float
    method: str

    @property
    def lo(self) -> float:
        """Lower end of the 95 % interval, N*s/m."""
        return self.total_ceq_ns_m - Z95 * self.std_ns_m

    @property
    def hi(self) -> float:
        """Upper end of the 95 % interval, N*s/m."""
        return self.total_ceq_ns_m + Z95 * self.std_ns_m

    @property
    def half_width_fraction(self) -> float:
        """Half the interval's width over |T| (inf when T is 0)."""
        value = abs(self.total_ceq_ns_m)
        return float(Z95 * self.std_ns_m / value) if value > 0 else float("inf")

    def within(self, fraction: float) -> bool:
        """Whether the interval lies within +- ``fraction`` of the value."""
        return self.half_width_fraction <= fraction

    @property
    def per_cell(self) -> float:
        """n_c / N: the design's total over the coupon's C_eq."""
        return self.n_cells / self.n_cells_coupon

    def target_std_ns_m(self, fraction: float) -> float:
        """The sigma_T at which the interval would be exactly +- ``fraction`` of T, N*s/m."""
        return fraction * abs(self.total_ceq_ns_m) / Z95


def design_interval(model, result: OptimisationResult, rule: BandRule) -> DesignInterval:
    """The 95 % interval of one design's total C_eq (see the module's text).

    Parameters
    ----------
    model
        Has ``predict_with_uncertainty(f, G, r) -> (mean, std)``, arrays in N*s/m; optionally
        ``predict_joint(f, G, r) -> (mean, covariance)``.
    result : OptimisationResult
        One design (:func:`pidpipe.design.designs.optimise_design`).
    rule : BandRule
        The band rule the design was optimised with.
    """
    design, budget = result.design, result.budget
    cells = whole_sphere_cells(budget, int(design.n_cells), result.bounds.get("fill_pct"))
    fills, shares = cells_weights(cells, budget.n_cells_coupon)
    f_star = g_star = float("nan")
    if result.kind == "peak":
        f, g, w = np.array([design.freq_hz], dtype=float), np.array([design.accel_g], dtype=float), np.ones(1)
        f_star, g_star = float(design.freq_hz), float(design.accel_g)
    elif result.kind == "band_mean":
        f, g, w = rule.quadrature(result.bounds)
    else:
        f, g = rule.grid(result.bounds)
        m, _ = _predict(model, *at_each_fill(f, g, fills))
        k = int(np.argmin(shares @ m.reshape(fills.size, f.size)))
        f, g, w = f[k:k + 1], g[k:k + 1], np.ones(1)
    value, std, joint = _linear(model, *at_each_fill(f, g, fills), np.outer(shares, w).ravel())
    single = {"peak": "point", "worst_case": "minimum point"}.get(result.kind)
    method = single if single and fills.size == 1 else ("joint" if joint else "correlated bound")
    return DesignInterval(environment=result.environment.name, kind=result.kind,
                          fill_pct=float(design.fill_pct), n_cells=int(design.n_cells),
                          n_cells_coupon=int(budget.n_cells_coupon), freq_hz=f_star, accel_g=g_star,
                          total_ceq_ns_m=value, std_ns_m=std, method=method)


def _linear(model, f, g, r, weights) -> tuple[float, float, bool]:
    """a^T C at the points and its standard deviation: (value, sigma, whether joint)."""
    m, s = _predict(model, f, g, r)
    value = float(weights @ m)
    if weights.size > 1 and hasattr(model, "predict_joint"):
        _, cov = model.predict_joint(f, g, r)
        return value, float(np.sqrt(max(weights @ np.asarray(cov, dtype=float) @ weights, 0.0))), True
    return value, float(np.sum(np.abs(weights) * s)), False


def design_intervals(model, results: list[OptimisationResult],
                     rule: BandRule) -> list[DesignInterval]:
    """:func:`design_interval` of every design, in the order of ``results``."""
    return [design_interval(model, result, rule) for result in results]


def _predict(model, f, g, r) -> tuple[np.ndarray, np.ndarray]:
    """The model's mean and standard deviation at the points (f, G, r), arrays, N*s/m."""
    mean, std = model.predict_with_uncertainty(np.asarray(f, dtype=float), np.asarray(g, dtype=float),
                                               np.asarray(r, dtype=float))
    return np.asarray(mean, dtype=float), np.asarray(std, dtype=float)
