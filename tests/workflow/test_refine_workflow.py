"""The campaign with the refinement loop (``refine.enabled``) on the reduced grid, shaken by
the compiled DEM: the loop runs as Snakemake steps (checkpoints) and jobs (``refine.run_cases:
as_jobs``) or in one step (``in_step``, the DEM's default) to the same table, the designs rest
on its table, and a campaign killed between or within rounds resumes with only the missing runs.

The loop's criterion (1 %) cannot be met in its 3 rounds: it stops at ``refine.max_rounds``,
having run a few cases of 1 cell x 10 cycles (a minute or two on 2 cores)."""

from __future__ import annotations

import json
import shutil

import pandas as pd
import pytest

from tests._snakemake import (
    WORKFLOW_MARKS,
    copy_campaign,
    planned_jobs,
    snakemake,
    write_config,
)

pytestmark = WORKFLOW_MARKS

REFINE = {"enabled": True, "interval_fraction": 0.01, "max_cpu_s": 15.0, "cases_per_round": 2,
          "max_rounds": 3}


def _config(workdir, run_cases: str) -> None:
    write_config(workdir, engine="dem", fidelity={"pour_engine": "dem"},
                 surrogate={"method": "gp", "allow_holes": True},
                 refine={**REFINE, "run_cases": run_cases})


#: What the loop wrote: removed from a copy of the campaign, its loop runs again from the grid.
LOOP_OUTPUTS = ("results/refine", "results/ceq_table_refined.csv")


@pytest.fixture(scope="module")
def campaign(dem_poured_campaign, tmp_path_factory):
    """The whole campaign, each loop run a job (the tests below kill and resume it).

    It starts from a copy of the DEM campaign poured by the DEM (tests/workflow/conftest.py),
    whose packings, cases and table are this config's: the refinement, surrogate and designs
    run here.
    """
    poured = dem_poured_campaign["run"]
    assert poured.returncode == 0, poured.stdout[-5000:]
    workdir = copy_campaign(dem_poured_campaign["workdir"],
                            tmp_path_factory.mktemp("refine_campaign_as_jobs") / "campaign")
    _config(workdir, "as_jobs")
    run = snakemake(workdir)
    assert run.returncode == 0, run.stdout[-5000:]
    # the campaign as it finished, for the in-step loop to start from the same grid
    copy_campaign(workdir, tmp_path_factory.getbasetemp() / "refine_campaign_finished")
    return workdir


@pytest.fixture(scope="module")
def campaign_in_step(campaign, tmp_path_factory):
    """The same grid's loop again, run in one step (the grid's cases are not run again)."""
    workdir = tmp_path_factory.getbasetemp() / "refine_campaign_in_step"
    copy_campaign(tmp_path_factory.getbasetemp() / "refine_campaign_finished", workdir)
    for name in LOOP_OUTPUTS:
        path = workdir / name
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    _config(workdir, "in_step")
    run = snakemake(workdir, "refine")
    assert run.returncode == 0, run.stdout[-5000:]
    assert "simulate_dem_cases" not in run.stdout and "run_refine_case" not in run.stdout
    return workdir


#: Columns that differ between two runs of one plan (the machine's timings).
TIMINGS = ["wall_time_s", "solver_wall_time_s", "liggghts_wall_time_s", "engine_cpu_s"]


def _loop_table(workdir) -> pd.DataFrame:
    """The loop's table without the runs' timings."""
    table = pd.read_csv(workdir / "results" / "refine" / "state" / "ceq_table.csv")
    return table.drop(columns=[c for c in TIMINGS if c in table.columns])


def _kill_after(workdir, step: int) -> None:
    """The campaign's files as a kill after the loop's ``step`` leaves them: no later step, and
    none of the finished loop's outputs."""
    results = workdir / "results"
    for path in (results / "refine" / "steps").glob("*.json"):
        if int(path.stem) > step:
            path.unlink()
    for name in ("ceq_table_refined.csv", "refine/rounds.csv", "refine/summary.json",
                 "refine/verify_points.csv", "refine/convergence.png", "refine/convergence.pdf"):
        (results / name).unlink()


