"""A layout at a modal force, solved to consistency; the response swept by continuation over a
fold (a hysteresis loop); intervals from a model's own std."""

import math

import numpy as np
import pytest

from pidpipe.loop.equivalent import solve_point
from pidpipe.panel.branches import SWEEPS, consistent_amplitudes, reached_amplitude, sweep_order
from pidpipe.panel.layout import antinode_layout
from pidpipe.panel.response import forced_response, response_curve
from pidpipe.panel.uncertainty import UncertainCeq, interval
from pidpipe.physics.contact import STANDARD_GRAVITY_M_S2
from tests.panel.test_layout import DOMAIN, mode_loss


def test_a_constant_ceq_gives_the_closed_form_resonant_amplitude():
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 200, 50.0)
    c = 30.0                                    # coupon C_eq, N s/m, at every G

    def model(f, g, r):
        return np.full(np.broadcast(f, g, r).shape, c)

    force, zeta = 0.2, 0.01
    response = forced_response(loss, model, layout, force, zeta)
    mode = loss.mode
    k = mode.omega**2 * mode.modal_mass_kg
    c_s = 2 * zeta * math.sqrt(k * mode.modal_mass_kg)
    a2 = np.sum(loss.phi[layout.cells] ** 2)
    c_p = c / 441 * a2                          # every cell is above the 1 g floor here
    omega = 2 * math.pi * loss.frequency_hz(layout)
    expected_g = force / (omega * (c_s + c_p)) * omega**2 / STANDARD_GRAVITY_M_S2
    assert response.accel_g > 1.0 / np.abs(loss.phi[layout.cells]).min()
    assert response.accel_g == pytest.approx(expected_g, rel=1e-6)
    assert response.eta_particles == pytest.approx(c_p / (omega * loss.modal_mass_kg(layout)), rel=1e-9)
    assert response.bare_accel_g > response.accel_g


def test_added_damping_that_grows_with_g_lowers_the_response_below_the_bare_plate():
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 400, 50.0)

    def model(f, g, r):
        return 5.0 * np.asarray(g) * np.ones_like(np.asarray(f))

    low, high = (forced_response(loss, model, layout, f, 0.01) for f in (0.05, 0.5))
    assert low.accel_g < low.bare_accel_g and high.accel_g < high.bare_accel_g
    assert high.eta_particles > low.eta_particles            # more G, more C_eq per cell
    assert high.n_solutions == 1


def test_a_models_own_std_gives_an_interval_around_the_mean():
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 300, 50.0)

    def mean(f, g, r):
        return 2.0 * np.asarray(g) * np.ones_like(np.asarray(f))

    def with_std(f, g, r):
        m = mean(f, g, r)
        return m, 0.1 * m

    model = UncertainCeq(predict=mean, domain=DOMAIN, predict_with_uncertainty=with_std)
    assert model.kind == "predictive_std"
    value = lambda predict: float(loss.loss_factor(predict, layout, [5.0])[0])
    lo, hi = interval(model, value, 0.95)
    centre = value(mean)
    assert lo < centre < hi
    # eta is linear in C_eq: the ends are (1 -/+ 1.96 x 0.1) times the mean's
    assert lo == pytest.approx(centre * (1 - 0.196), rel=1e-3)
    assert hi == pytest.approx(centre * (1 + 0.196), rel=1e-3)


def falls_above_3g(f, g, r):
    """A coupon C_eq of 41 N s/m below 2 g falling to 1 N s/m above 5 g: the response folds."""
    g = np.asarray(g, dtype=float)
    return (40.0 / (1.0 + (g / 3.0) ** 6) + 1.0) * np.ones_like(np.asarray(f, dtype=float))


def fold_sweeps():
    """200 antinode cells at 50 % on the test plate's mode (1,1), zeta 0.005, 0.12 N: the
    particles' dashpot is 3 times the structure's below 2 g and a twentieth of it above 5 g."""
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 200, 50.0)
    freqs = loss.frequency_hz(layout) * np.linspace(0.985, 1.015, 61)
    return freqs, {sweep: response_curve(loss, falls_above_3g, layout, 0.12, 0.005, freqs,
                                         sweep=sweep) for sweep in SWEEPS}


def jumps(rows, order):
    """Indices i (in ``order``) where the sweep's G changes by more than half between the state
    visited before and the one at i."""
    g = np.array([rows[i]["accel_g"] for i in order])
    return [int(order[j]) for j in np.flatnonzero(np.abs(np.diff(np.log(g))) > np.log(1.5)) + 1]


