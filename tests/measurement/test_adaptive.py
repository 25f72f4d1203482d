"""Measuring to a target standard error (pidpipe.measurement.adaptive), with a stand-in for LIGGGHTS whose
standard error falls as 1/sqrt(n) exactly."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config, validate_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.errors import ConfigError
from pidpipe.measurement.adaptive import (
    MAX_STAGES,
    SAFETY,
    cycles_for_target,
    run_to_target,
)

CASE = CaseSpec(500.0, 5.0, 50.0)


def fake_run(ceq: float, scatter: float):
    """A run() whose C_eq is ``ceq`` and whose SEM is scatter / sqrt(measured cycles); it logs
    the measured cycles of every call."""
    calls = []

    def run(settings, case, packing, workdir):
        n = settings.sampling.measured_cycles
        calls.append(n)
        return {"ceq_cell_ns_m": ceq, "ceq_cell_sem_ns_m": scatter / math.sqrt(n),
                "ceq_cell_cycle_sem_ns_m": scatter / math.sqrt(n),
                "engine": {"cpu_time_s": 0.1 * n}, "fidelity": {"measured_cycles": n}}

    return run, calls


def config_with(target, measured=40, cap=400):
    config = load_config()
    config["fidelity"].update(target_relative_sem=target, measured_cycles=measured,
                              max_measured_cycles=cap)
    return ShakeSettings.from_config(config)


def test_without_a_target_the_case_runs_once_as_configured(tmp_path):
    run, calls = fake_run(1.0, 1.0)
    record = run_to_target(config_with(None), CASE, None, tmp_path, run)
    assert calls == [40] and "target" not in record


def test_the_window_grows_until_the_target_is_met(tmp_path):
    # pilot: 40 cycles, SEM 1/sqrt(40) = 15.8 %; a 5 % target needs 400 cycles, 480 with the margin
    run, calls = fake_run(1.0, 1.0)
    record = run_to_target(config_with(0.05, cap=1000), CASE, None, tmp_path, run)
    assert calls == [40, math.ceil(40 * (1 / math.sqrt(40) / 0.05) ** 2 * SAFETY)]
    assert record["target"]["reached"] and record["target"]["stages"] == calls
    assert record["target"]["cpu_time_s"] == pytest.approx(0.1 * sum(calls))
    assert record["fidelity"]["measured_cycles"] == calls[-1]


def test_the_cap_stops_the_growth_and_says_the_target_was_missed(tmp_path):
    run, calls = fake_run(1.0, 1.0)
    record = run_to_target(config_with(0.01, cap=300), CASE, None, tmp_path, run)
    assert calls == [40, 300]
    assert not record["target"]["reached"]


def test_a_met_target_costs_no_second_run(tmp_path):
    run, calls = fake_run(1.0, 0.1)
    assert run_to_target(config_with(0.05), CASE, None, tmp_path, run)["target"]["reached"]
    assert calls == [40]


def test_a_ceq_not_above_zero_is_not_extended(tmp_path):
    run, calls = fake_run(-1e-9, 1.0)
    record = run_to_target(config_with(0.05), CASE, None, tmp_path, run)
    assert calls == [40] and not record["target"]["reached"]


def test_stages_are_bounded():
    assert cycles_for_target(40, 0.5, 0.05, 100000) == math.ceil(40 * 100 * SAFETY)
    assert cycles_for_target(40, 0.0501, 0.05, 100000) > 40  # always adds cycles
    assert cycles_for_target(400, 0.5, 0.05, 400) == 400
    assert MAX_STAGES >= 2


def test_a_cap_below_the_pilot_is_a_config_error():
    raw = yaml.safe_load((Path(__file__).resolve().parents[2] / "config.yaml").read_text())
    raw["fidelity"]["max_measured_cycles"] = 10
    with pytest.raises(ConfigError, match="fidelity.max_measured_cycles = 10"):
        validate_config(raw)
