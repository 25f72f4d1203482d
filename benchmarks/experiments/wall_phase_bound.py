"""How much a half-step error in the walls' phase can move C_eq at each 1 g case (issue 12).

Before the wall fix the DEM put its walls at z_w(t_n), while LIGGGHTS' ``viblin`` moves the mesh
by v_w(t_n) dt each step, so its walls run half a step, a phase of pi / N (N steps per cycle),
ahead of the velocity the wall work is taken with. The wall force on the bed is mostly
reactive at 1 g, where the bed rides the floor: a bed of mass m_bed moving with the walls
pushes back with m_bed a_w, in phase with the displacement. A phase error of pi / N turns a
fraction sin(pi / N) of that force into the in-phase (dissipative) part, so it moves C_eq by at
most

    dC <= (pi / N) m_bed omega,   i.e.   dC / C <= (pi / N) m_bed omega / C_eq,

with equality for a bed that moves rigidly with the walls. Where the bed's dissipation is small
against its inertia (low frequency at 1 g), the bound is many times pi / N. This script prints
the bound of every 1 g case of a campaign (flagged ones too) from its records (C_eq, N, the spheres) and, when the
campaign has a grid check, the paired DEM - LIGGGHTS difference it measured.

Run: .venv/bin/python benchmarks/experiments/wall_phase_bound.py RESULTS_DIR
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.config import load_config
from pidpipe.physics.contact import sphere_mass


def phase_bound(steps_per_cycle: int, n_spheres: int, sphere_mass_kg: float, freq_hz: float,
                ceq_ns_m: float) -> tuple[float, float]:
    """pi / N and the rigid-bed bound (pi / N) m_bed omega / C_eq, both as fractions of C_eq."""
    phase = math.pi / steps_per_cycle
    return phase, phase * n_spheres * sphere_mass_kg * 2.0 * math.pi * freq_hz / ceq_ns_m


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("results", type=Path, help="a campaign's results folder")
    args = parser.parse_args()
    config = load_config()
    material = config["materials"][config["particle_material"]]
    mass = sphere_mass(float(material["radius_m"]), float(material["density_kg_m3"]))
    grid_path = args.results / "validation" / "grid.csv"
    grid = pd.read_csv(grid_path).set_index("case_id") if grid_path.is_file() else None
    lines = ["Particle mass from config.yaml; C_eq, N and the spheres from each 1 g case's record. "
             "Bound: (pi / N) m_bed omega / C_eq, the most a phase error of pi / N can move C_eq.", "",
             "| case | status (LIGGGHTS) | N | m_bed omega / C_eq | pi / N | rigid-bed bound | "
             "paired DEM - LIGGGHTS |", "|---|---|---|---|---|---|---|"]
    records = [json.loads(path.read_text()) for path in (args.results / "cases").glob("*_G1_*.json")]
    for record in sorted(records, key=lambda r: (r["freq_hz"], r["fill_pct"])):
        steps = int(record["fidelity"]["steps_per_cycle"])
        phase, bound = phase_bound(steps, int(record["n_spheres"]), mass, record["freq_hz"],
                                   record["ceq_cell_ns_m"])
        paired = ""
        if grid is not None and record["case_id"] in grid.index:
            row = grid.loc[record["case_id"]]
            paired = f"{row['paired_rel_diff']:+.3%} +- {row['paired_rel_diff_sem']:.3%}"
        lines.append(f"| {record['case_id']} | {record['status']} | {steps} | {bound / phase:.1f} | {phase:.3%} | "
                     f"{bound:.2%} | {paired} |")
    append("The wall-phase bound at 1 g", f"python benchmarks/experiments/wall_phase_bound.py {args.results}", lines)


if __name__ == "__main__":
    main()
