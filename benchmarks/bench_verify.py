"""What does `snakemake --cores 2 verify` cost on a finished campaign, and what does it find (issue 15)?

Copies a campaign's ``config.yaml`` and ``results/`` (modification times kept, the source is
only read) into a scratch folder with this repository's workflow, checks by a dry run that
nothing of the campaign itself would run again, then runs ``verify`` and reports: wall time,
the CPU time of every process it started (user + system of the children: Snakemake, the
pours, the engines, the comparison), the engine CPU of each verifying case (every run its
target made), the pours' CPU (Snakemake's benchmark files) and the table's verdicts.

Run: .venv/bin/python benchmarks/bench_verify.py CAMPAIGN_DIR [--cores 2]
         [--set verify.engine=dem ...] [--workdir DIR]

``CAMPAIGN_DIR`` holds ``config.yaml`` and a finished campaign's ``results/`` (cases, table,
surrogate, optimum). Figures go to ``benchmarks/records/bench_verify.json`` (:mod:`harness`).
``--workdir DIR`` keeps the run in DIR (created) instead of a scratch folder.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd
from harness import SNAKEMAKE, measured, record, scratch_workflow

#: The rules of the verify stage: a dry run that plans any other rule means an unfinished campaign.
VERIFY_RULES = {"plan_verify", "pour_verify_packing", "check_verify_packings",
                "simulate_verify_case", "compare_designs", "verify"}


def planned_rules(output: str) -> set[str]:
    """The rules of a dry run's 'Job stats' table (empty when there is nothing to do)."""
    if "Job stats:" not in output:
        return set()
    table = output.split("Job stats:", 1)[1].splitlines()[3:]
    rules = set()
    for line in table:
        match = re.fullmatch(r"(\w+)\s+(\d+)", line.strip())
        if match is None:
            break
        rules.add(match[1])
    return rules - {"total"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", help="folder with config.yaml and a finished campaign's results/")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=YAML",
                        help="override one config value (repeatable), e.g. verify.engine=dem")
    parser.add_argument("--workdir", metavar="DIR", help="run in DIR and keep it")
    args = parser.parse_args()
    campaign = Path(args.campaign)
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(args.workdir) if args.workdir else Path(scratch)
        if args.workdir:
            work.mkdir(parents=True, exist_ok=False)
        config = scratch_workflow(work, campaign / "config.yaml", args.set)
        shutil.copytree(campaign / "results", work / "results", symlinks=True)   # copy2: mtimes kept
        for earlier in ("verify", "verify.csv", "verify.png", "verify.pdf"):      # measure afresh
            path = work / "results" / earlier
            shutil.rmtree(path) if path.is_dir() else path.unlink(missing_ok=True)
        shutil.rmtree(work / "results" / "benchmarks" / "verify", ignore_errors=True)
        command = [SNAKEMAKE, "verify", "--cores", str(args.cores), "--rerun-triggers", "mtime"]
        dry = subprocess.run(command + ["--dry-run"], cwd=work, text=True, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, check=False)
        other = planned_rules(dry.stdout) - VERIFY_RULES
        if dry.returncode != 0 or other:
            sys.exit(f"{campaign} is not a finished campaign: the dry run "
                     f"{'failed' if dry.returncode else 'plans ' + ', '.join(sorted(other))}; "
                     "nothing measured\n" + dry.stdout[-3000:])
        with measured() as run:
            done = subprocess.run(command + ["--quiet", "rules"], cwd=work, check=False, text=True,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        wall, cpu = run.wall_s, run.children_cpu_s
        if done.returncode != 0:
            sys.exit(f"snakemake verify failed (exit {done.returncode}); nothing recorded\n"
                     + done.stdout[-3000:])
        table = pd.read_csv(work / "results" / "verify.csv")
        pours = [pd.read_csv(p, sep="\t") for p in
                 (work / "results" / "benchmarks" / "verify" / "pour_packing").glob("*.tsv")]
    cases = table.drop_duplicates("case_id")
    pour_cpu = sum(float(frame["cpu_time"].iloc[0]) for frame in pours)
    engine = ", ".join(sorted(set(cases["engine"].astype(str))))
    rel_sem = cases["ceq_coupon_dem_sem_ns_m"] / cases["ceq_coupon_dem_ns_m"]
    target = config.get("fidelity", {}).get("target_relative_sem", "schema default")
    grid = config.get("grid", {})
    lines = [f"Campaign {campaign}: grid {len(grid.get('freq_hz', []))} f x "
             f"{len(grid.get('accel_g', []))} G x {len(grid.get('fill_pct', []))} fills, campaign "
             f"engine {config.get('engine', 'liggghts')}, fidelity {config.get('fidelity', {})}.", "",
             f"verify {' '.join(args.set)} (engine {engine}, target relative SEM "
             f"{target}): {len(table)} design points of "
             f"{table.groupby(['environment', 'design']).ngroups} designs in "
             f"{table['environment'].nunique()} environments, {len(cases)} distinct cases; wall "
             f"{wall:.0f} s on {args.cores} cores; CPU of every process {cpu:.0f} s, of which the "
             f"cases' engines {cases['dem_cpu_time_s'].sum():.0f} s and {len(pours)} pours "
             f"{pour_cpu:.0f} s; surrogate off (|z| > flag_z) at {int(table['surrogate_off'].sum())} "
             f"of {len(table)} design points", "",
             "| case | designs | engine CPU s | cells | cycles | rel. SEM | DEM C_eq N s/m | "
             "surrogate N s/m | z |", "|---|---|---|---|---|---|---|---|---|"]
    for row, rel in zip(cases.itertuples(), rel_sem):
        designs = "+".join(table.loc[table["case_id"] == row.case_id, "design"])
        lines.append(f"| {row.case_id} | {designs} | {row.dem_cpu_time_s:.1f} | "
                     f"{row.n_cells_measured} | {row.n_cycles} | {rel:.1%} | "
                     f"{row.ceq_coupon_dem_ns_m:.4g} ± {row.ceq_coupon_dem_sem_ns_m:.2g} | "
                     f"{row.ceq_coupon_surrogate_ns_m:.4g} ± {row.surrogate_u_ns_m:.2g} | "
                     f"{row.z_combined:+.2f} |")
    print("\n".join(lines))
    figures = {"design_points": len(table), "cases": len(cases), "engine": engine,
               "wall_s": round(wall, 1), "cores": args.cores, "cpu_all_processes_s": round(cpu, 1),
               "cases_engine_cpu_s": round(float(cases["dem_cpu_time_s"].sum()), 1),
               "pours": len(pours), "pours_cpu_s": round(pour_cpu, 1),
               "surrogate_off": int(table["surrogate_off"].sum()),
               "abs_z_combined_max": round(float(cases["z_combined"].abs().max()), 2)}
    record("bench_verify", figures, notes=lines[0])


if __name__ == "__main__":
    main()
