"""A case with a target SEM, through the case step with the real LIGGGHTS: it reaches the target
by the runs it plans (new packings poured on demand into the pool), and its record lists them."""

from __future__ import annotations

import json

import pytest

from pidpipe.cases import CaseSpec
from pidpipe.config.settings import PourSettings
from pidpipe.config.stages import stage_config
from pidpipe.measurement.adaptive import TARGET_NOT_REACHED
from pidpipe.steps.cases import extra_packing_index, pool_packings, simulate_case
from tests.conftest import short_config

pytestmark = [pytest.mark.engine, pytest.mark.slow]

CASE = CaseSpec(1000.0, 10.0, 25.0)   # 5 spheres: cheap pours and runs
TARGET = 0.03


@pytest.fixture(scope="module")
def targeted(tmp_path_factory):
    folder = tmp_path_factory.mktemp("target")
    config = stage_config(short_config(transient=10, measured=10), "case")
    config["fidelity"].update(cells_per_run=2, target_relative_sem=TARGET, max_cells_per_case=8,
                              max_measured_cycles=80, max_case_cpu_s=120.0)
    pool = folder / "pool"
    pilot = pool_packings(PourSettings.from_config(config), CASE.fill_pct, [0, 1], folder / "pilot")
    paths = sorted(str(p) for p in (folder / "pilot").glob("*.json"))
    assert [p.seed for p in pilot] == [config["fidelity"]["seed"], config["fidelity"]["seed"] + 1]
    record = simulate_case(config, CASE.case_id, paths, str(folder / "record.json"),
                           str(folder / "work"), str(folder / "log"), packing_pool=str(pool))
    return config, record, json.loads((folder / "record.json").read_text()), pool


def test_the_case_reaches_its_target(targeted):
    _, record, written, _ = targeted
    assert record.target["reached"], record.target
    assert written["ceq_cell_sem_ns_m"] <= TARGET * written["ceq_cell_ns_m"]
    assert TARGET_NOT_REACHED not in written["flags"]
    assert len(written["target"]["runs"]) >= 2          # the pilot did not reach 3 % by itself


def test_its_record_lists_every_run_that_made_it(targeted):
    config, _, written, pool = targeted
    runs = written["target"]["runs"]
    assert runs[0]["kind"] == "pilot" and runs[0]["cells"] == 2
    used = [run for run in runs if run["used"]]
    seeds = [seed for run in used for seed in run["seeds"]]
    # the used runs hold exactly the cells of the estimate, each packing once
    assert seeds == written["fidelity"]["seeds"] == [cell["seed"] for cell in written["cells"]]
    assert len(set(seeds)) == len(seeds) == written["target"]["cells"]
    assert all(run["measured_cycles"] == written["target"]["measured_cycles"] for run in used)
    assert written["target"]["cpu_time_s"] == pytest.approx(sum(run["cpu_time_s"] for run in runs))
    assert all(run["cpu_time_s"] > 0 for run in runs)
    # cells beyond the pilot's are the replicate's pool packings, poured once and kept
    seed = config["fidelity"]["seed"]
    extra = [s - seed for s in seeds[2:]]
    assert extra == [extra_packing_index(0, j) for j in range(2, 2 + len(extra))]
    assert sorted(p.name for p in pool.glob("*.json")) == sorted(
        f"r25pct_rep{index}.json" for index in extra)
