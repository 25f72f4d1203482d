"""One case in the compiled DEM (engine: dem): the LIGGGHTS record's keys, the same packings,
k cells as one batch, the adaptive cycles, and C_eq against LIGGGHTS on the same case."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cli import format_result
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.dem.case import BALANCE_TOLERANCE, run_dem_case, start_dem_case
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.shake import run_case
from pidpipe.measurement.adaptive import run_to_target
from pidpipe.measurement.case_record import RECORD_VERSION, CaseRecord
from pidpipe.steps.cases import case_runner, failed_record
from tests.conftest import short_config

pytestmark = pytest.mark.engine         # the packings are LIGGGHTS' pour

CASE = CaseSpec(1000, 10, 25)


@pytest.fixture(scope="module")
def packings(tmp_path_factory):
    """Replicates 0 and 1 of the 25 % fill (5 spheres each)."""
    folder = tmp_path_factory.mktemp("pour25")
    return [pour(PourSettings.from_config(short_config()), 25, k, folder / f"rep{k}") for k in range(2)]


@pytest.fixture(scope="module")
def both(packings, tmp_path_factory):
    """The same case and packing in LIGGGHTS and in the DEM (short windows)."""
    config = short_config(transient=10, measured=20)
    liggghts = run_case(ShakeSettings.from_config(config), CASE, packings[0], tmp_path_factory.mktemp("liggghts"))
    return liggghts, run_dem_case(ShakeSettings.from_config(config), CASE, packings[0])


def _keys(record: dict, prefix: str = "") -> set[str]:
    """Key paths of a record, nested dicts included (lists not entered)."""
    out = set()
    for key, value in record.items():
        out.add(prefix + key)
        if isinstance(value, dict):
            out |= _keys(value, prefix + key + ".")
    return out


def test_a_dem_record_has_every_key_of_a_liggghts_record(both):
    liggghts, dem = both
    # not compared: LIGGGHTS' own loop/CPU figures
    missing = {key for key in _keys(liggghts.to_dict()) - _keys(dem.to_dict())
               if not key.startswith("engine.liggghts_")}
    assert not missing
    # the bed's motion within the cycle (issue 17), sampled by both engines alike
    assert _keys(dem.motion) == _keys(liggghts.motion)
    for key in ("window_steps", "phase_bins"):
        assert dem.motion[key] == liggghts.motion[key]
    for name, quantity in liggghts.motion["profile"].items():
        if isinstance(quantity, dict):
            assert len(dem.motion["profile"][name]["mean"]) == len(quantity["mean"]), name
    assert dem.motion["cell_features"][0].keys() == liggghts.motion["cell_features"][0].keys()
    assert dem.regime == dem.motion["cell_regimes"][0]
    assert liggghts.solver == "liggghts" and dem.solver == "numba-dem"
    assert dem.engine["name"] == dem.fidelity["engine"] == "dem"
    assert liggghts.engine["name"] == liggghts.fidelity["engine"] == "liggghts"
    assert dem.fidelity["seed"] == liggghts.fidelity["seed"]
    assert dem.fidelity["timestep_s"] == liggghts.fidelity["timestep_s"]
    assert len(dem.cycles["dissipated_j"]) == len(liggghts.cycles["dissipated_j"]) == 30
    json.loads(dem.to_json())
    assert "numba-dem" in format_result(dem)


def test_both_engines_return_a_case_record_that_reads_back_from_its_json(both, tmp_path):
    for record, name in zip(both, ("liggghts", "dem")):
        assert isinstance(record, CaseRecord) and record.record_version == RECORD_VERSION
        path = record.write(tmp_path / f"{name}.json")
        back = CaseRecord.read(path)
        assert back.to_json() == path.read_text() == record.to_json()
        assert back.engine_name == back.fidelity.engine == name
        assert back.fidelity.seeds == [back.fidelity.seed] and back.engine_cpu_s > 0


def test_both_engines_give_the_same_ceq_within_their_errors(both):
    liggghts, dem = both
    combined = math.hypot(liggghts.ceq_cell_sem_ns_m, dem.ceq_cell_sem_ns_m)
    assert abs(dem.ceq_cell_ns_m - liggghts.ceq_cell_ns_m) < 3.0 * combined
    assert dem.status == "ok", dem.flags
    assert dem.ledger_mismatch_of_gross_work < BALANCE_TOLERANCE


def test_k_cells_are_one_batch_whose_first_cell_is_the_packing_alone(packings, both):
    """The DEM's cells are independent by construction: in a batch of two, the first cell's
    series is the single-cell run's to rounding, and the case reports the mean cell."""
    _, alone = both
    config = short_config(transient=10, measured=20)
    together = run_dem_case(ShakeSettings.from_config(config), CASE, packings)
    assert together.fidelity["cells_per_run"] == 2 and len(together.cells) == 2
    assert together.fidelity["seeds"] == [p.seed for p in packings]
    first = np.array(together.cells[0]["dissipated_j"])
    np.testing.assert_allclose(first, alone.cycles["dissipated_j"], rtol=1e-9)
    mean_cell = np.mean([c["ceq_cell_ns_m"] for c in together.cells])
    assert together.ceq_cell_ns_m == pytest.approx(mean_cell, rel=1e-9)
    assert together.ceq_cell_sem_ns_m >= together.ceq_cell_cycle_sem_ns_m


