"""The loop bound to its files: a finished campaign run again asks the engine for nothing."""

import json

import pandas as pd

from pidpipe.config.refine import RefineSettings
from pidpipe.refine.campaign import refine_files
from pidpipe.refine.loop import CRITERION_MET

from ._fakes import BUDGET, ENVIRONMENTS, SEARCH, FakeEngine, GPSurrogate

SETTINGS = RefineSettings(interval_fraction=0.10, max_cpu_s=2000.0, cases_per_round=3,
                          max_rounds=15)


def _run(engine, grid, out):
    return refine_files(grid, out, GPSurrogate, engine.measure, engine.verify, engine.cost,
                        ENVIRONMENTS, BUDGET, SEARCH, SETTINGS, 2.0)


def test_the_files_say_what_stopped_the_loop_and_a_rerun_runs_nothing(tmp_path):
    grid = tmp_path / "ceq_table.csv"
    FakeEngine().grid().to_csv(grid, index=False)
    out = tmp_path / "refine"
    engine = FakeEngine()
    outcome = _run(engine, grid, out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stopped_by"] == outcome.stopped_by == CRITERION_MET
    assert summary["open"] == []
    assert len(summary["designs"]) == 6
    assert all(d["half_width_fraction"] <= 0.10 for d in summary["designs"])
    rounds = pd.read_csv(out / "rounds.csv")
    assert sorted(set(rounds["round"])) == list(range(1, max(rounds["round"]) + 1))
    assert rounds["cumulative_cpu_s"].iloc[-1] == summary["planned_cpu_s"] > 0
    assert (out / "convergence.png").is_file() and (out / "convergence.pdf").is_file()
    points = pd.read_csv(out / "verify_points.csv")
    assert len(points) == len(outcome.rounds[-1].comparison) > 0
    assert points["passes"].all() and (points["z"].abs() <= 2.0).all()
    assert {"dem_dof", "t", "z", "surrogate_std_ns_m"} <= set(points.columns)
    table = pd.read_csv(out / "ceq_table.csv")
    assert len(table) == len(outcome.table)

    again = FakeEngine()
    rerun = _run(again, grid, out)
    assert again.requests == []
    assert rerun.stopped_by == CRITERION_MET
    assert len(pd.read_csv(out / "ceq_table.csv")) == len(table)
    assert pd.read_csv(out / "rounds.csv")["round"].tolist() == rounds["round"].tolist()
