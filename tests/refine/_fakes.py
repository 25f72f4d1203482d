"""What the loop's tests run on: an analytic C_eq with a known optimum, a fake engine whose SEM
falls as 1/sqrt(cells x cycles) and whose CPU grows with them, and a small Gaussian-process
surrogate (scikit-learn) with the interface the loop expects."""

from __future__ import annotations

import zlib

import numpy as np
import pandas as pd
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel

from pidpipe.design.band import BandRule
from pidpipe.design.designs import Search
from pidpipe.design.optimisation import Budget, Environment
from pidpipe.errors import DomainError

#: Fill (%) at which every design's total C_eq peaks: T ~ C / r ~ exp(-((r - R_OPT) / 30)^2).
R_OPT = 45.0

ENVIRONMENTS = [Environment("low", (250.0, 300.0), (4.0, 6.0)),
                Environment("high", (600.0, 700.0), (1.5, 2.5))]

#: 20 spheres fill a cell; 4410 spheres spread over at most 1000 cells: fills 22.05-100 %.
BUDGET = Budget(n_spheres=4410, full_cell_spheres=20, n_cells_coupon=441, n_cells_panel=1000)

#: A fast search: few SLSQP starts, a coarse band rule.
SEARCH = Search(starts=3, seed=7, rule=BandRule(quadrature_points=3, grid_points=3), maxiter=100)

#: Pilot relative SEM; planned CPU per unit of effort (cells x cycles of a pilot), s.
PILOT_RELATIVE_SEM = 0.10
CPU_PER_EFFORT_S = 10.0


def true_ceq(f, g, r):
    """The coupon's C_eq, N*s/m: smooth, falling with f, rising with G, T ~ C/r peaks at R_OPT."""
    f, g, r = (np.asarray(a, dtype=float) for a in (f, g, r))
    return 40.0 * (r / 50.0) * np.exp(-((r - R_OPT) / 30.0) ** 2) * (500.0 / f) ** 0.5 * (g / 3.0) ** 0.4


class TrueModel:
    """The analytic C_eq as a surrogate (for the true optimum)."""

    domain = {"freq_hz": (100.0, 900.0), "accel_g": (1.0, 8.0), "fill_pct": (25.0, 75.0)}

    def predict(self, f, g, r):
        return true_ceq(f, g, r)


def grid_cases() -> list[tuple[float, float, float]]:
    """The campaign's grid: 3 x 3 x 3 cases (Hz, g, %)."""
    return [(f, g, r) for f in (100.0, 400.0, 900.0) for g in (1.0, 4.0, 8.0) for r in (25.0, 50.0, 75.0)]


class FakeEngine:
    """C_eq = true + normal noise with SEM = PILOT_RELATIVE_SEM * true / sqrt(effort), seeded by
    the case, its effort and its run (so a repeated request repeats its answer); CPU =
    CPU_PER_EFFORT_S * effort added. Records every request it runs."""

    def __init__(self, fail_after: int | None = None, truth=None):
        self.requests: list = []
        self.fail_after = fail_after
        self.truth = true_ceq if truth is None else truth

    def _row(self, key: str, f, g, r, effort: float, run: int) -> dict:
        truth = float(self.truth(f, g, r))
        sem = PILOT_RELATIVE_SEM * truth / np.sqrt(effort)
        rng = np.random.default_rng(zlib.crc32(f"{key}|{effort:g}|{run}".encode()))
        return {"freq_hz": f, "accel_g": g, "fill_pct": r, "ceq_coupon_ns_m": truth + sem * rng.standard_normal(),
                "ceq_coupon_sem_ns_m": sem, "status": "ok", "flags": "", "effort": effort}

    def _count(self, requests) -> None:
        for request in requests:
            if self.fail_after is not None and len(self.requests) >= self.fail_after:
                raise KeyboardInterrupt("killed")
            self.requests.append(request)

    def grid(self) -> pd.DataFrame:
        rows = []
        for f, g, r in grid_cases():
            rows.append(self._row(f"grid_{f}_{g}_{r}", f, g, r, 1.0, 0))
        return pd.DataFrame(rows)

    def measure(self, cases, more) -> pd.DataFrame:
        self._count(list(cases) + list(more))
        rows = [self._row(q.key, q.freq_hz, q.accel_g, q.fill_pct, 1.0, 0) for q in cases]
        rows += [self._row(q.key, q.freq_hz, q.accel_g, q.fill_pct,
                           float(q.base.get("effort", 1.0)) * q.factor, 0) for q in more]
        return pd.DataFrame(rows)

    def verify(self, points) -> pd.DataFrame:
        self._count(points)
        return pd.DataFrame([self._row("verify_" + q.key, q.freq_hz, q.accel_g, q.fill_pct, 1.0,
                                       q.run) for q in points])

    @staticmethod
    def cost(request) -> float:
        if request.action == "extend":
            return CPU_PER_EFFORT_S * float(request.base.get("effort", 1.0)) * (request.factor - 1.0)
        return CPU_PER_EFFORT_S


class GPSurrogate:
    """A Gaussian process of C_eq on (f, G, r) scaled to [0, 1] by the table's bounding box, the
    rows' SEMs as their noise; ``predict_with_uncertainty`` returns the latent mean and std."""

    def __init__(self, table: pd.DataFrame, start=None):
        table = table[table["status"] == "ok"]          # as pidpipe's fits: only usable rows
        x = table[["freq_hz", "accel_g", "fill_pct"]].to_numpy(dtype=float)
        y = table["ceq_coupon_ns_m"].to_numpy(dtype=float)
        sem = table["ceq_coupon_sem_ns_m"].to_numpy(dtype=float)
        self.domain = {k: (float(x[:, i].min()), float(x[:, i].max()))
                       for i, k in enumerate(("freq_hz", "accel_g", "fill_pct"))}
        self._lo, self._span = x.min(axis=0), np.ptp(x, axis=0)
        self._mean, self._scale = float(y.mean()), float(y.std())
        kernel = ConstantKernel(1.0, (1e-2, 1e2)) * RBF([0.5, 0.5, 0.5], (0.05, 20.0))
        self._gp = GaussianProcessRegressor(kernel, alpha=(sem / self._scale) ** 2 + 1e-8,
                                            n_restarts_optimizer=0, random_state=0)
        self._gp.fit(self._scaled(x), (y - self._mean) / self._scale)

    def _scaled(self, x):
        return (x - self._lo) / self._span

    def predict_with_uncertainty(self, f, g, r):
        f, g, r = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (f, g, r)))
        x = np.column_stack([f.ravel(), g.ravel(), r.ravel()])
        mean, std = self._gp.predict(self._scaled(x), return_std=True)
        return ((mean * self._scale + self._mean).reshape(f.shape),
                (std * self._scale).reshape(f.shape))

    def predict(self, f, g, r):
        f, g, r = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (f, g, r)))
        x = np.column_stack([f.ravel(), g.ravel(), r.ravel()])
        return (self._gp.predict(self._scaled(x)) * self._scale + self._mean).reshape(f.shape)


class RefusingGP(GPSurrogate):
    """The GP refusing points outside the bounding box of its rows, as pidpipe's surrogates do."""

    def predict_with_uncertainty(self, f, g, r):
        for name, values in (("freq_hz", f), ("accel_g", g), ("fill_pct", r)):
            lo, hi = self.domain[name]
            values = np.asarray(values, dtype=float)
            if np.any((values < lo - 1e-9) | (values > hi + 1e-9)):
                raise DomainError(f"{name} outside the surrogate's domain [{lo:g}, {hi:g}]")
        return super().predict_with_uncertainty(f, g, r)
