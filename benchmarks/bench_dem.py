"""How much faster is the compiled DEM than LIGGGHTS per particle-step (issue 12)? Both in one run.

Scenes: 1, 7 and 28 cells of 11 and of 19 acrylic spheres (50 % and 90 % fill; one packing of
each size poured by LIGGGHTS, repeated in every cell), 500 Hz, 5 g, the default fidelity
(dt = 0.2 t_R, rotation and friction on), ledgers on in both (the compiled DEM's per-cycle
ledgers; LIGGGHTS' deck with its energy bookkeeping, as a case runs it). Each engine shakes
the scene for 1 + N cycles, N at least ``--cycles`` and enough that the timed cycles cost
at least ``--min-cpu`` CPU seconds (the DEM's N from its warm-up cycles, LIGGGHTS' from its
stored cost model, :mod:`pidpipe.measurement.cost_model`), so that each timing is long enough
to trust on a shared machine; the two engines may then run different N. Reported: particle-steps per second (spheres x cells
x steps / time) of each, from the compiled DEM's wall time of the timed cycles (after
warm-up cycles) and LIGGGHTS' own loop time, and their ratio; the compile time of the kernel
on the first call in a fresh process with an empty Numba cache and with the cache filled.

The machine is shared: the load average is printed with the figures, and CPU time is given
next to wall time for the compiled DEM. ``--repeats R`` times every scene R times, the two
engines alternating (DEM first in odd rounds, LIGGGHTS first in even ones, so that a drift in
the machine's load falls on both alike); the table then gives each engine's median over the
rounds, the ratio of the medians, and the lowest and highest ratio of one round's pair, so that
one noisy timing neither makes nor breaks a target.

Figures go to ``benchmarks/records/bench_dem.json`` (:mod:`harness`): per scene
(``spheres<n>_cells<k>_...``) each engine's ns per particle-step and the speed-up.

Run: .venv/bin/python benchmarks/bench_dem.py [--cycles 4] [--min-cpu 2] [--repeats 1]
     [--spheres 11 19] [--cells 1 7 28] [--no-liggghts]
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from harness import record

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.dem import run_cycles, start
from pidpipe.dem.from_scene import dem_scene

FREQ_HZ, ACCEL_G = 500.0, 5.0
FILLS = {11: 50.0, 19: 90.0}
CELLS = (1, 7, 28)

FIRST_CALL = """
import time, numpy as np
began = time.perf_counter()
from pidpipe.config import load_config
from pidpipe.dem import advance, start
from pidpipe.dem.from_scene import dem_scene
from pidpipe.cell.scene import CellScene
imported = time.perf_counter()
scene = dem_scene(CellScene.from_config(load_config()), 500.0, 5.0)
positions = np.loadtxt(r"{packing}", delimiter=",")
scene, state, ws = start(scene, positions)
advance(scene, state, ws, 1)
print(imported - began, time.perf_counter() - imported)
"""


def compile_times(packing_csv: Path) -> dict:
    """Seconds to import pidpipe.dem and to make the first kernel calls, with an empty Numba
    cache and then with the cache the first process wrote."""
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        for label in ("empty cache", "cached"):
            done = subprocess.run([sys.executable, "-c", FIRST_CALL.format(packing=packing_csv)],
                                  env=env, capture_output=True, text=True, check=True)
            imported, first_call = map(float, done.stdout.split())
            out[label] = (imported, first_call)
    return out


WARM_UP_CYCLES = 2
"""Cycles the compiled DEM runs before the timed ones (the first compiles or loads the kernel;
their CPU time sets how many cycles reach ``--min-cpu``)."""


def time_dem(config: dict, positions: np.ndarray, n_cells: int, cycles: int,
             min_cpu_s: float = 0.0) -> dict:
    """Compiled DEM: wall and CPU time of at least ``cycles`` cycles (more if they would take
    less than ``min_cpu_s`` CPU seconds) after the warm-up cycles."""
    scene = dem_scene(CellScene.from_config(config), FREQ_HZ, [ACCEL_G] * n_cells)
    scene, state, ws = start(scene, np.stack([positions] * n_cells))
    run_cycles(scene, state, ws, 1)
    cpu = time.process_time()
    run_cycles(scene, state, ws, WARM_UP_CYCLES - 1)
    per_cycle = (time.process_time() - cpu) / (WARM_UP_CYCLES - 1)
    cycles = max(cycles, math.ceil(min_cpu_s / max(per_cycle, 1e-9)))
    wall, cpu = time.perf_counter(), time.process_time()
    run_cycles(scene, state, ws, cycles)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    steps = cycles * scene.steps_per_cycle
    particle_steps = len(positions) * n_cells * steps
    return dict(steps=steps, seconds=wall, cpu_seconds=cpu,
                particle_steps_per_s=particle_steps / wall,
                cpu_particle_steps_per_s=particle_steps / cpu)


def liggghts_cycles(config: dict, n_spheres: int, n_cells: int, cycles: int,
                    min_cpu_s: float) -> int:
    """At least ``cycles``, and enough that LIGGGHTS' stored cost model predicts ``min_cpu_s``
    CPU seconds for them."""
    from pidpipe.measurement.cost_model import load_cost_model

    model = load_cost_model("liggghts")
    if model is None or min_cpu_s <= 0.0:
        return cycles
    steps = CellScene.from_config(config).timestep(FREQ_HZ).steps_per_cycle
    per_cycle = model.run_cpu_s(n_cells, n_spheres, steps) - model.overhead_s
    return max(cycles, math.ceil(min_cpu_s / per_cycle))


def time_liggghts(config: dict, packing, n_cells: int, cycles: int, workdir: Path) -> dict:
    """LIGGGHTS: its loop time for 1 + ``cycles`` cycles of ``n_cells`` cells of the packing.

    More cells than one run may hold (:data:`pidpipe.cell.layout.MAX_CELLS`) run as equal
    runs of fewer cells, one after the other; their particle-steps and loop times add up.
    """
    from pidpipe.cases import CaseSpec
    from pidpipe.cell.layout import MAX_CELLS
    from pidpipe.liggghts.shake import run_case

    config = copy.deepcopy(config)
    config["fidelity"].update(transient_cycles=1, transient_min_time_s=0.0,
                              measured_cycles=cycles)
    runs = -(-n_cells // MAX_CELLS)
    steps = particle_steps = seconds = cpu_seconds = 0
    for run in range(runs):
        cells = n_cells // runs
        record = run_case(ShakeSettings.from_config(config),
                          CaseSpec(FREQ_HZ, ACCEL_G, packing.fill_pct),
                          [packing] * cells, workdir / f"run{run}")
        engine = record.engine
        steps = engine["steps"]
        particle_steps += packing.n_spheres * cells * engine["steps"]
        seconds += engine["liggghts_loop_time_s"]
        cpu_seconds += engine["liggghts_cpu_time_s"]
    return dict(steps=steps, runs=runs, seconds=seconds, cpu_seconds=cpu_seconds,
                particle_steps_per_s=particle_steps / seconds,
                cpu_particle_steps_per_s=particle_steps / cpu_seconds)


def median_timing(timings: list[dict]) -> dict:
    """One engine's timings of a scene over the rounds: the medians of its times and rates, the
    steps and runs of the last round, and the number of rounds."""
    out = dict(timings[-1], rounds=len(timings))
    for key in ("seconds", "cpu_seconds", "particle_steps_per_s", "cpu_particle_steps_per_s"):
        out[key] = statistics.median(t[key] for t in timings)
    return out


def round_ratios(dem: list[dict], lig: list[dict], key: str) -> tuple[float, float]:
    """Lowest and highest DEM / LIGGGHTS rate ratio of one round's pair of timings."""
    ratios = [d[key] / l[key] for d, l in zip(dem, lig)]
    return min(ratios), max(ratios)


