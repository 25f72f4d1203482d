"""Model (c) of the host check: the host carrying the damper's effective mass and dashpot
(pidpipe.loop.equivalent.solve_mass_point, pidpipe.loop.host), on fake surrogates."""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pandas as pd
import pytest

from pidpipe.config import load_config
from pidpipe.config.settings import HostSettings
from pidpipe.design.damper import Damper
from pidpipe.loop.compare import find_peak
from pidpipe.loop.equivalent import damper_model, solve_mass_point
from pidpipe.loop.host import (
    MODELS,
    HostLoad,
    mass_curve,
    mass_draws,
    model_curves,
    summary_table,
)
from pidpipe.loop.sdof import complex_amplitude
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2
from tests._surrogates import FakeSurrogate, MeanOnlySurrogate, constant, lifting_bed

LOAD = HostLoad(n_cells=20, spheres_per_cell=11, fill_pct=50.0, sphere_mass_kg=9.65e-6,
                coupon_n_cells=441)
BED_KG = LOAD.spheres_per_cell * LOAD.sphere_mass_kg          # one cell's spheres
#: the coupon C_eq whose n_c / N share is 0.5 N s/m (the host's own c_h is 0.77 N s/m)
CEQ_COUPON = 0.5 * LOAD.coupon_n_cells / LOAD.n_cells


def _settings(force_n, draws=0, points=41) -> HostSettings:
    return dataclasses.replace(HostSettings.from_config(load_config()), force_n=tuple(force_n),
                               freq_points=points, surrogate_draws=draws)


def _peak(rows: list[dict]):
    return find_peak(np.array([r["freq_hz"] for r in rows]), np.array([r["amplitude_m"] for r in rows]),
                     np.array([r["loss_factor"] for r in rows]))


def test_a_solution_carries_the_mass_and_dashpot_of_its_own_acceleration():
    """M(Gamma) and C(Gamma) both vary: the solution's |X| is the linear host's with the M and C
    read at its own Gamma."""
    settings = _settings([0.01])
    model = lambda f, g: (2e-3 / (1 + np.asarray(g) ** 2), 0.3 + 0.05 * np.asarray(g))  # noqa: E731
    for freq in (250.0, 268.0, 290.0):
        point = solve_mass_point(freq, 0.01, settings.mass_kg, settings.stiffness_n_m,
                                 settings.damping_ns_m, model)
        omega = 2 * np.pi * freq
        mass, damping = model(freq, point.accel_g)
        assert point.added_mass_kg == pytest.approx(mass, rel=1e-9)
        assert point.ceq_ns_m == pytest.approx(damping, rel=1e-9)
        linear = complex_amplitude(0.01, settings.mass_kg + mass, settings.stiffness_n_m,
                                   settings.damping_ns_m + damping, omega)
        assert abs(point.amplitude / linear - 1) < 1e-9
        assert point.accel_g == pytest.approx(abs(linear) * omega**2 / STANDARD_GRAVITY_M_S2,
                                              rel=1e-9)


def test_an_undamped_host_with_a_vanishing_dashpot_has_no_bound():
    with pytest.raises(ValueError, match="no bound"):
        solve_mass_point(275.0, 0.01, 0.02, 6e4, 0.0, lambda f, g: (0 * np.asarray(g),
                                                                     0 * np.asarray(g)))


@pytest.mark.parametrize("bed_kg, reference", [(BED_KG, "equivalent"),
                                               (0.0, "equivalent_bare_mass")])
def test_a_constant_effective_mass_is_the_dashpot_model_with_that_mass(bed_kg, reference):
    """m_eff = the bed's mass everywhere is (b), m_h + m_p; m_eff = 0 is (b'), m_h alone."""
    settings = _settings([0.003, 0.05], points=9)
    ceq = FakeSurrogate(lambda f, g, r: CEQ_COUPON * np.minimum(g, 3.0) / 3.0)
    curves, note = model_curves(settings, LOAD, ceq, [], FakeSurrogate(constant(bed_kg)))
    assert note["included"]
    for force in settings.force_n:
        mine, theirs = curves["equivalent_mass", force][0], curves[reference, force][0]
        for a, b in zip(mine, theirs):
            assert abs(a["amplitude"] / b["amplitude"] - 1) < 1e-9
            assert a["loss_factor"] == pytest.approx(b["loss_factor"], rel=1e-9)
            assert a["m_eff_kg"] == pytest.approx(b["m_eff_kg"], rel=1e-12, abs=1e-15)


