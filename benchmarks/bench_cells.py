"""What do k cells in one LIGGGHTS run cost against k single-cell runs, and what does the spread
between cells add to the standard error (fidelity.cells_per_run, issue 5)? And what does a run
of k cells cost (``--cost``: the allocation's cost model)?

For each frequency (5 g, 50 % fill, the default fidelity) it shakes replicate packings 0..k-1
once together (one run, :mod:`pidpipe.replicate_cells`) and once each alone, and reports:
LIGGGHTS CPU time of the run of k cells against the sum of the k single runs; the mean cell's
C_eq with its cycle-to-cycle standard error and the between-cells one (std / sqrt(k)); and, for
each moved cell, how far its C_eq lies from the same packing shaken alone in units of their
combined standard errors (the cells' trajectories part by chaos: a check that a cell's own
standard error covers run-to-run noise).

Run: .venv/bin/python benchmarks/bench_cells.py [k] [freq_hz ...]   (default 7 cells, 100 500 1000 Hz)

With ``--cost`` it measures instead what a run of k cells costs, for k = 1, 2, 4, 7, 14, 24
(:data:`COST_CELLS`; a run holds at most 24 cells, :data:`pidpipe.cell.layout.MAX_CELLS`, so 28
are two runs) at 50 % fill and 1000 and 500 Hz, k = 1, 7 at 90 % and k = 1, 7, 24 at 25 % fill
and 1000 Hz (so that the costs per cell and per sphere are told apart), with the default fidelity, plus each pour's CPU time; fits the cost model of
:mod:`pidpipe.measurement.cost_model` to it and writes it, with the machine and the date, to
``pidpipe/measurement/cost_models.json`` (entry ``liggghts``), which the sequential allocation
reads (:mod:`pidpipe.measurement.allocation`).

Run: .venv/bin/python benchmarks/bench_cells.py --cost [packings folder]   (packings are kept
there and reused; default a temporary folder)

With ``--cost --engine dem`` it fits the compiled DEM's cost model instead (entry ``dem``): the
same fills and frequencies with k = 1, 2, 4, 7, 14, 28 (:data:`DEM_COST_RUNS`; the DEM runs any
number of cells as one batch), each run's CPU time the DEM case's own (``run_dem_case``: set-up,
kernel, ledgers and record, the motion sampling included), each the smaller of
:data:`DEM_REPETITIONS` repetitions (the runs take 0.1-3 s); the packings are the DEM's own
pours (``fidelity.pour_engine: dem``), timed as for the LIGGGHTS model, so that the entry's
pour term is what a DEM pour costs: the allocation prices a case's new packing with the pour
engine's entry.

Run: .venv/bin/python benchmarks/bench_cells.py --cost --engine dem [packings folder]

Records: ``benchmarks/records/bench_cells.json`` (k cells against single runs) and
``bench_cells_cost_<engine>.json`` (the cost measurement), :mod:`harness`.

``--cost --engine dem --pours-only`` measures the pours alone and refits the entry with the runs
it already holds (the run and pour terms are fitted apart): for a pour term to be measured
again without the runs, whose cost this machine's speed moves by up to 2x from one hour to the
next.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np
from harness import machine_line, record

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.dem.pouring import replicate_packings
from pidpipe.liggghts.shake import run_case
from pidpipe.measurement.case_record import CaseRecord

ACCEL_G, FILL_PCT = 5.0, 50.0


COST_CELLS = (1, 2, 4, 7, 14, 24)
"""Cells per run at which the cost of a run is measured (``--cost``)."""

COST_RUNS = ((50.0, 1000.0, COST_CELLS), (50.0, 500.0, COST_CELLS), (90.0, 1000.0, (1, 7)),
             (25.0, 1000.0, (1, 7, 24)))
"""(fill %, frequency Hz, cells per run) of the cost measurement, at 5 g."""

DEM_COST_CELLS = (1, 2, 4, 7, 14, 28)
DEM_COST_RUNS = ((50.0, 1000.0, DEM_COST_CELLS), (50.0, 500.0, DEM_COST_CELLS),
                 (90.0, 1000.0, (1, 7, 28)), (25.0, 1000.0, (1, 7, 28)))
"""(fill %, frequency Hz, cells per run) of the DEM's cost measurement, at 5 g."""
DEM_REPETITIONS = 3


