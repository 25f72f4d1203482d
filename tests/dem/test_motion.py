"""The bed's motion within the cycle, sampled inside the compiled DEM's kernel (the ``motion``
block of LIGGGHTS' records, issue 17): window sums that close on the cycle ledgers, heights above
the moving floor, and a phase profile whose dissipation is the cycles' E_d."""

from __future__ import annotations

import numpy as np
import pytest

from pidpipe.config.inspection import MotionSampling
from pidpipe.dem import run_cycles, start
from pidpipe.dem.run import run_cycles_sampled
from pidpipe.measurement.inspection import motion_record
from pidpipe.measurement.regime import REGIMES
from tests.dem.conftest import spec_scene

CYCLES = 10
FIRST_MEASURED = 3


def _aligned(steps_per_cycle: int, every: int = 1) -> MotionSampling:
    """A sampling whose windows tile every cycle exactly (so window sums are cycle sums)."""
    for windows in range(15, 40):
        if steps_per_cycle % (windows * every) == 0:
            sampling = MotionSampling(windows, every)
            assert sampling.window_steps(steps_per_cycle) * windows == steps_per_cycle
            return sampling
    raise AssertionError(f"no window count tiles {steps_per_cycle} steps")


@pytest.fixture(scope="module")
def bouncing(settled_11):
    """500 Hz, 5 g, two cells, sampled in windows that tile the cycle, forces every step."""
    scene = spec_scene(freq_hz=500.0, accel_g=[5.0, 5.0])
    scene, state, ws = start(scene, np.stack([settled_11, settled_11[::-1]]))
    sampling = _aligned(scene.steps_per_cycle)
    cycles, motion = run_cycles_sampled(scene, state, ws, CYCLES, sampling)
    return scene, sampling, cycles, motion


def test_window_sums_close_on_the_cycle_ledgers(bouncing):
    scene, sampling, cycles, motion = bouncing
    per_cycle = scene.steps_per_cycle // motion.window_steps
    assert motion.n_windows == CYCLES * per_cycle and motion.n_cells == 2
    assert motion.energy_j.shape == (motion.n_windows + 1, 2)
    # the walls' power is every step's work: its windows add up to each cycle's wall work
    work = (motion.power_w * motion.window_s).reshape(CYCLES, per_cycle, 2).sum(axis=1).T
    np.testing.assert_allclose(work, cycles["wall_work_j"], rtol=0,
                               atol=1e-12 * cycles["gross_work_j"].max())
    # K + K_rot + P at the window ends that are cycle ends is the ledger's, to rounding
    plain = (cycles["kinetic_translational_j"] + cycles["kinetic_rotational_j"]
             + cycles["potential_j"])
    np.testing.assert_allclose(motion.energy_j[::per_cycle].T, plain, rtol=0,
                               atol=1e-12 * np.abs(plain).max())


def test_the_profile_dissipates_the_cycles_e_d_and_the_floor_carries_the_bed(bouncing, settled_11):
    scene, sampling, cycles, motion = bouncing
    record = motion_record(motion, FIRST_MEASURED, scene.steps_per_cycle,
                           sampling.windows_per_cycle, [np.ptp(settled_11[:, 2])] * 2)
    profile = record["motion"]["profile"]
    dissipated = np.mean(profile["dissipation_w"]["mean"]) * profile["period_s"]
    # the mean cell's; only the elastic energy held at window ends is not in the profile
    expected = cycles["dissipated_terms_j"][:, FIRST_MEASURED:].mean()
    assert dissipated == pytest.approx(expected, rel=0.01)
    carried = (np.mean(profile["floor_force_n"]["mean"])
               - np.mean(profile["lid_force_n"]["mean"])) / profile["bed_weight_n"]
    assert 0.8 < carried < 1.2
    assert profile["bed_weight_n"] == pytest.approx(11 * scene.mass_kg * scene.gravity_m_s2)
    # 5 g at 500 Hz: the floor lets the bed go for part of the cycle and catches it hard
    assert min(profile["floor_force_n"]["mean"]) < 0.02 * profile["bed_weight_n"]
    assert max(profile["floor_force_n"]["mean"]) > 2.0 * profile["bed_weight_n"]


