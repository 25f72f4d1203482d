"""Statistics of scenes of several cells: per-cell C_eq, same-packing comparisons, packing scatter."""

import math

import numpy as np
import pytest

from pidpipe.liggghts.parsing import CycleSeries
from pidpipe.liggghts.patch_run import energy_drift
from pidpipe.measurement.cells import per_cell_ceq
from pidpipe.measurement.statistics import summarise_cycles
from pidpipe.physics.equivalent_damping import ceq_from_energy
from pidpipe.studies.scene_stats import (
    packing_scatter,
    same_packing_z,
    separate_runs_scene,
)


def _cell(seed, ceq, sem):
    return {"seed": seed, "ceq_cell_ns_m": ceq, "ceq_cell_sem_ns_m": sem}


def test_per_cell_ceq_averages_cells_and_divides_the_total_sem():
    total = summarise_cycles(np.array([3.0, 5.0, 3.0, 5.0, 4.0, 4.0]) * 1e-8, 500, 5, 1, 2)
    result = per_cell_ceq([0.1, 0.2, 0.3], total)
    assert result["ceq_ns_m"] == pytest.approx(0.2)
    assert result["std_cells_ns_m"] == pytest.approx(0.1)
    assert result["sem_cells_ns_m"] == pytest.approx(0.1 / math.sqrt(3))
    assert result["sem_time_ns_m"] == pytest.approx(total["ceq_cell_sem_ns_m"] / 3)
    assert math.isnan(per_cell_ceq([0.1], total)["sem_cells_ns_m"])


def test_separate_runs_sum_their_cycle_series():
    series = [np.array([1.0, 2.0, 1.0, 2.0]) * 1e-8, np.array([3.0, 3.0, 3.0, 3.0]) * 1e-8]
    records = []
    for k, s in enumerate(series):
        cell = {"seed": k, **summarise_cycles(s, 500, 5, 1, 2)}
        records.append({"freq_hz": 500, "accel_g": 5, "cells": [cell], "total_dissipated_j": s.tolist(),
                        "engine": {"cpu_time_s": 2.0}, "cell_cycles": 10})
    scene = separate_runs_scene(records, 2)
    assert scene["per_cell"]["ceq_ns_m"] == pytest.approx(ceq_from_energy(2.25e-8, 500, 5))
    assert scene["cpu_time_s"] == 4.0 and scene["cell_cycles"] == 20
    assert [c["cell"] for c in scene["cells"]] == [0, 1]


def test_same_packing_z_in_combined_sems_and_zero_when_identical():
    a = [_cell(1, 0.10, 0.003), _cell(2, 0.12, 0.003)]
    b = [_cell(1, 0.10, 0.004), _cell(2, 0.11, 0.004), _cell(3, 0.5, 0.1)]
    z = same_packing_z(a, b)
    assert z.tolist() == pytest.approx([0.0, 0.01 / 0.005])
    with pytest.raises(ValueError, match="seeds differ"):
        same_packing_z(a, [_cell(7, 0.1, 0.01)])


def test_packing_scatter_removes_the_cycle_noise():
    cells = [_cell(k, c, 0.03) for k, c in enumerate([0.1, 0.2, 0.3, 0.4])]
    scatter = packing_scatter(cells)
    std = np.std([0.1, 0.2, 0.3, 0.4], ddof=1)
    assert scatter["std_packing_ns_m"] == pytest.approx(math.sqrt(std**2 - 0.03**2))
    noisy = [_cell(k, c, 1.0) for k, c in enumerate([0.1, 0.2])]
    assert packing_scatter(noisy)["std_packing_ns_m"] == 0.0


def test_energy_drift_is_the_stored_share_of_the_dissipation():
    ed = np.array([5.0, 1.0, 1.0])
    energy = np.array([10.0, 6.0, 5.5, 5.0])
    series = CycleSeries(wall_work_j=ed, gross_work_j=ed, energy_j=energy, dissipated_j=ed,
                         lowest_z_m=ed, highest_z_m=ed)
    assert energy_drift(series, 1) == pytest.approx((6.0 - 5.0) / 2.0)


def test_cost_split_into_set_up_and_cycles():
    from pidpipe.studies.scene import split_cost

    record = {"engine": {"cpu_time_s": 10.0, "wall_time_s": 20.0, "loop_time_s": 15.0},
              "transient_cycles": 1, "measured_cycles": 2}
    setup, per_cycle = split_cost(record)
    assert setup == pytest.approx(2.5) and per_cycle == pytest.approx(7.5 / 3)


def test_run_to_run_noise_from_same_packing_pairs():
    from pidpipe.studies.scene_stats import run_to_run_noise

    a = [_cell(1, 0.10, 0.01), _cell(2, 0.12, 0.01), _cell(3, 0.20, 0.01)]
    b = [_cell(1, 0.10, 0.01), _cell(2, 0.14, 0.01), _cell(3, 0.18, 0.01)]   # cell 1 identical
    noise, n = run_to_run_noise([(a, b)])
    assert n == 2 and noise == pytest.approx(math.sqrt((0.02**2 + 0.02**2) / 2 / 2))
    scatter = packing_scatter(a, noise)
    assert scatter["run_noise_ns_m"] == noise
    assert scatter["std_packing_ns_m"] == pytest.approx(math.sqrt(np.var([0.1, 0.12, 0.2], ddof=1) - noise**2))
