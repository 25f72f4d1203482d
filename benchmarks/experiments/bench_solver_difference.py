"""Why the DEM dissipated less than LIGGGHTS at 1 g (issue 12): paired experiments on the same packings.

The grid check found the compiled DEM 0.23 +- 0.06 % (750 Hz) and 0.37 +- 0.13 % (1000 Hz)
below LIGGGHTS at 1 g / 75 %, cell by cell on the same packings. Each case here shakes the same
k packings (the campaign's replicates 0..k-1 of the fill, copied from ``--packings`` if given,
else poured) in every variant:

- ``liggghts``: LIGGGHTS as the campaign runs it (the reference of the paired differences);
- ``liggghts_mesh4``: the same walls with each hexagon side cut into 4 pieces, 7x the shared
  edges between coplanar triangles (the untested hypothesis: a sphere creeping across such an
  edge loses its tangential history);
- ``liggghts_dt0.1``: LIGGGHTS at dt = 0.1 t_R instead of 0.2 t_R;
- ``dem``, ``dem_dt0.1``: the compiled DEM at 0.2 t_R (the grid check's) and at 0.1 t_R. Since
  the wall fix its walls are where LIGGGHTS' ``viblin`` puts the mesh (before it, they were at
  the exact z_w(t_n): the results.md entries of 13:22-13:34 UTC on 2026-12-01 are of those);
- ``dem_exact``, ``dem_exact_dt0.1``: the NumPy reference DEM (the kernel's physics) with its
  walls at the exact z_w(t_n) (``walls="exact"``), the DEM as it was before the fix;
- ``dem_viblin``, ``dem_viblin_dt0.1``: the NumPy reference DEM with its walls where ``viblin``
  puts the mesh, :func:`pidpipe.dem.walls.viblin_wall_motion` (the compiled DEM's walls).

``dem_viblin vs dem_exact`` (when both run) is the wall fix's own effect, against pi / steps per
cycle, the slip the half-step offset integrates.

Every variant's cell C_eq is its mean E_d over the same cycles, the configured transient's
end to the run's end (no MSER choice, so the windows are the same). The paired difference of a
variant is the mean over the cells of C_variant - C_liggghts over the mean LIGGGHTS C_eq, with
its standard error over the cells (:func:`pidpipe.studies.grid_check.paired_cell_difference`, the
grid check's own test): the packings' spread cancels, what is left is the cycle noise and the
divergence of chaotic cells.

Run: .venv/bin/python benchmarks/experiments/bench_solver_difference.py [--cases 1000 750] [--fill 75]
         [--cells 7] [--cycles 80] [--packings DIR] [--variants NAME ...]
"""

from __future__ import annotations

import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.cases import CaseSpec
from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.dem import reference
from pidpipe.dem.case import run_dem_case
from pidpipe.dem.from_scene import dem_scene
from pidpipe.dem.pouring import replicate_packings
from pidpipe.liggghts.shake import run_case
from pidpipe.physics.equivalent_damping import ceq_from_energy
from pidpipe.studies.grid_check import paired_cell_difference

VARIANTS = {
    # name: (engine, dt / t_R, mesh subdivisions or DEM walls)
    "liggghts": ("liggghts", 0.2, 1),
    "liggghts_mesh4": ("liggghts", 0.2, 4),
    "liggghts_dt0.1": ("liggghts", 0.1, 1),
    "dem": ("dem", 0.2, "viblin"),
    "dem_dt0.1": ("dem", 0.1, "viblin"),
    "dem_exact": ("dem_reference", 0.2, "exact"),
    "dem_exact_dt0.1": ("dem_reference", 0.1, "exact"),
    "dem_viblin": ("dem_reference", 0.2, "viblin"),
    "dem_viblin_dt0.1": ("dem_reference", 0.1, "viblin"),
}
REFERENCE = "liggghts"
CLOSE = 1e-4
"""A cell whose C_eq is within this fraction of its LIGGGHTS value counts as reproduced."""


