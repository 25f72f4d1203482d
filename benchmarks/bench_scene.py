"""The scene (issue 5): one cell x N against replicate cells, patches and the whole coupon.

The campaign shakes one cell and multiplies its C_eq by N = 441. For each case (50 % fill;
500 Hz, 5 g and 1000 Hz, 10 g), at the default fidelity of config.yaml, this shakes

- each of the replicate packings 0-18 alone (the campaign's single cell, and k = 7 or 19
  replicates in separate runs),
- the 7-cell patch (one ring) and the 19-cell patch (two rings) with packings 0-6 and 0-18,
  in one LIGGGHTS run each,
- the 441-cell coupon (21 x 21, offset columns) with 441 distinct packings (replicates
  0-440, each poured as the campaign pours it), in one run; its cost is first estimated from
  a 3-cycle run, and if the full window would take more than COUPON_CPU_LIMIT_S of CPU the
  measured window is shortened (and the table says so).

Cell i of every scene holds replicate packing i, so cells with the same packing can be
compared across scenes. It prints (and appends to results.md) the C_eq per cell with its
standard error over cycles and over cells, the coupon's C_eq (x 441), LIGGGHTS' CPU time, CPU
per cell-cycle and the cost ratio to one cell; then the same-packing comparisons.

Run: .venv/bin/python benchmarks/bench_scene.py [--cases 500:5,1000:10] [--pour-workers 2]
Runs and records go to results/scene/ (packings are poured once and reused).
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import sys
from pathlib import Path

import numpy as np

from _record import append

from pidpipe.config import load_config
from pidpipe.packing import cell_from_config
from pidpipe.patch import coupon_centres, ring_centres
from pidpipe.scene import (packing_scatter, replicate_packings, run_patch, same_packing_z,
                           separate_runs_scene)

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "results" / "scene"
FILL_PCT = 50.0
SINGLES = 19
COUPON = (21, 21)
COUPON_CPU_LIMIT_S = 1200.0
ESTIMATE_CYCLES = (1, 2)          # transient, measured cycles of the coupon's cost estimate


def _short(config: dict, transient: int, measured: int) -> dict:
    short = copy.deepcopy(config)
    short["fidelity"].update(transient_cycles=transient, transient_min_time_s=0.0,
                             measured_cycles=measured)
    return short


def _save(record: dict, name: str) -> None:
    (OUT / "records").mkdir(parents=True, exist_ok=True)
    (OUT / "records" / f"{name}.json").write_text(json.dumps(record, indent=1))


def run_case_scenes(config: dict, freq: float, accel: float, packings: list) -> dict:
    """Every scene of one case; returns the records by scene name."""
    cell = cell_from_config(config)
    tag = f"f{freq:g}Hz_G{accel:g}"
    runs = OUT / "runs" / tag
    block = int(config["fidelity"]["sem_block_cycles"])
    singles = [run_patch(config, freq, accel, [packings[k]], np.zeros((1, 2)), runs / f"single{k}",
                         f"{tag}_single{k}") for k in range(SINGLES)]
    scenes = {"single": singles[0], "replicates7": separate_runs_scene(singles[:7], block),
              "replicates19": separate_runs_scene(singles, block)}
    scenes["patch7"] = run_patch(config, freq, accel, packings[:7], ring_centres(cell, 1),
                                 runs / "patch7", f"{tag}_patch7")
    scenes["patch19"] = run_patch(config, freq, accel, packings[:19], ring_centres(cell, 2),
                                  runs / "patch19", f"{tag}_patch19")
    centres = coupon_centres(cell, *COUPON)
    estimate = run_patch(_short(config, *ESTIMATE_CYCLES), freq, accel, packings[:len(centres)],
                         centres, runs / "coupon_estimate", f"{tag}_coupon_estimate")
    per_cell_cycle = estimate["engine"]["cpu_time_s"] / estimate["cell_cycles"]
    full_cycles = singles[0]["transient_cycles"] + singles[0]["measured_cycles"]
    predicted = per_cell_cycle * len(centres) * full_cycles
    coupon_config, note = config, "full window"
    if predicted > COUPON_CPU_LIMIT_S:
        affordable = int(COUPON_CPU_LIMIT_S / (per_cell_cycle * len(centres)))
        measured = max(2 * block, affordable - singles[0]["transient_cycles"])
        coupon_config = _short(config, singles[0]["transient_cycles"], measured)
        coupon_config["fidelity"]["transient_min_time_s"] = config["fidelity"]["transient_min_time_s"]
        note = f"shortened to {measured} measured cycles (full window predicted {predicted:.0f} s CPU)"
    scenes["coupon"] = run_patch(coupon_config, freq, accel, packings[:len(centres)], centres,
                                 runs / "coupon", f"{tag}_coupon")
    scenes["coupon"]["window_note"] = note
    scenes["coupon"]["estimate"] = {"cpu_time_s": estimate["engine"]["cpu_time_s"],
                                    "cell_cycles": estimate["cell_cycles"],
                                    "predicted_full_cpu_s": predicted}
    for name, record in scenes.items():
        _save(record, f"{tag}_{name}")
    for k, record in enumerate(singles):
        _save(record, f"{tag}_single{k}")
    return {"scenes": scenes, "singles": singles}


def _cost(scene: dict) -> tuple[float, int]:
    if "engine" in scene:
        return scene["engine"]["cpu_time_s"], scene["cell_cycles"]
    return scene["cpu_time_s"], scene["cell_cycles"]


def scene_rows(tag: str, result: dict, n_coupon: int, pour_cpu_s: float) -> list[str]:
    """Table rows of one case: C_eq per cell and of the coupon, with SEMs, and the cost."""
    scenes = result["scenes"]
    one_cpu, _ = _cost(scenes["single"])
    rows = []
    labels = {"single": "1 cell (replicate 0)", "replicates7": "7 replicate cells, separate runs",
              "replicates19": "19 replicate cells, separate runs", "patch7": "7-cell patch, one run",
              "patch19": "19-cell patch, one run", "coupon": "441-cell coupon, one run"}
    for name, label in labels.items():
        scene = scenes[name]
        if name == "single":
            cell = scene["cells"][0]
            mean, sem_t, sem_c, n = cell["ceq_cell_ns_m"], cell["ceq_cell_sem_ns_m"], float("nan"), 1
        else:
            per = scene["per_cell"]
            mean, sem_t, sem_c, n = per["ceq_ns_m"], per["sem_time_ns_m"], per["sem_cells_ns_m"], len(scene["cells"])
        cpu, cell_cycles = _cost(scene)
        # a coupon's uncertainty: over cells when the scene has several (packing scatter),
        # over cycles for one cell (all the single-cell campaign can report)
        coupon_sem = sem_c if n > 1 else sem_t
        rows.append(f"| {tag} | {label} | {n} | {mean:.4f} | {sem_t:.4f} | "
                    f"{'-' if n == 1 else f'{sem_c:.4f}'} | {n_coupon * mean:.1f} +- {n_coupon * coupon_sem:.1f} | "
                    f"{cpu:.1f} | {1e3 * cpu / cell_cycles:.3f} | {cpu / one_cpu:.1f} | "
                    f"{n * pour_cpu_s:.0f} |")
    return rows


def comparison_rows(tag: str, result: dict) -> list[str]:
    """Same packings in different scenes: z = difference / combined SEM, cell by cell."""
    scenes, singles = result["scenes"], result["singles"]
    alone = [record["cells"][0] for record in singles]
    rows = []
    pairs = (("7-cell patch vs alone", scenes["patch7"]["cells"], alone),
             ("19-cell patch vs alone", scenes["patch19"]["cells"], alone),
             ("coupon vs alone", scenes["coupon"]["cells"], alone),
             ("coupon vs 19-cell patch", scenes["coupon"]["cells"], scenes["patch19"]["cells"]))
    for label, cells_a, cells_b in pairs:
        z = same_packing_z(cells_a, cells_b)
        identical = z == 0.0                      # bit for bit the same C_eq
        moved = z[~identical]
        stats = (f"{np.mean(moved):+.2f} | {np.sqrt(np.mean(moved**2)):.2f} | {np.max(np.abs(moved)):.2f} | "
                 f"{np.sum(np.abs(moved) <= 3.0)}/{moved.size}") if moved.size else "- | - | - | -"
        rows.append(f"| {tag} | {label} | {len(z)} | {int(identical.sum())} | {stats} |")
    return rows


def verdict_rows(tag: str, result: dict, n_coupon: int) -> list[str]:
    """Packing scatter and how far each cheap scene lands from the coupon's own value."""
    scenes = result["scenes"]
    coupon = scenes["coupon"]
    scatter = packing_scatter(coupon["cells"])
    target = coupon["per_cell"]["ceq_ns_m"]
    target_sem = coupon["per_cell"]["sem_time_ns_m"]
    rows = [f"| {tag} | {scatter['std_cells_ns_m']:.4f} | {scatter['rms_sem_ns_m']:.4f} | "
            f"{scatter['std_packing_ns_m']:.4f} | {target:.4f} +- {target_sem:.4f} | "
            f"{coupon['total']['energy_drift_fraction']:+.3f} | {coupon['ledger_mismatch']['of_dissipation']:+.1e} | "
            f"{'yes' if coupon['contained'] else 'NO'} | {coupon['window_note']} |"]
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default="500:5,1000:10", help="freq:accel pairs, comma separated")
    parser.add_argument("--pour-workers", type=int, default=1, help="pours run at once (<= 2)")
    args = parser.parse_args(argv)
    config = load_config()
    n_coupon = int(config["geometry"]["coupon_n_cells"])
    packings, pour_cpu = replicate_packings(config, FILL_PCT, COUPON[0] * COUPON[1],
                                            OUT / "packings", workers=args.pour_workers)
    mean_pour = float(np.mean(list(pour_cpu.values()))) if pour_cpu else float("nan")
    table = ["| case | scene | cells | C_eq per cell (N s/m) | SEM over cycles | SEM over cells | "
             "coupon C_eq = 441 x per cell (N s/m) | CPU s | CPU ms per cell-cycle | CPU / 1 cell | pour CPU s |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    compare = ["| case | same packings | cells | identical | mean z | rms z | max abs z | within 3 SEM |",
               "|---|---|---|---|---|---|---|---|"]
    verdict = ["| case | std of C_eq over the coupon's cells | rms SEM of one cell | packing-to-packing std | "
               "coupon C_eq per cell | coupon drift | ledger mismatch / E_d | contained | coupon window |",
               "|---|---|---|---|---|---|---|---|---|"]
    for pair in args.cases.split(","):
        freq, accel = (float(v) for v in pair.split(":"))
        tag = f"{freq:g} Hz, {accel:g} g"
        result = run_case_scenes(config, freq, accel, packings)
        table += scene_rows(tag, result, n_coupon, mean_pour)
        compare += comparison_rows(tag, result)
        verdict += verdict_rows(tag, result, n_coupon)
    fid = config["fidelity"]
    lines = table + ["", f"50 % fill ({packings[0].n_spheres} spheres per cell), default fidelity "
                     f"(dt = {fid['timestep_rayleigh_fraction']} Rayleigh times, transient "
                     f">= {fid['transient_cycles']} cycles and {fid['transient_min_time_s']} s, "
                     f"{fid['measured_cycles']} measured cycles, SEM from {fid['sem_block_cycles']}-cycle blocks). "
                     "Every scene runs the patch deck (templates/patch.lmp.j2); cell i holds replicate "
                     "packing i. SEM over cycles: of the scene's total E_d series / cells (these packings); "
                     "SEM over cells: std over cells / sqrt(cells) (what a coupon of other packings would "
                     "scatter by). The coupon column uses the SEM over cells when there are several cells. "
                     f"CPU: LIGGGHTS' user + system time; pour CPU: cells x mean CPU of one pour "
                     f"({mean_pour:.2f} s, {len(pour_cpu)} pours measured).", "",
                     *compare, "", "z = (C_eq in scene A - C_eq in scene B) / combined SEM for the same "
                     "packing, over the cells whose C_eq is not bit for bit identical (identical: a cell "
                     "at the origin whose arithmetic did not change). Rms z near 1 means the scenes "
                     "differ only by cycle noise.", "", *verdict]
    append("Scene: one cell x N against replicates, patches and the coupon (issue 5)",
           "python benchmarks/bench_scene.py " + " ".join(sys.argv[1:] if argv is None else argv), lines)


if __name__ == "__main__":
    main()
