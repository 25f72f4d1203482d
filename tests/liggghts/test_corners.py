"""Stability at the corners of the grid, in LIGGGHTS.

Every corner (50 / 1000 Hz x 1 / 10 g x 25 / 90 % fill) is shaken at the default timestep and
at half of it, with the default transient (at least 5 cycles and 0.03 s) and a short measured
window (12 cycles), so these are checks of soundness, not numbers to report. At each corner:
no sphere leaves the cell, LIGGGHTS' own timestep check passes, the balance never shows
dissipation below zero beyond its uncertainty, the transient is detected on the series, and
C_eq agrees between the two timesteps — or the case is flagged, and then the C_eq table keeps
it out of the fit. 16 runs, about a minute on 2 cores.
"""

from __future__ import annotations

import copy
import itertools
import math
from concurrent.futures import ThreadPoolExecutor

import pytest

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.design.ceq_table import split_usable
from pidpipe.design.records import records_to_table
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.shake import run_case
from pidpipe.measurement.steady_state import NEGATIVE_SEMS
from tests.conftest import short_config

pytestmark = pytest.mark.engine

CORNERS = list(itertools.product((50.0, 1000.0), (1.0, 10.0), (25.0, 90.0)))
MEASURED_CYCLES = 12
AGREEMENT_SEMS = 3.0
"""C_eq at dt and dt/2 must agree within this many combined standard errors."""


def corner_config(timestep_fraction: float) -> dict:
    """The default physics and transient, a short measured window, the given dt / t_R."""
    config = short_config(measured=MEASURED_CYCLES)
    defaults = load_config()["fidelity"]
    config["fidelity"]["transient_cycles"] = defaults["transient_cycles"]
    config["fidelity"]["transient_min_time_s"] = defaults["transient_min_time_s"]
    config["fidelity"]["timestep_rayleigh_fraction"] = timestep_fraction
    return config


@pytest.fixture(scope="module")
def corner_records(tmp_path_factory):
    """Records of every corner at dt and dt/2: {(f, G, r): (record at dt, record at dt/2)}."""
    return shake_corners(tmp_path_factory, run_case)


def shake_corners(tmp_path_factory, run) -> dict:
    """Every corner at dt and dt/2 shaken by ``run`` (an engine's case function) on LIGGGHTS'
    pour: {(f, G, r): (record at dt, record at dt/2)}."""
    base = corner_config(load_config()["fidelity"]["timestep_rayleigh_fraction"])
    halved = copy.deepcopy(base)
    halved["fidelity"]["timestep_rayleigh_fraction"] /= 2.0
    packings = {fill: pour(PourSettings.from_config(base), fill, 0, tmp_path_factory.mktemp(f"pour{fill:g}"))
                for fill in (25.0, 90.0)}
    jobs = [(corner, config, label) for corner in CORNERS
            for config, label in ((base, "dt"), (halved, "half_dt"))]

    def shake(job):
        (freq, accel, fill), config, label = job
        case = CaseSpec(freq, accel, fill)
        workdir = tmp_path_factory.mktemp(f"{case.case_id}_{label}")
        return run(ShakeSettings.from_config(config), case, packings[fill], workdir)

    with ThreadPoolExecutor(max_workers=2) as pool:  # LIGGGHTS runs in subprocesses, the
        # compiled DEM releases no GIL: its jobs just run one after the other
        records = list(pool.map(shake, jobs))
    return {corner: (records[2 * i], records[2 * i + 1]) for i, corner in enumerate(CORNERS)}


def corner_id(corner) -> str:
    return "f{:g}Hz_G{:g}_r{:g}pct".format(*corner)


@pytest.mark.parametrize("corner", CORNERS, ids=corner_id)
def test_no_sphere_leaves_the_cell(corner_records, corner):
    for record in corner_records[corner]:
        assert not {"sphere_below_floor", "sphere_above_lid"} & set(record.flags)
        assert record.status in ("ok", "flagged")


@pytest.mark.parametrize("corner", CORNERS, ids=corner_id)
def test_timestep_check_passes(corner_records, corner):
    for record, fraction in zip(corner_records[corner], (0.2, 0.1)):
        assert "timestep_check" not in record.flags
        assert record.fidelity["rayleigh_fraction"] <= fraction * (1 + 1e-9)


@pytest.mark.parametrize("corner", CORNERS, ids=corner_id)
def test_dissipation_is_not_negative_beyond_its_uncertainty(corner_records, corner):
    for record in corner_records[corner]:
        assert "negative_dissipation" not in record.flags
        mean, sem = record.ed_cycle_mean_j, record.ed_cycle_sem_j
        assert mean + NEGATIVE_SEMS * sem >= 0.0


@pytest.mark.parametrize("corner", CORNERS, ids=corner_id)
def test_the_transient_is_detected_on_the_series(corner_records, corner):
    for record in corner_records[corner]:
        fidelity = record.fidelity
        assert fidelity["transient_cycles"] == max(fidelity["transient_cycles_configured"],
                                                   record.detected_transient_cycles)
        assert record.n_cycles + fidelity["transient_cycles"] == len(record.cycles["dissipated_j"])
        assert math.isfinite(record.halves_p_value)


@pytest.mark.parametrize("corner", CORNERS, ids=corner_id)
def test_ceq_converges_when_the_timestep_is_halved_or_the_case_is_flagged(corner_records, corner):
    record, halved = corner_records[corner]
    if record.status == "ok" and halved.status == "ok":
        difference = abs(record.ceq_cell_ns_m - halved.ceq_cell_ns_m)
        combined = math.hypot(record.ceq_cell_sem_ns_m, halved.ceq_cell_sem_ns_m)
        assert difference <= AGREEMENT_SEMS * combined
    else:
        for flagged in (r for r in (record, halved) if r.status != "ok"):
            table = records_to_table([flagged])
            fitted, left_out = split_usable(table)
            assert fitted.empty and len(left_out) == 1
            assert table["status"].iloc[0] == "flagged" and table["flags"].iloc[0]


def test_the_impacting_corners_are_sound_without_flags(corner_records):
    # The corners where spheres fly (10 g) must not pass the checks merely by being flagged.
    impacting = [corner for corner in CORNERS if corner[1] > 1.0]
    flagged = [(corner_id(c), r.flags) for c in impacting for r in corner_records[c]
               if r.status != "ok"]
    assert not flagged