def cell_series(engine: str, settings: ShakeSettings, case: CaseSpec, packings: list,
                option, workdir: Path) -> tuple[np.ndarray, float]:
    """Each cell's E_d per cycle, J, shape (k, cycles), and the run's CPU time, s."""
    cycles = settings.sampling.transient_cycles_at(case.freq_hz) + settings.sampling.measured_cycles
    started = time.process_time()
    if engine == "liggghts":
        record = run_case(settings, case, packings, workdir, mesh_subdivisions=option)
        return (np.array([cell["dissipated_j"] for cell in record.cells]),
                record.engine["liggghts_cpu_time_s"])
    if engine == "dem":
        record = run_dem_case(settings, case, packings)
        return (np.array([cell["dissipated_j"] for cell in record.cells]),
                record.engine["cpu_time_s"])
    scene = dem_scene(CellScene.of(settings), case.freq_hz, [case.accel_g] * len(packings))
    scene, state, ws = reference.start(scene, np.stack([p.centres() for p in packings]))
    out = reference.run_cycles(scene, state, ws, cycles, walls=option)
    return out["dissipated_terms_j"], time.process_time() - started


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser()
    parser.add_argument("--cases", type=float, nargs="+", default=[1000.0, 750.0],
                        help="frequencies, Hz, each at 1 g")
    parser.add_argument("--fill", type=float, default=75.0)
    parser.add_argument("--cells", type=int, default=7)
    parser.add_argument("--cycles", type=int, default=80, help="measured cycles")
    parser.add_argument("--packings", default=None,
                        help="folder holding r<fill>pct_rep<k>.json (copied, never written)")
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    args = parser.parse_args()
    variants = [REFERENCE] + [v for v in args.variants if v != REFERENCE]
    lines = [f"{args.cells} cells (packings r{args.fill:g}pct_rep0..{args.cells - 1}), "
             f"{args.cycles} measured cycles after the configured transient, the same window "
             "in every variant; C_eq per cell, N s/m, mean over the cells +- its SEM (the "
             "packings' spread); paired: (C - C_liggghts) over the cells, +- SE.", "",
             "| case | variant | dt / t_R | C_eq per cell | paired difference vs liggghts | "
             "z | cells within 0.01 % of liggghts | CPU s |", "|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch) / "packings"
        folder.mkdir()
        if args.packings:
            for k in range(args.cells):
                name = f"r{args.fill:g}pct_rep{k}.json"
                if (Path(args.packings) / name).is_file():
                    shutil.copy(Path(args.packings) / name, folder / name)
        packings, _ = replicate_packings(PourSettings.from_config(load_config()), args.fill,
                                         args.cells, folder)
        seeds = [p.seed for p in packings]
        for freq in args.cases:
            case = CaseSpec(freq, 1.0, args.fill)
            ceq, cpu = {}, {}
            for name in variants:
                engine, fraction, option = VARIANTS[name]
                config = load_config()
                config["fidelity"]["timestep_rayleigh_fraction"] = fraction
                config["fidelity"]["measured_cycles"] = args.cycles
                config["fidelity"]["target_relative_sem"] = None
                settings = ShakeSettings.from_config(config)
                series, cpu[name] = cell_series(engine, settings, case, packings, option,
                                                Path(scratch) / f"{case.case_id}_{name}")
                transient = settings.sampling.transient_cycles_at(freq)
                ceq[name] = np.array([ceq_from_energy(float(cell[transient:].mean()), freq, 1.0)
                                      for cell in series])
                print(f"{case.case_id} {name}: {ceq[name].mean():.6g} ({cpu[name]:.0f} s CPU); "
                      f"cells {' '.join(f'{c:.6g}' for c in ceq[name])}", file=sys.stderr, flush=True)
            for name in variants:
                engine, fraction, option = VARIANTS[name]
                values = ceq[name]
                text = f"{values.mean():.5g} +- {values.std(ddof=1) / math.sqrt(values.size):.2g}"
                close = int(np.sum(np.abs(values / ceq[REFERENCE] - 1.0) < CLOSE))
                if name == REFERENCE:
                    diff, z = "reference", ""
                else:
                    paired = paired_cell_difference(
                        [{"seed": s, "ceq_cell_ns_m": c} for s, c in zip(seeds, ceq[REFERENCE])],
                        [{"seed": s, "ceq_cell_ns_m": c} for s, c in zip(seeds, values)])
                    diff = (f"{100 * paired['paired_rel_diff']:+.3f} +- "
                            f"{100 * paired['paired_rel_diff_sem']:.3f} %")
                    z = f"{paired['z_paired']:+.1f}"
                lines.append(f"| {freq:g} Hz, 1 g, {args.fill:g} % | {name} | {fraction:g} | "
                             f"{text} | {diff} | {z} | {close} of {values.size} | {cpu[name]:.0f} |")
            for suffix, fraction in (("", 0.2), ("_dt0.1", 0.1)):
                exact = f"dem_exact{suffix}" if f"dem_exact{suffix}" in ceq else None
                viblin = next((v for v in (f"dem_viblin{suffix}", f"dem{suffix}") if v in ceq), None)
                if not (exact and viblin):
                    continue
                paired = paired_cell_difference(
                    [{"seed": s, "ceq_cell_ns_m": c} for s, c in zip(seeds, ceq[exact])],
                    [{"seed": s, "ceq_cell_ns_m": c} for s, c in zip(seeds, ceq[viblin])])
                config = load_config()
                config["fidelity"]["timestep_rayleigh_fraction"] = fraction
                steps = CellScene.of(ShakeSettings.from_config(config)).timestep(freq).steps_per_cycle
                lines.append(f"| {freq:g} Hz, 1 g, {args.fill:g} % | {viblin} vs {exact} | {fraction:g} | "
                             f"pi / steps per cycle = {100 * math.pi / steps:.3f} % | "
                             f"{100 * paired['paired_rel_diff']:+.3f} +- "
                             f"{100 * paired['paired_rel_diff_sem']:.3f} % | "
                             f"{paired['z_paired']:+.1f} | | |")
            print("\n".join(lines[-len(variants) - 1:]), file=sys.stderr, flush=True)
    command = "benchmarks/experiments/bench_solver_difference.py " + " ".join(sys.argv[1:])
    append("Why the DEM dissipated less at 1 g: paired variants on the same packings", command.strip(),
           lines)


if __name__ == "__main__":
    main()