def test_a_dem_case_reaches_its_target_by_continuing_its_run_and_lists_every_part(packings, tmp_path):
    """The case step (engine: dem) continues the pilot's run for more cycles, and the record
    lists the pilot and each continuation, all used; the case is the one longer run from the
    pour (its series to the last bit), at the CPU of the cycles added."""
    from pidpipe.steps.cases import measure_case

    config = short_config(transient=10, measured=8)
    config["engine"] = "dem"
    config["fidelity"].update(target_relative_sem=0.05, max_measured_cycles=200)
    settings = ShakeSettings.from_config(config)
    record = measure_case(settings, CASE, [packings[0]], tmp_path)
    target = record.target
    runs = target["runs"]
    assert runs[0]["kind"] == "pilot" and runs[0]["measured_cycles"] == 8
    # one packing and no pool to pour more from: only cycles can be added, by continuing
    assert len(runs) >= 2 and all(run["kind"] == "more_cycles" and run["continued"] for run in runs[1:])
    assert all(run["run"] == 0 and run["used"] for run in runs)
    for before, run in zip(runs, runs[1:]):
        assert run["from_measured_cycles"] == before["measured_cycles"] < run["measured_cycles"]
    assert record.fidelity["measured_cycles"] == target["measured_cycles"] == runs[-1]["measured_cycles"]
    assert target["reached"] or "target_not_reached" in record.flags
    assert target["cpu_time_s"] == pytest.approx(sum(run["cpu_time_s"] for run in runs))
    assert target["cpu_time_s"] > 0
    longer = run_dem_case(ShakeSettings.from_config(short_config(
        transient=10, measured=target["measured_cycles"])), CASE, packings[0])
    assert record.cycles == longer.cycles and list(record.flags) == list(longer.flags) + (
        [] if target["reached"] else ["target_not_reached"])
    assert record.ceq_cell_ns_m == longer.ceq_cell_ns_m
    assert record.ceq_cell_sem_ns_m == longer.ceq_cell_sem_ns_m


def _untimed(record) -> str:
    """A record as JSON without what only timing sets (engine, wall time)."""
    return json.dumps({key: value for key, value in record.to_dict().items()
                       if key not in ("engine", "wall_time_s")}, sort_keys=True)


def test_a_continued_dem_case_is_the_longer_run_from_the_pour_to_the_last_bit(packings):
    """Two cells shaken for 10 + 8 cycles and continued to 10 + 20 give the record of one run
    of 10 + 20 cycles: every series, summary, steady-state verdict and motion profile equal to
    the last bit; only the timing differs, the continuation's own."""
    config = short_config(transient=10, measured=8)
    run = start_dem_case(ShakeSettings.from_config(config), CASE, packings)
    assert run.record.fidelity["measured_cycles"] == 8
    continued = run.extend(20)
    longer = run_dem_case(ShakeSettings.from_config(short_config(transient=10, measured=20)),
                          CASE, packings)
    assert len(continued.cycles["dissipated_j"]) == 30
    assert _untimed(continued) == _untimed(longer)
    assert continued.engine["continued_from_cycles"] == 18
    assert continued.engine["steps"] == 12 * longer.fidelity["steps_per_cycle"]
    assert longer.engine["continued_from_cycles"] == 0
    with pytest.raises(ValueError, match="goes on to more"):
        run.extend(20)