def _steps(workdir) -> list[dict]:
    paths = sorted((workdir / "results" / "refine" / "steps").glob("*.json"),
                   key=lambda p: int(p.stem))
    return [json.loads(p.read_text()) for p in paths]


def test_in_a_new_folder_the_loop_waits_for_the_grid_it_starts_from(tmp_path):
    """From nothing, one run plans the DEM pours, the grid's cases and table, then the loop's
    first step (the campaign fixture starts from a finished grid)."""
    _config(tmp_path, "as_jobs")
    run = snakemake(tmp_path, "--dry-run")
    assert run.returncode == 0, run.stdout[-5000:]
    jobs = planned_jobs(run.stdout)
    assert jobs["pour_dem_packings"] == 2 and jobs["simulate_dem_cases"] == 4, jobs
    assert jobs["collect_table"] == 1 and jobs["refine_step"] == 1, jobs
    assert "run_refine_case" not in jobs  # the step names its runs once it has run
    step = run.stdout.split("checkpoint refine_step:", 1)[1].split("\n\n", 1)[0]
    assert "input: results/ceq_table.csv" in step and "output: results/refine/steps/1.json" in step


def test_the_loop_runs_as_steps_and_every_run_it_asked_for_is_in_its_table(campaign):
    steps = _steps(campaign)
    assert [s["status"] for s in steps] == ["runs needed"] * (len(steps) - 1) + ["done"]
    assert steps[-1]["stopped_by"] == "max rounds reached"
    assert any("wider than +-1 %" in line for line in steps[-1]["open"])
    asked = [run for step in steps for run in step.get("runs", [])]
    assert len(asked) == len(set(asked)) >= 2
    records = {p.stem for p in (campaign / "results" / "refine" / "work" / "cases").glob("*.json")}
    assert records == set(asked)
    state = pd.read_csv(campaign / "results" / "refine" / "state" / "ceq_table.csv")
    used = {part for ids in state["case_id"] for part in str(ids).split(";")}
    # the loop decided each round the same in every step that asked it: no run was wasted
    assert set(asked) <= used
    added = state[state["refine_round"] > 0]
    assert (added["planned_cpu_s"] > 0).all() and added["planned_cpu_s"].sum() <= 15.0
    assert set(added["source"]) <= {"refine round 1", "refine round 2"}


def test_the_designs_rest_on_the_table_the_loop_fitted_last(campaign):
    results = campaign / "results"
    refined = pd.read_csv(results / "ceq_table_refined.csv")
    grid = pd.read_csv(results / "ceq_table.csv")
    assert len(refined) >= len(grid) and refined["case_key"].is_unique
    assert set(refined["source"]) >= {"grid"} and "verify" not in set(refined["source"])
    assert (refined["source"] != "grid").any()
    summary = json.loads((results / "refine" / "summary.json").read_text())
    assert summary["rounds_run"] == [1, 2, 3]
    rounds = pd.read_csv(results / "refine" / "rounds.csv")
    assert sorted(set(rounds["round"])) == [1, 2, 3] and len(rounds) == 3 * 3
    assert (results / "refine" / "convergence.png").stat().st_size > 10_000
    points = pd.read_csv(results / "refine" / "verify_points.csv")
    assert {"design", "point", "dem_dof", "z", "passes"} <= set(points.columns)
    log = (campaign / "logs" / "fit_surrogate.log").read_text()
    assert "ceq_table_refined.csv" in log
    optimum = pd.read_csv(results / "optimum.csv")
    last = rounds[rounds["round"] == 3].set_index("design")
    peak = optimum[optimum["design"] == "peak"].iloc[0] if "design" in optimum else optimum.iloc[0]
    assert peak["fill_pct"] == pytest.approx(last.loc["peak", "fill_pct"], rel=1e-6)


