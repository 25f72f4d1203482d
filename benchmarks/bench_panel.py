"""Cost of the panel's layout optimisation: the default panel, every environment, every design.

    PYTHONPATH=. python benchmarks/bench_panel.py [--table FILE]

Fits the configured surrogate to the C_eq table (default: the analytic table of
tests/design/test_optimise_command.py, C = f G r exp(-r/30) / 1000 on the reference grid),
then for every environment and every mode in its band times the region layout optimisation of
each design (peak, band_mean, worst_case) in CPU seconds, and the whole modal stage (coupon
designs, bootstrap intervals, forced responses). Prints the figures and records them
(benchmarks/records/bench_panel.json and its history, :mod:`harness`).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from harness import record  # noqa: E402

from pidpipe.config import load_config  # noqa: E402
from pidpipe.config.panel import PanelSettings  # noqa: E402
from pidpipe.design.ceq_table import read_ceq_table  # noqa: E402
from pidpipe.design.surrogate import fit_surrogate  # noqa: E402
from pidpipe.panel.cells import cell_centres  # noqa: E402
from pidpipe.panel.layout import make_regions, optimise_layout  # noqa: E402
from pidpipe.panel.loss import KINDS, AccelBand, ModalLoss  # noqa: E402
from pidpipe.panel.study import sandwich_of  # noqa: E402
from pidpipe.panel.plate import plate_modes  # noqa: E402
from pidpipe.steps.panel import panel_study_from_config  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--table", type=Path, help="C_eq table (default: the analytic one)")
    args = parser.parse_args()
    config = load_config(ROOT / "config.yaml")
    if args.table:
        table_path = args.table
    else:
        sys.path.insert(0, str(ROOT / "tests" / "design"))
        from test_optimise_command import write_table

        table_path = write_table(Path(tempfile.mkdtemp()) / "analytic.csv")
    surrogate = fit_surrogate(read_ceq_table(table_path), method=config["surrogate"]["method"],
                              allow_holes=config["surrogate"]["allow_holes"])
    settings = PanelSettings.from_config(config)
    modes = plate_modes(sandwich_of(settings), settings.length_m, settings.width_m, settings.max_freq_hz)
    centres = cell_centres(settings.length_m, settings.width_m, settings.cell_inscribed_diameter_m)
    figures, lines = {"cells": int(len(centres)), "spheres": settings.n_spheres}, []
    total = 0.0
    for env in config["environments"]:
        band = AccelBand(*env["accel_g"])
        for mode in (m for m in modes if env["freq_hz"][0] <= m.freq_hz <= env["freq_hz"][1]):
            phi = mode.shape(centres[:, 0], centres[:, 1])
            loss = ModalLoss(mode, phi, int(config["geometry"]["coupon_n_cells"]),
                             settings.full_cell_spheres, settings.sphere_mass_kg, surrogate.domain)
            regions = make_regions(phi, settings.regions)
            for kind in KINDS:
                start = time.process_time()
                result = optimise_layout(loss, surrogate.predict, regions, band, kind, settings.n_spheres,
                                         starts=settings.starts, seed=settings.seed)
                cpu = time.process_time() - start
                total += cpu
                key = f"{env['name']} / mode ({mode.m},{mode.n}) / {kind}"
                figures.update({f"{key} cpu_s": round(cpu, 3), f"{key} starts": result.n_starts,
                                f"{key} converged": result.n_converged,
                                f"{key} evaluations": result.n_evaluations,
                                f"{key} eta": result.objective})
                lines.append(f"  {key:<48} {cpu:7.2f} CPU-s  {result.n_starts} starts "
                             f"({result.n_converged} converged), {result.n_evaluations} evaluations")
    start = time.process_time()
    wall = time.perf_counter()
    panel_study_from_config(config, surrogate)
    figures["layout_optimisation_cpu_s"] = round(total, 2)
    figures["stage_cpu_s"] = round(time.process_time() - start, 2)
    figures["stage_wall_s"] = round(time.perf_counter() - wall, 2)
    command = "PYTHONPATH=. python benchmarks/bench_panel.py" + (f" --table {args.table}" if args.table else "")
    print(f"panel {settings.length_m:g} m x {settings.width_m:g} m, {len(centres)} cells, "
          f"{settings.n_spheres} spheres, {settings.regions} regions, {settings.starts} Latin-hypercube "
          "starts + the antinode-first one")
    print("\n".join(lines))
    print(f"layout optimisation, every environment and design: {total:.2f} CPU-s")
    print(f"whole modal stage (coupon designs, {settings.surrogate_draws} bootstrap refits, "
          f"forced responses): {figures['stage_cpu_s']:.2f} CPU-s, {figures['stage_wall_s']:.2f} s wall")
    record("bench_panel", figures, command=command)


if __name__ == "__main__":
    main()