def test_the_engine_switch_picks_the_runner_and_names_the_solver_of_a_failed_case():
    config = short_config()
    dem = copy.deepcopy(config)
    dem["engine"] = "dem"
    assert case_runner(ShakeSettings.from_config(dem)) is run_dem_case
    assert case_runner(ShakeSettings.from_config(config)) is run_case
    failed = failed_record(ShakeSettings.from_config(dem), CASE, 5, [1], "boom")
    assert failed.solver == "numba-dem" and failed.fidelity["engine"] == "dem"


def test_a_dem_case_plans_its_runs_with_the_stored_dem_cost_model(packings, tmp_path):
    """The case step (engine: dem) hands the allocation the DEM's stored cost model
    (cost_models.json, entry dem), not one scaled from the pilot: the pilot's planned CPU is
    that model's for its cells, spheres and steps."""
    from pidpipe.cell.packing import save_packing
    from pidpipe.cell.scene import CellScene
    from pidpipe.config.stages import stage_config
    from pidpipe.measurement.cost_model import load_cost_model
    from pidpipe.steps.cases import simulate_case

    config = short_config(transient=10, measured=8)
    config["engine"] = "dem"
    config["fidelity"]["target_relative_sem"] = 0.05
    paths = [str(save_packing(p, tmp_path / f"packing{k}.json")) for k, p in enumerate(packings)]
    record = simulate_case(stage_config(config, "case"), CASE.case_id, paths,
                           str(tmp_path / "record.json"), str(tmp_path / "work"),
                           str(tmp_path / "case.log"))
    model = load_cost_model("dem")
    assert model is not None and model.engine == "dem"
    settings = ShakeSettings.from_config(config)
    steps = (CellScene.of(settings).timestep(CASE.freq_hz).steps_per_cycle
             * (settings.sampling.transient_cycles_at(CASE.freq_hz) + 8))
    pilot = record.target["runs"][0]
    assert pilot["kind"] == "pilot" and record.solver == "numba-dem"
    assert pilot["planned_cpu_s"] == pytest.approx(model.run_cpu_s(2, packings[0].n_spheres, steps))


def _without_timing(value):
    """A record without its wall and CPU times and host (they differ from run to run)."""
    if isinstance(value, dict):
        return {k: _without_timing(v) for k, v in value.items()
                if not any(t in k for t in ("wall_time", "cpu_time", "host"))}
    if isinstance(value, list):
        return [_without_timing(v) for v in value]
    return value


def test_cases_shaken_in_one_job_get_the_records_and_logs_of_jobs_of_their_own(packings, tmp_path):
    """simulate_cases (rule simulate_dem_cases) writes each case the record simulate_case would,
    and each case's messages into its own log."""
    from pidpipe.cell.packing import save_packing
    from pidpipe.config.stages import stage_config
    from pidpipe.steps.cases import simulate_case, simulate_cases
    from pidpipe.steps.run import run_step

    config = short_config(transient=4, measured=4)
    config["engine"] = "dem"
    case_config = stage_config(config, "case")
    paths = [str(save_packing(p, tmp_path / f"packing{k}.json")) for k, p in enumerate(packings)]
    cases = [CaseSpec(1000, 10, 25), CaseSpec(1000, 5, 25)]
    run_step(simulate_cases, str(tmp_path / "job.log"), config=case_config,     # as the rule runs it
             case_ids=[c.case_id for c in cases], packing_paths=[paths[:1], paths[1:]],
             record_paths=[str(tmp_path / f"{c.case_id}.json") for c in cases],
             workdirs=[str(tmp_path / "work" / c.case_id) for c in cases],
             log_paths=[str(tmp_path / "logs" / f"{c.case_id}.log") for c in cases])
    records = [json.loads((tmp_path / f"{c.case_id}.json").read_text()) for c in cases]
    alone = simulate_case(case_config, cases[1].case_id, paths[1:], str(tmp_path / "alone.json"),
                          str(tmp_path / "alone"), str(tmp_path / "alone.log"))
    same = json.dumps(_without_timing(records[1]), sort_keys=True)    # NaN == NaN here
    assert same == json.dumps(_without_timing(alone.to_dict()), sort_keys=True)
    for case, record in zip(cases, records):
        assert record["case_id"] == case.case_id and record["solver"] == "numba-dem"
        log = (tmp_path / "logs" / f"{case.case_id}.log").read_text()
        assert f"case {case.case_id} (numba-dem)" in log and len(log.splitlines()) == 1
        assert f"case {case.case_id} (numba-dem)" in (tmp_path / "job.log").read_text()
    with pytest.raises(ValueError, match="one entry per case"):
        simulate_cases(case_config, [cases[0].case_id], [paths[:1]], [], [], [])
