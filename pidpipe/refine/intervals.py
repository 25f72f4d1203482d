"""Each design's 95 % interval of its total C_eq, from the surrogate's predictive uncertainty.

A design (:mod:`pidpipe.design.designs`) fills n_c cells at fill r_d; its total C_eq is
T = (n_c / N) * J[C], with J the design's functional of the coupon's C_eq over the band:

``peak``
    C at the design's point (f*, G*, r_d): sigma_T = (n_c / N) * sigma(f*, G*, r_d).
``band_mean``
    sum_k w_k C(f_k, G_k, r_d) over the band's Gauss-Legendre nodes. With a model that offers
    ``predict_joint(f, G, r) -> (mean, covariance)`` the variance is w^T Sigma w (the GP drawn
    jointly over the nodes); otherwise sigma_T = (n_c / N) * sum_k w_k sigma_k, the value for
    fully correlated nodes, which is an upper bound of the true standard deviation (Cauchy-
    Schwarz: w^T Sigma w <= (sum_k w_k sigma_k)^2 for any correlation), so the interval is
    conservative.
``worst_case``
    min_k C(f_k, G_k, r_d) over the band's grid: sigma_T = (n_c / N) * sigma at the grid point
    that is the minimum (the minimum's own uncertainty when it does not change place).

The interval is T +- 1.96 sigma_T (normal predictive distribution). It is the interval of the
design's value as the surrogate predicts it at the design found; it does not hold the
uncertainty of where the optimum lies (at an optimum the objective is flat to first order, so a
nearby design gives nearly the same value).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pidpipe.design.band import BandRule
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
    per_cell = design.n_cells / budget.n_cells_coupon
    r = float(design.fill_pct)
    if result.kind == "peak":
        m, s = _predict(model, [design.freq_hz], [design.accel_g], r)
        value, std, method = m[0], s[0], "point"
        f_star, g_star = float(design.freq_hz), float(design.accel_g)
    elif result.kind == "band_mean":
        f, g, w = rule.quadrature(result.bounds)
        m, s = _predict(model, f, g, r)
        value = float(np.sum(w * m))
        if hasattr(model, "predict_joint"):
            _, cov = model.predict_joint(f, g, np.full_like(f, r))
            std, method = float(np.sqrt(max(w @ np.asarray(cov, dtype=float) @ w, 0.0))), "joint"
        else:
            std, method = float(np.sum(w * s)), "correlated bound"
        f_star = g_star = float("nan")
    else:
        f, g = rule.grid(result.bounds)
        m, s = _predict(model, f, g, r)
        k = int(np.argmin(m))
        value, std, method = m[k], s[k], "minimum point"
        f_star = g_star = float("nan")
    return DesignInterval(environment=result.environment.name, kind=result.kind, fill_pct=r,
                          n_cells=int(design.n_cells),
                          n_cells_coupon=int(budget.n_cells_coupon), freq_hz=f_star, accel_g=g_star,
                          total_ceq_ns_m=float(value) * per_cell, std_ns_m=float(std) * per_cell,
                          method=method)


def design_intervals(model, results: list[OptimisationResult],
                     rule: BandRule) -> list[DesignInterval]:
    """:func:`design_interval` of every design, in the order of ``results``."""
    return [design_interval(model, result, rule) for result in results]


def _predict(model, f, g, r: float) -> tuple[np.ndarray, np.ndarray]:
    f = np.asarray(f, dtype=float)
    mean, std = model.predict_with_uncertainty(f, np.asarray(g, dtype=float), np.full_like(f, r))
    return np.asarray(mean, dtype=float), np.asarray(std, dtype=float)
