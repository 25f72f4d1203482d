"""Runs: determinism, batches equal to single cells, the case record, refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pidpipe.dem import advance, simulate_cell, start
from pidpipe.errors import PackingError
from pidpipe.measurement.steady_state import assess_steady_state
from tests.dem.conftest import spec_scene


def _short_run(positions, accel_g=5.0, steps=600):
    scene, state, ws = start(spec_scene(freq_hz=1000.0, accel_g=accel_g), positions)
    advance(scene, state, ws, steps)
    return state


def test_same_inputs_give_the_same_result(settled_11):
    first, second = _short_run(settled_11), _short_run(settled_11)
    for name in ("x", "v", "omega", "force", "shear"):
        assert np.array_equal(getattr(first, name), getattr(second, name))


def test_a_batch_of_cells_evolves_each_cell_as_if_alone(settled_11):
    other = settled_11.copy()
    other[:, :2] *= -1.0                                  # the packing turned by 180 degrees
    batch = _short_run(np.stack([settled_11, other]), accel_g=[5.0, 10.0])
    alone = [_short_run(settled_11, 5.0), _short_run(other, 10.0)]
    for b, single in enumerate(alone):
        np.testing.assert_allclose(batch.x[:, b], single.x[:, 0], rtol=0, atol=1e-15)
        np.testing.assert_allclose(batch.v[:, b], single.v[:, 0], rtol=1e-9, atol=1e-15)


def test_case_record_matches_the_liggghts_record_keys(settled_11):
    scene = spec_scene(freq_hz=1000.0, accel_g=10.0)
    (record,) = simulate_cell(scene, settled_11, transient_cycles=1, measured_cycles=2,
                              block_cycles=1, n_cells=441, seed=7)
    for key in ("solver", "freq_hz", "accel_g", "n_spheres", "ed_cycle_mean_j",
                "ed_cycle_sem_j", "ceq_cell_ns_m", "ceq_coupon_ns_m", "cycles", "fidelity",
                "wall_time_s", "wall_work_cycle_mean_j"):
        assert key in record
    assert record["solver"] == "numba-dem" and record["n_spheres"] == 11
    assert record["fidelity"]["steps_per_cycle"] * record["fidelity"]["timestep_s"] == \
        pytest.approx(1e-3)
    assert record["fidelity"]["rayleigh_fraction"] <= 0.2 and record["fidelity"]["seed"] == 7
    assert len(record["cycles"]["wall_work_j"]) == 3
    assert record["ceq_coupon_ns_m"] == pytest.approx(441 * record["ceq_cell_ns_m"])
    assert abs(record["balance_mismatch_fraction"]) < 0.005
    json.dumps(record)                                     # plain JSON types only


def test_spheres_outside_the_cell_are_refused(settled_11):
    bad = settled_11.copy()
    bad[0, 2] = -20e-3
    with pytest.raises(PackingError, match="outside the cell"):
        start(spec_scene(), bad)


def test_record_discards_the_transient_by_the_liggghts_paths_rule(settled_11):
    """The cycles measured are those after max(configured, MSER-detected) transient cycles,
    as in pidpipe.liggghts.shake.run_case, so that the two solvers average like with like."""
    scene = spec_scene(freq_hz=1000.0, accel_g=10.0)
    (record,) = simulate_cell(scene, settled_11, transient_cycles=1, measured_cycles=9,
                              block_cycles=1)
    terms = np.array(record["cycles"]["dissipated_terms_j"])
    energy = np.array(record["cycles"]["ledger_energy_j"])
    expected = assess_steady_state(terms, energy, 1, 1)
    discarded = record["fidelity"]["transient_cycles"]
    assert discarded == expected.transient_cycles == max(1, record["detected_transient_cycles"])
    assert discarded > 1                  # the bed's start-up outlasts the configured cycle
    assert record["fidelity"]["transient_cycles_configured"] == 1
    assert record["n_cycles"] == 10 - discarded
    assert record["ed_cycle_mean_j"] == pytest.approx(terms[discarded:].mean(), rel=1e-12)
    assert record["flags"] == expected.flags
    assert record["status"] == ("flagged" if expected.flags else "ok")


def test_a_run_continued_gives_the_numbers_of_one_longer_run_to_the_last_bit(settled_11):
    """3 + 2 cycles in two kernel calls (with the bed's motion sampled in windows that do not
    tile the cycle, so one window straddles the calls) equal 5 cycles in one call, bit for bit:
    every ledger, every motion window and the end state with its contact history."""
    from pidpipe.config.inspection import MotionSampling
    from pidpipe.dem.run import CycleRun

    scene = spec_scene(freq_hz=1000.0, accel_g=[10.0, 10.0])
    sampling = MotionSampling(7, 3)
    assert scene.steps_per_cycle % sampling.window_steps(scene.steps_per_cycle) != 0
    packings = np.stack([settled_11, settled_11[::-1]])
    runs = []
    for calls in ([5], [3, 2]):
        run = CycleRun(*start(scene, packings), sampling)
        for n_cycles in calls:
            run.run(n_cycles)
        runs.append(run)
    one, two = runs
    assert two.n_cycles == 5 and two.state.step == one.state.step == 5 * scene.steps_per_cycle
    ledgers = one.cycles(), two.cycles()
    assert ledgers[0].keys() == ledgers[1].keys()
    for key in ledgers[0]:
        assert np.array_equal(ledgers[0][key], ledgers[1][key]), key
    assert ledgers[0]["wall_work_j"].shape == (2, 5)
    motions = one.motion(), two.motion()
    for field in ("power_w", "floor_force_n", "lid_force_n", "energy_j", "centre_m", "bottom_m",
                  "top_m"):
        assert np.array_equal(getattr(motions[0], field), getattr(motions[1], field)), field
    for name in ("x", "v", "omega", "force", "torque", "shear", "tangential_energy"):
        assert np.array_equal(getattr(one.state, name), getattr(two.state, name)), name
    assert np.array_equal(one.ws.history, two.ws.history)
    assert np.array_equal(one.ws.wall_force_z, two.ws.wall_force_z)
