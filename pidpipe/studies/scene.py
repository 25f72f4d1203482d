"""The scene study (issue 5): one cell x N against replicates, patches and the whole coupon.

For one case, every scene holds the same replicate packings: cell i holds the i-th replicate that
the campaign's check accepts (:func:`usable_packings`; replicate i unless an earlier pour was
refused), and the scenes are:

- ``single``: replicate 0 alone (what the campaign runs);
- ``replicates7`` / ``replicates19``: replicates 0-6 / 0-18, each alone in its own run;
- ``patch7`` / ``patch19``: the same packings in a patch of one / two rings, in one run;
- ``coupon``: the whole coupon (21 x 21 = 441 cells, replicates 0-440), in one run. Its cost is
  first estimated from a 3-cycle run; when the full window would take more than
  ``coupon_cpu_limit_s`` of CPU, the measured window is shortened, and the record says so.

:func:`scene_rows` turns the records into one row per scene (C_eq per cell with its standard
errors, the coupon's C_eq, the CPU time and its ratio to one cell), :func:`comparison_rows`
compares the same packings across scenes, and :func:`plot_scenes` draws C_eq per cell and the
CPU time against the number of cells.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from pidpipe.cell.packing import Packing
from pidpipe.cell.patch import coupon_centres, ring_centres
from pidpipe.cell.scene import CellScene
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.config.studies import SceneSettings
from pidpipe.liggghts.patch_run import run_patch
from pidpipe.studies.scene_stats import (
    packing_scatter,
    run_to_run_noise,
    same_packing_z,
    separate_runs_scene,
)

SCENE_LABELS = {"single": "1 cell (replicate 0)",
                "replicates7": "7 replicate cells, separate runs",
                "replicates19": "19 replicate cells, separate runs",
                "patch7": "7-cell patch, one run",
                "patch19": "19-cell patch, one run",
                "coupon": "coupon, one run"}
ESTIMATE_CYCLES = (1, 2)
"""Transient and measured cycles of the run that estimates the coupon's cost."""


def short_window(settings: ShakeSettings, transient: int, measured: int) -> ShakeSettings:
    """The settings with a fixed window of cycles (no minimum transient time)."""
    return replace(settings, sampling=replace(settings.sampling, transient_cycles=int(transient),
                                              transient_min_time_s=0.0,
                                              measured_cycles=int(measured)))