def time_scene(config: dict, packing, n_cells: int, args, workdir: Path) -> tuple[list, list | None]:
    """``args.repeats`` rounds of both engines on one scene, alternating which goes first."""
    dem, lig = [], []
    for round_ in range(args.repeats):
        order = ("dem", "liggghts") if round_ % 2 == 0 else ("liggghts", "dem")
        for engine in order:
            if engine == "dem":
                dem.append(time_dem(config, packing.centres(), n_cells, args.cycles, args.min_cpu))
            elif not args.no_liggghts:
                lig.append(time_liggghts(
                    config, packing, n_cells,
                    liggghts_cycles(config, packing.n_spheres, n_cells, args.cycles, args.min_cpu),
                    workdir / f"round{round_}"))
    return dem, (None if args.no_liggghts else lig)


def runs_note(runs: int) -> str:
    """`` (2 runs)`` when LIGGGHTS' cells were split over several runs."""
    return "" if runs == 1 else f" ({runs} runs)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=4, help="timed cycles per scene")
    parser.add_argument("--min-cpu", type=float, default=0.0,
                        help="least CPU seconds of each engine's timed cycles (more cycles)")
    parser.add_argument("--repeats", type=int, default=1,
                        help="rounds of both engines per scene, alternating (medians reported)")
    parser.add_argument("--spheres", type=int, nargs="+", default=list(FILLS), choices=list(FILLS),
                        help="packing sizes to time")
    parser.add_argument("--cells", type=int, nargs="+", default=list(CELLS),
                        help="cells per scene to time")
    parser.add_argument("--no-liggghts", action="store_true", help="time the compiled DEM only")
    args = parser.parse_args()
    if args.repeats < 1 or min(args.cells) < 1:
        parser.error("--repeats and --cells must be at least 1")
    from pidpipe.liggghts.pour import pour

    config = load_config()
    load_start = os.getloadavg()[0]
    lines = []
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        pouring = PourSettings.from_config(config)
        packings = {n: pour(pouring, FILLS[n], 0, scratch / f"pour{n}") for n in args.spheres}
        for n, packing in packings.items():
            assert packing.n_spheres == n, (n, packing.n_spheres)
        csv = scratch / "packing11.csv"
        np.savetxt(csv, packings[min(packings)].centres(), delimiter=",")
        compiled = compile_times(csv)
        rows = []
        for n, packing in packings.items():
            for k in args.cells:
                dem, lig = time_scene(config, packing, k, args, scratch / f"shake{n}_{k}")
                rows.append((n, k, dem, lig))
                print(n, k, dem, lig, flush=True)
    lines.append(f"Scene: 500 Hz, 5 g, default fidelity, at least {args.cycles} timed cycles "
                 f"and {args.min_cpu:g} CPU s per timing (steps columns: each engine's), "
                 f"{args.repeats} round(s) per scene; packings "
                 "poured by LIGGGHTS (seed fidelity.seed), one per size, repeated in every cell. "
                 f"Load average {load_start:.2f} at the start, {os.getloadavg()[0]:.2f} at the "
                 f"end, on {os.cpu_count()} cores.")
    lines += ["", "Wall: the DEM's wall time against LIGGGHTS' loop time. CPU: the DEM's process "
              "CPU time against the LIGGGHTS process's (which includes its start-up: reading "
              "the mesh and the set-up run, so the CPU ratio favours the DEM a little).", "",
              "| spheres | cells | DEM steps | DEM wall s | DEM CPU s | DEM ns per particle-step "
              "(wall / CPU) | LIGGGHTS steps | LIGGGHTS loop s | LIGGGHTS CPU s | LIGGGHTS ns "
              "per particle-step (loop / CPU) | DEM / LIGGGHTS, wall | DEM / LIGGGHTS, CPU |"
              + (" CPU ratio, lowest-highest round |" if args.repeats > 1 else ""),
              "|---|---|---|---|---|---|---|---|---|---|---|---|" + ("---|" if args.repeats > 1 else "")]
    if args.repeats > 1:
        lines[-3:-3] = ["", f"Times, rates and ratios: medians over the {args.repeats} rounds; "
                        "the last column: the lowest and highest ratio of one round's pair."]
    figures = {"load_average_start": round(load_start, 2), "load_average_end": round(os.getloadavg()[0], 2)}
    for n, k, dems, ligs in rows:
        dem = median_timing(dems)
        lig = None if ligs is None else median_timing(ligs)
        scene = f"spheres{n}_cells{k}"
        figures.update({f"{scene}_dem_steps": dem["steps"],
                        f"{scene}_dem_wall_ns_per_particle_step": round(1e9 / dem["particle_steps_per_s"], 1),
                        f"{scene}_dem_cpu_ns_per_particle_step": round(1e9 / dem["cpu_particle_steps_per_s"], 1)})
        if lig is not None:
            figures.update({
                f"{scene}_liggghts_steps": lig["steps"],
                f"{scene}_liggghts_loop_ns_per_particle_step": round(1e9 / lig["particle_steps_per_s"], 1),
                f"{scene}_liggghts_cpu_ns_per_particle_step": round(1e9 / lig["cpu_particle_steps_per_s"], 1),
                f"{scene}_speed_up_wall": round(dem["particle_steps_per_s"] / lig["particle_steps_per_s"], 2),
                f"{scene}_speed_up_cpu": round(dem["cpu_particle_steps_per_s"] / lig["cpu_particle_steps_per_s"], 2)})
        lig_cols = ("- | - | - | - | - | -" if lig is None else
                    f"{lig['steps']}{runs_note(lig['runs'])} | {lig['seconds']:.2f} | "
                    f"{lig['cpu_seconds']:.2f} | {1e9 / lig['particle_steps_per_s']:.0f} / "
                    f"{1e9 / lig['cpu_particle_steps_per_s']:.0f} | "
                    f"{dem['particle_steps_per_s'] / lig['particle_steps_per_s']:.1f}x | "
                    f"{dem['cpu_particle_steps_per_s'] / lig['cpu_particle_steps_per_s']:.1f}x")
        spread = ""
        if args.repeats > 1:
            spread = (" - |" if ligs is None else
                      " {:.1f}-{:.1f}x |".format(*round_ratios(dems, ligs, "cpu_particle_steps_per_s")))
            if ligs is not None:
                low, high = round_ratios(dems, ligs, "cpu_particle_steps_per_s")
                figures[f"{scene}_speed_up_cpu_rounds"] = f"{low:.1f}-{high:.1f}"
        lines.append(f"| {n} | {k} | {dem['steps']} | {dem['seconds']:.3f} | "
                     f"{dem['cpu_seconds']:.3f} | {1e9 / dem['particle_steps_per_s']:.0f} / "
                     f"{1e9 / dem['cpu_particle_steps_per_s']:.0f} | {lig_cols} |{spread}")
    lines += ["", "Compiled kernel, first call in a fresh process (import of pidpipe.dem, then "
              "start + one step of one cell of 11 spheres):"]
    for label, (imported, first_call) in compiled.items():
        lines.append(f"- {label}: import {imported:.2f} s, first call {first_call:.2f} s")
        key = label.replace(" ", "_")
        figures[f"{key}_import_s"] = round(imported, 2)
        figures[f"{key}_first_call_s"] = round(first_call, 2)
    print("\n".join(lines))
    record("bench_dem", figures, notes=lines[0])


if __name__ == "__main__":
    main()
