"""The scene (issue 5): one cell x N against replicate cells, patches and the whole coupon.

The campaign shakes one cell and multiplies its C_eq by N = 441. For each case (50 % fill;
500 Hz, 5 g and 1000 Hz, 10 g), at the default fidelity of config.yaml, this runs
:func:`pidpipe.studies.scene.run_scene_study`: replicate packings 0-18 each alone, the 7- and
19-cell patches with packings 0-6 and 0-18 in one run each, and the 441-cell coupon (21 x 21)
with 441 distinct packings (replicates 0-440, each poured as the campaign pours it) in one
run, its cost estimated first from a 3-cycle run (the window is shortened, and the table says
so, if the full one would take more than scene.coupon_cpu_limit_s of CPU).

It prints (and appends to results.md) C_eq per cell with its standard errors over cycles and
over cells, the coupon's C_eq (x 441), LIGGGHTS' CPU time, CPU per cell-cycle and the ratio to
one cell; the same packings compared across scenes; and the packing-to-packing scatter. The
rows also go to results/scene/scene.csv and the figure to results/scene/scene.png.

Run: .venv/bin/python benchmarks/experiments/bench_scene.py [--cases 500:5,1000:10] [--pour-workers 2]
The cases, fill, coupon layout and CPU limit are config.yaml's ``scene`` section (the same study
as ``snakemake --cores 2 scene``). Packings are poured once into results/work/scene/packings and reused.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.config import load_config
from pidpipe.studies.scene import plot_scenes, write_scene_study

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "results" / "scene"
WORK = ROOT / "results" / "work" / "scene"


def _f(value: float, digits: str = ".4f") -> str:
    return "-" if isinstance(value, float) and math.isnan(value) else format(value, digits)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=None,
                        help="freq:accel pairs, comma separated (default: config.yaml's scene.cases)")
    parser.add_argument("--pour-workers", type=int, default=1, help="pours run at once (<= 2)")
    parser.add_argument("--from-records", action="store_true",
                        help="tabulate the records of the last run again instead of running")
    args = parser.parse_args(argv)
    config = load_config()
    if args.cases:
        config["scene"]["cases"] = [dict(zip(("freq_hz", "accel_g"), map(float, pair.split(":"))))
                                    for pair in args.cases.split(",")]
    n_coupon = int(config["geometry"]["coupon_n_cells"])
    study = write_scene_study(config, OUT / "scene.csv", OUT / "scene_comparisons.csv", WORK,
                              workers=args.pour_workers, from_records=args.from_records)
    rows, compared, scatter = study["rows"], study["comparisons"], study["scatter"]
    plot_scenes(rows, OUT / "scene.png")
    pour_cpu = study["pour_cpu_s"]
    pour_s = float(np.mean(list(pour_cpu.values()))) if pour_cpu else float("nan")

    fid = config["fidelity"]
    refused = "; ".join(f"replicate {k}: {why.split(': ', 1)[1]}" for k, why in study["refused"]) or "none"
    lines = ["| case | scene | cells | C_eq per cell (N s/m) | SEM over cycles | SEM over cells | "
             f"coupon C_eq = {n_coupon} x per cell (N s/m) | CPU s | CPU ms per cell-cycle | CPU / 1 cell | pour CPU s |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['freq_hz']:g} Hz, {r['accel_g']:g} g | {r['label']} | {r['cells']} | "
                     f"{_f(r['ceq_cell_ns_m'])} | {_f(r['sem_cycles_ns_m'])} | {_f(r['sem_cells_ns_m'])} | "
                     f"{r['ceq_coupon_ns_m']:.1f} +- {r['sem_coupon_ns_m']:.1f} | {r['cpu_s']:.1f} | "
                     f"{r['cpu_ms_per_cell_cycle']:.2f} | {r['cpu_ratio_to_one_cell']:.1f} | "
                     f"{r['cells'] * pour_s:.0f} |")
    lines += ["", f"{config['scene']['fill_pct']:g} % fill ({study['n_spheres']} spheres per cell), fidelity (dt = "
              f"{fid['timestep_rayleigh_fraction']} Rayleigh times, transient >= {fid['transient_cycles']} "
              f"cycles and >= {fid['transient_min_time_s']} s, {fid['measured_cycles']} measured cycles, "
              f"SEM from {fid['sem_block_cycles']}-cycle blocks). Every scene runs the patch deck; "
              "cell i holds the i-th replicate packing the campaign's check accepts (refused pours: "
              f"{refused}). SEM over cycles: of the scene's total E_d series, / "
              "cells (the noise of these very packings); SEM over cells: std over cells / sqrt(cells) "
              "(packing scatter included: the error as an estimate of another coupon's cells). The "
              "coupon column takes the SEM over cells when there are several, else over cycles (all "
              "one cell can report). CPU: LIGGGHTS' user + system time; pour CPU: cells x the mean "
              f"CPU of one pour ({pour_s:.2f} s over {len(pour_cpu)} measured pours).", "",
              "| case | same packings | cells | identical | mean z | rms z | max abs z | within 3 SEM |",
              "|---|---|---|---|---|---|---|---|"]
    for c in compared:
        lines.append(f"| {c['freq_hz']:g} Hz, {c['accel_g']:g} g | {c['pair']} | {c['cells']} | "
                     f"{c['identical']} | {_f(c['mean_z'], '+.2f')} | {_f(c['rms_z'], '.2f')} | "
                     f"{_f(c['max_abs_z'], '.2f')} | {c['within_3_sem']}/{c['cells'] - c['identical']} |")
    lines += ["", "z = (C_eq in scene A - C_eq in scene B) / combined SEM, for each cell with the same "
              "packing, over the cells whose C_eq is not bit for bit identical (identical: a cell at "
              "the origin whose arithmetic did not change). Rms z near 1 or below: the scenes differ "
              "by no more than cycle noise.", "",
              "| case | std of C_eq over the coupon's cells | run-to-run noise of one cell (pairs) | "
              "packing-to-packing std | rms reported SEM of one cell | coupon C_eq per cell +- SEM over cycles | "
              "single: (single - coupon) / its SEM, percentile among the coupon's cells | coupon drift | "
              "ledger mismatch / E_d | contained | coupon window |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in scatter:
        lines.append(f"| {s['freq_hz']:g} Hz, {s['accel_g']:g} g | {s['std_cells_ns_m']:.4f} | "
                     f"{s['run_noise_ns_m']:.4f} ({s['noise_pairs']}) | {s['std_packing_ns_m']:.4f} | "
                     f"{s['rms_sem_ns_m']:.4f} | "
                     f"{s['coupon_ceq_cell_ns_m']:.4f} +- {s['coupon_sem_cycles_ns_m']:.4f} | "
                     f"{s['single_minus_coupon_in_single_sems']:+.2f}, {s['single_percentile_in_coupon']:.0f} % | "
                     f"{s['drift']:+.3f} | {s['ledger_mismatch_of_dissipation']:+.1e} | "
                     f"{'yes' if s['contained'] else 'NO'} | {s['window']} |")
    lines += ["", "Run-to-run noise: sqrt(mean d^2 / 2) over the same packings' C_eq in two scenes "
              "(coupon, 19-cell patch, alone; cells not bit for bit identical); packing-to-packing "
              "std = sqrt(std over the coupon's cells^2 - noise^2): what one cell's C_eq misses the "
              "coupon's mean cell by, beyond the noise of its run."]
    append("Scene: one cell x N against replicates, patches and the coupon (issue 5)",
           "python benchmarks/experiments/bench_scene.py " + " ".join(sys.argv[1:] if argv is None else argv), lines)


if __name__ == "__main__":
    main()
