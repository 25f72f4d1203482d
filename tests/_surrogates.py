"""Fakes of the surrogate interface that :mod:`pidpipe.design.damper` expects: ``domain`` and
``predict_with_uncertainty(freq_hz, accel_g, fill_pct) -> (mean, std)`` (or ``predict`` only)."""

from __future__ import annotations

from typing import Callable

import numpy as np

DOMAIN = {"freq_hz": (50.0, 1000.0), "accel_g": (0.05, 100.0), "fill_pct": (10.0, 95.0)}


class FakeSurrogate:
    """``mean(f, g, r)`` and ``std(f, g, r)`` (arrays) on :data:`DOMAIN`; records its queries."""

    def __init__(self, mean: Callable, std: Callable | None = None, domain: dict | None = None):
        self._mean, self._std = mean, std
        self.domain = dict(DOMAIN if domain is None else domain)
        self.queries: list[tuple[np.ndarray, ...]] = []

    def predict_with_uncertainty(self, freq_hz, accel_g, fill_pct):
        f, g, r = (np.asarray(a, dtype=float) for a in np.broadcast_arrays(freq_hz, accel_g,
                                                                          fill_pct))
        self.queries.append((f.copy(), g.copy(), r.copy()))
        std = np.zeros_like(f) if self._std is None else self._std(f, g, r)
        return np.broadcast_to(self._mean(f, g, r), f.shape), np.broadcast_to(std, f.shape)

    def predict(self, freq_hz, accel_g, fill_pct):
        return self.predict_with_uncertainty(freq_hz, accel_g, fill_pct)[0]

    def describe(self) -> str:
        return "fake surrogate"


class MeanOnlySurrogate:
    """A surrogate with ``predict`` only (as the spline surrogates)."""

    def __init__(self, mean: Callable, domain: dict | None = None):
        self._mean = mean
        self.domain = dict(DOMAIN if domain is None else domain)

    def predict(self, freq_hz, accel_g, fill_pct):
        f, g, r = (np.asarray(a, dtype=float) for a in np.broadcast_arrays(freq_hz, accel_g,
                                                                          fill_pct))
        return np.broadcast_to(self._mean(f, g, r), f.shape).astype(float)

    def describe(self) -> str:
        return "fake mean-only surrogate"


def constant(value: float) -> Callable:
    """f, g, r -> value everywhere."""
    return lambda f, g, r: np.full(np.shape(f), float(value))


def lifting_bed(bed_mass_kg: float, sharpness: float = 8.0) -> Callable:
    """m_eff of a bed that rides on the floor below 1 g and is airborne above: the bed's mass for
    Gamma < 1 falling smoothly to 0 above (0.5 (1 - tanh(sharpness ln Gamma))), kg."""
    return lambda f, g, r: bed_mass_kg * 0.5 * (1.0 - np.tanh(sharpness * np.log(g)))
