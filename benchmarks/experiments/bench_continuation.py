"""What continuing the DEM's runs saves (issue 13): the cases of a finished ``engine: dem``
campaign that took a more-cycles or both step, measured again both ways in this process.

Each case is measured to its target twice with today's code, on the campaign's pilot packings
and pool: once continuing its runs for more cycles (``engine: dem``'s default) and once making
them again, longer, from the pour (the replay, LIGGGHTS' way). The engine CPU of the runs by kind
(:func:`campaign_breakdown.cpu_by_kind`), the planned CPU and how many cases reached their
target are printed for both, and their ratio. The pool is copied to a scratch folder first
(packings a plan needs that the campaign did not pour are poured there, with the campaign's
settings, and their CPU is not counted), so the campaign's folder is only read. The first
case is shaken once beforehand, not counted, so that loading the compiled kernel is in neither.

Run: .venv/bin/python benchmarks/experiments/bench_continuation.py CAMPAIGN_DIR [--cases ID ...]
(CAMPAIGN_DIR holds config.yaml and results/; by default every case whose record has a
``more_cycles`` or ``both`` step.)
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402
from campaign_breakdown import cpu_by_kind

from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import load_packing
from pidpipe.config.schema import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.dem.case import run_dem_case
from pidpipe.steps.cases import measure_case
from pidpipe.steps.params import case_packing_ids

STEP_KINDS = {"more_cycles", "both"}


def chosen_cases(results: Path) -> list[str]:
    """The cases whose record took a more-cycles or both step."""
    chosen = []
    for path in sorted((results / "cases").glob("*.json")):
        record = json.loads(path.read_text())
        if STEP_KINDS & {step["kind"] for step in (record.get("target") or {}).get("steps", [])}:
            chosen.append(record["case_id"])
    return chosen


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("campaign", type=Path)
    parser.add_argument("--cases", nargs="*")
    args = parser.parse_args()
    config = load_config(args.campaign / "config.yaml")
    if config["engine"] != "dem":
        raise SystemExit(f"{args.campaign}: engine {config['engine']!r}, not dem")
    results = args.campaign / "results"
    case_ids = args.cases or chosen_cases(results)
    settings, pour_settings = ShakeSettings.from_config(config), PourSettings.from_config(config)
    records = {"continued": [], "replayed": []}
    with tempfile.TemporaryDirectory(prefix="bench_continuation_") as scratch:
        pool = Path(scratch) / "pool"
        shutil.copytree(results / "packings" / "pool", pool)
        for n, case_id in enumerate(case_ids):
            case = CaseSpec.from_id(case_id)
            packings = [load_packing(results / "packings" / f"{packing_id}.json")
                        for packing_id in case_packing_ids(config, case)]
            if n == 0:      # warm up: the kernel's first call loads it from Numba's cache
                run_dem_case(settings, case, packings)
            for label, continue_runs in (("continued", True), ("replayed", False)):
                records[label].append(measure_case(settings, case, packings,
                                                   Path(scratch) / label / case_id, pour_settings,
                                                   pool, continue_runs=continue_runs))
    lines = [f"{len(case_ids)} cases of {args.campaign} (engine dem) that took a more_cycles or "
             f"both step there, each measured to its {settings.sampling.target_relative_sem:.0%} "
             "target with its runs continued and replayed, in one process:", "",
             "| runs | engine CPU s | planned CPU s | cases at target | CPU by kind (used / not used), s |",
             "|---|---|---|---|---|"]
    totals = {}
    for label, cases in records.items():
        cpu = sum(r.target["cpu_time_s"] for r in cases)
        planned = sum(r.target["planned_cpu_s"] for r in cases)
        reached = sum(bool(r.target["reached"]) for r in cases)
        totals[label] = cpu
        lines.append(f"| {label} | {cpu:.1f} | {planned:.1f} | {reached} of {len(cases)} | "
                     f"{cpu_by_kind([r.to_dict() for r in cases])} |")
    same_plan = [(mine, theirs) for mine, theirs in zip(records["continued"], records["replayed"])
                 if _plan(mine) == _plan(theirs)]
    same = sum(mine.ceq_cell_ns_m == theirs.ceq_cell_ns_m
               and mine.ceq_cell_sem_ns_m == theirs.ceq_cell_sem_ns_m
               and mine.flags == theirs.flags for mine, theirs in same_plan)
    lines += ["", f"continued / replayed engine CPU: {totals['continued'] / totals['replayed']:.2f} "
              f"({totals['replayed'] - totals['continued']:.1f} s saved); {len(same_plan)} cases "
              f"took the same steps both ways, {same} of them with the same C_eq, SEM and flags "
              "to the last bit", "",
              "| case | continued: steps, CPU s, SEM % | replayed: steps, CPU s, SEM % |", "|---|---|---|"]
    for mine, theirs in zip(records["continued"], records["replayed"]):
        lines.append(f"| {mine.case_id} | {_steps(mine)} | {_steps(theirs)} |")
    command = f"python benchmarks/experiments/bench_continuation.py {args.campaign}"
    if args.cases:
        command += " --cases " + " ".join(args.cases)
    append("Continuing the DEM's runs for more cycles", command, lines)


def _plan(record) -> list:
    """A case's steps (a CaseRecord's): kind, cells added and cycles of each."""
    return [(step["kind"], step["new_cells"], step["cycles"]) for step in record.target["steps"]]


def _steps(record) -> str:
    target = record.target
    kinds = "+".join(step["kind"] for step in target["steps"]) or "pilot only"
    return (f"{kinds}, {target['cpu_time_s']:.1f}, "
            f"{100 * record.ceq_cell_sem_ns_m / record.ceq_cell_ns_m:.1f}")


if __name__ == "__main__":
    main()
