"""Speed of the NumPy DEM (issue 4): particle-steps per second on one cell and on batches.

The case: 11 acrylic spheres (the settled packing of tests/dem/data), 500 Hz, 5 g, the
default fidelity (dt = 0.2 t_R, rotation and friction on). It times whole cycles after one
warm-up cycle, for a batch of k = 1, 4 and 8 identical cells integrated together, and reports
particle-steps per second (spheres x cells x steps / wall time). With ``--liggghts`` it also
shakes the same packing in LIGGGHTS (pidpipe.liggghts.shake.run_case) and reports the ratio.

Run: .venv/bin/python benchmarks/bench_dem.py [--cycles 2] [--liggghts]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np
from _record import append

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.dem import run_cycles, start
from pidpipe.dem.from_scene import dem_scene

PACKING = Path(__file__).resolve().parent.parent / "tests" / "dem" / "data" / "settled_11.csv"
FREQ_HZ, ACCEL_G = 500.0, 5.0


def time_numpy_dem(config: dict, positions: np.ndarray, batch: int, cycles: int) -> dict:
    """Wall time of ``cycles`` cycles of a batch of identical cells (after one warm-up cycle)."""
    scene = dem_scene(CellScene.from_config(config), FREQ_HZ, [ACCEL_G] * batch)
    scene, state, ws = start(scene, positions)
    run_cycles(scene, state, ws, 1)
    began = time.perf_counter()
    run_cycles(scene, state, ws, cycles)
    seconds = time.perf_counter() - began
    steps = cycles * scene.steps_per_cycle
    return dict(batch=batch, steps=steps, seconds=seconds,
                particle_steps_per_s=state.n_spheres * batch * steps / seconds,
                us_per_cell_step=seconds / (steps * batch) * 1e6)


def time_liggghts(config: dict, positions: np.ndarray, workdir: Path) -> dict:
    """LIGGGHTS' loop time per particle-step on the same packing and case."""
    from pidpipe.cases import CaseSpec
    from pidpipe.cell.packing import Packing
    from pidpipe.liggghts.shake import run_case

    cell_height = config["geometry"]["core_height_m"]
    radius = config["materials"][config["particle_material"]]["radius_m"]
    packing = Packing(positions_m=positions.tolist(), radius_m=radius,
                      n_spheres=len(positions), seed=0,
                      pile_height_m=float(positions[:, 2].max() + radius + cell_height / 2),
                      lid_height_m=cell_height, max_speed_m_s=0.0, settle_time_s=0.0,
                      fill_pct=50.0)
    record = run_case(ShakeSettings.from_config(config), CaseSpec(FREQ_HZ, ACCEL_G, 50.0), packing, workdir)
    engine = record["engine"]
    return dict(steps=engine["steps"], seconds=engine["liggghts_loop_time_s"],
                particle_steps_per_s=len(positions) * engine["steps"]
                / engine["liggghts_loop_time_s"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=2, help="timed cycles per batch size")
    parser.add_argument("--liggghts", action="store_true", help="also time LIGGGHTS")
    args = parser.parse_args()
    config = load_config()
    positions = np.loadtxt(PACKING, delimiter=",")
    results = [time_numpy_dem(config, positions, batch, args.cycles) for batch in (1, 4, 8)]
    lines = [f"Case: {len(positions)} spheres, {FREQ_HZ:g} Hz, {ACCEL_G:g} g, default fidelity; "
             f"load average at the end {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores.", "",
             "| solver | cells k | steps | wall s | us per cell-step | particle-steps/s |",
             "|---|---|---|---|---|---|"]
    for r in results:
        lines.append(f"| numpy-dem | {r['batch']} | {r['steps']} | {r['seconds']:.2f} | "
                     f"{r['us_per_cell_step']:.1f} | {r['particle_steps_per_s']:.3g} |")
    if args.liggghts:
        with tempfile.TemporaryDirectory() as scratch:
            lig = time_liggghts(config, positions, Path(scratch))
        lines.append(f"| liggghts (loop time) | 1 | {lig['steps']} | {lig['seconds']:.2f} | "
                     f"{lig['seconds'] / lig['steps'] * 1e6:.1f} | "
                     f"{lig['particle_steps_per_s']:.3g} |")
        lines += ["", "LIGGGHTS / numpy-dem particle-steps per second: " + ", ".join(
            f"k = {r['batch']}: {lig['particle_steps_per_s'] / r['particle_steps_per_s']:.1f}x"
            for r in results)]
    append("NumPy DEM speed", "python benchmarks/bench_dem.py"
           + (" --liggghts" if args.liggghts else ""), lines)


if __name__ == "__main__":
    main()
