"""Tests of pidpipe.campaign: the aggregation of case records into the C_eq table, the failure
policy of a case, the packing check, the per-stage config and the step runner.

None of these runs LIGGGHTS (a failing stand-in binary is used where a run must fail);
tests/workflow/test_workflow.py runs the whole campaign with the real engine.
"""

from __future__ import annotations

import copy
import json
import math
import re
import shutil
import stat
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import Packing, random_start, save_packing
from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.config.stages import stage_config
from pidpipe.design.ceq_table import (
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    read_ceq_table,
    split_usable,
)
from pidpipe.design.optimisation_files import read_results_json
from pidpipe.design.records import TABLE_COLUMNS, combine_replicates, records_to_table
from pidpipe.errors import ConfigError, PackingError, ParseError, TableError
from pidpipe.measurement.case_record import CaseRecord
from pidpipe.steps.cases import failed_record, simulate_case
from pidpipe.steps.figures import plot_optimisation_convergence
from pidpipe.steps.packings import check_packings
from pidpipe.steps.params import WILDCARD_NUMBER, WILDCARD_REPLICATE, workflow_config
from pidpipe.steps.run import run_step
from pidpipe.steps.table import collect_table

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def config() -> dict:
    return load_config(REPO / ".test" / "config.yaml")


def record(freq=500.0, accel=5.0, fill=50.0, replicate=0, status="ok", ceq=10.0, sem=1.0,
           flags=()) -> CaseRecord:
    """A case record as pidpipe.liggghts.shake.run_case makes it (only the fields the table reads)."""
    case = CaseSpec(freq, accel, fill, replicate)
    return CaseRecord(
        solver="liggghts", case_id=case.case_id, freq_hz=freq, accel_g=accel, fill_pct=fill,
        replicate=replicate, n_spheres=11, status=status, flags=list(flags),
        ceq_coupon_ns_m=ceq, ceq_coupon_sem_ns_m=sem,
        ceq_cell_ns_m=ceq / 441, ceq_cell_sem_ns_m=sem / 441,
        ed_cycle_mean_j=ceq * 1e-9, ed_cycle_sem_j=sem * 1e-9, n_cycles=10,
        fidelity={"timestep_s": 9e-7, "rayleigh_fraction": 0.2, "steps_per_cycle": 2223,
                  "youngs_modulus_scale": 1.0, "transient_cycles": 30, "measured_cycles": 10,
                  "sem_block_cycles": 2, "rotation": True, "friction": True,
                  "seed": 20261123 + replicate},
        engine={"liggghts_version": "LIGGGHTS-PUBLIC 3.8.0", "liggghts_wall_time_s": 1.5},
        wall_time_s=2.0,
    )


# --------------------------------------------------------------------------------------------
# Combining replicates


def test_combine_replicates_single_replicate_keeps_its_value_and_error():
    assert combine_replicates([3.0], [0.5]) == (3.0, 0.5)


def test_combine_replicates_propagates_run_errors_when_replicates_agree():
    # two equal values: no scatter between packings; error of the mean = sqrt(s1^2 + s2^2) / 2
    mean, sem = combine_replicates([10.0, 10.0], [3.0, 4.0])
    assert mean == 10.0
    assert sem == pytest.approx(5.0 / 2.0)


def test_combine_replicates_uses_the_scatter_between_packings_when_it_is_larger():
    values = np.array([8.0, 10.0, 15.0])
    mean, sem = combine_replicates(values, [0.1, 0.1, 0.1])
    assert mean == pytest.approx(11.0)
    assert sem == pytest.approx(values.std(ddof=1) / math.sqrt(3))


def test_combine_replicates_of_nothing_is_nan():
    mean, sem = combine_replicates([], [])
    assert math.isnan(mean) and math.isnan(sem)


# --------------------------------------------------------------------------------------------
# records -> table