def run_scene_study(settings: ShakeSettings, freq_hz: float, accel_g: float, packings: list[Packing],
                    folder: str | Path, singles: int = 19, coupon: tuple[int, int] = (21, 21),
                    coupon_cpu_limit_s: float = 1200.0) -> dict:
    """Shake every scene of one case; keep each run's record as JSON in ``folder/records``.

    Parameters
    ----------
    settings : ShakeSettings
        Every scene's cell, materials, fidelity and sampling.
    freq_hz, accel_g : float
    packings : list of Packing
        Replicates 0, 1, ... of one fill; at least ``columns * rows`` of them.
    folder : path
        Runs go to ``folder/runs/<case>/<scene>``, records to ``folder/records``.
    singles : int
        Replicates shaken alone (>= 7).
    coupon : (columns, rows)
    coupon_cpu_limit_s : float
        Largest CPU time the coupon may take, s; above it the measured window is shortened.

    Returns
    -------
    dict
        ``scenes`` (records by scene name) and ``singles`` (the records of the runs alone).
    """
    if singles < 7 or len(packings) < max(singles, 19, coupon[0] * coupon[1]):
        raise ValueError(f"the study needs >= 7 singles and max(singles, 19, coupon cells) "
                         f"packings, got {singles} singles and {len(packings)} packings")
    folder = Path(folder)
    cell = CellScene.of(settings).cell
    tag = f"f{freq_hz:g}Hz_G{accel_g:g}"
    runs = folder / "runs" / tag
    block = settings.sampling.sem_block_cycles
    (folder / "records").mkdir(parents=True, exist_ok=True)

    def kept(name: str, record: dict) -> dict:
        (folder / "records" / f"{tag}_{name}.json").write_text(json.dumps(record, indent=1))
        return record

    # The coupon's cost estimate first: a failure of the largest run shows before the others.
    centres = coupon_centres(cell, *coupon)
    cells = packings[:len(centres)]
    estimate = kept("coupon_estimate", run_patch(short_window(settings, *ESTIMATE_CYCLES), freq_hz,
                                                 accel_g, cells, centres, runs / "coupon_estimate",
                                                 f"{tag}_coupon_estimate"))
    alone = [kept(f"single{k}", run_patch(settings, freq_hz, accel_g, [packings[k]], np.zeros((1, 2)),
                                          runs / f"single{k}", f"{tag}_single{k}"))
             for k in range(singles)]
    scenes = {"single": alone[0], "replicates7": separate_runs_scene(alone[:7], block)}
    if singles >= 19:
        scenes["replicates19"] = separate_runs_scene(alone[:19], block)
    for name, rings in (("patch7", 1), ("patch19", 2)):
        centres_ring = ring_centres(cell, rings)
        scenes[name] = kept(name, run_patch(settings, freq_hz, accel_g, packings[:len(centres_ring)],
                                            centres_ring, runs / name, f"{tag}_{name}"))
    setup_s, per_cycle_s = split_cost(estimate)
    transient = alone[0]["transient_cycles"]
    predicted = setup_s + per_cycle_s * (transient + alone[0]["measured_cycles"])
    coupon_settings, note = settings, "full window"
    if predicted > coupon_cpu_limit_s:
        measured = max(2 * block, int((coupon_cpu_limit_s - setup_s) / per_cycle_s) - transient)
        coupon_settings = short_window(settings, transient, measured)
        note = f"{measured} measured cycles (the full window was predicted at {predicted:.0f} s CPU)"
    scenes["coupon"] = run_patch(coupon_settings, freq_hz, accel_g, cells, centres, runs / "coupon",
                                 f"{tag}_coupon")
    scenes["coupon"].update(window_note=note, estimate={
        "cpu_time_s": estimate["engine"]["cpu_time_s"], "cell_cycles": estimate["cell_cycles"],
        "setup_cpu_s": setup_s, "cpu_per_cycle_s": per_cycle_s, "predicted_full_cpu_s": predicted})
    kept("coupon", scenes["coupon"])
    return {"freq_hz": freq_hz, "accel_g": accel_g, "scenes": scenes, "singles": alone}


def load_scene_study(block_cycles: int, singles: int, freq_hz: float, accel_g: float,
                     folder: str | Path) -> dict:
    """The result of :func:`run_scene_study` again, from the records it kept (no new runs).

    ``block_cycles`` is ``fidelity.sem_block_cycles``; ``singles`` the replicates shaken alone.

    Raises
    ------
    FileNotFoundError
        If a record is missing (the study did not run, or not to the end).
    """
    records = Path(folder) / "records"
    tag = f"f{freq_hz:g}Hz_G{accel_g:g}"

    def read(name: str) -> dict:
        return json.loads((records / f"{tag}_{name}.json").read_text(encoding="utf-8"))

    block = int(block_cycles)
    alone = [read(f"single{k}") for k in range(int(singles))]
    scenes = {"single": alone[0], "replicates7": separate_runs_scene(alone[:7], block)}
    if len(alone) >= 19:
        scenes["replicates19"] = separate_runs_scene(alone[:19], block)
    scenes.update(patch7=read("patch7"), patch19=read("patch19"), coupon=read("coupon"))
    return {"freq_hz": freq_hz, "accel_g": accel_g, "scenes": scenes, "singles": alone}


def split_cost(record: dict) -> tuple[float, float]:
    """A run's CPU time split into set-up (s) and per cycle (s), by the share of its wall time
    that LIGGGHTS spent in its time loop."""
    engine = record["engine"]
    loop_share = min(1.0, engine["loop_time_s"] / engine["wall_time_s"])
    cycles = record["transient_cycles"] + record["measured_cycles"]
    return engine["cpu_time_s"] * (1.0 - loop_share), engine["cpu_time_s"] * loop_share / cycles


