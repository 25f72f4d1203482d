"""The fidelity study: variant configs, error arithmetic, summary, table, figure and the plan.

No LIGGGHTS run here: records are made up, and the workflow is only planned (dry run).
"""

from __future__ import annotations

import copy
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from pidpipe.cases import CaseSpec
from pidpipe.config import DEFAULT_CONFIG_PATH, load_config, validate_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.errors import ConfigError
from pidpipe.measurement.case_record import CaseRecord
from pidpipe.studies.fidelity import (
    REFERENCE,
    SUMMARY_COLUMNS,
    TABLE_COLUMNS,
    collect_fidelity_study,
    median_with_sem,
    plan_study,
    planned_steps,
    relative_error,
    study_table,
    summarise_variants,
    variant_params,
)

REPO = Path(__file__).resolve().parents[2]
SNAKEMAKE = Path(sys.executable).with_name("snakemake")
RAW = yaml.safe_load(DEFAULT_CONFIG_PATH.read_text())


def config_with(change) -> dict:
    raw = copy.deepcopy(RAW)
    change(raw["fidelity_study"])
    return validate_config(raw)


# --------------------------------------------------------------------------------------------
# Building the variants' configs


def test_default_study_plans_reference_and_variants_on_the_campaign_fidelity():
    config = load_config()
    plan = plan_study(config)
    names = [v.name for v in plan.variants]
    assert names[0] == REFERENCE and names[1:] == [v["name"] for v in RAW["fidelity_study"]["variants"]]
    assert len(plan.jobs) == len(names) * len(RAW["fidelity_study"]["cases"])
    assert plan.packing_ids == ["r25pct_rep0", "r90pct_rep0"]
    # a variant changes only its own keys; the rest is the campaign's fidelity
    default, dt = plan.case_configs["default"]["fidelity"], plan.case_configs["dt_0p4"]["fidelity"]
    campaign = config["fidelity"]
    assert default == {k: campaign[k] for k in default}
    assert dt["timestep_rayleigh_fraction"] == 0.4
    assert {k: v for k, v in dt.items() if k != "timestep_rayleigh_fraction"} == \
        {k: v for k, v in default.items() if k != "timestep_rayleigh_fraction"}
    reference = plan.case_configs[REFERENCE]["fidelity"]
    assert reference["timestep_rayleigh_fraction"] == 0.05 and reference["measured_cycles"] == 200
    assert plan.case_configs["no_friction"]["fidelity"]["friction"] is False
    # the merged knob values reach the summary's parameters
    params = {p["name"]: p for p in variant_params(plan)}
    assert params["E_scale_0p01"]["fidelity"]["youngs_modulus_scale"] == 0.01
    assert params["no_friction"]["changes_physics"] and not params["dt_0p1"]["changes_physics"]


@pytest.mark.parametrize("change, fragments", [
    (lambda s: s["variants"][1]["fidelity"].update(timestep_rayleigh_fraction=0.9),
     ["fidelity_study.variants[1].fidelity", "'dt_0p1'", "fidelity.timestep_rayleigh_fraction = 0.9",
      "<= 0.5"]),
    (lambda s: s["variants"][3]["fidelity"].update(youngs_modulus_scael=0.1),
     ["fidelity_study.variants[3].fidelity", "'youngs_modulus_scael'", "not a known key"]),
    (lambda s: s["reference"].update(measured_cycles=1),
     ["fidelity_study.reference", "fidelity.measured_cycles = 1", ">= 2"]),
    (lambda s: s["variants"][0].setdefault("fidelity", {}).update(seed=3),
     ["fidelity_study.variants[0].fidelity.seed", "packings"]),
    (lambda s: s["variants"].append({"name": "reference"}),
     ["fidelity_study.variants[11].name", "reserved"]),
    (lambda s: s["variants"].append({"name": "dt_0p1"}),
     ["fidelity_study.variants[11].name = 'dt_0p1'", "another variant"]),
    (lambda s: s.update(baseline="fastest"), ["fidelity_study.baseline = 'fastest'", "default"]),
    (lambda s: s["cases"].append({"freq_hz": 50, "accel_g": 1, "fill_pct": 25}),
     ["fidelity_study.cases[10]", "twice"]),
], ids=["out of bounds", "unknown key", "bad reference", "packing setting", "reserved name",
        "duplicate name", "unknown baseline", "duplicate case"])