def test_table_has_one_row_per_case_with_the_contract_columns():
    records = [record(f, g, r) for f in (500.0, 1000.0) for g in (5.0, 10.0) for r in (25.0, 50.0)]
    table = records_to_table(records)
    assert len(table) == 8
    assert list(table.columns) == list(TABLE_COLUMNS)
    assert set(REQUIRED_COLUMNS) <= set(table.columns)
    assert set(OPTIONAL_COLUMNS) <= set(table.columns)
    assert (table["status"] == "ok").all()
    assert table["case_id"].iloc[0] == "f500Hz_G5_r25pct_rep0"
    # sorted by (f, G, r)
    assert table[["freq_hz", "accel_g", "fill_pct"]].equals(
        table[["freq_hz", "accel_g", "fill_pct"]].sort_values(["freq_hz", "accel_g", "fill_pct"]))
    row = table.iloc[0]
    assert row["dt_s"] == 9e-7 and row["measured_cycles"] == 10 and row["seed"] == 20261123
    assert row["liggghts_version"] == "LIGGGHTS-PUBLIC 3.8.0"


def test_replicates_are_averaged_into_one_row():
    records = [record(replicate=0, ceq=10.0, sem=3.0), record(replicate=1, ceq=10.0, sem=4.0)]
    table = records_to_table(records)
    assert len(table) == 1
    row = table.iloc[0]
    assert row["status"] == "ok" and row["n_replicates"] == 2
    assert row["ceq_coupon_ns_m"] == pytest.approx(10.0)
    assert row["ceq_coupon_sem_ns_m"] == pytest.approx(2.5)
    assert row["ceq_cell_sem_ns_m"] == pytest.approx(2.5 / 441)
    assert row["n_cycles"] == 20
    assert row["wall_time_s"] == pytest.approx(4.0)
    assert row["case_id"] == "f500Hz_G5_r50pct_rep0;f500Hz_G5_r50pct_rep1"


def test_failed_case_is_a_failed_row_without_values_and_is_not_fitted(config):
    case = CaseSpec(1000.0, 10.0, 50.0)
    failed = failed_record(ShakeSettings.from_config(config), case, n_spheres=11, seeds=[20261123],
                                    message="case f1000Hz_G10_r50pct_rep0 failed: boom")
    records = [record(1000.0, 10.0, 25.0), failed]
    table = records_to_table(records)
    row = table.set_index("case_id").loc["f1000Hz_G10_r50pct_rep0"]
    assert row["status"] == "failed"
    assert math.isnan(row["ceq_coupon_ns_m"]) and math.isnan(row["ceq_coupon_sem_ns_m"])
    assert "boom" in row["message"]
    assert row["n_replicates"] == 0
    # the settings it was run with are still recorded
    assert row["measured_cycles"] == config["fidelity"]["measured_cycles"]
    assert row["dt_s"] > 0
    used, excluded = split_usable(table)
    assert list(excluded["case_id"]) == ["f1000Hz_G10_r50pct_rep0"]
    assert len(used) == 1


def test_expected_case_without_record_is_missing():
    expected = [CaseSpec(500.0, 5.0, 25.0), CaseSpec(500.0, 5.0, 50.0)]
    table = records_to_table([record(500.0, 5.0, 25.0)], expected)
    assert list(table["status"]) == ["ok", "missing"]
    assert math.isnan(table["ceq_coupon_ns_m"].iloc[1])


def test_a_row_sits_at_the_fill_its_cells_hold_whatever_fill_named_the_case():
    """A case named 50 % pours 11 of 21 spheres: its row is at 52.381 %, the same place as a
    case the loop named by that count, so that the surrogate sees one fill axis."""
    named = record(500.0, 5.0, 50.0)                                    # 11 spheres
    by_count = record(1000.0, 5.0, 52.381)                              # 11 spheres too
    expected = [CaseSpec(500.0, 5.0, 25.0)]                             # missing: 5 spheres
    table = records_to_table([named, by_count], expected, full_cell_spheres=21)
    assert list(table["fill_pct"]) == [23.81, 52.381, 52.381]
    assert list(table["case_id"]) == ["f500Hz_G5_r25pct_rep0", "f500Hz_G5_r50pct_rep0",
                                      "f1000Hz_G5_r52.381pct_rep0"]
    # without the cell size, rows keep the fill they are named by
    assert list(records_to_table([named]).fill_pct) == [50.0]


