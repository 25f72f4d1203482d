"""The default timestep re-decided: C_eq at dt = 0.2, 0.3 and 0.4 t_R against 0.1 t_R, paired on the
same packings, and the restitution at each dt (issue 13).

Each reference case is shaken as k cells (their own packings, replicates 0..k-1 of its fill) at
every timestep. The error of a timestep is mean_i C_i(dt) / mean_i C_i(0.1 t_R) - 1 over the
same cells, and its standard error comes from the cells' paired differences d_i = C_i(dt) -
C_i(0.1) with the two-level estimate of :func:`pidpipe.measurement.cells.mean_of_cells` (each
d_i's cycle SEM is the two runs' combined): the packings' own spread, which is the same at
both timesteps, cancels, so a few cells resolve the timestep's error to about 1 %.

Run: .venv/bin/python benchmarks/experiments/bench_timestep.py [--cells 7] [--cycles-500 80] [--cycles-1000 40]
         [--fractions 0.1 0.2 0.3 0.4] [--fill 25 90 ...] [--packings DIR]
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.cases import CaseSpec
from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.liggghts.impacts import pair_restitution, wall_restitution
from pidpipe.dem.pouring import replicate_packings
from pidpipe.liggghts.shake import run_case
from pidpipe.measurement.cells import mean_of_cells

FRACTIONS = (0.1, 0.2, 0.3, 0.4)
"""dt / Rayleigh time; the first is the reference."""

CASES = ((1000.0, 10.0, 25.0), (1000.0, 10.0, 90.0), (500.0, 5.0, 25.0), (500.0, 5.0, 90.0))
"""(f Hz, G, fill %): the steady reference cases of the fidelity study."""


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser()
    parser.add_argument("--cells", type=int, default=7)
    parser.add_argument("--cycles-500", type=int, default=80)
    parser.add_argument("--cycles-1000", type=int, default=40)
    parser.add_argument("--fractions", type=float, nargs="+", default=list(FRACTIONS))
    parser.add_argument("--fill", type=float, nargs="+", default=None)
    parser.add_argument("--packings", default=None)
    args = parser.parse_args()
    cells, cycles_500, fractions = args.cells, args.cycles_500, tuple(args.fractions)
    cases = [c for c in CASES if args.fill is None or c[2] in args.fill]
    lines = ["| case | dt / t_R | C_eq per cell, N s/m | error vs 0.1 t_R | CPU s (k cells) |",
             "|---|---|---|---|---|"]
    cpu_by_fraction = {fraction: 0.0 for fraction in fractions}
    worst = {fraction: 0.0 for fraction in fractions[1:]}
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(args.packings) if args.packings else Path(scratch) / "packings"
        for freq, accel, fill in cases:
            packings, _ = replicate_packings(PourSettings.from_config(load_config()), fill, cells, folder)
            case = CaseSpec(freq, accel, fill)
            records = {}
            for fraction in fractions:
                config = load_config()
                config["fidelity"]["timestep_rayleigh_fraction"] = fraction
                config["fidelity"]["measured_cycles"] = cycles_500 if freq < 1000.0 else args.cycles_1000
                records[fraction] = run_case(ShakeSettings.from_config(config), case, packings,
                                             Path(scratch) / f"{case.case_id}_{fraction}")
                cpu_by_fraction[fraction] += records[fraction].engine["liggghts_cpu_time_s"]
            reference = records[fractions[0]]
            for fraction, record in records.items():
                value, sem = record.ceq_cell_ns_m, record.ceq_cell_sem_ns_m
                text = "reference"
                if fraction != fractions[0]:
                    diff = mean_of_cells(
                        np.array([a["ceq_cell_ns_m"] - b["ceq_cell_ns_m"]
                                  for a, b in zip(record.cells, reference.cells)]),
                        np.array([math.hypot(a["ceq_cell_sem_ns_m"], b["ceq_cell_sem_ns_m"])
                                  for a, b in zip(record.cells, reference.cells)]))
                    error = diff.mean / reference.ceq_cell_ns_m
                    error_sem = diff.sem / reference.ceq_cell_ns_m
                    worst[fraction] = max(worst[fraction], abs(error) + error_sem)
                    text = f"{100 * error:+.2f} +- {100 * error_sem:.2f} %"
                flags = f" ({', '.join(record.flags)})" if record.flags else ""
                lines.append(f"| {freq:g} Hz / {accel:g} g / {fill:g} % | {fraction} | "
                             f"{value:.4g} +- {sem:.2g}{flags} | {text} | "
                             f"{record.engine['liggghts_cpu_time_s']:.1f} |")
                print(lines[-1], flush=True)
        lines += ["", f"| dt / t_R | sphere-wall e (0.70) | sphere-sphere e (0.70) | CPU x {fractions[0]} t_R | worst abs(error) + SEM |",
                  "|---|---|---|---|---|"]
        for fraction in fractions:
            config = load_config()
            config["fidelity"]["timestep_rayleigh_fraction"] = fraction
            wall = wall_restitution(CellScene.from_config(config), 0.5, Path(scratch) / "w")
            pair = pair_restitution(CellScene.from_config(config), 0.5, Path(scratch) / "p")
            bound = f"{100 * worst[fraction]:.2f} %" if fraction in worst else "reference"
            lines.append(f"| {fraction} | {wall:.4f} | {pair:.4f} | "
                         f"{cpu_by_fraction[fraction] / cpu_by_fraction[fractions[0]]:.2f} | {bound} |")
            print(lines[-1], flush=True)
    lines += ["", f"{cells} cells per case (replicate packings 0..{cells - 1}, the same at every dt); "
              f"{args.cycles_1000} measured cycles at 1000 Hz, {cycles_500} at 500 Hz; other settings default. "
              "Error = mean cell at dt / mean cell at 0.1 t_R - 1, +- the two-level SEM of the "
              "cells' paired differences. Restitution at an impact speed of 0.5 m/s."]
    append("Timestep: C_eq at 0.2 / 0.3 / 0.4 t_R against 0.1 t_R on the same packings",
           "python benchmarks/experiments/bench_timestep.py " + " ".join(sys.argv[1:]), lines)


if __name__ == "__main__":
    main()