def measure_cost(engine: str = "liggghts", folder_arg: str | None = None,
                 pours_only: bool = False) -> None:
    """Measure the CPU time of runs of k cells and of pours; fit and store ``engine``'s cost
    model (``pours_only``: the pours alone, the runs kept from the stored entry)."""
    from pidpipe.cell.scene import CellScene
    from pidpipe.measurement.cost_model import fit_cost_model, load_cost_model, store_cost_model

    kept = load_cost_model(engine) if pours_only else None
    if pours_only and not (kept and kept.points):
        raise SystemExit(f"--pours-only: no stored {engine} entry with runs to keep")

    config = load_config()
    if engine == "dem":
        from pidpipe.dem.case import run_dem_case

        config["fidelity"]["pour_engine"] = "dem"     # the entry's pour term: a DEM pour's

        def cpu_of_run(case, packings, workdir):
            run_dem_case(ShakeSettings.from_config(config), case, packings)      # compiled
            return min(run_dem_case(ShakeSettings.from_config(config), case, packings)
                       .engine["cpu_time_s"] for _ in range(DEM_REPETITIONS))
        runs = DEM_COST_RUNS
    else:
        def cpu_of_run(case, packings, workdir):
            return run_case(ShakeSettings.from_config(config), case, packings,
                            workdir).engine["liggghts_cpu_time_s"]
        runs = COST_RUNS
    command = ("python benchmarks/bench_cells.py --cost" + (" --engine dem" if engine == "dem" else "")
               + (" --pours-only" if pours_only else ""))
    points, pours = ([dict(point) for point in kept.points] if kept else []), []
    lines = ["| fill % | spheres/cell | f Hz | cells k | steps | CPU s | us per step | model s |",
             "|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(folder_arg) if folder_arg else Path(scratch) / "packings"
        for fill, freq, cell_counts in runs:
            packings, pour_cpu = replicate_packings(PourSettings.from_config(config), fill, max(cell_counts), folder, workers=1)
            if fill not in {p["fill_pct"] for p in pours}:
                pours += [{"fill_pct": fill, "n_spheres": packings[0].n_spheres, "cpu_s": cpu}
                          for cpu in pour_cpu.values()]
            case = CaseSpec(freq, ACCEL_G, fill)
            sampling = ShakeSettings.from_config(config).sampling
            steps = (CellScene.from_config(config).timestep(freq).steps_per_cycle
                     * (sampling.transient_cycles_at(freq) + sampling.measured_cycles))
            for k in () if pours_only else cell_counts:
                cpu = cpu_of_run(case, packings[:k], Path(scratch) / f"r{fill:g}_f{freq:g}_k{k}")
                points.append({"fill_pct": fill, "n_spheres": packings[0].n_spheres, "freq_hz": freq,
                               "cells": k, "steps": steps, "cpu_s": cpu})
                print(points[-1], flush=True)
    model = fit_cost_model(points, pours, engine=engine, machine=machine_line(), command=command,
                           pairs=engine == "dem")
    path = store_cost_model(model)
    for p in points:
        lines.append(f"| {p['fill_pct']:g} | {p['n_spheres']} | {p['freq_hz']:g} | {p['cells']} | "
                     f"{p['steps']} | {p['cpu_s']:.2f} | {1e6 * p['cpu_s'] / p['steps']:.1f} | "
                     f"{model.run_cpu_s(p['cells'], p['n_spheres'], p['steps']):.2f} |")
    if pours_only:
        lines += ["", f"Runs kept from the stored entry ({kept.date}, `{kept.command}`); pours measured now."]
    pour_cpu = [p["cpu_s"] for p in pours]
    lines += ["", f"Model (written to {path.name}): {model.describe()}",
              f"Pours: {len(pours)}, CPU s each {np.mean(pour_cpu):.2f} mean, "
              f"{np.min(pour_cpu):.2f}-{np.max(pour_cpu):.2f}."]
    print("\n".join(lines))
    figures = {"model": model.describe(), "runs": len(points), "pours": len(pours),
               "pour_cpu_mean_s": round(float(np.mean(pour_cpu)), 3),
               "pour_cpu_range_s": f"{np.min(pour_cpu):.2f}-{np.max(pour_cpu):.2f}"}
    for p in points:
        name = f"fill{p['fill_pct']:g}_f{p['freq_hz']:g}Hz_cells{p['cells']}"
        figures[f"{name}_cpu_s"] = round(p["cpu_s"], 3)
        figures[f"{name}_model_s"] = round(model.run_cpu_s(p["cells"], p["n_spheres"], p["steps"]), 3)
    record(f"bench_cells_cost_{engine}", figures,
           notes=f"Cost of a run of k cells, {'LIGGGHTS' if engine == 'liggghts' else 'compiled DEM'}; "
                 f"the model is written to pidpipe/measurement/{path.name}."
                 + (" Runs kept from the stored entry; pours measured now." if pours_only else ""))


def compare_cells(freq: float, together: CaseRecord,
                  alone: list[CaseRecord]) -> tuple[str, dict]:
    """One frequency's table line and figures: the run of k cells (``together``) against the k
    packings each shaken alone (``alone``, in the same order), from the records' attributes."""
    cpu_alone = sum(r.engine["liggghts_cpu_time_s"] for r in alone)
    cpu_together = together.engine["liggghts_cpu_time_s"]
    z = [(cell["ceq_cell_ns_m"] - single.ceq_cell_ns_m)
         / math.hypot(cell["ceq_cell_sem_ns_m"], single.ceq_cell_sem_ns_m)
         for cell, single in zip((together.cells or ())[1:], alone[1:])]
    max_z = float(np.max(np.abs(z))) if z else float("nan")
    ceq = together.ceq_cell_ns_m
    cycle = together.ceq_cell_cycle_sem_ns_m
    between = together.ceq_cell_between_cells_sem_ns_m
    line = (f"| {freq:g} | {cpu_together:.1f} | {cpu_alone:.1f} | "
            f"{cpu_together / cpu_alone:.2f} | {ceq:.4g} | "
            f"{cycle:.2g} ({cycle / ceq:.1%}) | "
            f"{between:.2g} ({between / ceq:.1%}) | "
            f"{between / cycle:.2f} | {max_z:.2f} |")
    figures = {f"f{freq:g}Hz_cpu_together_s": round(cpu_together, 2),
               f"f{freq:g}Hz_cpu_alone_s": round(cpu_alone, 2),
               f"f{freq:g}Hz_cpu_ratio": round(cpu_together / cpu_alone, 3),
               f"f{freq:g}Hz_ceq_cell_ns_m": ceq,
               f"f{freq:g}Hz_cycle_sem_pct": round(100 * cycle / ceq, 2),
               f"f{freq:g}Hz_between_cells_sem_pct": round(100 * between / ceq, 2),
               f"f{freq:g}Hz_max_abs_z": round(max_z, 2)}
    return line, figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("values", nargs="*", metavar="K [FREQ_HZ ...] | PACKINGS_DIR",
                        help="cells and frequencies to compare (default 7 cells, 100 500 1000 Hz); "
                             "with --cost, a folder that keeps the packings")
    parser.add_argument("--cost", action="store_true", help="measure and store the cost model")
    parser.add_argument("--engine", choices=("liggghts", "dem"), default="liggghts",
                        help="the cost model's engine (with --cost)")
    parser.add_argument("--pours-only", action="store_true",
                        help="with --cost: measure the pours, keep the stored runs")
    args = parser.parse_args()
    if args.cost:
        if len(args.values) > 1:
            parser.error("--cost takes at most one packings folder")
        measure_cost(args.engine, args.values[0] if args.values else None, args.pours_only)
        return
    if args.engine != "liggghts" or args.pours_only:
        parser.error("--engine and --pours-only go with --cost")
    cells = int(args.values[0]) if args.values else 7
    freqs = [float(f) for f in args.values[1:]] or [100.0, 500.0, 1000.0]
    config = load_config()
    figures = {"cells": cells}
    lines = [f"| f Hz | CPU s, {cells} cells in one run | CPU s, {cells} single runs | ratio | "
             "C_eq per cell N s/m | cycle SEM | between-cells SEM | between / cycle | "
             "moved cells vs alone: max abs z |",
             "|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as scratch:
        packings, _ = replicate_packings(PourSettings.from_config(config), FILL_PCT, cells, Path(scratch) / "packings")
        for freq in freqs:
            case = CaseSpec(freq, ACCEL_G, FILL_PCT)
            together = run_case(ShakeSettings.from_config(config), case, packings, Path(scratch) / f"together_{freq:g}")
            alone = [run_case(ShakeSettings.from_config(config), case, packing, Path(scratch) / f"alone_{freq:g}_{k}")
                     for k, packing in enumerate(packings)]
            line, found = compare_cells(freq, together, alone)
            lines.append(line)
            print(lines[-1], flush=True)
            figures.update(found)
    notes = (f"{ACCEL_G:g} g, {FILL_PCT:g} % fill, default fidelity; replicate packings "
             f"0..{cells - 1} (seeds fidelity.seed + k). CPU = LIGGGHTS process CPU time. "
             "z = (moved cell - same packing alone) / combined SEM.")
    print("\n".join(lines + ["", notes]))
    record("bench_cells", figures, notes=notes)


if __name__ == "__main__":
    main()
