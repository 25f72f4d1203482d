"""Reading an amplitude-frequency curve: its peak and its loss factor there, with uncertainties.

The peak of a sampled curve is the vertex of the parabola through the largest sample and its
two neighbours (the largest sample itself, flagged ``peak_at_edge``, when it is the first or the
last). The loss factor at the peak is interpolated linearly in frequency. Uncertainties come
from draws of the curve (the coupled host's amplitudes redrawn within their standard errors, or
the dashpot model solved with each redrawn surrogate): the standard deviation of the peak's
values over the draws.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Peak:
    """A curve's peak: frequency (Hz), amplitude (m), loss factor there, and whether the
    largest sample is at the sweep's edge (the true peak may lie outside it)."""

    freq_hz: float
    amplitude_m: float
    loss_factor: float
    at_edge: bool


def find_peak(freq_hz: np.ndarray, amplitude_m: np.ndarray, loss_factor: np.ndarray) -> Peak:
    """The peak of one sampled curve (module docstring).

    Parameters
    ----------
    freq_hz, amplitude_m, loss_factor : ndarray, shape (n,)
        The sweep's frequencies (increasing), amplitudes (m) and loss factors.
    """
    f = np.asarray(freq_hz, dtype=float)
    a = np.asarray(amplitude_m, dtype=float)
    eta = np.asarray(loss_factor, dtype=float)
    i = int(np.nanargmax(a))
    if i == 0 or i == a.size - 1:
        return Peak(float(f[i]), float(a[i]), float(eta[i]), True)
    c2, c1, c0 = np.polyfit(f[i - 1:i + 2], a[i - 1:i + 2], 2)
    f_peak = float(np.clip(-c1 / (2 * c2), f[i - 1], f[i + 1])) if c2 < 0 else float(f[i])
    a_peak = float(max(np.polyval([c2, c1, c0], f_peak), a[i]))
    return Peak(f_peak, a_peak, float(np.interp(f_peak, f, eta)), False)


def peak_with_uncertainty(freq_hz: np.ndarray, amplitude_m: np.ndarray, loss_factor: np.ndarray,
                          amplitude_draws: np.ndarray | None, loss_factor_draws: np.ndarray | None
                          ) -> dict:
    """The peak of the central curve and the standard deviation of the draws' peaks.

    Parameters
    ----------
    freq_hz, amplitude_m, loss_factor : ndarray, shape (n,)
        The central curve.
    amplitude_draws, loss_factor_draws : ndarray, shape (draws, n), or None
        Draws of the curve; None (or fewer than two draws): no uncertainty (NaN).

    Returns
    -------
    dict
        ``peak_freq_hz``, ``peak_amplitude_m``, ``peak_loss_factor``, ``peak_at_edge`` and
        ``*_sd`` of the first three.
    """
    peak = find_peak(freq_hz, amplitude_m, loss_factor)
    out = {"peak_freq_hz": peak.freq_hz, "peak_amplitude_m": peak.amplitude_m,
           "peak_loss_factor": peak.loss_factor, "peak_at_edge": peak.at_edge}
    draws = [] if amplitude_draws is None or len(amplitude_draws) < 2 else [
        find_peak(freq_hz, a, e) for a, e in zip(amplitude_draws, loss_factor_draws)]
    for key, attr in (("peak_freq_hz", "freq_hz"), ("peak_amplitude_m", "amplitude_m"),
                      ("peak_loss_factor", "loss_factor")):
        out[f"{key}_sd"] = (float(np.std([getattr(d, attr) for d in draws], ddof=1)) if draws
                            else float("nan"))
    return out


def redraw(values: np.ndarray, sems: np.ndarray, draws: int, seed: int) -> np.ndarray:
    """``draws`` copies of a curve with each value redrawn within its standard error (NaN SEM:
    kept), shape (draws, n)."""
    values = np.asarray(values, dtype=float)
    sems = np.nan_to_num(np.asarray(sems, dtype=float), nan=0.0)
    noise = np.random.default_rng(seed).standard_normal((draws, values.size))
    return values + sems * noise


def relative_difference(value: float, value_sd: float, reference: float, reference_sd: float
                        ) -> tuple[float, float]:
    """value / reference - 1 and its standard deviation (first-order propagation, NaN SDs as 0)."""
    ratio = value / reference
    rel = np.hypot(np.nan_to_num(value_sd) / value, np.nan_to_num(reference_sd) / reference)
    return float(ratio - 1.0), float(abs(ratio) * rel)
