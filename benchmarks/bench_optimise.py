"""Is the optimise_environments step faster (and still the same) with this code than with an older commit?

The step (:func:`pidpipe.steps.design.optimise_surrogate`, two worker processes as the rule's
``threads: 2``, BLAS on one thread as the rule's script sets it) runs on a finished campaign's
surrogate and config, alternately with this checkout's pidpipe and with ``--base``'s (exported
by ``git archive`` into a scratch folder and put first on the path), ``--repeats`` times each,
each in a fresh process; wall and CPU (the process and its workers) are printed, and the files
the two write are compared byte for byte. The machine is shared: compare the runs of one call.
Figures go to ``benchmarks/records/bench_optimise.json`` (:mod:`harness`).

Run: .venv/bin/python benchmarks/bench_optimise.py CAMPAIGN_DIR [--base REV] [--repeats 2] [--note TEXT]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from harness import REPO, export_package, measured, record

FILES = ("optimum.csv", "history.csv", "optimum.json", "bootstrap.csv")

STEP = r'''
import json, os, sys, time
os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
import yaml
from pidpipe.steps.design import optimise_surrogate
from pidpipe.steps.params import budget_params, environment_params, optimisation_params, workflow_config
campaign, out = sys.argv[1], sys.argv[2]
config = workflow_config(yaml.safe_load(open(os.path.join(campaign, "config.yaml"))))
wall = time.perf_counter()
optimise_surrogate(os.path.join(campaign, "results", "surrogate.json"), environment_params(config),
                   budget_params(config), optimisation_params(config),
                   *(os.path.join(out, name) for name in ("optimum.csv", "history.csv", "optimum.json", "bootstrap.csv")),
                   workers=2)
print(json.dumps({"wall": time.perf_counter() - wall}))
'''


def run(campaign: Path, out: Path, path: str | None) -> dict:
    """One run of the step in a fresh process: its wall time (the step alone, s) and the CPU of
    the process and its workers (imports included, s)."""
    env = dict(os.environ)
    if path:
        env["PYTHONPATH"] = path
    out.mkdir(parents=True, exist_ok=True)
    with measured() as step:
        done = subprocess.run([sys.executable, "-c", STEP, str(campaign), str(out)], env=env,
                              capture_output=True, text=True, cwd=campaign)
    if done.returncode != 0:
        sys.exit(f"the optimise step failed:\n{done.stderr[-3000:]}")
    return {"wall": json.loads(done.stdout.strip().splitlines()[-1])["wall"],
            "cpu": step.children_cpu_s}


def compare_optima(before: Path, this: Path) -> list[str]:
    """Bullet lines: per design, the whole-cell design of each, and the largest relative change
    of the continuous optimum's objective and of the bootstrap interval's ends."""
    import pandas as pd

    old, new = pd.read_csv(before), pd.read_csv(this)
    out = []
    for (_, a), (_, b) in zip(old.iterrows(), new.iterrows()):
        changes = {column: abs(b[column] - a[column]) / max(abs(a[column]), 1e-300)
                   for column in ("continuous_total_ceq_ns_m", "total_ceq_ns_m_lo", "total_ceq_ns_m_hi",
                                  "fill_pct_lo", "fill_pct_hi")}
        same_design = (a["n_cells"], a["fill_pct"]) == (b["n_cells"], b["fill_pct"])
        out.append(f"- {a['environment']}, {a['design']}: n_c {a['n_cells']} / {b['n_cells']}, r "
                   f"{a['fill_pct']:.4g} / {b['fill_pct']:.4g} % ({'same' if same_design else 'DIFFERENT'} "
                   "whole-cell design); relative change: " + ", ".join(f"{k} {v:.1e}" for k, v in changes.items())
                   + f"; bootstrap wins: {a['optimum_wins']} / {b['optimum_wins']}")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path, help="a finished campaign folder (config.yaml, results/surrogate.json)")
    parser.add_argument("--base", default="main", help="the commit to compare with")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--note", default="")
    args = parser.parse_args()
    campaign = args.campaign.resolve()
    load = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench_optimise_") as scratch:
        scratch = Path(scratch)
        old = export_package(args.base, scratch / "base")
        times = {"base": [], "this": []}
        for _ in range(args.repeats):
            times["base"].append(run(campaign, scratch / "out_base", str(old)))
            times["this"].append(run(campaign, scratch / "out_this", None))
        same = all((scratch / "out_base" / name).read_bytes() == (scratch / "out_this" / name).read_bytes()
                   for name in FILES)
        differences = [] if same else compare_optima(scratch / "out_base" / "optimum.csv",
                                                     scratch / "out_this" / "optimum.csv")
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                          text=True).stdout.strip()
    lines = ([f"Note: {args.note}", ""] if args.note else []) + [
        f"optimise_environments' step on {campaign}'s surrogate (workers 2), {args.repeats} runs each, "
        f"alternating; load average before {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, after "
        + " ".join(f"{x:.2f}" for x in os.getloadavg()) + ".", "",
        "| code | wall s (each run) | CPU s (each run) | median wall | median CPU |", "|---|---|---|---|---|"]
    for label, key in ((f"{args.base} (before)", "base"), (f"{head} (this checkout)", "this")):
        walls, cpus = [t["wall"] for t in times[key]], [t["cpu"] for t in times[key]]
        lines.append(f"| {label} | {', '.join(f'{w:.1f}' for w in walls)} | {', '.join(f'{c:.1f}' for c in cpus)} | "
                     f"{statistics.median(walls):.1f} | {statistics.median(cpus):.1f} |")
    ratio_w = statistics.median(t["wall"] for t in times["this"]) / statistics.median(t["wall"] for t in times["base"])
    ratio_c = statistics.median(t["cpu"] for t in times["this"]) / statistics.median(t["cpu"] for t in times["base"])
    lines += ["", f"This / before: wall {ratio_w:.2f}, CPU {ratio_c:.2f}. Files ({', '.join(FILES)}) identical "
              f"byte for byte: {'yes' if same else 'NO'}."]
    if differences:
        lines += ["", "Where the designs differ (optimum.csv, this against before):", *differences]
    print("\n".join(lines))
    figures = {"base": args.base, "head": head, "repeats": args.repeats,
               "base_wall_median_s": round(statistics.median(t["wall"] for t in times["base"]), 2),
               "base_cpu_median_s": round(statistics.median(t["cpu"] for t in times["base"]), 2),
               "this_wall_median_s": round(statistics.median(t["wall"] for t in times["this"]), 2),
               "this_cpu_median_s": round(statistics.median(t["cpu"] for t in times["this"]), 2),
               "this_over_base_wall": round(ratio_w, 3), "this_over_base_cpu": round(ratio_c, 3),
               "files_identical": same}
    record("bench_optimise", figures, notes=args.note)


if __name__ == "__main__":
    main()