def test_bad_study_config_names_the_key(change, fragments):
    with pytest.raises(ConfigError) as info:
        plan_study(config_with(change))
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} missing from: {message}"


def test_schema_refuses_bad_variant_entries_naming_the_key():
    with pytest.raises(ConfigError, match=r"fidelity_study\.variants\[0\]\.fidelity\.rotation = 'no'"):
        config_with(lambda s: s["variants"][0].update(fidelity={"rotation": "no"}))
    with pytest.raises(ConfigError, match=r"'colour' under fidelity_study\.variants\[2\] is not a known key"):
        config_with(lambda s: s["variants"][2].update(colour="red"))
    with pytest.raises(ConfigError, match=r"fidelity_study\.error_target_fraction = 0"):
        config_with(lambda s: s.update(error_target_fraction=0))


def test_planned_steps_follow_cycles_over_frequency_and_timestep():
    plan = plan_study(load_config())
    from pidpipe.cases import CaseSpec

    case = CaseSpec(50.0, 10.0, 25.0)
    default = planned_steps(ShakeSettings.from_config(plan.case_configs["default"]), case)
    # 0.2 -> 0.1 Rayleigh times doubles the steps (to the whole-steps-per-cycle rounding)
    assert planned_steps(ShakeSettings.from_config(plan.case_configs["dt_0p1"]), case) / default == pytest.approx(2.0, rel=1e-3)
    # softening by 100 lengthens the Rayleigh time, and dt, tenfold
    assert planned_steps(ShakeSettings.from_config(plan.case_configs["E_scale_0p01"]), case) / default == pytest.approx(0.1, rel=1e-3)


# --------------------------------------------------------------------------------------------
# Errors, their uncertainty and the summary


def test_relative_error_and_its_propagated_uncertainty():
    error, sem = relative_error([1.1, 0.5, 0.0, 2.0], [0.011, 0.05, 0.01, 0.1],
                                [1.0, 1.0, 2.0, 0.0], [0.02, 0.0, 0.02, 0.1])
    assert error[:3] == pytest.approx([0.1, -0.5, -1.0])
    # 1.1 * sqrt(0.01^2 + 0.02^2); a reference without error leaves the value's relative error
    assert sem[0] == pytest.approx(1.1 * math.hypot(0.01, 0.02))
    assert sem[1] == pytest.approx(0.05)
    assert sem[2] == pytest.approx(0.01 / 2.0)  # finite where the variant's value is 0
    assert np.isnan(error[3]) and np.isnan(sem[3])  # no reference to compare with
    # first-order propagation agrees with sampling for small relative errors
    rng = np.random.default_rng(1)
    ratio = rng.normal(1.1, 0.011, 200_000) / rng.normal(1.0, 0.02, 200_000)
    assert ratio.std() == pytest.approx(sem[0], rel=0.02)


def test_median_with_sem_takes_the_middle_cases():
    assert median_with_sem([0.3, 0.1, 0.2], [3.0, 1.0, 2.0]) == (0.2, 2.0)
    median, sem = median_with_sem([0.4, 0.1, 0.2, 0.3], [0.04, 0.01, 0.02, 0.03])
    assert median == pytest.approx(0.25) and sem == pytest.approx(0.5 * math.hypot(0.02, 0.03))
    assert all(math.isnan(v) for v in median_with_sem([], []))


def record(case_id: str, ceq: float, sem: float, cpu: float, flags=(), status=None) -> CaseRecord:
    case = CaseSpec.from_id(case_id)
    return CaseRecord(
        solver="liggghts", case_id=case_id, freq_hz=case.freq_hz, accel_g=case.accel_g,
        fill_pct=case.fill_pct, replicate=case.replicate,
        status=status or ("flagged" if flags else "ok"),
        flags=list(flags), n_spheres=5, ceq_cell_ns_m=ceq, ceq_cell_sem_ns_m=sem,
        energy_drift_fraction=0.01, wall_time_s=cpu * 1.1,
        fidelity={"timestep_s": 9e-7, "rayleigh_fraction": 0.2, "youngs_modulus_scale": 1.0,
                  "transient_cycles": 5, "measured_cycles": 40, "rotation": True,
                  "friction": True},
        engine={"liggghts_cpu_time_s": cpu, "steps": 1000})