def _cost(scene: dict) -> tuple[float, int]:
    """CPU time (s) and cell-cycles run of a scene record."""
    cpu = scene["engine"]["cpu_time_s"] if "engine" in scene else scene["cpu_time_s"]
    return cpu, scene["cell_cycles"]


def scene_rows(result: dict, n_coupon: int) -> list[dict]:
    """One row per scene of :func:`run_scene_study`'s result.

    Returns
    -------
    list of dict
        ``freq_hz``, ``accel_g``, ``scene``, ``label``, ``cells``, ``ceq_cell_ns_m`` (mean over
        cells), ``sem_cycles_ns_m`` (of the scene's total series, / cells), ``sem_cells_ns_m``
        (std over cells / sqrt(cells); NaN for one cell), ``ceq_coupon_ns_m`` (x N),
        ``sem_coupon_ns_m`` (x N of the SEM over cells, or over cycles for one cell: all that a
        single cell can report), ``cpu_s``, ``cpu_ms_per_cell_cycle``, ``cpu_ratio_to_one_cell``,
        ``measured_cycles``.
    """
    scenes = result["scenes"]
    one_cpu, _ = _cost(scenes["single"])
    rows = []
    for name, scene in scenes.items():
        if name == "single":
            cell = scene["cells"][0]
            mean, sem_t, sem_c, n = cell["ceq_cell_ns_m"], cell["ceq_cell_sem_ns_m"], float("nan"), 1
        else:
            per = scene["per_cell"]
            mean, sem_t, sem_c, n = per["ceq_ns_m"], per["sem_time_ns_m"], per["sem_cells_ns_m"], len(scene["cells"])
        cpu, cell_cycles = _cost(scene)
        label = SCENE_LABELS[name] if name != "coupon" else f"{n}-cell coupon, one run"
        rows.append({"freq_hz": result["freq_hz"], "accel_g": result["accel_g"], "scene": name,
                     "label": label, "cells": n, "ceq_cell_ns_m": mean, "sem_cycles_ns_m": sem_t,
                     "sem_cells_ns_m": sem_c, "ceq_coupon_ns_m": n_coupon * mean,
                     "sem_coupon_ns_m": n_coupon * (sem_c if n > 1 else sem_t), "cpu_s": cpu,
                     "cpu_ms_per_cell_cycle": 1e3 * cpu / cell_cycles,
                     "cpu_ratio_to_one_cell": cpu / one_cpu,
                     "measured_cycles": scene.get("measured_cycles",
                                                  scenes["single"]["measured_cycles"])})
    return rows


def comparison_rows(result: dict) -> list[dict]:
    """The same packings in two scenes, cell by cell (:func:`pidpipe.studies.scene_stats.same_packing_z`).

    Returns
    -------
    list of dict
        ``pair``, ``cells``, ``identical`` (cells with bit-for-bit the same C_eq), and over the
        other cells ``mean_z``, ``rms_z``, ``max_abs_z``, ``within_3_sem`` (a count).
    """
    scenes, alone = result["scenes"], [record["cells"][0] for record in result["singles"]]
    pairs = (("7-cell patch vs alone", scenes["patch7"]["cells"], alone),
             ("19-cell patch vs alone", scenes["patch19"]["cells"], alone),
             ("coupon vs alone", scenes["coupon"]["cells"], alone),
             ("coupon vs 19-cell patch", scenes["coupon"]["cells"], scenes["patch19"]["cells"]))
    rows = []
    for pair, cells_a, cells_b in pairs:
        z = same_packing_z(cells_a, cells_b)
        moved = z[z != 0.0]
        rows.append({"freq_hz": result["freq_hz"], "accel_g": result["accel_g"], "pair": pair,
                     "cells": int(z.size), "identical": int(np.sum(z == 0.0)),
                     "mean_z": float(moved.mean()) if moved.size else float("nan"),
                     "rms_z": float(np.sqrt(np.mean(moved**2))) if moved.size else float("nan"),
                     "max_abs_z": float(np.abs(moved).max()) if moved.size else float("nan"),
                     "within_3_sem": int(np.sum(np.abs(moved) <= 3.0))})
    return rows