def test_ok_replicates_are_used_and_the_others_named_in_flags():
    records = [record(replicate=0, ceq=12.0, sem=1.0),
               record(replicate=1, status="failed", ceq=float("nan"), sem=float("nan")),
               record(replicate=2, status="flagged", ceq=99.0, flags=["not_steady"])]
    row = records_to_table(records).iloc[0]
    assert row["status"] == "ok"
    assert row["n_replicates"] == 1
    assert row["ceq_coupon_ns_m"] == 12.0
    assert row["flags"].split(";") == ["rep1:failed", "rep2:not_steady", "rep2:flagged"]


def test_flagged_without_ok_replicate_keeps_values_for_inspection():
    row = records_to_table([record(status="flagged", ceq=7.0, flags=["not_steady"])]).iloc[0]
    assert row["status"] == "flagged"
    assert row["flags"] == "not_steady"
    assert row["ceq_coupon_ns_m"] == 7.0


def test_collect_table_writes_a_valid_table_and_marks_missing_records(tmp_path):
    paths = []
    for rec in (record(500.0, 5.0, 25.0), record(500.0, 5.0, 50.0, status="failed", ceq=float("nan"))):
        path = tmp_path / "cases" / f"{rec.case_id}.json"
        path.parent.mkdir(exist_ok=True)
        path.write_text(rec.to_json())
        paths.append(str(path))
    paths.append(str(tmp_path / "cases" / "f1000Hz_G5_r25pct_rep0.json"))  # never written
    out = tmp_path / "ceq_table.csv"
    collect_table(paths, str(out))
    table = read_ceq_table(out)
    assert dict(zip(table["case_id"], table["status"])) == {
        "f500Hz_G5_r25pct_rep0": "ok", "f500Hz_G5_r50pct_rep0": "failed",
        "f1000Hz_G5_r25pct_rep0": "missing"}
    assert not list(tmp_path.glob(".*.part"))


def test_collect_table_says_which_flagged_points_a_surrogate_fits(tmp_path, caplog):
    """A point flagged for precision is fitted by the GP with its SEM; one of a failed check by
    no surrogate (pidpipe.design.fit_policy): the log says which, not 'not fitted' for both."""
    paths = []
    for rec in (record(500.0, 5.0, 25.0, status="flagged", flags=["target_not_reached"]),
                record(500.0, 5.0, 50.0, status="flagged", flags=["sphere_above_lid"])):
        path = tmp_path / f"{rec.case_id}.json"
        path.write_text(rec.to_json())
        paths.append(str(path))
    with caplog.at_level("WARNING", logger="pidpipe"):
        collect_table(paths, str(tmp_path / "t.csv"))
    lines = {line.split(" (")[0]: line for line in caplog.messages if line.startswith("grid point")}
    assert "the gp surrogate fits it with its SEM" in lines["grid point f=500 Hz, G=5 g, r=25 %"]
    assert "no surrogate fits it (failed check: sphere_above_lid)" in lines["grid point f=500 Hz, G=5 g, r=50 %"]


def test_collect_table_refuses_a_corrupt_record(tmp_path):
    bad = tmp_path / "f500Hz_G5_r25pct_rep0.json"
    bad.write_text("{not json")
    with pytest.raises(ParseError, match="cannot be read"):
        collect_table([str(bad)], str(tmp_path / "t.csv"))


# --------------------------------------------------------------------------------------------
# A case's failure policy


def _packing(config: dict, n_spheres: int, pile_m: float | None = None) -> Packing:
    cell = CellScene.from_config(config).cell
    radius = config["materials"]["acrylic"]["radius_m"]
    centres = random_start(cell, n_spheres, radius, seed=1)
    pile = pile_m if pile_m is not None else float(centres[:, 2].max() + radius - cell.floor_z_m)
    return Packing(positions_m=centres.tolist(), radius_m=radius, n_spheres=n_spheres, seed=1,
                   pile_height_m=pile, lid_height_m=cell.height_m, max_speed_m_s=0.0,
                   settle_time_s=0.1, fill_pct=50.0)


