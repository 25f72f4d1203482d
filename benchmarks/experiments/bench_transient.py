"""Does a packing already shaken at the case's own (f, G) shorten the transient? (issue 13)

For each case below, k cells of LIGGGHTS-poured packings are shaken in the compiled DEM:

- **fresh**: from the poured packings at rest, for the case's configured transient plus the
  measured cycles (the pilot of a campaign case);
- **pre-shaken**: from the pilot's end state (positions, velocities and spins at its last cycle
  boundary, where the wall is at rest at z = 0), with the contact history cleared (what a new
  LIGGGHTS run re-created from that state would have), for ``--cycles`` cycles.

Reported per case: the transient the campaign discards (configured), the transient MSER detects
on the k cells' summed series of each run (the campaign's own detector,
:func:`pidpipe.measurement.steady_state.mser_truncation` on 2-cycle blocks), the bias of each
run's first 5 cycles against its own steady mean (cycles after the configured transient, or
after 10 for the pre-shaken run), the drop of the bed's centre of mass over each run
(compaction), and the two steady means' ratio with its standard error (they must agree: same
bed, same physics). CPU times are the DEM's.

Run: .venv/bin/python benchmarks/experiments/bench_transient.py [--cells 7] [--cycles 50]
         [--packings DIR]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.dem import run_cycles, start
from pidpipe.dem.from_scene import dem_scene
from pidpipe.measurement.steady_state import mser_truncation
from pidpipe.steps.cases import pool_packings

REPO = Path(__file__).resolve().parents[2]
CASES = ((1000, 10, 25), (1000, 5, 90), (750, 5, 50), (500, 5, 25), (500, 10, 90),
         (100, 5, 50), (50, 1, 75))
"""(frequency Hz, acceleration g, fill %) of the grid: both ends of f, G and fill."""
SETTLE_CYCLES = 10
"""Cycles of the pre-shaken run left out of its steady mean."""
BIAS_CYCLES = 5


def shake(cell_scene: CellScene, freq_hz: float, accel_g: float, positions, velocities,
          spins, cycles: int) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray, float]:
    """Shake the batch for ``cycles``; return the ledgers, the end state (x, v, w as
    (k, n, 3)) and the CPU time, s."""
    cpu = time.process_time()
    scene = dem_scene(cell_scene, freq_hz, [accel_g] * positions.shape[0])
    scene, state, ws = start(scene, positions, velocities, spins)
    ledgers = run_cycles(scene, state, ws, cycles)
    ends = [np.moveaxis(array, 0, 2).copy() for array in (state.x, state.v, state.omega)]
    return ledgers, *ends, time.process_time() - cpu


def steady(series: np.ndarray, skip: int) -> tuple[float, float]:
    """Mean and standard error (2-cycle blocks) of the summed series after ``skip`` cycles."""
    rest = series[skip:]
    blocks = rest[: rest.size // 2 * 2].reshape(-1, 2).mean(axis=1)
    return float(rest.mean()), float(blocks.std(ddof=1) / np.sqrt(blocks.size))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--cells", type=int, default=7)
    parser.add_argument("--cycles", type=int, default=50, help="cycles of the pre-shaken run")
    parser.add_argument("--packings", type=Path, default=Path("/tmp/pidpipe_bench_transient"),
                        help="where the packings are poured (and reused)")
    args = parser.parse_args()
    config = load_config(REPO / "config.yaml")
    shaking, pouring = ShakeSettings.from_config(config), PourSettings.from_config(config)
    cell_scene = CellScene.of(shaking)
    sampling = shaking.sampling
    rows = []
    for freq, accel, fill in CASES:
        packings = pool_packings(pouring, fill, list(range(args.cells)), args.packings)
        positions = np.stack([packing.centres() for packing in packings])
        configured = sampling.transient_cycles_at(freq)
        pilot_cycles = configured + sampling.measured_cycles
        fresh, x, v, w, cpu_fresh = shake(cell_scene, freq, accel, positions, None, None,
                                          pilot_cycles)
        again, _, _, _, cpu_again = shake(cell_scene, freq, accel, x, v, w, args.cycles)
        row = {"case": f"{freq} Hz / {accel} g / {fill} %", "n": positions.shape[1],
               "configured": configured, "cpu": (cpu_fresh, cpu_again)}
        for name, ledgers, skip in (("fresh", fresh, configured), ("shaken", again, SETTLE_CYCLES)):
            series = ledgers["dissipated_terms_j"].sum(axis=0)
            mean, sem = steady(series, skip)
            com = ledgers["centre_of_mass_z_m"].mean(axis=0)
            row[name] = {"mser": mser_truncation(series, sampling.sem_block_cycles),
                         "bias": float(series[:BIAS_CYCLES].mean() / mean - 1.0),
                         "mean": mean, "sem": sem, "drop_um": float(com[0] - com[-1]) * 1e6}
        rows.append(row)
        print(row, flush=True)
    lines = [f"{args.cells} cells per case (LIGGGHTS pours, seeds fidelity.seed + 0..{args.cells - 1}), "
             f"default fidelity, compiled DEM. Fresh: the pilot from the poured packings "
             f"(configured transient + {sampling.measured_cycles} measured cycles). Pre-shaken: "
             f"{args.cycles} cycles from the pilot's end state, contact history cleared. MSER: "
             f"cycles the campaign's detector would discard on the cells' summed series; bias: "
             f"first {BIAS_CYCLES} cycles' mean E_d over the run's steady mean - 1 (steady: "
             f"after the configured transient, or after {SETTLE_CYCLES} cycles for the "
             "pre-shaken run); drop: the bed's centre of mass, first to last cycle boundary.", "",
             "| case | spheres | configured transient | fresh: MSER / bias / drop um | "
             "pre-shaken: MSER / bias / drop um | steady pre-shaken / fresh | DEM CPU s (fresh, pre-shaken) |",
             "|---|---|---|---|---|---|---|"]
    for row in rows:
        fresh, shaken = row["fresh"], row["shaken"]
        ratio = shaken["mean"] / fresh["mean"]
        error = ratio * np.hypot(shaken["sem"] / shaken["mean"], fresh["sem"] / fresh["mean"])
        lines.append(f"| {row['case']} | {row['n']} | {row['configured']} | {fresh['mser']} / "
                     f"{fresh['bias']:+.0%} / {fresh['drop_um']:.0f} | {shaken['mser']} / "
                     f"{shaken['bias']:+.0%} / {shaken['drop_um']:.0f} | {ratio:.3f} +- {error:.3f} | "
                     f"{row['cpu'][0]:.1f}, {row['cpu'][1]:.1f} |")
    append("Transient of a fresh and of a pre-shaken packing",
           f"python benchmarks/experiments/bench_transient.py --cells {args.cells} --cycles {args.cycles}", lines)


if __name__ == "__main__":
    main()
