"""`pidpipe case` measures a case to the config's target, as the campaign does, unless told not to."""

from __future__ import annotations

import json

import pytest
import yaml

from pidpipe.cli import main
from tests._snakemake import TEST_CONFIG

pytestmark = pytest.mark.engine     # the pilot's packings and the pool's are poured by LIGGGHTS


def _config(tmp_path, **fidelity) -> str:
    raw = yaml.safe_load(TEST_CONFIG.read_text())
    raw["fidelity"].update(transient_cycles=5, transient_min_time_s=0.0, measured_cycles=8,
                           cells_per_run=2, **fidelity)
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(raw))
    return str(path)


def _case(tmp_path, config: str, *extra: str) -> dict:
    record = tmp_path / "record.json"
    code = main(["--config", config, "case", "--engine", "dem", "--freq-hz", "500", "--accel-g", "5",
                 "--fill-pct", "25", "--workdir", str(tmp_path / "work"), "--record", str(record),
                 *extra])
    assert code == 0
    return json.loads(record.read_text())


def test_pidpipe_case_goes_on_past_the_pilot_until_a_cap_stops_it(tmp_path, capsys):
    # a target no case of 4 cells x 16 cycles can reach: the case must add cells (poured into the
    # workdir's pool) and cycles up to the caps, then say that it stopped there
    config = _config(tmp_path, target_relative_sem=0.001, max_cells_per_case=4,
                     max_measured_cycles=16)
    record = _case(tmp_path, config)
    out = capsys.readouterr().out
    target = record["target"]
    assert len(target["runs"]) >= 2
    assert target["runs"][0]["kind"] == "pilot"
    assert not target["reached"]
    assert "target_not_reached" in record["flags"]
    assert target["cells"] > 2 or target["measured_cycles"] > 8
    assert target["cells"] <= 4 and target["measured_cycles"] <= 16
    assert target["cells"] == len(record["cells"])
    if target["cells"] > 2:
        assert sorted((tmp_path / "work" / "pool").glob("r25pct_rep*.json"))
    assert "NOT reached (a cap stopped it)" in out
    assert f"{target['cells']} cells x {target['measured_cycles']} measured cycles" in out


def test_pilot_only_runs_the_configured_cells_and_cycles_once(tmp_path, capsys):
    config = _config(tmp_path, target_relative_sem=0.001, max_cells_per_case=4,
                     max_measured_cycles=16)
    record = _case(tmp_path, config, "--pilot-only")
    assert not record.get("target")
    # the configured 5 transient + 8 measured cycles, run once; the cycles averaged are those
    # after the transient MSER detects (at least the configured 5)
    assert record["fidelity"]["measured_cycles"] == 8
    assert record["n_cycles"] + record["detected_transient_cycles"] == 5 + 8
    assert len(record["cells"]) == 2
    assert "target_not_reached" not in record["flags"]
    assert "target " not in capsys.readouterr().out
