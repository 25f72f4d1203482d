"""The typed case record (pidpipe.measurement.case_record): its JSON is the engines' record as
they wrote it before it was typed, byte for byte; other versions are refused with a fix."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest

from pidpipe.cases import CaseSpec
from pidpipe.config.settings import ShakeSettings
from pidpipe.errors import ParseError
from pidpipe.measurement.case_record import (
    RECORD_VERSION,
    CaseRecord,
    Engine,
    Fidelity,
    RecordVersionError,
)
from pidpipe.steps.cases import failed_record
from tests.conftest import short_config

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "case_records"
RECORDS = sorted(FIXTURES.glob("*.json"))


def test_fixtures_are_there():
    assert {path.name for path in RECORDS} >= {"dem_f500Hz_G5_r50pct_target.json",
                                              "liggghts_f1000Hz_G10_r25pct.json"}


@pytest.mark.parametrize("path", RECORDS, ids=lambda path: path.stem)
def test_a_record_written_before_the_type_reads_and_writes_back_byte_for_byte(path, tmp_path):
    """Records the engines wrote as plain dicts (tests/fixtures/README.md): read, the record's
    JSON is the file's text, and written again the file is the same bytes."""
    text = path.read_text(encoding="utf-8")
    record = CaseRecord.read(path)
    assert record.to_json() == text
    assert record.write(tmp_path / path.name).read_bytes() == path.read_bytes()
    assert list(record.to_dict()) == list(json.loads(text))          # the key order too


@pytest.mark.parametrize("path", RECORDS, ids=lambda path: path.stem)
def test_the_widely_read_values_are_attributes(path):
    raw = json.loads(path.read_text(encoding="utf-8"))
    record = CaseRecord.read(path)
    assert (record.case_id, record.freq_hz, record.accel_g, record.fill_pct, record.replicate) == (
        raw["case_id"], raw["freq_hz"], raw["accel_g"], raw["fill_pct"], raw["replicate"])
    assert record.status == raw["status"] and list(record.flags) == raw["flags"]
    assert record.ceq_cell_ns_m == raw["ceq_cell_ns_m"]
    assert record.ceq_coupon_sem_ns_m == raw["ceq_coupon_sem_ns_m"]
    assert record.ed_cycle_mean_j == raw["ed_cycle_mean_j"] and record.n_spheres == raw["n_spheres"]
    assert isinstance(record.fidelity, Fidelity) and isinstance(record.engine, Engine)
    assert record.fidelity.seeds == raw["fidelity"]["seeds"]
    assert record.fidelity.transient_cycles == raw["fidelity"]["transient_cycles"]
    assert record.engine_name == raw["engine"]["name"] and record.solver == raw["solver"]
    assert record.engine_cpu_s == raw["engine"]["cpu_time_s"]
    if "target" in raw:
        assert record.cpu_time_s == raw["target"]["cpu_time_s"]
        assert record.target.runs == raw["target"]["runs"]
    else:
        assert record.target is None and record.cpu_time_s == record.engine_cpu_s


def _made_up(**changes) -> CaseRecord:
    record = CaseRecord(solver="liggghts", case_id="f500Hz_G5_r50pct_rep0", freq_hz=500.0,
                        accel_g=5.0, fill_pct=50.0, replicate=0, n_spheres=11, status="ok",
                        flags=[], n_cycles=3, ed_cycle_mean_j=1e-8, ed_cycle_sem_j=float("nan"),
                        ceq_cell_ns_m=0.01, ceq_cell_sem_ns_m=float("nan"), ceq_coupon_ns_m=4.41,
                        ceq_coupon_sem_ns_m=float("nan"), cells=[],
                        cycles={"dissipated_j": [1e-8, 1.1e-8, 0.9e-8]},
                        fidelity={"transient_cycles": 2, "measured_cycles": 3, "seed": 7,
                                  "seeds": [7]},
                        engine={"name": "liggghts", "cpu_time_s": 1.5}, wall_time_s=2.0)
    return record.with_(**changes)


