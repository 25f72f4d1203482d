"""What does the surrogate's cross-validation cost with each fold's GP started from the whole table's fit, and what does it change?

The step (:func:`pidpipe.design.surrogate.cross_validate`, every method and scheme, the folds in
``--workers`` worker processes, BLAS on one thread as the rule's script sets it) runs on a C_eq
table twice in each of ``--repeats`` alternating rounds, each in a fresh process: once with each
fold's GP optimiser started from the initial kernel and
:data:`pidpipe.design.gaussian_process.RESTARTS` random ones (``fold_start="restarts"``, each fold
fitted as the table itself is), once started from the hyperparameters fitted to the whole
table, without restarts (``"table"``, the default). Printed: wall and CPU (the process and its
workers) of each run, their medians and ratio, and every ``gp`` row of the two tables side by
side (RMS and worst relative error, RMS error per SEM, the z-scores' mean and spread, the 68 %
and 95 % coverages), with the largest change of any ``gp`` figure. Rows of the other methods
do not depend on the option and must be identical (checked).

The machine is shared: compare the runs of one call. Figures go to
``benchmarks/records/bench_cross_validation.json`` (:mod:`harness`).

Run: .venv/bin/python benchmarks/bench_cross_validation.py [TABLE] [--workers 2] [--repeats 1] [--note TEXT]
(default TABLE: ``tests/fixtures/ceq_table_dem_default_100.csv``, a DEM campaign's grid table)
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

from harness import REPO, measured, record

DEFAULT_TABLE = REPO / "tests" / "fixtures" / "ceq_table_dem_default_100.csv"

#: The gp figures compared (columns of ``results/surrogate_cv.csv``).
GP_FIGURES = ("rms_rel_error", "max_rel_error", "rms_error_per_sem", "z_mean", "z_std",
              "coverage_68", "coverage_95")

STEP = r'''
import json, os, sys, time
os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
from pidpipe.design.ceq_table import read_ceq_table
from pidpipe.design.surrogate import cross_validate
if __name__ == "__main__":
    table, out, workers, start = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    wall = time.perf_counter()
    cross_validate(read_ceq_table(table), workers=workers, fold_start=start).to_csv(out, index=False)
    print(json.dumps({"wall": time.perf_counter() - wall}))
'''


def run(table: Path, out: Path, workers: int, start: str, scratch: Path) -> dict:
    """One cross-validation in a fresh process: the step's wall time and the CPU of the
    process and its workers (imports included), s."""
    script = scratch / "step.py"              # a file: the spawned workers import __main__
    script.write_text(STEP)
    with measured() as step:
        done = subprocess.run([sys.executable, str(script), str(table), str(out), str(workers), start],
                              capture_output=True, text=True, cwd=REPO)
    if done.returncode != 0:
        sys.exit(f"the cross-validation ({start}) failed:\n{done.stderr[-3000:]}")
    return {"wall": json.loads(done.stdout.strip().splitlines()[-1])["wall"],
            "cpu": step.children_cpu_s}


def compare_tables(restarts: Path, table: Path) -> tuple[list[str], float, bool]:
    """Markdown lines of the gp rows side by side, the largest absolute change of a gp figure,
    and whether the other methods' rows are identical."""
    import pandas as pd

    old, new = pd.read_csv(restarts), pd.read_csv(table)
    key = ["method", "target", "scheme"]
    merged = old.merge(new, on=key, suffixes=("_restarts", "_table"))
    others = merged[merged["method"] != "gp"]
    columns = [c for c in old.columns if c not in key]
    same_others = all(others[f"{c}_restarts"].equals(others[f"{c}_table"]) for c in columns)
    lines = ["| gp row | " + " | ".join(GP_FIGURES) + " |", "|---|" + "---|" * len(GP_FIGURES)]
    largest = 0.0
    for _, row in merged[merged["method"] == "gp"].iterrows():
        cells = []
        for name in GP_FIGURES:
            a, b = row[f"{name}_restarts"], row[f"{name}_table"]
            largest = max(largest, abs(b - a))
            cells.append(f"{a:.3f} / {b:.3f}")
        lines.append(f"| {row['target']}, {row['scheme']} (restarts / table) | " + " | ".join(cells) + " |")
    return lines, largest, same_others


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("table", type=Path, nargs="?", default=DEFAULT_TABLE, help="a C_eq table (CSV)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--note", default="")
    args = parser.parse_args()
    table = args.table.resolve()
    load = os.getloadavg()
    times = {"restarts": [], "table": []}
    with tempfile.TemporaryDirectory(prefix="bench_cv_") as scratch:
        scratch = Path(scratch)
        for _ in range(args.repeats):
            for start in times:
                times[start].append(run(table, scratch / f"cv_{start}.csv", args.workers, start, scratch))
        rows, largest, same_others = compare_tables(scratch / "cv_restarts.csv", scratch / "cv_table.csv")
    median = {start: {k: statistics.median(t[k] for t in runs) for k in ("wall", "cpu")}
              for start, runs in times.items()}
    ratio_w = median["table"]["wall"] / median["restarts"]["wall"]
    ratio_c = median["table"]["cpu"] / median["restarts"]["cpu"]
    lines = ([f"Note: {args.note}", ""] if args.note else []) + [
        f"cross_validate on {args.table} (workers {args.workers}), {args.repeats} run(s) of each, "
        f"alternating; load average before {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, after "
        + " ".join(f"{x:.2f}" for x in os.getloadavg()) + ".", "",
        "| folds' GP starts | wall s (each run) | CPU s (each run) |", "|---|---|---|"]
    for start, runs in times.items():
        walls = ", ".join(f"{t['wall']:.1f}" for t in runs)
        cpus = ", ".join(f"{t['cpu']:.1f}" for t in runs)
        lines.append(f"| {start} | {walls} | {cpus} |")
    lines += ["", f"table / restarts: wall {ratio_w:.2f}, CPU {ratio_c:.2f}.", "", *rows, "",
              f"Largest change of a gp figure: {largest:.3g}. Other methods' rows identical: "
              f"{'yes' if same_others else 'NO'}."]
    print("\n".join(lines))
    figures = {"workers": args.workers, "repeats": args.repeats,
               "restarts_wall_median_s": round(median["restarts"]["wall"], 2),
               "restarts_cpu_median_s": round(median["restarts"]["cpu"], 2),
               "table_wall_median_s": round(median["table"]["wall"], 2),
               "table_cpu_median_s": round(median["table"]["cpu"], 2),
               "table_over_restarts_wall": round(ratio_w, 3),
               "table_over_restarts_cpu": round(ratio_c, 3),
               "gp_figure_largest_change": float(f"{largest:.3g}"),
               "other_methods_identical": same_others}
    record("bench_cross_validation", figures, notes=args.note)


if __name__ == "__main__":
    main()
