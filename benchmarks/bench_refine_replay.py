"""What does the refinement loop's own computing cost (fits, designs, choices), and is it unchanged, against an older commit?

A finished campaign's loop is replayed: its config, its grid table and the records of every run
the loop made (``results/refine/work/cases``) are copied into a scratch folder without the loop's
state, and the loop's step (:func:`pidpipe.steps.refine.refine_step`, ``--cores`` workers) runs
there from its first round. Every run it asks for has its record, so it shakes nothing: what it
spends is the loop's own computing, round after round (the GP fits, the designs' optimisation,
the intervals, the choices, the figure), which a campaign spends between its runs. The step
runs alternately with this checkout's pidpipe and with ``--base``'s (exported by ``git
archive``), ``--repeats`` times each, each in a fresh process; wall and CPU (the process and
its workers) are printed, and the loop's files (its table, ``rounds.csv``, ``summary.json``,
``verify_points.csv``) are compared byte for byte. The machine is shared: compare the runs of
one call. Figures go to ``benchmarks/records/bench_refine_replay.json`` (:mod:`harness`).

Run: .venv/bin/python benchmarks/bench_refine_replay.py CAMPAIGN_DIR [--base REV] [--cores 2] [--repeats 1] [--note TEXT]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd
from harness import REPO, export_package, measured, record

#: The loop's files compared (in its state folder).
FILES = ("ceq_table.csv", "rounds.csv", "summary.json", "verify_points.csv")

STEP = r'''
import json, os, sys, time
os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
import yaml
from pidpipe.steps.params import workflow_config
from pidpipe.steps.refine import refine_step
if __name__ == "__main__":
    folder, cores = sys.argv[1], int(sys.argv[2])
    os.chdir(folder)
    config = workflow_config(yaml.safe_load(open("config.yaml")))
    wall = time.perf_counter()
    step = refine_step(config, "results/ceq_table.csv", "results/refine", "step.json", cores=cores)
    print(json.dumps({"wall": time.perf_counter() - wall, "status": step["status"],
                      "runs": len(step.get("runs_in_step", step.get("runs", [])))}))
'''


def replay_folder(campaign: Path, folder: Path) -> None:
    """A copy of the campaign's config, grid table and the loop's run records, without state."""
    (folder / "results" / "refine" / "work").mkdir(parents=True)
    shutil.copy(campaign / "config.yaml", folder / "config.yaml")
    shutil.copy(campaign / "results" / "ceq_table.csv", folder / "results" / "ceq_table.csv")
    shutil.copytree(campaign / "results" / "refine" / "work" / "cases",
                    folder / "results" / "refine" / "work" / "cases")


def run(campaign: Path, folder: Path, path: str | None, cores: int, scratch: Path) -> dict:
    """One replay in a fresh process: the step's wall time and the CPU of the process and its
    workers (imports included), s."""
    if folder.exists():
        shutil.rmtree(folder)
    replay_folder(campaign, folder)
    script = scratch / "step.py"              # a file: the spawned workers import __main__
    script.write_text(STEP)
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = path
    with measured() as step:
        done = subprocess.run([sys.executable, str(script), str(folder), str(cores)], env=env,
                              capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"the replay failed:\n{done.stderr[-3000:]}")
    out = json.loads(done.stdout.strip().splitlines()[-1])
    if out["runs"]:
        sys.exit(f"the replay ran {out['runs']} case(s): {campaign}'s records are not the loop's")
    return {"wall": out["wall"], "cpu": step.children_cpu_s}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path, help="a finished campaign folder whose loop ran")
    parser.add_argument("--base", default="HEAD", help="the commit to compare with")
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--note", default="")
    args = parser.parse_args()
    campaign = args.campaign.resolve()
    load = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench_refine_replay_") as scratch:
        scratch = Path(scratch)
        old = export_package(args.base, scratch / "base")
        times = {"base": [], "this": []}
        for _ in range(args.repeats):
            times["base"].append(run(campaign, scratch / "base_run", str(old), args.cores, scratch))
            times["this"].append(run(campaign, scratch / "this_run", None, args.cores, scratch))
        state = Path("results") / "refine" / "state"
        same = {name: (scratch / "base_run" / state / name).read_bytes()
                == (scratch / "this_run" / state / name).read_bytes() for name in FILES}
        rounds = int(pd.read_csv(scratch / "this_run" / state / "rounds.csv")["round"].nunique())
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                          text=True).stdout.strip()
    median = {key: {k: statistics.median(t[k] for t in runs) for k in ("wall", "cpu")}
              for key, runs in times.items()}
    ratio_w = median["this"]["wall"] / median["base"]["wall"]
    ratio_c = median["this"]["cpu"] / median["base"]["cpu"]
    lines = ([f"Note: {args.note}", ""] if args.note else []) + [
        f"The loop of {campaign} replayed from its records ({rounds} rounds, cores {args.cores}), "
        f"{args.repeats} run(s) each, alternating; load average before {load[0]:.2f} {load[1]:.2f} "
        f"{load[2]:.2f}, after " + " ".join(f"{x:.2f}" for x in os.getloadavg()) + ".", "",
        "| code | wall s (each run) | CPU s (each run) |", "|---|---|---|"]
    for label, key in ((f"{args.base} (before)", "base"), (f"{head} + working tree (this checkout)", "this")):
        walls = ", ".join(f"{t['wall']:.1f}" for t in times[key])
        cpus = ", ".join(f"{t['cpu']:.1f}" for t in times[key])
        lines.append(f"| {label} | {walls} | {cpus} |")
    lines += ["", f"This / before: wall {ratio_w:.2f}, CPU {ratio_c:.2f}. Identical byte for byte: "
              + ", ".join(f"{name} {'yes' if ok else 'NO'}" for name, ok in same.items()) + "."]
    print("\n".join(lines))
    figures = {"base": args.base, "head": head, "cores": args.cores, "repeats": args.repeats,
               "rounds": rounds,
               "base_wall_median_s": round(median["base"]["wall"], 2),
               "base_cpu_median_s": round(median["base"]["cpu"], 2),
               "this_wall_median_s": round(median["this"]["wall"], 2),
               "this_cpu_median_s": round(median["this"]["cpu"], 2),
               "this_over_base_wall": round(ratio_w, 3), "this_over_base_cpu": round(ratio_c, 3),
               "files_identical": all(same.values())}
    record("bench_refine_replay", figures, notes=args.note)


if __name__ == "__main__":
    main()
