"""C_eq models with an uncertainty: what the panel's loss factors take.

The panel stage needs the coupon's C_eq at (f, G, r) and, for every loss factor's interval, its
uncertainty. Two kinds of model serve (:class:`UncertainCeq`):

- a surrogate that offers ``predict_with_uncertainty(f, G, r) -> (mean, std)`` (a Gaussian
  process); the interval of a loss factor is then its value with every C_eq at mean -/+ z std
  (:func:`interval_from_std`: the errors taken fully correlated between cells, which bounds the
  interval from above, as the loss factor is a positive sum of C_eq);
- the project's spline surrogate with the C_eq table's standard errors: surrogates refitted to
  the table redrawn within its SEMs (:func:`pidpipe.design.bootstrap.resampled_surrogates`);
  a loss factor's interval is the percentile interval of its value on each refit.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.stats import norm

from pidpipe.design.damper import has_uncertainty

Predict = Callable[..., np.ndarray]
"""C_eq_coupon(freq_hz, accel_g, fill_pct) -> N*s/m, broadcast over the inputs."""


@dataclass
class UncertainCeq:
    """A coupon C_eq model and what it knows of its own uncertainty.

    Attributes
    ----------
    predict : callable
        The mean C_eq_coupon(f Hz, G g, r %), N*s/m.
    domain : dict
        ``freq_hz``, ``accel_g``, ``fill_pct`` -> (low, high).
    draws : list of callable
        Predictions of refitted surrogates (bootstrap); empty if none.
    predict_with_uncertainty : callable or None
        (f, G, r) -> (mean, std), N*s/m; used when there are no draws.
    """

    predict: Predict
    domain: dict
    draws: list = field(default_factory=list)
    predict_with_uncertainty: Callable | None = None

    @classmethod
    def from_surrogate(cls, surrogate, draws: int = 0, seed: int = 11) -> "UncertainCeq":
        """Wrap a surrogate: its own ``predict_with_uncertainty`` if it has one, else ``draws``
        bootstrap refits when its table has SEMs (none otherwise)."""
        own = surrogate.predict_with_uncertainty if has_uncertainty(surrogate) else None
        refits = []
        if own is None and draws > 0:
            from pidpipe.design.bootstrap import has_sem, resampled_surrogates

            if has_sem(surrogate):
                refits = [_unchecked(s) for s in resampled_surrogates(surrogate, draws, seed)]
        return cls(predict=_unchecked(surrogate), domain=dict(surrogate.domain), draws=refits,
                   predict_with_uncertainty=own)

    @property
    def kind(self) -> str:
        """How intervals are made: ``bootstrap``, ``predictive_std`` or ``none``."""
        if self.draws:
            return "bootstrap"
        return "predictive_std" if self.predict_with_uncertainty is not None else "none"


def _unchecked(surrogate) -> Predict:
    """The surrogate's prediction without its per-call domain check (the panel clips first)."""
    fast = getattr(surrogate, "_predict", None)
    if fast is None:
        return surrogate.predict

    def predict(freq_hz, accel_g, fill_pct):
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (freq_hz, accel_g, fill_pct)))
        return fast(*(a.ravel() for a in arrays)).reshape(arrays[0].shape)

    return predict


def interval(model: UncertainCeq, evaluate: Callable[[Predict], float],
             confidence: float) -> tuple[float, float]:
    """(lo, hi) of a quantity ``evaluate(predict)`` that is built from C_eq predictions.

    Bootstrap draws give the percentile interval; a predictive std gives
    :func:`interval_from_std`; without either the interval is (nan, nan).
    """
    if model.draws:
        values = np.array([evaluate(draw) for draw in model.draws])
        tail = 0.5 * (1.0 - confidence)
        lo, hi = np.quantile(values, [tail, 1.0 - tail])
        return float(lo), float(hi)
    if model.predict_with_uncertainty is not None:
        return interval_from_std(model.predict_with_uncertainty, evaluate, confidence)
    return float("nan"), float("nan")


def interval_from_std(predict_with_uncertainty: Callable, evaluate: Callable[[Predict], float],
                      confidence: float) -> tuple[float, float]:
    """The quantity with every C_eq at mean - z std and at mean + z std (z of the two-sided
    ``confidence``; the lower end clipped at 0 N*s/m)."""
    z = float(norm.ppf(0.5 + 0.5 * confidence))

    def shifted(sign: float) -> Predict:
        def predict(freq_hz, accel_g, fill_pct):
            mean, std = predict_with_uncertainty(freq_hz, accel_g, fill_pct)
            return np.maximum(np.asarray(mean) + sign * z * np.asarray(std), 0.0)
        return predict

    return float(evaluate(shifted(-1.0))), float(evaluate(shifted(+1.0)))
