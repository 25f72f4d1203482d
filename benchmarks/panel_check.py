"""The DEM check of a mode on the default panel: the coupled mode against the panel model.

    PYTHONPATH=. .venv/bin/python benchmarks/panel_check.py [--table FILE] [--workers 2]
        [--set SECTION.KEY=YAML ...] [--workdir DIR]

Fits the configured C_eq surrogate and the m_eff Gaussian process to a DEM campaign's table
(default: tests/fixtures/ceq_table_dem_default_100.csv, the compiled DEM's 100-case campaign on
the default grid), runs the modal stage for ``panel.check``'s environment (its layouts; no
bootstrap refits), then the DEM check of its lowest mode in the band
(:func:`pidpipe.steps.panel.mode_check_from_config`): the checked layout's cells in groups
along the mode shape, compiled-DEM cells poured by the compiled DEM (as the table's were),
swept in frequency at one modal force by continuation, up (reported) and down, coupled host and
panel model alike. Prints each curve's peak and the panel models'
differences, the groups, the force and the stage's loss factor of the layout as designed, and
the CPU; records them as ``panel_check``. ``--set panel.check.KEY=VALUE`` changes the check's
size (groups, cells_per_group, freq_points, transient_cycles, measured_cycles) or its force.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from harness import apply_overrides, command_line, load_average, record  # noqa: E402

from pidpipe.config import validate_config  # noqa: E402
from pidpipe.config.panel import PanelCheckSettings, PanelSettings, panel_check_params  # noqa: E402
from pidpipe.design.ceq_table import M_EFF_COLUMN, M_EFF_SEM_COLUMN, read_ceq_table  # noqa: E402
from pidpipe.design.surrogate import fit_surrogate  # noqa: E402
from pidpipe.panel.check import summary_lines  # noqa: E402
from pidpipe.panel.study import run_panel_study  # noqa: E402
from pidpipe.steps.design import environment_objects, search_settings  # noqa: E402
from pidpipe.steps.panel import mode_check_from_config  # noqa: E402

TABLE = ROOT / "tests" / "fixtures" / "ceq_table_dem_default_100.csv"
#: The table's packings were poured by the compiled DEM; the stage's layouts need no intervals.
DEFAULTS = ("fidelity.pour_engine=dem", "panel.surrogate_draws=0")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--table", type=Path, default=TABLE, help="DEM C_eq table with m_eff")
    parser.add_argument("--workers", type=int, default=2, help="coupled runs at a time")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=YAML",
                        help="config override (after the benchmark's own: " + ", ".join(DEFAULTS) + ")")
    parser.add_argument("--workdir", type=Path, help="where the packings are poured (default: a temporary folder)")
    args = parser.parse_args()
    raw = yaml.safe_load((ROOT / "config.yaml").read_text())
    config = validate_config(apply_overrides(raw, [*DEFAULTS, *args.set]))
    started = time.process_time()
    table = read_ceq_table(args.table)
    surrogate = fit_surrogate(table, method=config["surrogate"]["method"], source=str(args.table),
                              allow_holes=config["surrogate"]["allow_holes"])
    m_eff = fit_surrogate(table, method="gp", target="linear", source=str(args.table),
                          allow_holes=config["surrogate"]["allow_holes"], value_column=M_EFF_COLUMN,
                          sem_column=M_EFF_SEM_COLUMN)
    check = PanelCheckSettings.from_config(config)
    environment = environment_objects(config["environments"])[check.environment]
    settings = PanelSettings.from_config(config)
    study = run_panel_study(settings, surrogate, [environment], search_settings(config["optimisation"]),
                            int(config["geometry"]["coupon_n_cells"]), m_eff_surrogate=m_eff)
    stage_cpu = time.process_time() - started
    workdir = args.workdir or Path(tempfile.mkdtemp(prefix="panel_check_"))
    result = mode_check_from_config(panel_check_params(config), surrogate, m_eff, study.layouts,
                                    str(workdir / "packings"), args.workers)
    for name, frame in (("curves.csv", result.curves), ("summary.csv", result.summary)):
        frame.to_csv(workdir / name, index=False)
    meta = result.meta
    reported = meta["reported_sweep"]
    by_sweep = {sweep: frame.set_index("model") for sweep, frame in result.summary.groupby("sweep")}
    summary = by_sweep[reported]
    designs = study.designs
    row = designs[(designs.design == check.design) & (designs.layout == check.layout)].iloc[0]
    groups, layout, designed = meta["groups"], meta["layout"], meta["designed"]
    print(f"table {args.table.name}; {environment.name}: mode ({meta['mode']['m']},{meta['mode']['n']}) "
          f"{meta['mode']['freq_hz']:.2f} Hz, bare modal mass {meta['mode']['modal_mass_kg']:.4f} kg, "
          f"zeta {meta['mode']['damping_ratio']:g}")
    print(f"{check.design} {check.layout} layout: {layout['cells']} cells at "
          f"{', '.join(f'{r:.4g}' for r in layout['design_fill_pct'])} % (DEM: "
          f"{layout['spheres_per_cell']} spheres, {layout['dem_fill_pct']:.4g} %); stage's band eta_p "
          f"{row.eta:.4g} ({check.design}); modal mass: {meta['modal_mass_source']}")
    print(f"groups: |phi| rms {', '.join(f'{w:.3f}' for w in groups['weights'])}, cells "
          f"{', '.join(str(n) for n in groups['cells'])}, {groups['dem_cells_per_group']} DEM cells each")
    print(f"modal force {meta['force_n']:.4g} N ({meta['force_source']}); the stage's forced response "
          f"of the layout as designed: {designed['freq_hz']:.2f} Hz, G {designed['accel_g']:.3g} g, "
          f"eta_p {designed['eta_particles']:.4g}, total {designed['eta_total']:.4g}")
    print("\n".join(summary_lines(result.summary)))
    coupled_cpu = meta["coupled"]["cpu_s"]
    print(f"CPU: modal stage {stage_cpu:.1f} s, pours {sum(meta['packings']['pour_cpu_s'].values()):.1f} s, "
          f"coupled runs {coupled_cpu:.1f} s ({len(meta['sweeps'])} sweeps x {len(meta['frequencies_hz'])} frequencies x "
          f"{meta['coupled']['transient_cycles']} + {meta['coupled']['measured_cycles']} cycles, "
          f"{len(groups['cells']) * groups['dem_cells_per_group']} cells)")
    print(f"curves and summary: {workdir}")
    figures = {"mode_freq_hz": meta["mode"]["freq_hz"], "force_n": meta["force_n"],
               "layout_cells": layout["cells"], "dem_spheres_per_cell": layout["spheres_per_cell"],
               "groups": len(groups["cells"]), "dem_cells": len(groups["cells"]) * groups["dem_cells_per_group"],
               "stage_eta_p": float(row.eta), "designed_eta_particles": designed["eta_particles"],
               "designed_eta_total": designed["eta_total"], "designed_accel_g": designed["accel_g"],
               "stage_cpu_s": round(stage_cpu, 2), "coupled_cpu_s": round(coupled_cpu, 2)}
    figures["panel_particle_loss_factor_at_coupled_peak"] = summary.loc["coupled", "panel_particle_loss_factor"]
    figures["reported_sweep"] = reported
    for sweep, frame in by_sweep.items():
        suffix = "" if sweep == reported else f"_{sweep}"      # the reported sweep's keys unsuffixed
        for model in frame.index:
            peak = frame.loc[model]
            name = f"{model}{suffix}"
            figures.update({f"{name}_peak_freq_hz": peak.peak_freq_hz,
                            f"{name}_peak_amplitude_um": 1e6 * peak.peak_amplitude_m,
                            f"{name}_peak_accel_g": peak.peak_accel_g,
                            f"{name}_peak_loss_factor": peak.peak_loss_factor,
                            f"{name}_peak_particle_loss_factor": peak.peak_particle_loss_factor,
                            f"{name}_max_solutions": int(peak.max_solutions)})
            if model == "coupled":
                figures.update({f"{name}_peak_freq_hz_sd": peak.peak_freq_hz_sd,
                                f"{name}_peak_amplitude_um_sd": 1e6 * peak.peak_amplitude_m_sd,
                                f"{name}_peak_loss_factor_sd": peak.peak_loss_factor_sd,
                                f"{name}_panel_particle_loss_factor": peak.panel_particle_loss_factor})
    record("panel_check", figures, notes=f"load average {load_average()}",
           command=command_line())


if __name__ == "__main__":
    main()
