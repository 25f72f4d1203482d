"""What does one host-coupled frequency sweep cost against the dashpot model's (issue 15)?

One force level of the host check (config ``host``; default: the middle level), every frequency
of its sweep, run one after the other in this process: the coupled host with its k cells in the
compiled DEM (:func:`pidpipe.loop.coupled_sweep.run_point`), then the dashpot model at the same
frequencies with every redrawn surrogate (:func:`pidpipe.loop.host.equivalent_curves` of that
level). It prints (and records in ``benchmarks/records/bench_host.json``) the CPU time of each, per frequency and per
cell-step, and their ratio.

It needs the design and the surrogate of the config's campaign (made by
``snakemake optimum --cores 2 --configfile benchmarks/host_check.yaml``); the host's packings
are poured into RESULTS/work/host/packings on first use and reused (as ``snakemake host`` does).

Run: .venv/bin/python benchmarks/bench_host.py [--configfile benchmarks/host_check.yaml] [--level 1]
         [--results results] [--set host.freq_points=3 ...]
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import sys
import time

import numpy as np
import yaml
from harness import REPO, apply_overrides, record

from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config, validate_config
from pidpipe.loop.coupled_sweep import run_point
from pidpipe.loop.host import coupled_points, equivalent_curves
from pidpipe.steps.host import host_params, prepare_host


def _merged(base: dict, extra: dict) -> dict:
    """``base`` updated key by key with ``extra`` (nested mappings merged, as Snakemake does)."""
    out = copy.deepcopy(base)
    for key, value in extra.items():
        out[key] = _merged(out[key], value) if isinstance(value, dict) and isinstance(
            out.get(key), dict) else value
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--configfile", default="benchmarks/host_check.yaml",
                        help="extends config.yaml, as snakemake --configfile does")
    parser.add_argument("--level", type=int, default=None, help="index into host.force_n")
    parser.add_argument("--results", default="results",
                        help="the campaign's results folder (surrogate.json, optimum.json), "
                             "relative to the repository")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=YAML",
                        help="override one config value (repeatable), e.g. host.freq_points=3")
    args = parser.parse_args(argv)
    raw = yaml.safe_load((REPO / "config.yaml").read_text())
    extra = yaml.safe_load((REPO / args.configfile).read_text())
    config = host_params(validate_config(apply_overrides(_merged(raw, extra), args.set)))
    results = REPO / args.results
    for name in ("surrogate.json", "optimum.json"):
        if not (results / name).is_file():
            sys.exit(f"bench_host: {args.results}/{name} is missing: run `snakemake optimum --cores 2 "
                     f"--configfile {args.configfile}` first")
    settings, load, surrogate, draws, packings, _ = prepare_host(
        config, str(results / "surrogate.json"), str(results / "optimum.json"),
        str(results / "work" / "host" / "packings"), workers=2)
    level = len(settings.force_n) // 2 if args.level is None else args.level
    force = settings.force_n[level]
    one = dataclasses.replace(settings, force_n=(force,))
    scene = CellScene.from_config(config)
    draws = list(draws)
    started = time.process_time()
    equivalent = equivalent_curves(one, load, surrogate, draws)
    equivalent_cpu = time.process_time() - started
    points = coupled_points(one, load, packings.shape[0], equivalent)
    run_point(scene, packings, dataclasses.replace(points[0], transient_cycles=0,
                                                   measured_cycles=4))   # compile/load the kernel
    started, wall = time.process_time(), time.perf_counter()
    rows = [run_point(scene, packings, point) for point in points]
    coupled_cpu, coupled_wall = time.process_time() - started, time.perf_counter() - wall
    cycles = settings.transient_cycles + settings.measured_cycles
    steps = sum(row["steps_per_cycle"] for row in rows) * cycles
    cell_steps = steps * packings.shape[0]
    lines = [
        f"Config {args.configfile} (extending config.yaml): {settings.design} design of "
        f"{settings.environment.name!r}, {load.n_cells} cells x {load.spheres_per_cell} spheres; "
        f"host m_h {settings.mass_kg:.4g} kg, f_n {settings.natural_freq_hz:g} Hz, "
        f"zeta {settings.damping_ratio:g}; F0 = {force:g} N (level {level}); "
        f"{len(points)} frequencies {points[0].freq_hz:g}-{points[-1].freq_hz:g} Hz, "
        f"{cycles} cycles each ({settings.transient_cycles} transient), k = {packings.shape[0]} "
        f"cells, dt {rows[0]['timestep_s']:.3g} s ({rows[0]['steps_per_cycle']} steps per cycle "
        f"at {points[0].freq_hz:g} Hz); one process, after the kernel was loaded.",
        "",
        "| model | CPU s, whole sweep | CPU s per frequency | us per cell-step | wall s |",
        "|---|---|---|---|---|",
        f"| coupled DEM (a) | {coupled_cpu:.1f} | {coupled_cpu / len(points):.2f} | "
        f"{1e6 * coupled_cpu / cell_steps:.3f} | {coupled_wall:.1f} |",
        f"| dashpot C_eq (b and b'), {len(draws)} redrawn surrogates | {equivalent_cpu:.1f} | "
        f"{equivalent_cpu / len(points):.3f} | - | - |",
        "",
        f"Coupled : dashpot CPU = {coupled_cpu / equivalent_cpu:.1f} : 1. Numba "
        f"{__import__('numba').__version__}. The whole `snakemake host` runs "
        f"{len(settings.force_n)} such sweeps, two runs at a time with --cores 2.",
    ]
    print("\n".join(lines))
    record("bench_host", {
        "force_n": force, "frequencies": len(points), "cells": int(packings.shape[0]),
        "cycles_per_frequency": cycles,
        "coupled_cpu_s": round(coupled_cpu, 2), "coupled_wall_s": round(coupled_wall, 2),
        "coupled_cpu_per_frequency_s": round(coupled_cpu / len(points), 3),
        "coupled_us_per_cell_step": round(1e6 * coupled_cpu / cell_steps, 4),
        "dashpot_cpu_s": round(equivalent_cpu, 3), "dashpot_surrogates": len(draws),
        "coupled_over_dashpot_cpu": round(coupled_cpu / equivalent_cpu, 1)}, notes=lines[0])


if __name__ == "__main__":
    main()
