"""The grid check replays a target case's runs in the DEM on the very cells LIGGGHTS shook."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import save_packing
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.config.stages import stage_config
from pidpipe.dem.case import run_dem_case
from pidpipe.errors import PidpipeError
from pidpipe.liggghts.pour import pour
from pidpipe.measurement.adaptive import cell_series
from pidpipe.measurement.case_record import CaseRecord
from pidpipe.steps.validate import check_case_with_dem
from tests.conftest import short_config

pytestmark = pytest.mark.engine         # the packings are LIGGGHTS' pour

CASE = CaseSpec(1000, 10, 25)
POOL_INDEX = 10000


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Two pilot packings, one pool packing (of the campaign's pool naming), and a LIGGGHTS
    record whose target made three runs, two of them used."""
    folder = tmp_path_factory.mktemp("campaign")
    config = short_config(transient=3, measured=6)
    settings = PourSettings.from_config(config)
    pilot = [pour(settings, 25, k, folder / f"pour{k}") for k in range(2)]
    pilot_paths = [save_packing(p, folder / f"r25pct_rep{k}.json") for k, p in enumerate(pilot)]
    pool = folder / "pool"
    pool.mkdir()
    extra = pour(settings, 25, POOL_INDEX, folder / "pour_extra")
    save_packing(extra, pool / f"r25pct_rep{POOL_INDEX}.json")
    seeds = [p.seed for p in pilot]
    record = CaseRecord(solver="liggghts", case_id=CASE.case_id, freq_hz=CASE.freq_hz,
                        accel_g=CASE.accel_g, fill_pct=CASE.fill_pct, replicate=CASE.replicate,
                        status="ok", fidelity={"seeds": seeds + [extra.seed]},
                        ceq_cell_ns_m=0.05, ceq_cell_sem_ns_m=0.002,
                        target={"runs": [
                            {"run": 0, "kind": "pilot", "seeds": seeds, "measured_cycles": 6, "used": False},
                            {"run": 1, "kind": "more_cells", "seeds": [extra.seed], "measured_cycles": 8,
                             "used": True},
                            {"run": 2, "kind": "more_cycles", "seeds": seeds, "measured_cycles": 8,
                             "used": True}]})
    record_path = record.write(folder / "case.json")
    return {"config": config, "pilot": pilot, "pilot_paths": [str(p) for p in pilot_paths],
            "extra": extra, "pool": str(pool), "record": str(record_path), "folder": folder}


def test_the_used_runs_are_replayed_cell_for_cell(campaign):
    out = campaign["folder"] / "dem.json"
    record = check_case_with_dem(stage_config(campaign["config"], "case"), campaign["record"],
                                 campaign["pilot_paths"], str(out), campaign["pool"])
    replay = record.target["replay_of"]
    assert [entry["run"] for entry in replay] == [1, 2]          # the unused pilot is not replayed
    assert [entry["measured_cycles"] for entry in replay] == [8, 8]
    assert record.target["cells"] == 3
    assert sorted(record.fidelity["seeds"]) == sorted(
        [p.seed for p in campaign["pilot"]] + [campaign["extra"].seed])
    assert json.loads(out.read_text())["ceq_cell_ns_m"] == pytest.approx(record.ceq_cell_ns_m)
    # the DEM is deterministic: a replayed cell is the cell of its run made on its own
    settings = ShakeSettings.from_config(campaign["config"])
    staged = replace(settings, sampling=replace(settings.sampling, measured_cycles=8))
    alone = cell_series(run_dem_case(staged, CASE, [campaign["extra"]]))[0]
    cell = next(c for c in record.cells if c["seed"] == campaign["extra"].seed)
    np.testing.assert_allclose(cell["dissipated_j"], alone["dissipated_all_j"], rtol=1e-12)


def test_a_packing_missing_from_the_pool_is_named(campaign, tmp_path):
    with pytest.raises(PidpipeError, match=r"seed \d+ \(r25pct_rep10000\.json\), which is not in"):
        check_case_with_dem(stage_config(campaign["config"], "case"), campaign["record"],
                            campaign["pilot_paths"], str(tmp_path / "dem.json"),
                            str(tmp_path / "empty_pool"))