@pytest.fixture
def failing_liggghts(tmp_path, monkeypatch):
    script = tmp_path / "liggghts"
    script.write_text("#!/bin/sh\necho 'ERROR: stand-in LIGGGHTS fails on purpose'\nexit 1\n")
    script.chmod(script.stat().st_mode | stat.S_IXUSR)
    monkeypatch.setenv("PIDPIPE_LIGGGHTS", str(script))
    return script


def test_engine_failure_writes_a_failed_record_naming_case_and_logs(config, tmp_path, failing_liggghts):
    case_config = stage_config(config, "case")
    packing_path = save_packing(_packing(config, 11), tmp_path / "r50pct_rep0.json")
    record_path = tmp_path / "cases" / "f500Hz_G5_r50pct_rep0.json"
    log = tmp_path / "case.log"
    rec = simulate_case(case_config, "f500Hz_G5_r50pct_rep0", [str(packing_path)],
                                 str(record_path), str(tmp_path / "work"), str(log))
    written = json.loads(record_path.read_text())
    assert written["status"] == rec.status == "failed"
    assert "f500Hz_G5_r50pct_rep0" in written["message"]
    assert str(tmp_path / "work" / "screen.txt") in written["message"]
    assert str(log) in written["message"]
    assert "stand-in LIGGGHTS fails" in written["message"]
    assert "after 2 attempt(s)" in written["message"] and written["engine_attempts"] == 2


def test_failure_of_the_first_run_is_retried(config, tmp_path, monkeypatch):
    liggghts = shutil.which("liggghts")
    if liggghts is None:
        pytest.skip("LIGGGHTS is not installed (apt-get install -y --no-install-recommends liggghts)")
    marker = tmp_path / "failed_once"
    script = tmp_path / "liggghts"
    script.write_text(f"#!/bin/sh\nif [ ! -e {marker} ]; then touch {marker}; "
                      "echo 'ERROR: MPI_ABORT (stand-in)'; exit 1; fi\n"
                      f'exec {liggghts} "$@"\n')
    script.chmod(0o755)
    monkeypatch.setenv("PIDPIPE_LIGGGHTS", str(script))
    case_config = stage_config(config, "case")
    case_config["fidelity"].update(transient_cycles=1, measured_cycles=2, target_relative_sem=None)
    packing_path = save_packing(_packing(config, 5), tmp_path / "r25pct_rep0.json")
    log = tmp_path / "case.log"
    run_step(simulate_case, str(log), config=case_config,
                      case_id="f1000Hz_G5_r25pct_rep0", packing_paths=[str(packing_path)],
                      record_path=str(tmp_path / "rec.json"), workdir=str(tmp_path / "work"),
                      log_path=str(log))
    written = json.loads((tmp_path / "rec.json").read_text())
    assert written["status"] in ("ok", "flagged") and written["engine_attempts"] == 2
    assert "attempt 1 of 2" in log.read_text() and "MPI_ABORT (stand-in)" in log.read_text()


def test_case_ids_match_the_wildcard_constraints():
    number = WILDCARD_NUMBER
    pattern = re.compile(f"f(?P<freq>{number})Hz_G(?P<accel>{number})_r(?P<fill>{number})pct"
                         f"_rep(?P<replicate>{WILDCARD_REPLICATE})")
    for case in (CaseSpec(62.5, 0.5, 33.3, 2), CaseSpec(1000.0, 10.0, 100.0), CaseSpec(0.25, 1e-3, 5)):
        match = pattern.fullmatch(case.case_id)
        assert match is not None, case.case_id
        assert CaseSpec(float(match["freq"]), float(match["accel"]), float(match["fill"]),
                        int(match["replicate"])) == case


def test_packing_that_does_not_fit_fails_the_case(config, tmp_path, failing_liggghts):
    packing_path = save_packing(_packing(config, 11, pile_m=0.03), tmp_path / "r50pct_rep0.json")
    with pytest.raises(PackingError, match="do not fit"):
        simulate_case(stage_config(config, "case"), "f500Hz_G5_r50pct_rep0",
                               [str(packing_path)], str(tmp_path / "rec.json"), str(tmp_path / "w"),
                               str(tmp_path / "log"))
    assert not (tmp_path / "rec.json").exists()


