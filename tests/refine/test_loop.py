"""The loop on an analytic C_eq with a known optimum and a fake engine with synthetic noise."""

from collections import Counter

import numpy as np
import pytest

from pidpipe.config.refine import RefineSettings
from pidpipe.design.designs import optimise_designs
from pidpipe.refine.loop import BUDGET_SPENT, CRITERION_MET, refine
from pidpipe.refine.outputs import read_table, write_table
from pidpipe.refine.table import GRID_SOURCE, VERIFY_SOURCE, round_source

from ._fakes import BUDGET, ENVIRONMENTS, SEARCH, FakeEngine, GPSurrogate, TrueModel

SETTINGS = RefineSettings(interval_fraction=0.10, max_cpu_s=2000.0, cases_per_round=3,
                          max_rounds=15)
FLAG_Z = 2.0


def run(engine, table, settings=SETTINGS, **kwargs):
    return refine(table, GPSurrogate, engine.measure, engine.verify, engine.cost, ENVIRONMENTS,
                  BUDGET, SEARCH, settings, FLAG_Z, **kwargs)


@pytest.fixture(scope="module")
def whole():
    """One uninterrupted loop from the grid: (engine, outcome)."""
    engine = FakeEngine()
    return engine, run(engine, engine.grid())


@pytest.fixture(scope="module")
def truth():
    """Every design optimised on the analytic C_eq itself."""
    return optimise_designs(TrueModel(), ENVIRONMENTS, BUDGET, SEARCH)


def test_the_loop_stops_when_every_design_verifies_within_the_interval_criterion(whole):
    _, outcome = whole
    assert outcome.stopped_by == CRITERION_MET
    assert outcome.open == []
    assert len(outcome.intervals) == 6
    for interval in outcome.intervals:
        assert interval.half_width_fraction <= SETTINGS.interval_fraction
    last = outcome.rounds[-1]
    assert all(np.isfinite(z) and z <= FLAG_Z for z in last.worst_z.values())
    assert len(outcome.rounds) >= 2          # the grid alone did not meet the criterion
    first = outcome.rounds[0]
    assert any(i.half_width_fraction > SETTINGS.interval_fraction for i in first.intervals)


def test_each_designs_interval_covers_the_true_optimum(whole, truth):
    _, outcome = whole
    for interval, true in zip(outcome.intervals, truth):
        assert (interval.environment, interval.kind) == (true.environment.name, true.kind)
        assert interval.lo <= true.design.total_ceq_ns_m <= interval.hi, interval


def test_the_rows_say_where_they_came_from_and_why(whole):
    _, outcome = whole
    table = outcome.table
    grid = table[table["refine_round"] == 0]
    assert set(grid["source"]) == {GRID_SOURCE}
    added = table[table["refine_round"] > 0]
    for _, row in added.iterrows():
        if row["action"] in ("verify", "reverify"):
            assert row["source"] == VERIFY_SOURCE
        else:
            assert row["source"] == round_source(row["refine_round"])
        assert row["reason"]
    assert {"new", "verify"} <= set(added["action"])
    assert outcome.rounds[-1].cumulative_cpu_s == pytest.approx(added["planned_cpu_s"].sum())


def test_a_round_whose_intervals_all_meet_the_criterion_runs_only_what_its_failing_points_ask(
        whole):
    _, outcome = whole
    table = outcome.table
    narrow = [r.round for r in outcome.rounds
              if all(i.half_width_fraction <= SETTINGS.interval_fraction for i in r.intervals)]
    assert narrow
    for index in narrow:
        fitted = table[(table["refine_round"] == index) & table["action"].isin(["new", "extend"])]
        assert all(reason.startswith("verify |z|") for reason in fitted["reason"]), fitted


def test_an_unreachable_criterion_stops_at_the_cpu_budget_and_says_so():
    engine = FakeEngine()
    settings = RefineSettings(interval_fraction=0.01, max_cpu_s=150.0, cases_per_round=3,
                              max_rounds=50)
    outcome = run(engine, engine.grid(), settings)
    assert outcome.stopped_by == BUDGET_SPENT
    spent = outcome.table["planned_cpu_s"].sum()
    assert spent <= settings.max_cpu_s
    assert settings.max_cpu_s - spent < 30.0           # less than the dearest request is left
    assert len(outcome.open) == 6
    assert all("wider than +-1 %" in line for line in outcome.open)


def _killed_then_resumed(tmp_path, kill):
    """Run until ``kill`` interrupts, saving the table as it grows; resume from the file."""
    path = tmp_path / "ceq_table.csv"
    first = FakeEngine(**kill.get("engine", {}))
    with pytest.raises(KeyboardInterrupt):
        run(first, first.grid(), save=lambda table: write_table(table, path),
            on_round=kill.get("on_round"))
    saved = read_table(path)
    second = FakeEngine()
    return saved, second, run(second, saved)


def _requests(table):
    rows = table[table["refine_round"] > 0]
    return Counter(zip(rows["case_key"], rows["action"], rows["refine_round"]))


def _stop_after_round(k):
    def on_round(record):
        if record.round == k:
            raise KeyboardInterrupt(f"killed after round {k}")
    return on_round