def scatter_row(result: dict) -> dict:
    """How C_eq varies over the coupon's cells, and the coupon run's own checks.

    The run noise of one cell comes from the same packings in different scenes (coupon, 19-cell
    patch, alone: :func:`pidpipe.studies.scene_stats.run_to_run_noise`); the packing-to-packing scatter is
    what the spread over the coupon's cells holds beyond it.
    """
    scenes = result["scenes"]
    coupon = scenes["coupon"]
    alone = [record["cells"][0] for record in result["singles"]]
    noise, n_pairs = run_to_run_noise([(coupon["cells"], alone), (scenes["patch19"]["cells"], alone),
                                       (coupon["cells"], scenes["patch19"]["cells"])])
    single = scenes["single"]["cells"][0]
    per = coupon["per_cell"]
    ceq = np.array([cell["ceq_cell_ns_m"] for cell in coupon["cells"]])
    return {"freq_hz": result["freq_hz"], "accel_g": result["accel_g"],
            **packing_scatter(coupon["cells"], noise), "noise_pairs": n_pairs,
            "coupon_ceq_cell_ns_m": per["ceq_ns_m"],
            "coupon_sem_cycles_ns_m": per["sem_time_ns_m"],
            "single_minus_coupon_in_single_sems": (single["ceq_cell_ns_m"] - per["ceq_ns_m"])
            / single["ceq_cell_sem_ns_m"],
            "single_percentile_in_coupon": float(100.0 * np.mean(ceq < single["ceq_cell_ns_m"])),
            "drift": coupon["total"]["energy_drift_fraction"],
            "ledger_mismatch_of_dissipation": coupon["ledger_mismatch"]["of_dissipation"],
            "contained": coupon["contained"], "window": coupon["window_note"]}