def test_to_json_and_from_json_round_trip():
    record = _made_up(flags=["not_resolved"], status="flagged",
                      target={"reached": False, "cpu_time_s": 3.0, "runs": []})
    text = record.to_json()
    back = CaseRecord.from_json(text)
    assert back.to_json() == text and back.to_dict().keys() == record.to_dict().keys()
    assert "NaN" in text and math.isnan(back.ceq_cell_sem_ns_m)       # NaN kept, as before
    same = {name: getattr(back, name) == getattr(record, name)
            for name in (field.name for field in dataclasses.fields(CaseRecord))}
    assert [name for name, equal in same.items() if not equal] == [
        "ed_cycle_sem_j", "ceq_cell_sem_ns_m", "ceq_coupon_sem_ns_m"]   # NaN != NaN
    assert back.flags == ("not_resolved",) and back.target.reached is False


def test_a_field_left_none_is_not_written_and_the_order_is_the_fields():
    data = _made_up().to_dict()
    assert "message" not in data and "target" not in data and "motion" not in data
    order = [field.name for field in dataclasses.fields(CaseRecord)]
    assert list(data) == [name for name in order if name in data]
    assert list(data)[:3] == ["record_version", "solver", "case_id"]
    assert data["record_version"] == RECORD_VERSION


def test_a_record_is_frozen():
    record = _made_up()
    with pytest.raises(dataclasses.FrozenInstanceError):
        record.status = "flagged"
    assert record.with_(status="flagged").status == "flagged" and record.status == "ok"


def test_a_record_of_another_version_is_refused_naming_file_versions_and_fix(tmp_path):
    path = tmp_path / "f500Hz_G5_r50pct_rep0.json"
    path.write_text(json.dumps({**_made_up().to_dict(), "record_version": RECORD_VERSION - 1},
                               indent=1))
    with pytest.raises(RecordVersionError) as info:
        CaseRecord.read(path)
    message = str(info.value)
    assert str(path) in message
    assert f"record version {RECORD_VERSION - 1}" in message
    assert f"reads record version {RECORD_VERSION}" in message
    assert "Delete the record and run its case again" in message
    assert isinstance(info.value, ParseError)     # the CLI and the scripts print it, no traceback
    unversioned = _made_up().to_dict()
    del unversioned["record_version"]
    path.write_text(json.dumps(unversioned))
    with pytest.raises(RecordVersionError, match="has no record_version"):
        CaseRecord.read(path)


def test_what_is_not_a_case_record_is_refused(tmp_path):
    path = tmp_path / "r.json"
    path.write_text(json.dumps({**_made_up().to_dict(), "surprise": 1}))
    with pytest.raises(ParseError, match="surprise"):
        CaseRecord.read(path)
    path.write_text(json.dumps({"case_id": "x"}))
    with pytest.raises(ParseError, match="no case_id or status"):
        CaseRecord.read(path)
    path.write_text("{not json")
    with pytest.raises(ParseError, match="cannot be read"):
        CaseRecord.read(path)
    with pytest.raises(ValueError, match="status 'done'"):
        _made_up(status="done")


def test_a_failed_record_is_a_record_of_no_values(tmp_path):
    settings = ShakeSettings.from_config(short_config())
    record = failed_record(settings, CaseSpec(500, 5, 50), 11, [20261123, 20261124], "boom")
    assert isinstance(record, CaseRecord)
    assert record.status == "failed" and record.message == "boom" and record.flags == ()
    assert math.isnan(record.ceq_coupon_ns_m) and math.isnan(record.wall_time_s)
    assert record.n_cycles == 0 and not record.measured
    assert record.fidelity.seeds == [20261123, 20261124] and record.engine_name == "liggghts"
    path = record.with_(engine_attempts=2).write(tmp_path / "failed.json")
    back = CaseRecord.read(path)
    assert back.to_json() == path.read_text() and back.engine_attempts == 2
    assert json.loads(path.read_text())["record_version"] == RECORD_VERSION


def test_write_is_atomic_and_leaves_no_part_file(tmp_path):
    path = _made_up().write(tmp_path / "deep" / "record.json")
    assert path.is_file() and not list(path.parent.glob(".*.part"))
