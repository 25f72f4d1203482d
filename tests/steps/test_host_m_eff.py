"""The host step finds the m_eff surrogate next to the C_eq one, or leaves model (c) out."""

from __future__ import annotations

import logging

from pidpipe.design.damper import M_EFF_FILE
from pidpipe.steps.host import load_m_eff_surrogate


def test_the_m_eff_surrogate_next_to_the_c_eq_one_is_loaded(tmp_path):
    (tmp_path / M_EFF_FILE).write_text("{}")
    loaded = load_m_eff_surrogate(str(tmp_path / "surrogate.json"), loader=lambda p: p.name)
    assert loaded == M_EFF_FILE
    other = tmp_path / "elsewhere.json"
    other.write_text("{}")
    assert load_m_eff_surrogate(str(tmp_path / "surrogate.json"), str(other),
                                loader=lambda p: p.name) == "elsewhere.json"


def test_without_an_m_eff_surrogate_model_c_is_left_out_with_a_reason(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="pidpipe.campaign"):
        assert load_m_eff_surrogate(str(tmp_path / "surrogate.json"),
                                    loader=lambda p: 1 / 0) is None
    assert "model (c)" in caplog.text and M_EFF_FILE in caplog.text


def test_a_summary_line_gives_the_peak_shift_in_standard_deviations():
    import pandas as pd

    from pidpipe.steps.host import summary_lines

    row = dict(level=0, force_n=0.1, peak_freq_hz=275.0, peak_freq_hz_sd=0.06,
               peak_amplitude_m=4e-5, peak_amplitude_m_sd=8e-7, peak_loss_factor=0.037,
               peak_loss_factor_sd=0.001, peak_accel_g=12.2, peak_at_edge=False)
    other = dict(row, model="equivalent_mass", amplitude_rel_diff=-0.02, amplitude_rel_diff_sd=0.03,
                 peak_shift_hz=-0.1, peak_shift_sd_hz=0.08, peak_shift_sigmas=1.25,
                 loss_factor_rel_diff=0.05, loss_factor_rel_diff_sd=0.03, holds=True)
    lines = summary_lines(pd.DataFrame([dict(row, model="coupled"), other]))
    assert lines[1].startswith("F0 0.1 N equivalent_mass") and "holds (peak 1.2 sd" in lines[1]