def test_the_regime_classifier_reads_a_dem_run(settled_11):
    """The default sampling (20 windows, forces every 10 steps) over 27 measured cycles at
    500 Hz / 5 g: a bouncing bed, as LIGGGHTS finds for the half-fill cell there. (Over 7
    cycles the landing phase's scatter, in steps of 1/20 cycle, can round to just above the
    classifier's 0.1 and one cell reads as irregular.)"""
    scene = spec_scene(freq_hz=500.0, accel_g=[5.0, 5.0])
    scene, state, ws = start(scene, np.stack([settled_11, settled_11[::-1]]))
    sampling = MotionSampling(20, 10)
    _, motion = run_cycles_sampled(scene, state, ws, 30, sampling)
    record = motion_record(motion, FIRST_MEASURED, scene.steps_per_cycle,
                           sampling.windows_per_cycle, [np.ptp(settled_11[:, 2])] * 2)
    assert record["motion"]["phase_bins"] == 20
    for features in record["motion"]["cell_features"]:
        assert features["n_cycles"] == 27 and features["lift_off_cycles"] == 1.0
        assert features["landings_per_cycle"] == 1 and features["lid_cycles"] == 0.0
        assert 0.5 < features["flight"] < 0.8 and features["expansion_diameters"] < 0.1
    assert record["motion"]["cell_regimes"] == ["bouncing_bed"] * 2
    assert record["regime"] == "bouncing_bed" and record["regime"] in REGIMES


def test_sampling_leaves_the_physics_alone(bouncing, settled_11):
    scene, _, sampled, _ = bouncing
    plain = run_cycles(*start(scene, np.stack([settled_11, settled_11[::-1]])), CYCLES)
    assert plain.keys() == sampled.keys()
    for key, values in plain.items():
        np.testing.assert_array_equal(values, sampled[key], err_msg=key)


def test_heights_are_above_the_moving_floor(settled_11):
    """At 100 Hz and 1 g the floor moves by 2 W = 50 um, 4 % of a radius, and the bed rides on
    it: the lowest sphere centre stays one radius above the floor to within the contact
    overlap, in every window, and the floor carries the bed's weight (the side walls' friction
    some of it: 0.90 here)."""
    scene = spec_scene(freq_hz=100.0, accel_g=[1.0])
    scene, state, ws = start(scene, settled_11)
    sampling = MotionSampling(20, 10)              # the default sampling
    window = sampling.window_steps(scene.steps_per_cycle)
    _, motion = run_cycles_sampled(scene, state, ws, 4, sampling)
    assert motion.window_steps == window and motion.n_windows == 4 * scene.steps_per_cycle // window
    amplitude = float(scene.amplitude_m[0])
    assert 2 * amplitude > 0.03 * scene.radius_m
    assert np.abs(motion.bottom_m - scene.radius_m).max() < 1e-3 * scene.radius_m
    assert np.all(motion.top_m > motion.centre_m) and np.all(motion.centre_m > motion.bottom_m)
    weight = motion.weight_n[0]
    assert 0.8 < motion.floor_force_n.mean() / weight < 1.2
    assert np.abs(motion.lid_force_n).max() == 0.0
    # the wall's position at the window centres is the base motion W (cos(omega t) - 1)
    t = (np.arange(motion.n_windows) + 0.5) * window * scene.timestep_s
    np.testing.assert_allclose(motion.wall_z_m, amplitude * (np.cos(scene.omega_rad_s * t) - 1.0),
                               rtol=0, atol=1e-12 * amplitude)


def test_a_window_that_samples_no_whole_number_of_forces_is_refused(settled_11):
    from pidpipe.dem.compiled import run_cycles as kernel_cycles

    scene = spec_scene(freq_hz=500.0, accel_g=[5.0])
    scene, state, ws = start(scene, settled_11)
    with pytest.raises(ValueError, match="do not divide"):
        kernel_cycles(scene, state, ws, 1, np.zeros(1), 110, 7)
