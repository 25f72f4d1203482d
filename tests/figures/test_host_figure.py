"""The host check's figure draws every model of the curves table, model (c) when it is there."""

from __future__ import annotations

import numpy as np
import pandas as pd

from pidpipe.figures.host import plot_host


def _curves(models) -> pd.DataFrame:
    f = np.linspace(240.0, 310.0, 7)
    rows = []
    for shift, model in enumerate(models):
        amplitude = 1e-6 / (1 + ((f - 262.0 - 4 * shift) / 5.0) ** 2)
        for fi, a in zip(f, amplitude):
            rows.append({"model": model, "level": 0, "force_n": 0.01, "freq_hz": fi,
                         "amplitude_m": a, "amplitude_unc_m": 0.02 * a, "loss_factor": 0.05,
                         "loss_factor_unc": 0.001, "steady": True, "surrogate_clipped": False})
    return pd.DataFrame(rows)


def _labels(figure) -> list[str]:
    return [text.get_text() for text in figure.axes[0].get_legend().get_texts()]


def test_model_c_is_drawn_and_labelled_when_present():
    models = ["coupled", "equivalent", "equivalent_bare_mass", "equivalent_mass"]
    labels = _labels(plot_host(_curves(models)))
    assert len(labels) == 4 and sum(label.endswith("(c)") for label in labels) == 1
    assert len(_labels(plot_host(_curves(models[:3])))) == 3