def plot_scenes(rows: list[dict], path: str | Path) -> Path:
    """C_eq per cell against the number of cells of each scene, with error bars (SEM over
    cells, or over cycles for one cell), and LIGGGHTS' CPU time on a second axis; one panel
    per case. Scenes run in one LIGGGHTS run are filled, separate runs hollow."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    cases = sorted({(r["freq_hz"], r["accel_g"]) for r in rows})
    fig, axes = plt.subplots(1, len(cases), figsize=(5.5 * len(cases), 4.8), squeeze=False)
    for ax, (freq, accel) in zip(axes[0], cases):
        mine = [r for r in rows if (r["freq_hz"], r["accel_g"]) == (freq, accel)]
        cost = ax.twinx()
        for separate in (False, True):
            pick = sorted((r for r in mine if r["scene"].startswith("replicates") == separate),
                          key=lambda r: r["cells"])
            cells = np.array([r["cells"] for r in pick], dtype=float) * (1.1 if separate else 1.0)
            error = [r["sem_cells_ns_m"] if r["cells"] > 1 else r["sem_cycles_ns_m"] for r in pick]
            style = dict(color="C0", mfc="white" if separate else "C0")
            ax.errorbar(cells, [r["ceq_cell_ns_m"] for r in pick], yerr=error, fmt="o", capsize=3,
                        label="C_eq, " + ("separate runs" if separate else "one run"), **style)
            cost.plot(cells, [r["cpu_s"] for r in pick], "s--" if separate else "s-", color="C3",
                      mfc="white" if separate else "C3",
                      label="CPU, " + ("separate runs" if separate else "one run"))
        ax.set_xscale("log")
        cost.set_yscale("log")
        ax.set_xlabel("cells in the scene")
        ax.set_ylabel("C_eq per cell (N s/m), +- 1 SEM", color="C0")
        cost.set_ylabel("LIGGGHTS CPU time (s)", color="C3")
        ax.set_title(f"{freq:g} Hz, {accel:g} g")
        handles = ax.get_legend_handles_labels()
        more = cost.get_legend_handles_labels()
        ax.legend(handles[0] + more[0], handles[1] + more[1], fontsize=7, ncol=2, loc="upper center",
                  bbox_to_anchor=(0.5, -0.16))
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def usable_packings(packings: list[Packing]) -> tuple[list[Packing], list[tuple[int, str]]]:
    """The packings that the campaign's check accepts, in order, and the refused ones.

    Returns
    -------
    usable : list of Packing
    refused : list of (replicate, reason)
    """
    from pidpipe.cell.packing import check_packing
    from pidpipe.errors import PackingError

    usable, refused = [], []
    for replicate, packing in enumerate(packings):
        try:
            check_packing(packing, f"replicate {replicate}")
            usable.append(packing)
        except PackingError as error:
            refused.append((replicate, str(error)))
    return usable, refused


def write_scene_study(config: dict, table_path: str | Path, comparisons_path: str | Path,
                      folder: str | Path, workers: int = 1, from_records: bool = False) -> dict:
    """The whole study of the config's ``scene`` section: pour (or reuse) the packings, run every case's
    scenes, write the scene table and the comparisons as CSV.

    Parameters
    ----------
    config : dict
        Validated config with its ``scene`` section.
    table_path, comparisons_path : path
        CSV outputs: :func:`scene_rows` and :func:`comparison_rows` of every case.
    folder : path
        Packings (``folder/packings``), runs and records.
    workers : int
        Pours run at once.
    from_records : bool
        Tabulate the records of an earlier run of the study instead of running it
        (:func:`load_scene_study`).

    Returns
    -------
    dict
        ``rows``, ``comparisons``, ``scatter`` (:func:`scatter_row` per case), ``pour_cpu_s``
        (by replicate), ``n_spheres`` (per cell), ``refused`` ((replicate, reason) of the pours
        the campaign would refuse; the next replicates took their places).
    """
    import csv

    from pidpipe.dem.pouring import replicate_packings

    settings = SceneSettings.from_config(config)
    shaking, pouring = ShakeSettings.from_config(config), PourSettings.from_config(config)
    coupon = (settings.coupon_columns, settings.coupon_rows)
    n_packings = max(settings.singles, settings.coupon_cells)
    packings, refused, pour_cpu = [], [], {}
    while len(packings) < n_packings:
        # A pour the campaign would refuse (not settled, or above the lid) is left out and the
        # next replicate takes its place.
        poured, pour_cpu = replicate_packings(pouring, settings.fill_pct,
                                              n_packings + len(refused), Path(folder) / "packings",
                                              workers=workers)
        packings, refused = usable_packings(poured)
    rows, compared, scatter = [], [], []
    for case in settings.cases:
        if from_records:
            result = load_scene_study(shaking.sampling.sem_block_cycles, settings.singles,
                                      float(case.freq_hz), float(case.accel_g), folder)
        else:
            result = run_scene_study(shaking, float(case.freq_hz), float(case.accel_g),
                                     packings, folder, singles=settings.singles,
                                     coupon=coupon,
                                     coupon_cpu_limit_s=settings.coupon_cpu_limit_s)
        rows += scene_rows(result, shaking.coupon_n_cells)
        compared += comparison_rows(result)
        scatter.append(scatter_row(result))
    for path, table in ((table_path, rows), (comparisons_path, compared)):
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".part")
        with open(tmp, "w", newline="", encoding="utf-8") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(table[0]))
            writer.writeheader()
            writer.writerows(table)
        tmp.replace(path)
    return {"rows": rows, "comparisons": compared, "scatter": scatter, "pour_cpu_s": pour_cpu,
            "n_spheres": packings[0].n_spheres, "refused": refused}


def read_scene_table(path: str | Path) -> list[dict]:
    """Rows written by :func:`write_scene_study` (numbers as floats, ``cells`` as int)."""
    import csv

    with open(path, newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        for key, value in row.items():
            if key not in ("scene", "label"):
                row[key] = int(value) if key in ("cells", "measured_cycles") else float(value)
    return rows


def plot_table(table_path: str | Path, png: str | Path) -> Path:
    """:func:`plot_scenes` of a scene table written by :func:`write_scene_study`."""
    return plot_scenes(read_scene_table(table_path), png)
