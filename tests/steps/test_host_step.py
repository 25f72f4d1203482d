"""The host step's choice of design and its summary lines (pidpipe.steps.host)."""

from __future__ import annotations

from types import SimpleNamespace

import pandas as pd
import pytest

from pidpipe.config import load_config
from pidpipe.config.settings import HostSettings
from pidpipe.errors import ConfigError
from pidpipe.steps.host import chosen_design, host_params, summary_lines


def _result(name: str, kind: str):
    return SimpleNamespace(environment=SimpleNamespace(name=name), kind=kind)


def test_the_design_of_the_hosts_environment_and_kind_is_chosen():
    settings = HostSettings.from_config(load_config())
    results = [_result("250-300 Hz, 5-6 g", "peak"), _result("250-300 Hz, 5-6 g", "band_mean"),
               _result("450-500 Hz, 1-2 g", "band_mean")]
    assert chosen_design(results, settings) is results[1]
    with pytest.raises(ConfigError, match="host.design = 'band_mean'.*no band_mean design"):
        chosen_design(results[:1], settings)


def test_the_host_depends_on_its_section_and_the_packings_not_on_the_grid():
    config = load_config()
    params = host_params(config)
    assert params["host"] == config["host"] and "grid" not in params
    assert params["fidelity"]["settle_time_s"] == config["fidelity"]["settle_time_s"]


def test_a_summary_line_per_model_with_the_verdict():
    row = dict(level=0, force_n=0.03, peak_freq_hz=264.2, peak_freq_hz_sd=0.1,
               peak_amplitude_m=5.4e-6, peak_amplitude_m_sd=1e-8, peak_loss_factor=0.08,
               peak_loss_factor_sd=0.001, peak_accel_g=1.5, peak_at_edge=False)
    other = dict(row, model="equivalent", amplitude_rel_diff=0.104, amplitude_rel_diff_sd=0.016,
                 peak_shift_hz=-3.5, peak_shift_sd_hz=0.1, loss_factor_rel_diff=-0.08,
                 loss_factor_rel_diff_sd=0.01, holds=True)
    lines = summary_lines(pd.DataFrame([dict(row, model="coupled"), other]))
    assert lines[0].startswith("F0 0.03 N coupled: peak 5.4 +- 0.01 um at 264.2")
    assert "amplitude +10.4% +- 1.6%" in lines[1] and lines[1].endswith("holds")