def test_check_packings_lists_every_misfit_and_its_cases_in_one_message(config, tmp_path):
    paths = []
    for packing_id, pile in (("r25pct_rep0", 0.01), ("r75pct_rep0", 0.027), ("r90pct_rep0", 0.038)):
        paths.append(str(save_packing(_packing(config, 5, pile_m=pile), tmp_path / f"{packing_id}.json")))
    case_ids = [CaseSpec(f, 5.0, r).case_id for f in (500.0, 1000.0) for r in (25.0, 75.0, 90.0)]
    report = tmp_path / "check.tsv"
    with pytest.raises(PackingError) as info:
        check_packings(paths, case_ids, str(report))
    message = str(info.value)
    assert message.startswith("2 of 3 packing(s) refused")
    for case_id in ("f500Hz_G5_r75pct_rep0", "f1000Hz_G5_r75pct_rep0", "f500Hz_G5_r90pct_rep0",
                    "f1000Hz_G5_r90pct_rep0"):
        assert case_id in message
    assert "r25pct" not in message
    assert not report.exists()


def test_check_packings_writes_the_summary_when_all_fit(config, tmp_path):
    path = save_packing(_packing(config, 5), tmp_path / "r25pct_rep0.json")
    report = tmp_path / "check.tsv"
    check_packings([str(path)], ["f500Hz_G5_r25pct_rep0"], str(report))
    summary = pd.read_csv(report, sep="\t")
    assert list(summary["verdict"]) == ["ok"] and list(summary["packing_id"]) == ["r25pct_rep0"]
    assert summary.loc[0, "settle_time_s"] > 0


def test_check_packings_names_the_cases_of_every_cell(config, tmp_path):
    """With 2 cells per run, a misfit packing of replicate 3 belongs to the case of replicate 1."""
    paths = [str(save_packing(_packing(config, 5, pile_m=0.038 if k == 3 else 0.01),
                              tmp_path / f"r25pct_rep{k}.json")) for k in range(4)]
    case_ids = [CaseSpec(500.0, 5.0, 25.0, q).case_id for q in (0, 1)]
    with pytest.raises(PackingError) as info:
        check_packings(paths, case_ids, str(tmp_path / "check.tsv"), cells_per_run=2)
    assert "1 of 4 packing(s) refused" in str(info.value)
    assert "f500Hz_G5_r25pct_rep1" in str(info.value) and "f500Hz_G5_r25pct_rep0" not in str(info.value)


# --------------------------------------------------------------------------------------------
# Config per stage, and the step runner


def test_stage_config_ignores_what_the_stage_does_not_use(config):
    changed = copy.deepcopy(config)
    changed["optimisation"]["starts"] += 1
    changed["environments"] = []
    changed["grid"]["freq_hz"] = [123.0]
    changed["geometry"]["coupon_width_m"] *= 2
    changed["materials"]["unused"] = {"density_kg_m3": 1.0, "youngs_modulus_pa": 1e7, "poisson_ratio": 0.3}
    for stage in ("packing", "case"):
        assert repr(stage_config(changed, stage)) == repr(stage_config(config, stage))


@pytest.mark.parametrize("stage, path, value", [
    ("case", ("fidelity", "measured_cycles"), 11),
    ("case", ("materials", "aluminium", "youngs_modulus_pa"), 71e9),
    ("case", ("geometry", "coupon_n_cells"), 400),
    ("packing", ("fidelity", "seed"), 5),
    ("packing", ("fill", "poured_capacity_spheres"), 20),
])
def test_stage_config_follows_what_the_stage_uses(config, stage, path, value):
    changed = copy.deepcopy(config)
    target = changed
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    assert stage_config(changed, stage) != stage_config(config, stage)


def test_stage_config_is_enough_to_render_a_case(config, tmp_path):
    from pidpipe.liggghts.shake import render_shake_deck

    plan = render_shake_deck(ShakeSettings.from_config(stage_config(config, "case")), CaseSpec(500.0, 5.0, 50.0),
                             _packing(config, 11), tmp_path)
    assert plan["deck"].is_file()


