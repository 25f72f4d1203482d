"""What does a whole campaign cost on this machine, wall and CPU, and where by stage? (issues 3, 13)

Runs ``snakemake --cores 2`` on a config (default: the repository's config.yaml, the 60-case
reference campaign) in a scratch copy of the workflow, then sums the per-job benchmark files
and the case records: wall and engine CPU time per frequency (every run a case made, its
target's included), every case's relative SEM, how many cases reached their target (and how
many were not chased: C_eq not resolved from zero, or a pilot flagged not_steady or
not_stationary), the cells and cycles they ended with, and
the pours (the grid's and those poured on demand into the shared pool).

Its figures go to ``benchmarks/records/bench_campaign.json`` (:mod:`harness`).

Run: .venv/bin/python benchmarks/bench_campaign.py [config.yaml] [--cores 2]
         [--set fidelity.target_relative_sem=0.1 --set grid.freq_hz=[500,1000] ...] [--keep DIR]
         [--workdir DIR]

``--workdir DIR`` runs the campaign in DIR (created, kept afterwards) instead of a scratch
folder, so that its results can be used again, e.g. by ``snakemake validate`` in DIR; the
figures are also written to DIR/bench_campaign.json (read by ``compare_campaigns.py``). With
``refine.enabled`` the refinement loop's runs (``results/refine/work/cases``) are counted too.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd
from harness import REPO, SNAKEMAKE, load_average, measured, record, scratch_workflow


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default=str(REPO / "config.yaml"),
                        help="the campaign's config (default: the repository's config.yaml)")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=YAML",
                        help="override one config value (repeatable)")
    parser.add_argument("--keep", metavar="DIR", help="copy the case records here")
    parser.add_argument("--workdir", metavar="DIR",
                        help="run in DIR and keep it (default: a scratch folder, removed)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(args.workdir) if args.workdir else Path(scratch)
        if args.workdir:
            work.mkdir(parents=True, exist_ok=False)
        config = scratch_workflow(work, args.config, args.set)
        load_before = load_average()
        with measured() as run:
            done = subprocess.run([SNAKEMAKE, "--cores", str(args.cores), "--quiet", "rules", "all"],
                                  cwd=work, check=False, stdout=subprocess.DEVNULL)
        load_after = load_average()
        if done.returncode != 0:
            sys.exit(f"snakemake failed (exit {done.returncode}); nothing recorded")
        wall, cpu = run.wall_s, run.children_cpu_s
        rows = []
        for tsv in (work / "results" / "benchmarks").rglob("*.tsv"):
            frame = pd.read_csv(tsv, sep="\t")
            rows.append({"rule": tsv.parent.name if tsv.parent.name != "benchmarks" else tsv.stem,
                         "job": tsv.stem, "s": float(frame["s"].iloc[0])})
        jobs = pd.DataFrame(rows)
        records = [json.loads(p.read_text()) for p in (work / "results" / "cases").glob("*.json")]
        refine_records = [json.loads(p.read_text()) for p in
                          (work / "results" / "refine" / "work" / "cases").glob("*.json")]
        pool = len(list((work / "results" / "packings" / "pool").glob("*rep*.json")))
        if args.keep:
            shutil.copytree(work / "results" / "cases", args.keep, dirs_exist_ok=True)
        cases = pd.DataFrame([case_row(r) for r in records])
    counted = cases[cases["status"] != "failed"]
    target = config.get("fidelity", {}).get("target_relative_sem", "schema default")
    figures = {"cases": len(records), "cores": args.cores, "wall_s": round(wall, 1),
               "engine_cpu_s": round(float(counted["cpu_s"].sum()), 1),
               **{f"status_{status}": int(n) for status, n in cases["status"].value_counts().items()},
               "target_relative_sem": "null" if target is None else target,
               "reached": int(counted["reached"].sum()), "not_chased": int(counted["not_chased"].sum()),
               "rel_sem_median_pct": round(100 * float(counted["rel_sem"].median()), 2),
               "rel_sem_max_pct": round(100 * float(counted["rel_sem"].max()), 2),
               "pool_packings": pool,
               "core_use": round(float(jobs["s"].sum()) / (wall * args.cores), 2),
               "cpu_all_processes_s": round(cpu, 1)}
    if refine_records:
        refine_cpu = float(sum(case_row(r)["cpu_s"] for r in refine_records))
        figures.update({"refine_runs": len(refine_records),
                        "refine_engine_cpu_s": round(refine_cpu, 1),
                        "engine_cpu_with_refine_s": round(float(counted["cpu_s"].sum())
                                                          + refine_cpu, 1)})
    lines = [f"Campaign {args.config} {' '.join(args.set)}: {len(records)} cases, wall time "
             f"{wall:.0f} s on {args.cores} cores; engine CPU of the cases {counted['cpu_s'].sum():.0f} s; "
             f"case status counts: {cases['status'].value_counts().to_dict()}; target "
             f"{target}: {int(counted['reached'].sum())} of {len(counted)} reached, "
             f"{int(counted['not_chased'].sum())} not chased (not resolved from zero, or a pilot or later "
             f"run failing a steady-state check); relative SEM "
             f"median {counted['rel_sem'].median():.1%}, largest {counted['rel_sem'].max():.1%}; "
             f"{pool} packings poured on demand into the pool (their CPU is inside the case jobs)", "",
             "| stage (rule) | jobs | summed job time s |", "|---|---|---|"]
    for rule, group in jobs.groupby("rule"):
        lines.append(f"| {rule} | {len(group)} | {group['s'].sum():.1f} |")
        figures[f"{rule}_jobs"] = len(group)
        figures[f"{rule}_job_time_s"] = round(float(group["s"].sum()), 1)
    lines += ["", "| frequency Hz | cases | wall s (summed) | engine CPU s (summed) | mean CPU s per case | "
              "at target | median rel. SEM | cells (min-max) | measured cycles (min-max) |",
              "|---|---|---|---|---|---|---|---|---|"]
    for freq, group in counted.groupby("freq_hz"):
        lines.append(f"| {freq:g} | {len(group)} | {group['wall_s'].sum():.1f} | {group['cpu_s'].sum():.1f} | "
                     f"{group['cpu_s'].mean():.1f} | {int(group['reached'].sum())} | "
                     f"{group['rel_sem'].median():.1%} | {group['cells'].min()}-{group['cells'].max()} | "
                     f"{group['cycles'].min()}-{group['cycles'].max()} |")
        figures.update({f"f{freq:g}Hz_cases": len(group),
                        f"f{freq:g}Hz_engine_cpu_s": round(float(group["cpu_s"].sum()), 1),
                        f"f{freq:g}Hz_reached": int(group["reached"].sum()),
                        f"f{freq:g}Hz_rel_sem_median_pct": round(100 * float(group["rel_sem"].median()), 2),
                        f"f{freq:g}Hz_cells": f"{group['cells'].min()}-{group['cells'].max()}",
                        f"f{freq:g}Hz_measured_cycles": f"{group['cycles'].min()}-{group['cycles'].max()}"})
    lines += ["", "Every case: " + "; ".join(
        f"{row.case_id} {row.rel_sem:.1%}{'' if row.reached or target is None else ' (missed)'}"
        for row in counted.sort_values("case_id").itertuples())]
    lines.append(f"\nSummed job time / (wall x cores) = {jobs['s'].sum() / (wall * args.cores):.2f} (core use).")
    conditions = (f"CPU of Snakemake and every job (all processes) {cpu:.0f} s, i.e. {cpu / args.cores:.0f} s "
                  f"on {args.cores} busy cores; load average (1, 5, 15 min) before {load_before}, after "
                  f"{load_after} (other sessions share the cores).")
    lines.append(conditions)
    if refine_records:
        lines.append(f"The refinement loop ran {len(refine_records)} case(s) beyond the grid: "
                     f"engine CPU {figures['refine_engine_cpu_s']:.0f} s, so the campaign's engine "
                     f"CPU is {figures['engine_cpu_with_refine_s']:.0f} s in all.")
    print("\n".join(lines))
    if args.workdir:
        # beside the campaign, for benchmarks/compare_campaigns.py
        (work / "bench_campaign.json").write_text(json.dumps(figures, indent=1) + "\n")
    record("bench_campaign", figures, notes=f"Config {args.config} {' '.join(args.set)}. "
           + conditions)


def case_row(record: dict) -> dict:
    """One case's figures: wall and engine CPU over every run it made, relative SEM, target."""
    target = record.get("target") or {}
    value, sem = record.get("ceq_cell_ns_m", float("nan")), record.get("ceq_cell_sem_ns_m", float("nan"))
    engine = record.get("engine") or {}
    return {"case_id": record["case_id"], "freq_hz": record["freq_hz"], "status": record["status"],
            "wall_s": target.get("wall_time_s", record.get("wall_time_s", float("nan"))),
            "cpu_s": target.get("cpu_time_s", engine.get("cpu_time_s",
                                                      engine.get("liggghts_cpu_time_s", float("nan")))),
            "rel_sem": abs(sem / value) if value else float("nan"),
            "reached": bool(target.get("reached", False)),
            "not_chased": bool(target.get("not_chased")) or (
                bool(target) and len(target.get("runs", [])) == 1 and not target.get("reached")
                and "not_resolved" in record.get("flags", [])),
            "cells": int(target.get("cells", record.get("fidelity", {}).get("cells_per_run", 1))),
            "cycles": int(target.get("measured_cycles", record.get("n_cycles", 0)))}


if __name__ == "__main__":
    main()