def test_a_campaign_killed_within_a_round_reruns_only_the_missing_run(campaign):
    # killed after one of the last round's runs had finished and before the other had, so
    # the loop's table lacks the round's rows
    steps = _steps(campaign)
    asked_at = max(n for n, s in enumerate(steps, start=1) if s["status"] == "runs needed")
    runs = steps[asked_at - 1]["runs"]
    state = campaign / "results" / "refine" / "state" / "ceq_table.csv"
    before = _loop_table(campaign)
    table = pd.read_csv(state)
    theirs = table["case_id"].map(lambda ids: bool(set(str(ids).split(";")) & set(runs)))
    table[~theirs].to_csv(state, index=False)
    (campaign / "results" / "refine" / "work" / "cases" / f"{runs[0]}.json").unlink()
    _kill_after(campaign, asked_at)
    jobs = planned_jobs(snakemake(campaign, "--dry-run").stdout)
    assert jobs.get("run_refine_case") == 1
    run = snakemake(campaign, "refine")  # the loop's outputs; the designs on them: test above
    assert run.returncode == 0, run.stdout[-5000:]
    # the rerun run is the same plan on the same packings: the deterministic DEM gives the row
    # it gave
    pd.testing.assert_frame_equal(_loop_table(campaign), before)
    assert _steps(campaign)[asked_at - 1]["runs"] == runs


def test_a_campaign_killed_between_rounds_runs_no_case_again(campaign):
    state = campaign / "results" / "refine" / "state" / "ceq_table.csv"
    before = state.read_text()
    _kill_after(campaign, 1)
    run = snakemake(campaign, "refine")
    assert run.returncode == 0, run.stdout[-5000:]
    assert "run_refine_case" not in run.stdout
    # the loop's table is ahead of the steps: the second step finds every round's rows
    assert _steps(campaign)[-1]["status"] == "done"
    assert state.read_text() == before


def test_one_step_that_runs_the_cases_itself_gives_the_same_table(campaign, campaign_in_step):
    steps = _steps(campaign_in_step)
    assert len(steps) == 1 and steps[0]["status"] == "done"
    assert steps[0]["stopped_by"] == "max rounds reached"
    # the runs of the campaign whose steps asked for them as jobs (its records: the tests that
    # kill it rerun what they delete)
    asked = sorted(p.stem for p in (campaign / "results" / "refine" / "work" / "cases").glob("*.json"))
    assert sorted(steps[0]["runs_in_step"]) == asked
    pd.testing.assert_frame_equal(_loop_table(campaign_in_step), _loop_table(campaign))
    log = (campaign_in_step / "logs" / "refine" / "step1.log").read_text()
    assert log.count("refine: shook ") == len(asked)
    assert f"refine: the step ran {len(asked)} case(s); measured: shaking " in log


def test_a_step_killed_while_running_cases_reruns_only_the_missing_one(campaign_in_step):
    steps = _steps(campaign_in_step)
    runs = steps[0]["runs_in_step"]
    before = _loop_table(campaign_in_step)
    state = campaign_in_step / "results" / "refine" / "state" / "ceq_table.csv"
    table = pd.read_csv(state)
    # killed inside the last round's cases: its rows are not in the loop's table yet, one of
    # its runs' records is written, the other not
    last = table["refine_round"].max()
    last_runs = [r for ids in table.loc[table["refine_round"] == last, "case_id"]
                 for r in str(ids).split(";") if r in runs]
    assert len(last_runs) >= 2
    table[table["refine_round"] < last].to_csv(state, index=False)
    (campaign_in_step / "results" / "refine" / "work" / "cases" / f"{last_runs[0]}.json").unlink()
    _kill_after(campaign_in_step, 0)
    run = snakemake(campaign_in_step, "refine")
    assert run.returncode == 0, run.stdout[-5000:]
    assert _steps(campaign_in_step)[0]["runs_in_step"] == [last_runs[0]]
    pd.testing.assert_frame_equal(_loop_table(campaign_in_step), before)
