"""Where a finished campaign's CPU went and what its steps bought (issue 13), and how its grid
check reads (issue 12): the figures the README quotes from the default 5 % campaigns.

From ``results/cases/*.json``: the ``ok`` cases that reached the target; the CPU and the
reached count of the 1 g cases; the cases whose pilot failed a steady-state check
(``not_steady``/``not_stationary``), the CPU of their runs after the pilot and how many ended
without such a flag. From ``results/validation/grid.csv`` if present: the median |z_combined|
and |z_paired|, and the paired agreement by acceleration among the cases both solvers passed.

Run: .venv/bin/python benchmarks/campaign_breakdown.py RESULTS_DIR
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd
from _record import append

UNSTEADY = {"not_steady", "not_stationary"}


def main() -> None:
    results = Path(sys.argv[1])
    records = [json.loads(p.read_text()) for p in sorted((results / "cases").glob("*.json"))]
    ok = [r for r in records if r["status"] == "ok"]
    reached = [r for r in ok if (r.get("target") or {}).get("reached")]
    total_cpu = sum(r["target"]["cpu_time_s"] for r in records)
    one_g = [r for r in records if r["accel_g"] == 1]
    one_g_cpu = sum(r["target"]["cpu_time_s"] for r in one_g)
    unsteady = [r for r in records if UNSTEADY & set(r["target"]["runs"][0]["flags"])]
    after = sum(run["cpu_time_s"] for r in unsteady for run in r["target"]["runs"][1:])
    cleared = sum(1 for r in unsteady if not UNSTEADY & set(r["flags"]))
    lines = [f"{len(records)} cases, engine CPU {total_cpu:.0f} s; {len(reached)} of the {len(ok)} ok "
             f"cases reached their target; 1 g: {len(one_g)} cases, {one_g_cpu:.0f} s CPU "
             f"({one_g_cpu / total_cpu:.0%}), {sum(1 for r in one_g if r['target'].get('reached'))} "
             f"reached; pilots failing a steady-state check: {len(unsteady)}, their later runs "
             f"{after:.0f} s CPU, {cleared} of them ended without such a flag"]
    grid_path = results / "validation" / "grid.csv"
    if grid_path.is_file():
        grid = pd.read_csv(grid_path)
        both = grid[grid["both_ok"]]
        by_g = "; ".join(f"{g:g} g: {int(part['paired_agree'].sum())} of {len(part)}"
                         for g, part in both.groupby("accel_g"))
        lines.append(f"grid check: median |z_combined| {grid['z_combined'].abs().median():.2f}, "
                     f"median |z_paired| (both ok) {both['z_paired'].abs().median():.2f}; paired "
                     f"agreement of the cases both solvers passed: {by_g}")
    append("Campaign breakdown", f"python benchmarks/campaign_breakdown.py {results}", lines)


if __name__ == "__main__":
    main()
