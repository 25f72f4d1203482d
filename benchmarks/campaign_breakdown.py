"""Where did a finished campaign's CPU go, what did its steps buy (issue 13), and how does its
grid check read (issue 12)? The figures the README quotes from the default 5 % campaigns.

From ``results/cases/*.json`` (a case made without a target counts its pilot alone): the ``ok`` cases that reached the target; the CPU and the
reached count of the 1 g cases; the engine CPU of the runs by kind, used and not used (a
pilot replaced by a longer run is not used); each case's CPU over its pilot's, by
acceleration; the flagged cases and the spread between packings over C_eq, by acceleration;
the cases whose pilot failed a steady-state check (``not_steady``/
``not_stationary``), the CPU of their runs after the pilot and how many ended without such a
flag. From ``results/validation/grid.csv`` if present: the median |z_combined|
and |z_paired|, the paired agreement by acceleration among the cases both solvers passed, the
median |paired_rel_diff| by acceleration, each 1 g case's paired difference and the cases
beyond 2 paired SEM.
With ``--against OTHER_RESULTS_DIR`` (the same config run by other code): for the cases both
have, whether their records agree apart from timing (C_eq, its SEM, cells and cycles, flags),
and the engine CPU of those cases in each, by frequency, as a ratio measured on the same cases;
then each case measured differently, with its cells, cycles, status, flags and CPU in each.

Figures go to ``benchmarks/records/campaign_breakdown.json`` (:mod:`harness`).

Run: .venv/bin/python benchmarks/campaign_breakdown.py RESULTS_DIR [--against OTHER_RESULTS_DIR]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd
from harness import record

UNSTEADY = {"not_steady", "not_stationary"}
SAME_KEYS = ("ceq_cell_ns_m", "ceq_cell_sem_ns_m", "status", "flags")
"""What two records of one case must share to count as the same measurement (besides cells and cycles)."""


def load_records(results: Path) -> list[dict]:
    """Every case record of a results folder, by case id order; a record made without a target
    (``fidelity.target_relative_sem: null``) gets one of its pilot alone (:func:`pilot_only`)."""
    records = [json.loads(p.read_text()) for p in sorted((results / "cases").glob("*.json"))]
    for record in records:
        if not record.get("target"):
            record["target"] = pilot_only(record)
    return records


def pilot_only(record: dict) -> dict:
    """The ``target`` entry of a case measured by its pilot alone: one used run, its engine CPU
    (s), cells and cycles, not reached (there was no target)."""
    engine = record.get("engine") or {}
    cpu = engine.get("cpu_time_s", engine.get("liggghts_cpu_time_s", 0.0))
    return {"cpu_time_s": cpu, "reached": False, "no_target": True,
            "cells": int((record.get("fidelity") or {}).get("cells_per_run", 1)),
            "measured_cycles": int(record.get("n_cycles", 0)),
            "runs": [{"kind": "pilot", "used": True, "cpu_time_s": cpu, "flags": record.get("flags", [])}]}


def cpu_by_kind(records: list[dict]) -> str:
    """The engine CPU of the cases' runs by kind, used and not used (a run replaced by a longer
    one), s: e.g. ``pilot 88.7 / 38.9; more_cycles (continued) 20.1 / 0.0``."""
    sums: dict[str, list[float]] = {}
    for record in records:
        for run in (record.get("target") or {}).get("runs", []):
            kind = run["kind"] + (" (continued)" if run.get("continued") else "")
            sums.setdefault(kind, [0.0, 0.0])[0 if run["used"] else 1] += run["cpu_time_s"]
    return "; ".join(f"{kind} {used:.1f} / {unused:.1f}" for kind, (used, unused) in sums.items())


def growth_by_acceleration(records: list[dict]) -> str:
    """Each case's engine CPU over its pilot's, median and largest by acceleration: how much of
    a case the pilot's cost foretells (the DEM jobs are scheduled by it)."""
    ratios: dict[float, list[float]] = {}
    for record in records:
        runs = (record.get("target") or {}).get("runs", [])
        if runs and runs[0]["cpu_time_s"] > 0:
            ratios.setdefault(record["accel_g"], []).append(
                record["target"]["cpu_time_s"] / runs[0]["cpu_time_s"])
    return "; ".join(f"{g:g} g {pd.Series(v).median():.1f} ({max(v):.1f})"
                     for g, v in sorted(ratios.items()))