CASES = ("f50Hz_G1_r25pct_rep0", "f50Hz_G10_r25pct_rep0", "f500Hz_G5_r25pct_rep0",
         "f1000Hz_G10_r25pct_rep0")
VARIANTS = [{"name": REFERENCE, "label": "reference", "changes_physics": False,
             "fidelity": {"timestep_rayleigh_fraction": 0.05}},
            {"name": "default", "label": "campaign default", "changes_physics": False,
             "fidelity": {"timestep_rayleigh_fraction": 0.2}},
            {"name": "cheap", "label": "cheap", "changes_physics": False,
             "fidelity": {"timestep_rayleigh_fraction": 0.4}}]


def made_up_records() -> dict:
    """Reference not steady at 50 Hz / 1 g; 'cheap' flags 1000 Hz / 10 g, where it is 90 % off."""
    ref = {CASES[0]: (1.0, 0.5), CASES[1]: (2.0, 0.02), CASES[2]: (4.0, 0.04), CASES[3]: (1.0, 0.01)}
    records = {}
    for case_id, (ceq, sem) in ref.items():
        records[(REFERENCE, case_id)] = record(case_id, ceq, sem, 40.0,
                                               ["not_steady"] if case_id == CASES[0] else ())
        records[("default", case_id)] = record(case_id, ceq * 1.02, 2 * sem, 10.0)
    cheap = {CASES[0]: 5.0, CASES[1]: 0.92, CASES[2]: 1.06, CASES[3]: 0.1}
    for case_id, factor in cheap.items():
        records[("cheap", case_id)] = record(case_id, ref[case_id][0] * factor, 2 * ref[case_id][1],
                                             5.0, ["not_steady"] if case_id == CASES[3] else ())
    return records


def test_table_errors_steadiness_and_cost():
    table = study_table(made_up_records(), VARIANTS, "default")
    assert list(table.columns) == list(TABLE_COLUMNS) and len(table) == 12
    row = table.set_index(["variant", "case_id"])
    assert row.loc[("cheap", CASES[1]), "error_rel"] == pytest.approx(-0.08)
    assert row.loc[("cheap", CASES[1]), "error_rel_sem"] == pytest.approx(0.92 * math.hypot(0.04 / 1.84, 0.01))
    assert row.loc[("cheap", CASES[1]), "cpu_rel_baseline"] == pytest.approx(0.5)
    assert row.loc[(REFERENCE, CASES[2]), "error_rel"] == 0.0
    assert row.loc[(REFERENCE, CASES[2]), "error_rel_sem"] == pytest.approx(0.01)
    # the reference's flag is carried to every variant's row of that case: not steady
    assert (table.loc[table["case_id"] == CASES[0], "reference_flags"] == "not_steady").all()
    assert not table.loc[table["case_id"] == CASES[0], "steady"].any()
    assert not row.loc[("cheap", CASES[3]), "steady"] and row.loc[("default", CASES[3]), "steady"]
    assert row.loc[("cheap", CASES[3]), "flags"] == "not_steady"


def test_summary_leaves_flagged_cases_out_and_names_them():
    table = study_table(made_up_records(), VARIANTS, "default")
    summary = summarise_variants(table, VARIANTS, "default", 0.05).set_index("variant")
    assert list(summary.reset_index().columns) == list(SUMMARY_COLUMNS)
    cheap = summary.loc["cheap"]
    # used: 50 Hz/10 g (-8 %) and 500 Hz/5 g (+6 %); 1000 Hz/10 g (-90 %, flagged) is not
    # averaged in, and 50 Hz/1 g (+400 %) has a reference that is not steady
    assert cheap["n_used"] == 2 and cheap["n_flagged"] == 1 and cheap["n_reference_not_steady"] == 1
    assert cheap["flagged_cases"] == f"{CASES[3]}(not_steady)"
    assert cheap["median_abs_error"] == pytest.approx(0.07)
    assert cheap["max_abs_error"] == pytest.approx(0.08) and cheap["max_error_case"] == CASES[1]
    assert cheap["cpu_time_s"] == 20.0 and cheap["cpu_rel_baseline"] == pytest.approx(0.5)
    assert not cheap["meets_target"]  # over 5 %, and it flags a case the baseline ran steady
    default = summary.loc["default"]
    assert default["n_used"] == 3 and default["median_abs_error"] == pytest.approx(0.02)
    assert default["meets_target"] and default["cpu_rel_baseline"] == 1.0
    assert default["dt_rayleigh_fraction"] == 0.2
    assert np.isnan(summary.loc[REFERENCE, "median_abs_error"])
    assert summary.loc[REFERENCE, "cpu_rel_baseline"] == pytest.approx(4.0)


