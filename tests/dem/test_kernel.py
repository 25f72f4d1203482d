"""The compiled kernel against the NumPy reference, step by step, and its refusals.

Both integrate the same scene from the same packing, and the reference computes each quantity
in the kernel's order of operations (a wall's distance n . x summed from the left, not by a
matrix product, which rounded differently by an ulp of x: at rest a wall overlap is ~4e-8 m,
so that was already 4e-11 of the force, and the 10 g impacts amplified it to 1e-11 of the
exchanged work over a cycle). They differ only in the order of the force and energy sums over
contacts (the reference's pairwise sums over dense rows, the kernel's contact by contact).
Measured over the 1000 steps below (worst case of the scenes): positions the same to the last
bit, energies (K, K_rot, P, U and the ledger total) to 1.2e-16 of the ledger scale, the
accumulated wall work to 2.3e-13 of the work exchanged with the walls and the dissipation
terms to 7e-16 of it, forces and torques to 5e-15 of the bed's weight; the bounds below keep a
margin of 40 or more over these.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from pidpipe.dem import KernelError, reference, run_cycles, start
from pidpipe.dem import advance as kernel_advance
from pidpipe.dem.compiled import _call, accumulated_dissipation
from pidpipe.dem.contacts import accumulated_dissipation as reference_dissipation
from pidpipe.dem.energy import ledger_energy
from pidpipe.dem.reference import advance as reference_advance
from tests.dem.conftest import spec_scene

STEPS = 1000
SCENES = {
    "500Hz_5g_and_2g": dict(freq_hz=500.0, accel_g=[5.0, 2.0]),
    "100Hz_1g_resting": dict(freq_hz=100.0, accel_g=[1.0]),
    "1000Hz_10g_impacts": dict(freq_hz=1000.0, accel_g=[10.0]),
    "no_friction_no_rotation": dict(freq_hz=500.0, accel_g=[5.0], friction=False,
                                    rotation=False),
}
ENERGY_KEYS = ("kinetic_translational", "kinetic_rotational", "potential", "elastic", "ledger")


@pytest.mark.parametrize("name", SCENES)
def test_kernel_follows_the_reference_step_by_step(settled_11, name):
    scene = spec_scene(**SCENES[name])
    scene, ref_state, ref_ws = reference.start(scene, settled_11)
    _, state, ws = start(scene, settled_11)
    bed_weight = settled_11.shape[0] * scene.mass_kg * scene.gravity_m_s2
    worst = dict.fromkeys(("x", "force", "torque", "energy", "work", "terms"), 0.0)
    energy_scale = work_scale = 0.0
    for _ in range(STEPS):
        reference_advance(scene, ref_state, ref_ws, 1)
        kernel_advance(scene, state, ws, 1)
        worst["x"] = max(worst["x"], np.abs(state.x - ref_state.x).max() / scene.radius_m)
        worst["force"] = max(worst["force"],
                             np.abs(state.force - ref_state.force).max() / bed_weight)
        worst["torque"] = max(worst["torque"], np.abs(state.torque - ref_state.torque).max()
                              / (bed_weight * scene.radius_m))
        mine, theirs = ledger_energy(scene, state, ws), ledger_energy(scene, ref_state, ref_ws)
        energy_scale = max(energy_scale, np.abs(theirs["ledger"]).max())
        worst["energy"] = max(worst["energy"], max(np.abs(mine[k] - theirs[k]).max()
                                                   for k in ENERGY_KEYS))
        work_scale = max(work_scale, ref_ws.gross_wall_work_acc.max())
        worst["work"] = max(worst["work"],
                            np.abs(ws.wall_work_acc - ref_ws.wall_work_acc).max())
        worst["terms"] = max(worst["terms"], np.abs(
            accumulated_dissipation(ws, scene.timestep_s)
            - reference_dissipation(ref_ws, scene.timestep_s)).max())
        assert np.array_equal(ws.contact, ref_ws.contact)
        assert np.array_equal(ws.slide, ref_ws.slide)
    worst["energy"] /= energy_scale
    worst["work"] /= work_scale
    worst["terms"] /= work_scale
    assert worst["x"] < 1e-12, worst
    assert worst["energy"] < 1e-12, worst
    assert worst["terms"] < 1e-12 and worst["work"] < 1e-11, worst
    assert worst["force"] < 1e-12 and worst["torque"] < 1e-12, worst
    # the history the kernel keeps for i < j reads as the reference's dense arrays
    np.testing.assert_allclose(state.shear, ref_state.shear, rtol=0,
                               atol=1e-6 * max(np.abs(ref_state.shear).max(), 1e-30))
    np.testing.assert_allclose(state.tangential_energy, ref_state.tangential_energy, rtol=0,
                               atol=1e-6 * max(ref_state.tangential_energy.max(), 1e-30))


def test_cycle_ledgers_of_one_call_equal_the_references(settled_11):
    """run_cycles: a whole cycle (1112 steps at 1000 Hz) in one kernel call. Every energy and
    ledger agrees to 1e-11 of the work exchanged with the walls in the cycle (measured: 3.4e-14
    at 10 g, 1.8e-16 at 5 g; 1.3e-11 and 2.5e-13 while the reference took a wall's distance by a
    matrix product, which rounds differently, see the module docstring). The two codes sum the
    same terms in different orders, and the impacts at 10 g amplify those roundings over the
    cycle."""
    scene = spec_scene(freq_hz=1000.0, accel_g=[10.0, 5.0])
    scene, ref_state, ref_ws = reference.start(scene, settled_11)
    mine = run_cycles(*start(scene, settled_11), 1)
    theirs = reference.run_cycles(scene, ref_state, ref_ws, 1)
    assert mine.keys() == theirs.keys()
    exchanged = theirs["gross_work_j"].max()
    for key, expected in theirs.items():
        assert mine[key].shape == expected.shape, key
        if key.endswith("_z_m"):
            np.testing.assert_allclose(mine[key], expected, rtol=1e-13, err_msg=key)
        else:
            np.testing.assert_allclose(mine[key], expected, rtol=0, atol=1e-11 * exchanged,
                                       err_msg=key)
    assert np.all(theirs["dissipated_terms_j"] > 0)


def test_a_missing_numba_is_one_error_naming_the_fix(tmp_path):
    blocker = tmp_path / "sitecustomize.py"
    blocker.write_text("import sys\nsys.modules['numba'] = None\n")
    env = dict(os.environ, PYTHONPATH=f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}")
    code = textwrap.dedent("""
        try:
            import pidpipe.dem
        except ImportError as error:
            print(error)
        else:
            print("imported")
    """)
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          check=True)
    assert "pip install numba" in done.stdout and "install.sh" in done.stdout, done.stdout


def test_a_kernel_that_fails_to_compile_is_one_error_naming_the_fix():
    from numba import njit

    @njit
    def broken(values):
        return values.no_such_attribute

    with pytest.raises(KernelError, match="failed to compile.*install.sh"):
        _call(broken, np.zeros(3))