def test_up_and_down_sweeps_over_a_fold_make_a_hysteresis_loop():
    freqs, curves = fold_sweeps()
    up, down, largest = (curves[s] for s in ("up", "down", "largest"))
    g = {s: np.array([row["accel_g"] for row in curves[s]]) for s in SWEEPS}
    count = np.array([row["n_solutions"] for row in up])
    assert set(count.tolist()) == {1, 3}
    assert all(row["n_stable"] == (2 if row["n_solutions"] == 3 else 1) for row in up)
    # where one amplitude is consistent every rule finds it; where three are, the sweeps differ
    single = count == 1
    assert np.allclose(g["up"][single], g["down"][single], rtol=1e-9)
    assert np.allclose(g["largest"][single], g["up"][single], rtol=1e-9)
    folded = np.flatnonzero(count == 3)
    assert folded.size >= 4 and np.all(np.abs(g["up"][folded] / g["down"][folded] - 1) > 0.5)
    # the largest root is the upper branch: it is the larger sweep's at every frequency
    assert np.allclose(g["largest"], np.maximum(g["up"], g["down"]), rtol=1e-9)
    # each sweep jumps twice: up onto the upper branch and down off it, each where the branch it
    # was on ends (three consistent amplitudes before the jump, one after)
    up_jumps = jumps(up, range(freqs.size))
    down_jumps = jumps(down, range(freqs.size - 1, -1, -1))
    assert len(up_jumps) == 2 and len(down_jumps) == 2
    for rows, (rise, fall), step in ((up, up_jumps, -1), (down, down_jumps, +1)):
        assert rows[rise]["accel_g"] > 2 * rows[rise + step]["accel_g"]
        assert rows[fall]["accel_g"] < 0.5 * rows[fall + step]["accel_g"]
        for i in (rise, fall):
            assert rows[i + step]["n_solutions"] == 3 and rows[i]["n_solutions"] == 1
    # the loop: the up sweep jumps up later and falls later than the down sweep
    assert freqs[up_jumps[0]] > freqs[down_jumps[1]] and freqs[up_jumps[1]] > freqs[down_jumps[0]]
    # below the resonance the up sweep stays on the lower branch where the down sweep is high
    assert g["up"][folded[0]] < g["down"][folded[0]] and g["up"][folded[-1]] > g["down"][folded[-1]]


def test_a_monotone_ceq_gives_one_branch_equal_to_the_largest_root():
    loss, _ = mode_loss()
    layout = antinode_layout(loss.phi, 400, 50.0)

    def model(f, g, r):
        return 5.0 * np.asarray(g) * np.ones_like(np.asarray(f))

    freqs = loss.frequency_hz(layout) * np.linspace(0.97, 1.03, 13)
    force, zeta = 0.5, 0.01
    curves = {s: response_curve(loss, model, layout, force, zeta, freqs, sweep=s) for s in SWEEPS}
    mode = loss.mode
    k = mode.omega**2 * mode.modal_mass_kg
    c_s = 2 * zeta * math.sqrt(k * mode.modal_mass_kg)
    for i, freq in enumerate(freqs):
        old = solve_point(freq, force, loss.modal_mass_kg(layout), k, c_s,
                          lambda f, g: loss.damping_ns_m(model, layout, g, freq_hz=freq).reshape(np.shape(g)))
        for sweep in SWEEPS:
            row = curves[sweep][i]
            assert row["n_solutions"] == 1 and row["sweep"] == sweep
            assert row["amplitude_m"] == pytest.approx(abs(old.amplitude), rel=1e-9)
            assert row["ceq_ns_m"] == pytest.approx(old.ceq_ns_m, rel=1e-9)


def residual_with_three_roots(x):
    """r(x) = (x - 1)(x - 2)(x - 3): negative near 0, roots 1 and 3 stable, 2 unstable."""
    x = np.asarray(x, dtype=float)
    return (x - 1.0) * (x - 2.0) * (x - 3.0)


@pytest.mark.parametrize("start, reached", [(0.0, 1.0), (0.5, 1.0), (1.5, 1.0), (1.0, 1.0),
                                            (2.5, 3.0), (3.5, 3.0), (None, 3.0)])
def test_a_state_relaxes_to_the_adjacent_stable_root(start, reached):
    amplitudes = consistent_amplitudes(residual_with_three_roots, np.linspace(1e-3, 4.0, 400))
    assert amplitudes.roots_m == pytest.approx([1.0, 2.0, 3.0], rel=1e-9)
    assert amplitudes.stable.tolist() == [True, False, True] and amplitudes.count == 3
    assert reached_amplitude(amplitudes, residual_with_three_roots, start) == pytest.approx(reached)


def test_an_unknown_sweep_is_refused_in_one_line():
    with pytest.raises(ValueError, match="sweep = 'sideways' is not one of up, down, largest"):
        sweep_order([1.0, 2.0], "sideways")
