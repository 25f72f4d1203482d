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