@pytest.mark.parametrize("kill", [
    {"on_round": _stop_after_round(2)},               # between rounds
    {"engine": {"fail_after": 21}},                   # in round 3, after its verifying runs
], ids=["between_rounds", "within_a_round"])
def test_a_killed_loop_resumes_with_only_the_missing_cases_and_ends_the_same(tmp_path, whole, kill):
    _, outcome = whole
    saved, second, resumed = _killed_then_resumed(tmp_path, kill)
    last = saved["refine_round"].max()
    assert last >= 2
    if "engine" in kill:                               # the kill left round 3 half done
        assert set(saved.loc[saved["refine_round"] == last, "action"]) == {"verify"}
    # the resumed table starts with the saved rows, and the engine was asked only for the rest
    assert resumed.table.iloc[:len(saved)]["case_key"].tolist() == saved["case_key"].tolist()
    assert len(second.requests) == len(resumed.table) - len(saved)
    assert resumed.stopped_by == outcome.stopped_by
    assert _requests(resumed.table) == _requests(outcome.table)
    for a, b in zip(resumed.intervals, outcome.intervals):
        assert (a.total_ceq_ns_m, a.std_ns_m, a.fill_pct) == pytest.approx(
            (b.total_ceq_ns_m, b.std_ns_m, b.fill_pct), rel=1e-9)


def test_the_same_inputs_choose_the_same_cases():
    tables = []
    for _ in range(2):
        engine = FakeEngine()
        settings = RefineSettings(0.10, 2000.0, 3, max_rounds=2)
        tables.append(run(engine, engine.grid(), settings).table)
    chosen = [t[t["refine_round"] > 0][["case_key", "action", "reason"]] for t in tables]
    assert len(chosen[0]) > 0
    assert chosen[0].reset_index(drop=True).equals(chosen[1].reset_index(drop=True))


def test_a_design_whose_whole_sphere_fill_leaves_the_domain_gets_a_case_there_and_verifies():
    """The default campaign's case: 21 spheres at 100 %, the design at the lowest grid fill
    25 %, which a cell holds as 5 spheres, 23.81 %, below the surrogate's fill domain."""
    from pidpipe.design.optimisation import Budget
    from pidpipe.loop.verify import poured_fill

    from ._fakes import RefusingGP

    def falling(f, g, r):                       # T ~ C / r falls with r: the design sits at 25 %
        return 0.6 * np.asarray(r, dtype=float) ** 0.5 * (500.0 / np.asarray(f)) ** 0.5 * (
            np.asarray(g) / 3.0) ** 0.4

    budget = Budget(n_spheres=2000, full_cell_spheres=21, n_cells_coupon=441, n_cells_panel=1000)
    engine = FakeEngine(truth=falling)
    outcome = refine(engine.grid(), RefusingGP, engine.measure, engine.verify, engine.cost,
                     ENVIRONMENTS[:1], budget, SEARCH, SETTINGS, FLAG_Z)
    table = outcome.table
    below = table[(table["fill_pct"] < 25.0) & (table["refine_round"] > 0)]
    assert set(below["fill_pct"].round(2)) == {23.81}
    reasons = " ".join(below.loc[below["action"] == "new", "reason"])
    assert "outside the surrogate's domain" in reasons
    assert outcome.stopped_by == CRITERION_MET
    # every design now lies at the domain's new lowest fill, and pours as 5 spheres there
    assert all(poured_fill(i.fill_pct, 21) == (23.81, 5) for i in outcome.intervals)
    assert all(z <= FLAG_Z for z in outcome.rounds[-1].worst_z.values())


def test_a_budget_stop_still_reports_the_designs_whose_points_were_verified(whole):
    # the finished loop's table without one environment's verifying runs, and a budget that
    # cannot pay for them again: the other environment's designs keep their |z|, only the
    # first's are open
    _, outcome = whole
    table = outcome.table
    last = outcome.rounds[-1].comparison
    environment = last["design"].str.split("/").str[0]
    first = environment.iloc[0]
    theirs = set(last.loc[environment == first, "case_key"])
    assert theirs.isdisjoint(last.loc[environment != first, "case_key"])
    dropped = table[~((table["source"] == VERIFY_SOURCE) & table["case_key"].isin(theirs))]
    # the resumed loop decides the last round again: what it had spent before that round and
    # what its verifying runs cost, less a little
    n = int(table["refine_round"].max())
    spent = table.loc[(table["refine_round"] < n) | ((table["refine_round"] == n)
                                                     & (table["action"] == "verify")),
                      "planned_cpu_s"].sum()
    budget = float(spent) - 1e-6
    settings = RefineSettings(interval_fraction=0.10, max_cpu_s=budget, cases_per_round=3,
                              max_rounds=50)
    engine = FakeEngine()
    resumed = run(engine, dropped, settings)
    assert resumed.stopped_by == BUDGET_SPENT and engine.requests == []
    mine = [line for line in resumed.open if line.startswith(first + "/")]
    assert mine and all(line.endswith(": not verified") for line in mine)
    # the other environment's designs are compared with the runs they have (the old record
    # said "not verified" for every design at a budget stop)
    others = {d: z for d, z in resumed.rounds[-1].worst_z.items() if not d.startswith(first + "/")}
    assert others and all(np.isfinite(z) for z in others.values())
    assert not any("not verified" in line for line in resumed.open
                   if not line.startswith(first + "/"))