def test_stage_config_keys_are_sorted(config):
    part = stage_config(config, "case")
    assert list(part) == sorted(part)
    assert list(part["fidelity"]) == sorted(part["fidelity"])


def test_workflow_config_refuses_unknown_surrogate_method_and_missing_external_table(tmp_path,
                                                                                     monkeypatch):
    raw = load_config(REPO / ".test" / "config.yaml")
    raw["surrogate"]["method"] = "kriging"
    with pytest.raises(ConfigError, match="surrogate.method = 'kriging'"):
        workflow_config(raw)
    raw["surrogate"]["method"] = "rbf_thin_plate"
    raw["optimisation"]["external_ceq_table"] = "nowhere.csv"
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match="external_ceq_table = 'nowhere.csv'"):
        workflow_config(raw)


def test_run_step_turns_a_pidpipe_error_into_exit_1_with_the_message(tmp_path, capsys):
    def step(value):
        raise TableError(f"C_eq table x: bad value {value}")

    log = tmp_path / "logs" / "step.log"
    with pytest.raises(SystemExit) as info:
        run_step(step, str(log), value=3)
    assert info.value.code == 1
    err = capsys.readouterr().err
    assert "C_eq table x: bad value 3" in err and "Traceback" not in err
    assert "C_eq table x: bad value 3" in log.read_text()


def test_run_step_lets_bugs_keep_their_traceback(tmp_path):
    def step():
        raise ZeroDivisionError("bug")

    with pytest.raises(ZeroDivisionError):
        run_step(step, str(tmp_path / "step.log"))


# --------------------------------------------------------------------------------------------
# Optimisation results read back for the convergence figure


class _Plane:
    """C_eq = f * G * r / 1000 on a box: the optimum is at the top of the f and G bands."""

    domain = {"freq_hz": (100.0, 1000.0), "accel_g": (1.0, 10.0), "fill_pct": (20.0, 80.0)}

    def predict(self, freq_hz, accel_g, fill_pct):
        return np.asarray(freq_hz) * np.asarray(accel_g) * np.asarray(fill_pct) / 1000.0


def test_results_json_reads_back_and_plots(tmp_path):
    from pidpipe.design.designs import Search, optimise_designs, write_results_json
    from pidpipe.design.optimisation import Budget, Environment

    results = optimise_designs(_Plane(), [Environment("e", (200.0, 300.0), (2.0, 3.0))],
                               Budget(n_spheres=1000, full_cell_spheres=21, n_cells_coupon=441),
                               Search(starts=3, seed=1))
    path = tmp_path / "optimum.json"
    write_results_json(results, path)
    back = read_results_json(path)
    assert [r.kind for r in back] == ["peak", "band_mean", "worst_case"]
    for again, result in zip(back, results):
        assert again.design == result.design and again.band == result.band
        assert again.optimum == result.optimum
        assert [s.history_ns_m for s in again.starts] == [s.history_ns_m for s in result.starts]
    plot_optimisation_convergence(str(path), str(tmp_path / "convergence.png"))
    assert (tmp_path / "convergence.png").stat().st_size > 1000
    assert (tmp_path / "convergence.pdf").stat().st_size > 1000


def test_table_names_the_regime_and_whether_the_signal_is_resolved():
    rows = records_to_table([record(accel=1.0, ceq=2.0, sem=0.9),
                                      record(accel=5.0, ceq=10.0, sem=1.0),
                                      record(accel=10.0, status="failed", ceq=float("nan"), sem=float("nan"))])
    one_g, five_g, failed = (rows[rows.accel_g == g].iloc[0] for g in (1.0, 5.0, 10.0))
    assert (one_g["regime"], one_g["signal"]) == ("no_lift_off", "uncertain")
    assert one_g["ceq_relative_sem"] == pytest.approx(0.45)
    assert (five_g["regime"], five_g["signal"]) == ("impacting", "resolved")
    assert failed["signal"] == "none"

