"""The refinement loop's engine on LIGGGHTS (pidpipe.steps.refine_engine.CaseEngine): a new
case, a verifying run and an extension run in the real LIGGGHTS on LIGGGHTS' pours, each as
planned, and the workflow's way (run nothing, name the missing plans, run a plan as a job)."""

from __future__ import annotations

import shutil

import pytest
import yaml

from pidpipe.config import load_config
from pidpipe.refine.candidates import Request
from pidpipe.steps.refine import run_refine_plan
from pidpipe.steps.refine_engine import CaseEngine, Plan, RunsNeeded

from tests._snakemake import TEST_CONFIG

pytestmark = [pytest.mark.engine, pytest.mark.slow]


@pytest.fixture(scope="module")
def config(tmp_path_factory):
    if shutil.which("liggghts") is None:
        pytest.fail("LIGGGHTS is not installed (apt-get install -y --no-install-recommends "
                    "liggghts): the refinement's LIGGGHTS binding cannot be tested")
    root = tmp_path_factory.mktemp("refine_liggghts")
    raw = yaml.safe_load(TEST_CONFIG.read_text())
    raw["engine"] = "liggghts"
    path = root / "config.yaml"
    path.write_text(yaml.safe_dump(raw))
    return load_config(path)


def test_liggghts_runs_what_the_loop_plans_and_the_workflow_way_names_what_is_missing(
        config, tmp_path):
    refine_dir = tmp_path / "refine"
    planner = CaseEngine.from_config(config, refine_dir / "work", run_missing=False)
    new, check = Request(750.0, 7.5, 25.0), Request(750.0, 7.5, 25.0, "verify")
    assert planner.cost(new) > 0 and planner.cost(check) == pytest.approx(planner.cost(new))
    with pytest.raises(RunsNeeded) as needed:
        planner.measure([new], [])
    (case_id,) = needed.value.case_ids
    plan = Plan.read(planner.plan_path(case_id))
    assert plan == planner.plan(new) and plan.cells == 1 and plan.measured_cycles == 10

    record_path = run_refine_plan(config, refine_dir, case_id)
    assert record_path.is_file()
    row = planner.measure([new], []).iloc[0]
    assert row["solver"] == "liggghts" and row["status"] in ("ok", "flagged")
    assert row["ceq_coupon_ns_m"] > 0 and row["ceq_coupon_sem_ns_m"] > 0
    assert row["cells"] == 1 and row["n_cycles"] == 10

    # a verifying run of the same point: its own packing, so not a rerun of the fitted case
    runner = CaseEngine.from_config(config, refine_dir / "work")
    verified = runner.verify([check]).iloc[0]
    assert runner.runs == [planner.plan(check).case.case_id]
    assert verified["case_id"] != row["case_id"]
    assert verified["ceq_coupon_ns_m"] != pytest.approx(row["ceq_coupon_ns_m"], rel=1e-9)
    assert runner.measured["shake_cpu_s"] > 0 and runner.measured["pour_cpu_s"] > 0
