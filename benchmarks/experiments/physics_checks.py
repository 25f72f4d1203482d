"""The physics figures the README quotes, measured with the real LIGGGHTS (and the NumPy DEM).

1. Restitution of a sphere on the wall and of two spheres (configured 0.70) at three timesteps.
2. e = 1, mu = 0: mean dissipation over 60 cycles against the work exchanged per cycle.
3. Pour capacity: pile heights of 20, 21 and 22 spheres for five seeds (the lid is at 25.4 mm).
4. Steady state at 1000 Hz, 5 g, 50 %: stored-energy drift with 5 transient cycles and with the
   default minimum transient time.
5. LIGGGHTS against the NumPy DEM on five cases (at least 5 transient + 24 measured cycles; each
   solver discards the transient its own run shows, by the same rule; --no-dem to skip,
   --validation-only to run only this part).

Run: .venv/bin/python benchmarks/experiments/physics_checks.py [--no-dem | --validation-only]   (about 6 minutes on 2 cores)
"""

from __future__ import annotations

import argparse
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
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.shake import run_case

VALIDATION_CASES = [(1000, 10), (1000, 1), (500, 5), (100, 10), (100, 1)]


def restitution_lines(scratch: Path) -> list[str]:
    lines = ["| dt / Rayleigh time | sphere-wall e (0.70) | sphere-sphere e (0.70) |", "|---|---|---|"]
    for fraction in (0.4, 0.2, 0.1, 0.05):
        cfg = load_config()
        cfg["fidelity"]["timestep_rayleigh_fraction"] = fraction
        lines.append(f"| {fraction} | {wall_restitution(CellScene.from_config(cfg), 0.5, scratch / 'w'):.4f} | "
                     f"{pair_restitution(CellScene.from_config(cfg), 0.5, scratch / 'p'):.4f} |")
    return lines + ["(impact speed 0.5 m/s)", ""]


def elastic_lines(scratch: Path, packing) -> list[str]:
    cfg = load_config()
    cfg["fidelity"].update(transient_cycles=2, transient_min_time_s=0.0, measured_cycles=60, friction=False)
    for pair in cfg["pairs"]:
        pair["restitution"] = 1.0
    cycles = run_case(ShakeSettings.from_config(cfg), CaseSpec(500, 5, 50), packing, scratch / "elastic").cycles
    dissipated, exchanged = np.array(cycles["dissipated_j"][2:]), np.array(cycles["gross_work_j"][2:])
    return [f"e = 1, mu = 0, 500 Hz, 5 g, 11 spheres, 60 cycles: mean E_d / mean work exchanged per "
            f"cycle = {dissipated.mean() / exchanged.mean():+.4%}; per-cycle std "
            f"{dissipated.std(ddof=1) / exchanged.mean():.3%}; largest single cycle "
            f"{np.abs(dissipated).max() / exchanged.mean():.3%}", ""]


def capacity_lines(scratch: Path) -> list[str]:
    cfg = load_config()
    cfg["fill"]["definition"] = "source_36"
    lines = ["| spheres | pile heights, seeds 0-4 (mm) | below the 25.4 mm lid |", "|---|---|---|"]
    for count in (20, 21, 22):
        piles = [pour(PourSettings.from_config(cfg), 100.0 * count / 36 + 1e-9, k, scratch / "pour").pile_height_m * 1e3
                 for k in range(5)]
        lines.append(f"| {count} | {', '.join(f'{p:.2f}' for p in piles)} | "
                     f"{sum(p <= 25.4 for p in piles)} of 5 |")
    return lines + [""]


def steady_lines(scratch: Path, packing) -> list[str]:
    lines = []
    for label, minimum in (("5 transient cycles", 0.0), ("default (>= 0.03 s)", None)):
        cfg = load_config()
        if minimum is not None:
            cfg["fidelity"]["transient_min_time_s"] = minimum
        record = run_case(ShakeSettings.from_config(cfg), CaseSpec(1000, 5, 50), packing, scratch / "steady")
        lines.append(f"1000 Hz, 5 g, 50 %, {label}: {record.fidelity['transient_cycles']} transient "
                     f"cycles, drift {record.energy_drift_fraction:.3f}, status {record.status}")
    return lines + [""]


def validation_lines(scratch: Path, packing) -> list[str]:
    from pidpipe.studies.validation import run_validation

    cfg = load_config()
    cfg["fidelity"].update(transient_cycles=5, measured_cycles=24)
    cases = [CaseSpec(f, g, 50) for f, g in VALIDATION_CASES]
    table = run_validation(ShakeSettings.from_config(cfg), cases, {"r50pct_rep0": packing}, scratch / "validation")
    lines = ["| case | transient cycles LIGGGHTS / DEM | C_eq LIGGGHTS N s/m | C_eq NumPy DEM N s/m | "
             "ratio | difference / combined SEM | agree (2 SEM) | flags LIGGGHTS / DEM | "
             "DEM term-by-term vs balance |",
             "|---|---|---|---|---|---|---|---|---|"]
    for row in table.itertuples():
        lines.append(f"| {row.case_id} | {row.liggghts_transient_cycles} / {row.dem_transient_cycles} | "
                     f"{row.ceq_cell_liggghts_ns_m:.4g} +- {row.ceq_cell_liggghts_sem_ns_m:.2g} | "
                     f"{row.ceq_cell_dem_ns_m:.4g} +- {row.ceq_cell_dem_sem_ns_m:.2g} | "
                     f"{row.ratio_dem_over_liggghts:.3f} +- {row.ratio_sem:.3f} | "
                     f"{row.difference_over_combined_sem:+.2f} | {row.agree} | "
                     f"{row.liggghts_flags or '-'} / {row.dem_flags or '-'} | "
                     f"{row.dem_balance_mismatch_fraction:+.2e} |")
    return lines + ["(11 spheres, the seed-0 50 % packing; each solver runs 5 + 24 cycles (more transient "
                    "where the 0.03 s minimum asks) and measures the cycles after the transient its own "
                    "run shows; +- one standard error)", ""]


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--no-dem", action="store_true", help="skip the NumPy DEM comparison")
    parser.add_argument("--validation-only", action="store_true",
                        help="run only the comparison of LIGGGHTS and the NumPy DEM")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        scratch = Path(folder)
        packing = pour(PourSettings.from_config(load_config()), 50, 0, scratch / "pour50")
        if args.validation_only:
            lines = validation_lines(scratch, packing)
        else:
            lines = (restitution_lines(scratch) + elastic_lines(scratch, packing)
                     + capacity_lines(scratch) + steady_lines(scratch, packing))
            if not args.no_dem:
                lines += validation_lines(scratch, packing)
    title = "Physics checks: LIGGGHTS against the NumPy DEM" if args.validation_only else "Physics checks"
    flag = " --validation-only" if args.validation_only else (" --no-dem" if args.no_dem else "")
    append(title, f"python benchmarks/experiments/physics_checks.py{flag}", lines)


if __name__ == "__main__":
    main()