def test_the_peak_moves_from_the_full_mass_to_the_bare_host_as_the_bed_lifts_off():
    """m_eff the bed's mass below 1 g, falling to 0 above: at forces whose resonance stays below
    1 g model (c) peaks where (b) does, at forces that throw the bed well above 1 g where (b')
    does, and in between its peak moves monotonically from one to the other."""
    forces = np.logspace(-3, -0.7, 11)
    settings = _settings(forces)
    ceq = FakeSurrogate(constant(CEQ_COUPON))
    curves, _ = model_curves(settings, LOAD, ceq, [], FakeSurrogate(lifting_bed(BED_KG, 2.0)))
    full = _peak(curves["equivalent", forces[0]][0]).freq_hz
    bare = _peak(curves["equivalent_bare_mass", forces[0]][0]).freq_hz
    assert bare - full > 10.0                        # the bed's 10 % of the mass: ~12 Hz apart
    peaks = np.array([_peak(curves["equivalent_mass", f][0]).freq_hz for f in forces])
    assert abs(peaks[0] - full) < 0.01 * (bare - full)
    assert abs(peaks[-1] - bare) < 0.01 * (bare - full)
    assert np.all(np.diff(peaks) >= -1e-6)
    middle = peaks[(peaks > full + 0.1 * (bare - full)) & (peaks < bare - 0.1 * (bare - full))]
    assert middle.size >= 2                          # it passes through, not jumps over


def test_a_sharp_lift_off_jumps_to_the_airborne_branch():
    """A nearly step-like m_eff gives several consistent amplitudes near the peak; the largest
    (airborne, bare-host) one is taken and the count reported."""
    settings = _settings([0.02])
    curves, _ = model_curves(settings, LOAD, FakeSurrogate(constant(CEQ_COUPON)), [],
                             FakeSurrogate(lifting_bed(BED_KG, 8.0)))
    rows = curves["equivalent_mass", 0.02][0]
    assert max(r["n_solutions"] for r in rows) >= 3
    bare = _peak(curves["equivalent_bare_mass", 0.02][0]).freq_hz
    assert abs(_peak(rows).freq_hz - bare) < 0.05


def test_the_peak_uncertainty_follows_the_effective_mass_uncertainty():
    """m_eff = the bed's mass with a 20 % standard uncertainty: the peak frequency's spread over
    the draws is f_peak / 2 x n_c sd(m_eff) / (m_h + m_p) (first order), and C_eq's 10 % spreads
    the peak amplitude."""
    settings = _settings([0.002], draws=100, points=21)
    ceq = FakeSurrogate(constant(CEQ_COUPON), constant(0.1 * CEQ_COUPON))
    m_eff = FakeSurrogate(constant(BED_KG), constant(0.2 * BED_KG))
    curves, note = model_curves(settings, LOAD, ceq, [], m_eff)
    assert note["draws"] == 100
    frame = _curves_frame(settings, curves)
    summary = summary_table(settings, frame, curves).set_index("model")
    row = summary.loc["equivalent_mass"]
    moving = settings.mass_kg + LOAD.particle_mass_kg
    expected = 0.5 * row.peak_freq_hz * LOAD.n_cells * 0.2 * BED_KG / moving
    assert row.peak_freq_hz_sd == pytest.approx(expected, rel=0.2)
    # at resonance |X| ~ F / (Omega (c_h + C)): C's 10 % of 0.5 N s/m over c_h + C
    expected_amp = row.peak_amplitude_m * 0.05 / (settings.damping_ns_m + 0.5)
    assert row.peak_amplitude_m_sd == pytest.approx(expected_amp, rel=0.3)
    mine = frame[frame.model == "equivalent_mass"]
    assert np.all(mine.m_eff_unc_kg > 0.5 * 0.2 * LOAD.particle_mass_kg)


def _curves_frame(settings: HostSettings, curves: dict) -> pd.DataFrame:
    """A curves table of the surrogate models only (no coupled run)."""
    from pidpipe.loop.host import curves_table

    return curves_table(settings, LOAD, [], curves)


