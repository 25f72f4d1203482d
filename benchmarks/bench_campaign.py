"""Wall time of a whole campaign on this machine, with the split by stage (issue 3).

Runs ``snakemake --cores 2`` on a config (default: the repository's config.yaml, the 60-case
reference campaign) in a scratch copy of the workflow, then sums the per-job benchmark files
and the case records by rule.

Run: .venv/bin/python benchmarks/bench_campaign.py [config.yaml] [--cores 2]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
from _record import append

REPO = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("config", nargs="?", default=str(REPO / "config.yaml"))
    parser.add_argument("--cores", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        for item in ("Snakefile", "workflow", "templates"):
            source = REPO / item
            (shutil.copytree if source.is_dir() else shutil.copy)(source, work / item)
        shutil.copy(args.config, work / "config.yaml")
        start = time.perf_counter()
        done = subprocess.run([str(Path(sys.executable).parent / "snakemake"), "--cores", str(args.cores),
                               "--quiet", "rules", "all"], cwd=work, check=False, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - start
        if done.returncode != 0:
            sys.exit(f"snakemake failed (exit {done.returncode}); nothing recorded")
        rows = []
        for tsv in (work / "results" / "benchmarks").rglob("*.tsv"):
            frame = pd.read_csv(tsv, sep="\t")
            rows.append({"rule": tsv.parent.name if tsv.parent.name != "benchmarks" else tsv.stem,
                         "job": tsv.stem, "s": float(frame["s"].iloc[0])})
        jobs = pd.DataFrame(rows)
        records = [json.loads(p.read_text()) for p in (work / "results" / "cases").glob("*.json")]
        cases = pd.DataFrame({"freq_hz": [r["freq_hz"] for r in records],
                              "s": [r.get("wall_time_s", float("nan")) for r in records],
                              "status": [r["status"] for r in records]})
    lines = [f"Campaign {Path(args.config).name}: {len(records)} cases, wall time {wall:.0f} s on "
             f"{args.cores} cores; case status counts: {cases['status'].value_counts().to_dict()}", "",
             "| stage (rule) | jobs | summed job time s |", "|---|---|---|"]
    for rule, group in jobs.groupby("rule"):
        lines.append(f"| {rule} | {len(group)} | {group['s'].sum():.1f} |")
    lines += ["", "| frequency Hz | cases | summed case time s | mean s per case |", "|---|---|---|---|"]
    for freq, group in cases.groupby("freq_hz"):
        lines.append(f"| {freq:g} | {len(group)} | {group['s'].sum():.1f} | {group['s'].mean():.1f} |")
    lines.append(f"\nSummed job time / (wall x cores) = {jobs['s'].sum() / (wall * args.cores):.2f} (core use).")
    append("Whole campaign", f"python benchmarks/bench_campaign.py {Path(args.config).name}", lines)


if __name__ == "__main__":
    main()