def test_collect_writes_table_summary_and_a_missing_row(tmp_path):
    from pidpipe.figures.fidelity import plot_fidelity

    records = made_up_records()
    jobs, paths = [], []
    for (variant, case_id), rec in records.items():
        path = tmp_path / "cases" / variant / f"{case_id}.json"
        if (variant, case_id) != ("cheap", CASES[2]):  # one record is missing
            rec.write(path)
        jobs.append([variant, case_id])
        paths.append(str(path))
    summary = collect_fidelity_study(paths, jobs, VARIANTS, "default", 0.05,
                                     str(tmp_path / "fidelity.csv"), str(tmp_path / "summary.csv"))
    table = pd.read_csv(tmp_path / "fidelity.csv", keep_default_na=False, na_values=[""])
    missing = table[(table["variant"] == "cheap") & (table["case_id"] == CASES[2])].iloc[0]
    assert missing["status"] == "missing" and np.isnan(missing["ceq_cell_ns_m"])
    assert summary.set_index("variant").loc["cheap", "n_used"] == 1
    assert summary.set_index("variant").loc["cheap", "n_flagged"] == 2

    figure = plot_fidelity(table, summary, 0.05)  # not saved: drawing it takes seconds
    case_axes = [ax for ax in figure.axes if ax.get_xscale() == "log"][:-1]
    assert len(case_axes) == 4
    assert all(ax.get_xlabel() in ("", "LIGGGHTS CPU time (s)") for ax in case_axes)
    assert any("(%)" in ax.get_ylabel() for ax in case_axes)
    assert "not summarised" in case_axes[0].get_title()  # 50 Hz / 1 g: reference not steady


# --------------------------------------------------------------------------------------------
# The workflow plans one job per (case, setting)


@pytest.mark.skipif(not SNAKEMAKE.is_file(), reason=f"snakemake is not installed next to {sys.executable}")
def test_dry_run_plans_one_job_per_case_and_setting(tmp_path):
    raw = yaml.safe_load((REPO / ".test" / "config.yaml").read_text())
    raw["fidelity_study"] = {
        "cases": [{"freq_hz": 1000, "accel_g": 10, "fill_pct": 25},
                  {"freq_hz": 500, "accel_g": 5, "fill_pct": 50}],
        "reference": {"timestep_rayleigh_fraction": 0.1, "measured_cycles": 20},
        "variants": [{"name": "default"}, {"name": "dt_0p4", "fidelity": {"timestep_rayleigh_fraction": 0.4}}],
    }
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(raw))
    command = [str(SNAKEMAKE), "--snakefile", str(REPO / "Snakefile"), "--directory", str(tmp_path),
               "--cores", "2", "--dry-run", "fidelity"]
    run = subprocess.run(command, cwd=tmp_path, text=True, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:]
    stats = run.stdout.split("Job stats:", 1)[1]
    counts = dict(re.findall(r"^(\w+)\s+(\d+)$", stats, re.MULTILINE))
    assert counts == {"pour_packing": "2", "simulate_fidelity_case": "6",
                      "collect_fidelity_table": "1", "plot_fidelity": "1", "fidelity": "1",
                      "total": "11"}
    for setting in ("reference", "default", "dt_0p4"):
        for case_id in ("f1000Hz_G10_r25pct_rep0", "f500Hz_G5_r50pct_rep0"):
            assert f"results/fidelity/cases/{setting}/{case_id}.json" in run.stdout
    assert "simulate_case " not in run.stdout  # the campaign is not run

    # a bad variant stops the run before any job, naming the key, without a traceback
    raw["fidelity_study"]["variants"][1]["fidelity"]["timestep_rayleigh_fraction"] = 0.9
    (tmp_path / "config.yaml").write_text(yaml.safe_dump(raw))
    run = subprocess.run(command, cwd=tmp_path, text=True, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, timeout=300)
    assert run.returncode != 0
    assert "fidelity_study.variants[1].fidelity" in run.stdout and "<= 0.5" in run.stdout
    assert "Traceback" not in run.stdout
