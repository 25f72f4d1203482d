"""The refinement loop on the real compiled DEM (pidpipe.steps.refine, ``pidpipe refine``).

A small real table: the ``.test`` grid's 8 cases as DEM pilots of 1 cell x 10 measured cycles
(a few seconds once Numba's cache is warm); then the loop for real under a CPU budget that
stops it after a round or two, and a rerun that must resume without shaking anything.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import pandas as pd
import pytest
import yaml

pytest.importorskip("numba")

from pidpipe.cli import main  # noqa: E402
from pidpipe.config import load_config  # noqa: E402
from pidpipe.design.packing_noise import LOADS_COLUMN, parse_loads  # noqa: E402
from pidpipe.refine.candidates import Request  # noqa: E402
from pidpipe.steps.refine_engine import CaseEngine, pool_rows  # noqa: E402
from pidpipe.refine.loop import BUDGET_SPENT  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
GRID = [(f, g, r) for f in (500.0, 1000.0) for g in (5.0, 10.0) for r in (25.0, 50.0)]


@pytest.fixture(scope="module")
def problem(tmp_path_factory):
    """(config path, grid table path, the engine that made the grid)."""
    root = tmp_path_factory.mktemp("refine_dem")
    with open(REPO / ".test" / "config.yaml", encoding="utf-8") as stream:
        config = yaml.safe_load(stream)
    config["engine"] = "dem"
    config["surrogate"] = {"method": "gp", "allow_holes": True}
    # an interval criterion no round can meet, and a budget of a few cases: the loop must stop
    # on the budget
    config["refine"] = {"interval_fraction": 0.01, "max_cpu_s": 12.0, "cases_per_round": 2,
                        "max_rounds": 6}
    config_path = root / "config.yaml"
    config_path.write_text(yaml.safe_dump(config), encoding="utf-8")
    engine = CaseEngine.from_config(load_config(config_path), root / "grid_work")
    grid = engine.measure([Request(*point) for point in GRID], [])
    grid_path = root / "ceq_table.csv"
    grid.to_csv(grid_path, index=False)
    return config_path, grid_path, engine


def test_a_new_case_is_the_configured_pilot_and_costs_what_the_model_plans(problem):
    _, grid_path, engine = problem
    grid = pd.read_csv(grid_path)
    assert len(engine.runs) == len(GRID)
    assert list(grid["status"]) == ["ok"] * len(GRID)
    assert (grid["cells"] == 1).all() and (grid["n_cycles"] == 10).all()
    assert (grid["ceq_coupon_sem_ns_m"] > 0).all()
    costs = [engine.cost(Request(*point)) for point in GRID]
    assert all(c > 0 for c in costs)
    # the fuller cell and the higher frequency (more steps per second of motion) cost more
    assert engine.cost(Request(500.0, 5.0, 50.0)) > engine.cost(Request(500.0, 5.0, 25.0))


def test_an_extension_runs_three_times_the_base_effort_and_pools_it(problem):
    _, grid_path, engine = problem
    base = pd.read_csv(grid_path).iloc[0].to_dict()
    request = Request(base["freq_hz"], base["accel_g"], base["fill_pct"], "extend", factor=4.0,
                      base=base)
    plan = engine.plan(request)
    assert plan.cells == 3 and plan.case.replicate == 101
    assert engine.cost(request) > 2.5 * engine.cost(Request(*GRID[0]))
    row = engine.measure([], [request]).iloc[0]
    assert row["cells"] == 4 and row["n_replicates"] == 2
    assert row["ceq_coupon_sem_ns_m"] < base["ceq_coupon_sem_ns_m"]
    assert row["ceq_coupon_ns_m"] != base["ceq_coupon_ns_m"]
    # the row sits at the fill its cells hold (5 of 21 spheres), and the extension is named by it
    assert base["fill_pct"] == 23.81 and engine.runs[-1] == "f500Hz_G5_r23.81pct_rep101"
    # the base's one cell has no loads; the extension's three cells carry theirs, with the
    # extension's weight in the pooled mean
    loads = parse_loads(row[LOADS_COLUMN])
    assert len(loads) == 3
    weight = 1.0 - row["ceq_coupon_sem_ns_m"] ** 2 / base["ceq_coupon_sem_ns_m"] ** 2
    assert sum(w for w, _ in loads.values()) == pytest.approx(weight)


def test_pooling_is_by_inverse_variance_and_keeps_a_failed_extension_out():
    base = {"ceq_coupon_ns_m": 10.0, "ceq_coupon_sem_ns_m": 2.0, "ceq_cell_ns_m": 1.0,
            "ceq_cell_sem_ns_m": 0.2, "status": "ok", "flags": "", "n_replicates": 1,
            "cells": 1, "case_id": "a"}
    new = dict(base, ceq_coupon_ns_m=13.0, ceq_coupon_sem_ns_m=1.0, case_id="b", cells=3,
               status="flagged", flags="not_stationary")
    row = pool_rows(dict(base, **{LOADS_COLUMN: "0:0.5:1;1:0.5:-1"}),
                    dict(new, **{LOADS_COLUMN: "5:0.5:2;6:0.5:-2"}))
    loads = parse_loads(row[LOADS_COLUMN])
    for seed, (weight, load) in {0: (0.1, 0.2), 1: (0.1, -0.2), 5: (0.4, 1.6), 6: (0.4, -1.6)}.items():
        assert loads[seed] == pytest.approx((weight, load))
    assert row["ceq_coupon_ns_m"] == pytest.approx((10 / 4 + 13 / 1) / (1 / 4 + 1))
    assert row["ceq_coupon_sem_ns_m"] == pytest.approx(1 / math.sqrt(1 / 4 + 1))
    assert row["status"] == "flagged" and row["flags"] == "ext1:not_stationary"
    assert row["cells"] == 4 and row["n_replicates"] == 2
    failed = dict(new, status="failed", ceq_coupon_ns_m=float("nan"))
    kept = pool_rows(base, failed)
    assert kept["ceq_coupon_ns_m"] == 10.0 and kept["status"] == "ok"
    assert "ext1:failed" in kept["flags"]


def test_pidpipe_refine_adds_rounds_stops_on_the_budget_and_resumes(problem, tmp_path,
                                                                     capsys, monkeypatch):
    config_path, grid_path, _ = problem
    out = tmp_path / "refine"
    argv = ["--config", str(config_path), "refine", "--table", str(grid_path),
            "--output-dir", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    table = pd.read_csv(out / "state" / "ceq_table.csv")
    added = table[table["refine_round"] > 0]
    assert (table["source"] == "refine round 1").sum() >= 1
    assert set(added["source"]) <= {f"refine round {n}" for n in range(1, 7)} | {"verify"}
    assert (added["planned_cpu_s"] > 0).all()
    assert added["planned_cpu_s"].sum() <= 12.0
    assert (added["status"] == "ok").all() and (added["ceq_coupon_sem_ns_m"] > 0).all()
    assert f"stopped: {BUDGET_SPENT}" in printed
    assert "round 1:" in printed and "worst |z|" in printed
    rounds = pd.read_csv(out / "rounds.csv")
    assert rounds["round"].min() == 1 and (rounds["cumulative_cpu_s"] <= 12.0).all()

    def no_engine(*args, **kwargs):
        raise AssertionError("the engine ran on a resumed loop")

    monkeypatch.setattr("pidpipe.steps.cases.measure_case", no_engine)
    before = (out / "state" / "ceq_table.csv").read_text()
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert (out / "state" / "ceq_table.csv").read_text() == before
    assert f"stopped: {BUDGET_SPENT}" in printed and "the engine ran 0 case(s)" in printed

    # killed inside the last round's measure, after its cases had run: the table lacks their
    # rows, the work folder has their records; the rerun reads them and shakes nothing
    last = int(table["refine_round"].max())
    table[table["refine_round"] < last].to_csv(out / "state" / "ceq_table.csv", index=False)
    assert main(argv) == 0
    capsys.readouterr()
    assert pd.read_csv(out / "state" / "ceq_table.csv").equals(pd.read_csv(io.StringIO(before)))


def test_requests_run_on_two_cores_give_the_rows_they_give_one_after_another(problem, tmp_path):
    config_path, _, _ = problem
    config = load_config(config_path)
    points = [Request(750.0, 7.5, 25.0, "verify"), Request(750.0, 7.5, 50.0, "verify"),
              Request(600.0, 6.0, 25.0, "verify")]
    serial = CaseEngine.from_config(config, tmp_path / "serial")
    parallel = CaseEngine.from_config(config, tmp_path / "parallel", cores=2)
    one, two = serial.verify(points), parallel.verify(points)
    assert sorted(parallel.runs) == sorted(serial.runs) and len(parallel.runs) == 3
    assert parallel.measured["shake_cpu_s"] > 0
    for column in ("case_id", "ceq_coupon_ns_m", "ceq_coupon_sem_ns_m", "status", "n_spheres"):
        assert list(two[column]) == list(one[column])


def test_one_extension_on_two_cores_pours_its_packings_in_two_batches_first(problem, tmp_path,
                                                                           caplog):
    """A single request of several fresh packings: the two workers pour them ahead, half each,
    and the row is the one the same request gives run here alone."""
    config_path, grid_path, _ = problem
    config = load_config(config_path)
    base = pd.read_csv(grid_path).iloc[0].to_dict()
    request = Request(base["freq_hz"], base["accel_g"], base["fill_pct"], "extend", factor=5.0,
                      base=base)
    serial = CaseEngine.from_config(config, tmp_path / "serial")
    caplog.set_level("INFO", logger="pidpipe.refine")
    with CaseEngine.from_config(config, tmp_path / "parallel", cores=2) as parallel:
        plan = parallel.plan(request)
        assert plan.cells == 4
        two = parallel.measure([], [request])
        poured = sorted((tmp_path / "parallel" / "packings").glob("*.json"))
    one = serial.measure([], [request])
    assert len(poured) == 4 and parallel.measured["pour_cpu_s"] > 0
    assert "poured 4 packing(s) ahead in 2 batch(es)" in caplog.text
    for column in ("ceq_coupon_ns_m", "ceq_coupon_sem_ns_m", "status", "cells"):
        assert list(two[column]) == list(one[column])


def test_an_extension_of_a_case_its_allocation_took_past_the_pilot_keeps_its_cycles(problem):
    _, _, engine = problem
    # the DEM campaign's f1000Hz_G1_r90pct: the allocation took it to 20 cells x 400 cycles
    base = {"freq_hz": 1000.0, "accel_g": 1.0, "fill_pct": 50.0, "status": "ok",
            "regime_cells": "no_lift_off:20", "cells_per_run": 20, "measured_cycles": 400,
            "n_replicates": 1, "ceq_coupon_ns_m": 1.0, "ceq_coupon_sem_ns_m": 0.04}
    request = Request(1000.0, 1.0, 50.0, "extend", factor=4.0, base=base)
    plan = engine.plan(request)
    assert (plan.cells, plan.measured_cycles) == (60, 400)
    pilot = engine.plan(Request(1000.0, 1.0, 50.0))
    assert (pilot.cells, pilot.measured_cycles) == (1, 10)
    assert set(plan.packings).isdisjoint(pilot.packings)
    assert engine.cost(request) > 60 * engine.cost(Request(1000.0, 1.0, 50.0))


def test_a_rounds_designs_in_the_workers_are_the_designs_optimised_here(problem, tmp_path):
    """The loop optimises a round's designs in the engine's workers (CaseEngine.map): each
    design is the one optimised here, bit for bit, in the same order."""
    from pidpipe.design.designs import Search, optimise_designs
    from pidpipe.design.optimisation import Budget, Environment
    from pidpipe.design.surrogate import fit_surrogate

    _, grid_path, _ = problem
    model = fit_surrogate(pd.read_csv(grid_path), method="gp", allow_holes=True)
    environments = [Environment("a", (600.0, 700.0), (6.0, 8.0)),
                    Environment("b", (800.0, 900.0), (5.0, 7.0))]
    budget, search = Budget(2000, 21, 441), Search(starts=3, seed=1)
    here = optimise_designs(model, environments, budget, search)
    with CaseEngine.from_config(load_config(problem[0]), tmp_path / "work", cores=2) as engine:
        there = optimise_designs(model, environments, budget, search, engine.map)
        assert engine._pool is not None                  # the workers ran them
    assert [(r.environment.name, r.kind) for r in there] == [(r.environment.name, r.kind) for r in here]
    for a, b in zip(here, there):
        assert (a.design.fill_pct, a.design.n_cells, a.design.total_ceq_ns_m) == \
            (b.design.fill_pct, b.design.n_cells, b.design.total_ceq_ns_m)
        assert a.band.mean_total_ceq_ns_m == b.band.mean_total_ceq_ns_m
