"""The surrogate's predictive mean and standard deviation, NaN where it refuses a point.

A surrogate may refuse points outside its domain (:class:`~pidpipe.errors.DomainError`); the
loop asks about points there on purpose (a design's verifying point at a whole-sphere fill just
below the grid's lowest fill, a candidate one sphere beyond it). Such points get NaN, and the
loop treats them as unknown: a verifying point without a surrogate value does not pass, and
becomes a case of the next round, which widens the domain to it.
"""

from __future__ import annotations

import numpy as np

from pidpipe.errors import DomainError


def predict_or_nan(model, freq_hz, accel_g, fill_pct) -> tuple[np.ndarray, np.ndarray]:
    """``model.predict_with_uncertainty`` at m points, NaN at the points it refuses.

    Parameters
    ----------
    model
        Has ``predict_with_uncertainty(f, G, r) -> (mean, std)``.
    freq_hz, accel_g, fill_pct : array_like, shape (m,)
        Hz, g, %.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        Mean and standard deviation of the coupon's C_eq, N*s/m, each shape (m,).
    """
    f, g, r = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (freq_hz, accel_g, fill_pct))
    try:
        mean, std = model.predict_with_uncertainty(f, g, r)
        return (np.asarray(mean, dtype=float).reshape(f.shape),
                np.asarray(std, dtype=float).reshape(f.shape))
    except DomainError:
        pass
    mean, std = np.full(f.shape, np.nan), np.full(f.shape, np.nan)
    for i in range(f.size):
        try:
            m, s = model.predict_with_uncertainty(f[i:i + 1], g[i:i + 1], r[i:i + 1])
        except DomainError:
            continue
        mean[i], std[i] = float(np.asarray(m).ravel()[0]), float(np.asarray(s).ravel()[0])
    return mean, std