def spread_by_acceleration(records: list[dict]) -> str:
    """By acceleration: the flagged cases, and each case's spread between packings over its
    C_eq (``ceq_cell_packing_std_ns_m`` / ``ceq_cell_ns_m``), median and range: what more cells
    must beat when a target is out of reach."""
    parts = []
    for g in sorted({r["accel_g"] for r in records}):
        here = [r for r in records if r["accel_g"] == g]
        spread = pd.Series([r.get("ceq_cell_packing_std_ns_m", float("nan")) / abs(r["ceq_cell_ns_m"])
                            for r in here if r["ceq_cell_ns_m"]]).dropna()
        flagged = sum(1 for r in here if r["status"] == "flagged")
        parts.append(f"{g:g} g {flagged} of {len(here)} flagged, spread {spread.median():.0%} "
                     f"({spread.min():.0%}-{spread.max():.0%})")
    return "; ".join(parts)


def paired_cpu(records: list[dict], others: list[dict], other_dir: Path) -> list[str]:
    """Lines comparing the engine CPU of the cases both campaigns have, by frequency."""
    theirs = {r["case_id"]: r for r in others}
    pairs = [(r, theirs[r["case_id"]]) for r in records if r["case_id"] in theirs]
    def alike(a: dict, b: dict) -> bool:
        return (all(a.get(k) == b.get(k) for k in SAME_KEYS)
                and a["target"]["cells"] == b["target"]["cells"]
                and a["target"]["measured_cycles"] == b["target"]["measured_cycles"])

    def outcome(record: dict) -> str:
        target = record["target"]
        flags = ", ".join(record["flags"]) or "no flags"
        return (f"{target['cells']} cells x {target['measured_cycles']} cycles, {record['status']} "
                f"({flags}), {target['cpu_time_s']:.1f} CPU-s")

    same = sum(alike(a, b) for a, b in pairs)
    header = (f"against {other_dir}: {len(pairs)} cases in both, {same} of them the same measurement "
              "(C_eq, SEM, status, flags, cells, cycles)")
    lines = [header, "",
             "| frequency Hz | cases | CPU s here | CPU s there | here / there |", "|---|---|---|---|---|"]
    frame = pd.DataFrame([{"freq": a["freq_hz"], "here": a["target"]["cpu_time_s"],
                           "there": b["target"]["cpu_time_s"]} for a, b in pairs])
    for freq, part in [*frame.groupby("freq"), ("all", frame)]:
        label = freq if freq == "all" else f"{freq:g}"
        lines.append(f"| {label} | {len(part)} | {part['here'].sum():.0f} | {part['there'].sum():.0f} | "
                     f"{part['here'].sum() / part['there'].sum():.2f} |")
    differing = [(a, b) for a, b in pairs if not alike(a, b)]
    if differing:
        lines += ["", "The cases measured differently (here / there):"]
        lines += [f"- {a['case_id']}: {outcome(a)} / {outcome(b)}" for a, b in differing]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=Path, help="a finished campaign's results/ folder")
    parser.add_argument("--against", type=Path, metavar="OTHER_RESULTS_DIR",
                        help="the same config's results from other code, to compare with")
    args = parser.parse_args()
    results = args.results
    records = load_records(results)
    ok = [r for r in records if r["status"] == "ok"]
    reached = [r for r in ok if (r.get("target") or {}).get("reached")]
    total_cpu = sum(r["target"]["cpu_time_s"] for r in records)
    one_g = [r for r in records if r["accel_g"] == 1]
    one_g_cpu = sum(r["target"]["cpu_time_s"] for r in one_g)
    unsteady = [r for r in records if UNSTEADY & set(r["target"]["runs"][0]["flags"])]
    after = sum(run["cpu_time_s"] for r in unsteady for run in r["target"]["runs"][1:])
    cleared = sum(1 for r in unsteady if not UNSTEADY & set(r["flags"]))
    figures = {"cases": len(records), "engine_cpu_s": round(total_cpu, 1), "ok": len(ok),
               "cases_without_target": sum(1 for r in records if r["target"].get("no_target")),
               "ok_reached": len(reached), "one_g_cases": len(one_g), "one_g_cpu_s": round(one_g_cpu, 1),
               "one_g_reached": sum(1 for r in one_g if r["target"].get("reached")),
               "unsteady_pilots": len(unsteady), "unsteady_later_runs_cpu_s": round(after, 1),
               "unsteady_cleared": cleared, "cpu_by_kind_used_unused_s": cpu_by_kind(records),
               "case_over_pilot_cpu_by_g": growth_by_acceleration(records),
               "flagged_and_packing_spread_by_g": spread_by_acceleration(records)}
    lines = [f"{len(records)} cases, engine CPU {total_cpu:.0f} s; {len(reached)} of the {len(ok)} ok "
             f"cases reached their target; 1 g: {len(one_g)} cases, {one_g_cpu:.0f} s CPU "
             f"({one_g_cpu / total_cpu:.0%}), {sum(1 for r in one_g if r['target'].get('reached'))} "
             f"reached; pilots failing a steady-state check: {len(unsteady)}, their later runs "
             f"{after:.0f} s CPU, {cleared} of them ended without such a flag",
             f"engine CPU of the runs by kind (used / not used), s: {cpu_by_kind(records)}",
             "a case's CPU over its pilot's, median (largest), by acceleration: "
             f"{growth_by_acceleration(records)}",
             "flagged cases and the spread between packings over C_eq, median (range), by "
             f"acceleration: {spread_by_acceleration(records)}"]
    grid_path = results / "validation" / "grid.csv"
    if grid_path.is_file():
        grid = pd.read_csv(grid_path)
        both = grid[grid["both_ok"]]
        by_g = "; ".join(f"{g:g} g: {int(part['paired_agree'].sum())} of {len(part)}"
                         for g, part in both.groupby("accel_g"))
        lines.append(f"grid check: median |z_combined| {grid['z_combined'].abs().median():.2f}, "
                     f"median |z_paired| (both ok) {both['z_paired'].abs().median():.2f}; paired "
                     f"agreement of the cases both solvers passed: {by_g}")
        size = "; ".join(f"{g:g} g: {part['paired_rel_diff'].abs().median():.2%}"
                         for g, part in both.groupby("accel_g"))
        one_g = ", ".join(f"{row.case_id} {row.paired_rel_diff:+.3%} (z_paired {row.z_paired:+.1f})"
                          for row in both[both["accel_g"] == 1].itertuples())
        lines.append(f"median |paired_rel_diff| (both ok): {size}; at 1 g: {one_g}")
        beyond = ", ".join(f"{row.case_id} {row.paired_rel_diff:+.1%} (z_paired {row.z_paired:+.1f})"
                           for row in both[both["z_paired"].abs() > 2].itertuples())
        lines.append(f"beyond 2 paired SEM (both ok): {beyond or 'none'}")
        figures.update({"grid_median_abs_z_combined": round(float(grid["z_combined"].abs().median()), 3),
                        "grid_median_abs_z_paired": round(float(both["z_paired"].abs().median()), 3),
                        "grid_paired_agreement_by_g": by_g, "grid_median_abs_paired_rel_diff_by_g": size,
                        "grid_one_g_paired": one_g, "grid_beyond_2_paired_sem": beyond or "none"})
    if args.against:
        compared = paired_cpu(records, load_records(args.against), args.against)
        lines += ["", *compared]
        theirs = {r["case_id"]: r for r in load_records(args.against)}
        pairs = [(r, theirs[r["case_id"]]) for r in records if r["case_id"] in theirs]
        figures["against"] = compared[0]
        if pairs:
            figures["cpu_here_over_there"] = round(
                sum(a["target"]["cpu_time_s"] for a, _ in pairs)
                / sum(b["target"]["cpu_time_s"] for _, b in pairs), 3)
    print("\n".join(lines))
    record("campaign_breakdown", figures)


if __name__ == "__main__":
    main()
