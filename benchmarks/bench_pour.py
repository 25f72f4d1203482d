"""What does a pour cost in each engine (fidelity.pour_engine: liggghts | dem), and do their piles agree?

For each default fill (25, 50, 75, 90 %) and replicates 0 .. ``--seeds``-1, the packing is
poured by LIGGGHTS (:func:`pidpipe.liggghts.pour.pour`) and by the compiled DEM
(:func:`pidpipe.dem.pour.pour`) with the default config (dt = 0.2 t_R at the 100 Hz tapping,
settle 0.15 s, tap 20 cycles, settle 0.15 s, further settling if needed). Reported per fill
and engine:

- CPU per pour in this process, s (mean and standard deviation over the seeds): LIGGGHTS' child
  process and this process's own share (deck, parsing); the DEM's this process's, after one
  warm-up pour that loads the compiled kernel;
- CPU of one pour in a fresh Python process, as a campaign's ``pour_packing`` job makes it
  (imports, the DEM's kernel loaded from Numba's cache, the pour), replicate 0;
- the piles: mean pile height and centre-of-mass height above the floor (mm, with standard
  errors over the seeds) of each engine and their difference, the pours that needed further
  settling, and the fastest sphere of any pour.

The machine is shared: CPU time, not wall time, is compared, and the load average is printed.

With ``--jobs`` instead: the DEM campaign's pour stage as Snakemake runs it, before and after
the pours of one fill were batched (issue 13). A scratch copy of the workflow (config.yaml,
``engine: dem``, ``fidelity.pour_engine: dem``) runs ``snakemake --cores 2 packings`` twice:
once with the scratch copy's ruleorder turned round (``pour_packing`` first: one job per
packing, as before) and once as it is (``pour_dem_packings``, one job per fill). Each run's wall (Snakemake start
to end), the CPU of all its processes, and the jobs' summed wall and CPU (Snakemake's benchmark
files); the two runs' packings are compared byte for byte. Then, in this process, each fill's
packings poured one by one (:func:`pidpipe.dem.pour.pour`) against one batched call
(:func:`pidpipe.dem.pour.pour_replicates`), CPU s, and whether they are identical.

Records: ``benchmarks/records/bench_pour.json`` and, with ``--jobs``, ``bench_pour_jobs.json``
(:mod:`harness`).

Run: .venv/bin/python benchmarks/bench_pour.py [--seeds 10] | [--jobs [--note TEXT]]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from harness import (DEM_ENGINES, SNAKEMAKE, children_cpu_s, measured, own_cpu_s, record,
                     scratch_workflow)

from pidpipe.cell.pour_protocol import plan_pour
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings

FILLS = (25.0, 50.0, 75.0, 90.0)
ENGINES = ("liggghts", "dem")

FRESH_POUR = """
import sys
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings
from pidpipe.dem.pouring import pour_with_engine
config = load_config()
config["fidelity"]["pour_engine"] = sys.argv[1]
pour_with_engine(PourSettings.from_config(config), float(sys.argv[2]), 0, sys.argv[3])
"""


def cpu_s() -> float:
    """CPU time of this process and its finished children, s."""
    return own_cpu_s() + children_cpu_s()


def fresh_process_cpu_s(engine: str, fill: float, workdir: Path) -> float:
    """CPU of one pour in a new Python process (and its LIGGGHTS child), s."""
    with measured() as fresh:
        subprocess.run([sys.executable, "-c", FRESH_POUR, engine, str(fill), str(workdir)], check=True,
                       capture_output=True, text=True)
    return fresh.children_cpu_s


def pour_stage(work: Path, per_packing: bool) -> dict:
    """Run ``snakemake --cores 2 packings`` in ``work`` (its results removed first), with
    ``per_packing`` the scratch workflow's ruleorder turned round (pour_packing first); wall, CPU
    of all its processes, the jobs' summed wall and CPU, and the packings' bytes."""
    import shutil

    rules = work / "workflow" / "rules" / "pour_dem.smk"
    order = ("ruleorder: pour_dem_packings > pour_packing", "ruleorder: pour_packing > pour_dem_packings")
    text = rules.read_text()
    if order[0] not in text and order[1] not in text:
        sys.exit(f"{rules}: no ruleorder of pour_dem_packings and pour_packing to turn round")
    rules.write_text(text.replace(*(order if per_packing else order[::-1])))

    shutil.rmtree(work / "results", ignore_errors=True)
    shutil.rmtree(work / ".snakemake", ignore_errors=True)
    command = [SNAKEMAKE, "packings", "--cores", "2"]
    with measured() as run:
        done = subprocess.run(command, cwd=work, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"snakemake packings failed:\n{done.stderr[-3000:]}")
    jobs = []
    for tsv in sorted((work / "results" / "benchmarks").rglob("*.tsv")):
        header, values = tsv.read_text().splitlines()[:2]
        row = dict(zip(header.split("\t"), values.split("\t")))
        jobs.append((tsv.parent.name, float(row["s"]), float(row["cpu_time"])))
    return {"wall": run.wall_s, "cpu": run.children_cpu_s,
            "jobs": jobs, "packings": {path.name: path.read_bytes()
                                       for path in (work / "results" / "packings").glob("r*.json")}}


def bench_jobs(note: str) -> None:
    """The pour stage of the DEM campaign, one job per packing against one job per fill."""
    from pidpipe.dem.pour import pour as dem_pour
    from pidpipe.dem.pour import pour_replicates

    load_start = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="bench_pour_jobs_") as scratch:
        work = Path(scratch)
        config = scratch_workflow(work, overrides=DEM_ENGINES)
        runs = {"one job per packing (pour_packing, before)": pour_stage(work, True),
                "one job per fill (pour_dem_packings, after)": pour_stage(work, False)}
    (before, one), (after, batched) = runs.items()
    same = one["packings"].keys() == batched["packings"].keys() and all(
        one["packings"][name] == batched["packings"][name] for name in one["packings"])
    lines = [f"Note: {note}" if note else "", f"Load average before: {load_start[0]:.2f} {load_start[1]:.2f} {load_start[2]:.2f}", "",
             "`snakemake --cores 2 packings` on config.yaml with engine dem and pour_engine dem "
             f"({len(one['packings'])} packings, 4 fills x 7 cells):", "",
             "| pour stage | jobs | Snakemake wall s | CPU s, all processes | jobs' wall s (summed) | jobs' CPU s (summed) |",
             "|---|---|---|---|---|---|"]
    for label, run in runs.items():
        pours = [j for j in run["jobs"] if j[0].startswith("pour")]
        lines.append(f"| {label} | {len(pours)} | {run['wall']:.1f} | {run['cpu']:.1f} | "
                     f"{sum(j[1] for j in pours):.1f} | {sum(j[2] for j in pours):.1f} |")
    lines += ["", f"After / before: Snakemake wall {batched['wall'] / one['wall']:.2f}, CPU "
              f"{batched['cpu'] / one['cpu']:.2f}. Packings of the two runs identical byte for byte: "
              f"{'yes' if same else 'NO'} ({len(one['packings'])} files).", ""]
    settings = PourSettings.from_config(config)
    dem_pour(settings, FILLS[0], 0)                 # warm-up: loads the kernel
    lines += ["In one process, the 7 packings of each fill (CPU s):", "",
              "| fill % | one by one (pour) | one call (pour_replicates) | ratio | batched cells | identical |",
              "|---|---|---|---|---|---|"]
    batched_figures = {}
    for fill in FILLS:
        began = cpu_s()
        alone = [dem_pour(settings, fill, k) for k in range(7)]
        single = cpu_s() - began
        began = cpu_s()
        together = pour_replicates(settings, fill, range(7))
        batch = cpu_s() - began
        tops = [plan_pour(settings, fill, k).top_z_m for k in range(7)]
        shared = sum(tops.count(t) for t in set(tops) if tops.count(t) > 1)
        lines.append(f"| {fill:g} | {single:.2f} | {batch:.2f} | {batch / single:.2f} | {shared} of 7 | "
                     f"{'yes' if alone == together else 'NO'} |")
        batched_figures.update({f"fill{fill:g}_one_by_one_cpu_s": round(single, 2),
                                f"fill{fill:g}_one_call_cpu_s": round(batch, 2),
                                f"fill{fill:g}_identical": alone == together})
    lines += ["", "(Batched cells: those sharing their open pouring cell with another replicate, "
              "which one kernel call pours together; the others are poured one by one in the same call.)",
              f"Load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}"]
    print("\n".join(lines))
    figures = {"packings": len(one["packings"]), "packings_identical": same}
    for key, run in (("per_packing", one), ("per_fill", batched)):
        pours = [j for j in run["jobs"] if j[0].startswith("pour")]
        figures.update({f"{key}_jobs": len(pours), f"{key}_snakemake_wall_s": round(run["wall"], 1),
                        f"{key}_cpu_all_processes_s": round(run["cpu"], 1),
                        f"{key}_jobs_cpu_s": round(sum(j[2] for j in pours), 1)})
    figures.update(batched_figures)
    record("bench_pour_jobs", figures, notes=(f"{note}. " if note else "") + lines[1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="replicates poured per fill and engine")
    parser.add_argument("--jobs", action="store_true",
                        help="the DEM campaign's pour stage, per packing against per fill")
    parser.add_argument("--note", default="", help="a note recorded with --jobs (e.g. the load)")
    args = parser.parse_args()
    if args.jobs:
        bench_jobs(args.note)
        return
    from pidpipe.dem.pour import pour as dem_pour
    from pidpipe.liggghts.pour import pour as liggghts_pour

    pour = {"liggghts": liggghts_pour, "dem": dem_pour}
    settings = PourSettings.from_config(load_config())
    load_start, wall_start = os.getloadavg()[0], time.perf_counter()
    dem_pour(settings, FILLS[0], 0)                 # warm-up: loads (or compiles) the kernel
    results = {}
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        for fill in FILLS:
            for engine in ENGINES:
                rows = []
                for replicate in range(args.seeds):
                    began = cpu_s()
                    packing = pour[engine](settings, fill, replicate, scratch / f"{engine}{fill:g}_{replicate}")
                    centres = packing.centres()
                    rows.append((cpu_s() - began, packing.pile_height_m,
                                 centres[:, 2].mean() + 0.5 * packing.lid_height_m,
                                 packing.settle_time_s, packing.max_speed_m_s, packing.n_spheres))
                fresh = fresh_process_cpu_s(engine, fill, scratch / f"fresh_{engine}{fill:g}")
                results[fill, engine] = (np.array(rows), fresh)
                print(f"r={fill:g} %, {engine}: {np.mean([r[0] for r in rows]):.2f} s per pour, "
                      f"fresh process {fresh:.2f} s", flush=True)
    load_end, wall = os.getloadavg()[0], time.perf_counter() - wall_start

    lines = [f"{args.seeds} seeds (replicates 0-{args.seeds - 1}) per fill and engine, default config "
             f"(dt 0.2 t_R, settle 0.15 s, 20 taps at 100 Hz, 10 g); load average {load_start:.1f} "
             f"at the start, {load_end:.1f} at the end; wall {wall:.0f} s.", "",
             "| fill % | spheres | LIGGGHTS CPU s per pour | DEM CPU s per pour | ratio | fresh process: LIGGGHTS s | DEM s |",
             "|---|---|---|---|---|---|---|"]
    for fill in FILLS:
        (lig, lig_fresh), (dem, dem_fresh) = results[fill, "liggghts"], results[fill, "dem"]
        lines.append(f"| {fill:g} | {int(lig[0, 5])} | {lig[:, 0].mean():.2f} ± {lig[:, 0].std(ddof=1):.2f} | "
                     f"{dem[:, 0].mean():.2f} ± {dem[:, 0].std(ddof=1):.2f} | "
                     f"{lig[:, 0].mean() / dem[:, 0].mean():.1f} | {lig_fresh:.2f} | {dem_fresh:.2f} |")
    lines += ["", "(± is the standard deviation over the seeds; fresh process: one pour, replicate 0, "
              "in a new Python process as a pour_packing job makes it, imports and the kernel's "
              "cache load included.)", "",
              "| fill % | pile mm LIGGGHTS | pile mm DEM | DEM - LIGGGHTS mm | centre of mass mm LIGGGHTS | DEM | DEM - LIGGGHTS mm | further settling (L/D) | fastest sphere m/s |",
              "|---|---|---|---|---|---|---|---|---|"]
    n = args.seeds
    for fill in FILLS:
        lig, dem = results[fill, "liggghts"][0], results[fill, "dem"][0]
        cells = []
        for column in (1, 2):
            a, b = 1e3 * lig[:, column], 1e3 * dem[:, column]
            se = np.sqrt((a.var(ddof=1) + b.var(ddof=1)) / n)
            cells += [f"{a.mean():.2f} ± {a.std(ddof=1) / np.sqrt(n):.2f}",
                      f"{b.mean():.2f} ± {b.std(ddof=1) / np.sqrt(n):.2f}",
                      f"{b.mean() - a.mean():+.2f} ± {se:.2f}"]
        configured = plan_pour(settings, fill, 0).settle_period_s
        further = [int(np.sum(rows[:, 3] > 1.5 * configured)) for rows in (lig, dem)]
        lines.append(f"| {fill:g} | {' | '.join(cells)} | {further[0]}/{further[1]} | "
                     f"{max(lig[:, 4].max(), dem[:, 4].max()):.1g} |")
    lines += ["", "(± is the standard error of the mean over the seeds, and of the difference.)"]
    print("\n".join(lines))
    figures = {"seeds": args.seeds, "wall_s": round(wall, 1)}
    for fill in FILLS:
        (lig, lig_fresh), (dem, dem_fresh) = results[fill, "liggghts"], results[fill, "dem"]
        figures.update({f"fill{fill:g}_spheres": int(lig[0, 5]),
                        f"fill{fill:g}_liggghts_cpu_per_pour_s": round(float(lig[:, 0].mean()), 3),
                        f"fill{fill:g}_dem_cpu_per_pour_s": round(float(dem[:, 0].mean()), 3),
                        f"fill{fill:g}_liggghts_over_dem_cpu": round(float(lig[:, 0].mean() / dem[:, 0].mean()), 2),
                        f"fill{fill:g}_liggghts_fresh_process_cpu_s": round(lig_fresh, 2),
                        f"fill{fill:g}_dem_fresh_process_cpu_s": round(dem_fresh, 2),
                        f"fill{fill:g}_pile_dem_minus_liggghts_mm": round(1e3 * float(dem[:, 1].mean() - lig[:, 1].mean()), 3)})
    record("bench_pour", figures, notes=lines[0])


if __name__ == "__main__":
    main()