def test_the_summary_compares_model_c_with_the_coupled_host():
    """Model (c) gets a summary row per level after (b) and (b'), with its peak shift in units of
    the combined standard deviation."""
    settings = _settings([0.002, 0.2], draws=20, points=21)
    ceq = FakeSurrogate(constant(CEQ_COUPON), constant(0.05 * CEQ_COUPON))
    m_eff = FakeSurrogate(lifting_bed(BED_KG, 2.0), constant(0.1 * BED_KG))
    curves, _ = model_curves(settings, LOAD, ceq, [], m_eff)
    frame = _curves_frame(settings, curves)
    # a stand-in for the coupled host: model (c)'s curve itself, with 1 % standard errors
    coupled = frame[frame.model == "equivalent_mass"].copy()
    coupled["model"] = "coupled"
    coupled["amplitude_unc_m"] = 0.01 * coupled["amplitude_m"]
    coupled["loss_factor_unc"] = 0.0
    frame = pd.concat([coupled, frame], ignore_index=True)
    summary = summary_table(settings, frame, curves)
    assert list(summary.model) == list(MODELS) * 2
    mass = summary[summary.model == "equivalent_mass"]
    assert np.all(mass.peak_shift_hz.abs() < 1e-9) and np.all(mass.holds)
    assert np.all(mass.peak_shift_sigmas < 1e-6)
    full = summary[summary.model == "equivalent"]
    # at 0.2 N the bed is airborne: (b) misses the coupled stand-in's peak by many sigmas
    assert full.peak_shift_sigmas.iloc[1] > 3


def test_model_c_is_left_out_without_an_m_eff_surrogate(caplog):
    settings = _settings([0.01], points=5)
    with caplog.at_level(logging.WARNING, logger="pidpipe.loop"):
        curves, note = model_curves(settings, LOAD, FakeSurrogate(constant(CEQ_COUPON)), [], None)
    assert not note["included"] and "m_eff" in note["reason"]
    assert not any(model == "equivalent_mass" for model, _ in curves)
    assert "model (c)" in caplog.text
    frame = _curves_frame(settings, curves)
    assert "equivalent_mass" not in set(frame.model)


def test_the_draws_use_the_refitted_c_eq_surrogates_when_it_has_no_uncertainty(caplog):
    mean = MeanOnlySurrogate(constant(CEQ_COUPON))
    refits = [MeanOnlySurrogate(constant(CEQ_COUPON * k)) for k in (0.5, 1.5)]
    damper = Damper(mean, FakeSurrogate(constant(BED_KG), constant(0.1 * BED_KG)), 441)
    with caplog.at_level(logging.WARNING, logger="pidpipe.loop"):
        draws = mass_draws(damper, refits, 4, seed=3)
    assert "refitted" in caplog.text
    assert [d.ceq_surrogate for d, _, _ in draws] == refits * 2
    assert all(z_c == 0.0 and z_m != 0.0 for _, z_m, z_c in draws)
    # neither surrogate with an uncertainty, no refits: no draws at all
    assert mass_draws(Damper(mean, MeanOnlySurrogate(constant(BED_KG)), 441), [], 4, 3) == []


def test_the_damper_model_reads_the_domain_edge_and_flags_it():
    ceq = FakeSurrogate(lambda f, g, r: CEQ_COUPON * g)
    m_eff = FakeSurrogate(constant(BED_KG), domain={"freq_hz": (100.0, 500.0),
                                                    "accel_g": (0.5, 20.0),
                                                    "fill_pct": (25.0, 90.0)})
    model, clipped = damper_model(Damper(ceq, m_eff, 441), 50.0, 21)
    mass, damping = model(600.0, np.array([0.1, 5.0, 40.0]))
    assert damping == pytest.approx(21 / 441 * CEQ_COUPON * np.array([0.5, 5.0, 20.0]))
    assert mass == pytest.approx(21 * BED_KG * np.ones(3))
    f, g, r = ceq.queries[-1]
    assert np.all(f == 500.0) and np.all(r == 50.0)
    assert clipped(600.0, 5.0) and clipped(300.0, 0.2) and not clipped(300.0, 5.0)


def test_a_redrawn_dashpot_is_never_negative():
    ceq = FakeSurrogate(constant(1.0), constant(2.0))
    model, _ = damper_model(Damper(ceq, FakeSurrogate(constant(BED_KG)), 441), 50.0, 441,
                            mass_shift=0.0, damping_shift=-3.0)
    assert np.all(model(275.0, np.array([1.0, 2.0]))[1] == 0.0)


def test_mass_curve_shifts_move_the_curve():
    settings = _settings([0.002], points=11)
    damper = Damper(FakeSurrogate(constant(CEQ_COUPON)),
                    FakeSurrogate(constant(BED_KG), constant(0.5 * BED_KG)), 441)
    central = _peak(mass_curve(settings, LOAD, damper, 0.002)).freq_hz
    heavier = _peak(mass_curve(settings, LOAD, damper, 0.002, mass_shift=1.0)).freq_hz
    assert heavier < central - 1.0
