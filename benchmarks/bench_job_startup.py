"""Where does the wall time of a DEM campaign's Snakemake jobs go, and the campaign's (issue 13)?

Part 1, one job of each kind. A scratch copy of the workflow runs a one-case DEM campaign
(engine dem, pour_engine dem; 1000 Hz, 10 g, 25 %; the config's cells_per_run pours) with
``snakemake cases --skip-script-cleanup``, which keeps the Python script Snakemake made for
each job. The ``pour_dem_packings`` (the fill's cells_per_run packings) and ``simulate_dem_cases`` (here one case) scripts are then run again, ``--repeats``
times each in a fresh process as Snakemake runs them, timed phase by phase from inside
(CPU and wall; the machine is shared, so CPU is the steadier figure):

- interpreter start: a fresh ``python -c pass``;
- Snakemake's preamble (unpickling the job's ``snakemake`` object, importing Snakemake);
- the script's imports, and the imports the step makes on its way (to the first kernel call);
- each compiled function's first call: Numba loading it from its cache (for every dispatcher);
- the engine: the pour, or the case's kernel runs (the record's engine CPU), and any packings
  poured into the pool;
- the rest: reading the packings, parsing the config, writing the record, logging.

Then the imports by top-level package (``python -X importtime``, summed self time; importtime
itself slows imports a little), and from the Snakemake run: its own start-up (until the first
job) and finish, and the job span Snakemake records against the script's process time.

Part 2, a whole campaign (``--campaign DIR``, a finished ``bench_campaign.py --workdir``
folder; read only): from Snakemake's metadata, the span of each stage (pours, packing check,
cases, the stages after the table), the idle core-seconds in each (span x cores - job time),
the chain after the last case (the critical path's tail), the first pours (which include
compiling the kernel if Numba's cache was cold) and the packings poured on demand inside case
jobs (from the case logs' time stamps).

Figures go to ``benchmarks/records/bench_job_startup.json`` (:mod:`harness`).

Run: .venv/bin/python benchmarks/bench_job_startup.py [--repeats 3] [--campaign DIR] [--cores 2]
         [--skip-jobs]
"""

from __future__ import annotations

import argparse
import base64
import datetime
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path

from harness import DEM_ENGINES, SNAKEMAKE, load_average, measured, record, scratch_workflow

PYTHON = sys.executable

# Run inside the fresh process: time the phases of one saved Snakemake job script.
HOOK = r'''
import json, sys, time
def now():
    return time.perf_counter(), time.process_time()
def since(start):
    wall, cpu = now()
    return [wall - start[0], cpu - start[1]]
phases = {}
script = open(sys.argv[1]).read()
marker = "######## snakemake preamble end #########"
preamble, body = script.split(marker, 1)
head, call = body.split("\nrun_step(", 1)
__file__ = sys.argv[1]
start = now()
exec(compile(preamble, "preamble", "exec"), globals())
phases["snakemake_preamble"] = since(start)
start = now()
exec(compile(head, "imports", "exec"), globals())
for module in sys.argv[2].split(","):
    __import__(module)
phases["imports"] = since(start)
import numba.core.dispatcher as _dispatcher
loads = {}
_compile = _dispatcher.Dispatcher._compile_for_args
def _timed(self, *args, **kws):
    t = now()
    try:
        return _compile(self, *args, **kws)
    finally:
        loads[self.py_func.__name__] = [a + b for a, b in zip(loads.get(self.py_func.__name__, [0, 0]), since(t))]
_dispatcher.Dispatcher._compile_for_args = _timed
engine = [0.0, 0.0]
pool = [0.0, 0.0, 0]
def timing(module, name, box, count=False):
    original = getattr(module, name)
    def timed(*args, **kws):
        t = now()
        try:
            return original(*args, **kws)
        finally:
            box[:2] = [a + b for a, b in zip(box[:2], since(t))]
            if count:
                box[2] += len(args[2])
    setattr(module, name, timed)
import pidpipe.steps.cases as _cases
timing(_cases, "pool_packings", pool, count=True)
if ".pour_" in sys.argv[1]:
    import pidpipe.dem.pour as _pour
    timing(_pour, "pour_replicates", engine)
else:   # run_dem_case starts its run with start_dem_case; a continued run extends it
    import pidpipe.dem.case as _case
    timing(_case, "start_dem_case", engine)
    timing(_case.DemCaseRun, "extend", engine)
start = now()
exec(compile("run_step(" + call, "step", "exec"), globals())
step = since(start)
loaded = [sum(v[0] for v in loads.values()), sum(v[1] for v in loads.values())]
phases["numba_cache_loads"] = loaded
phases["engine"] = [engine[0] - loaded[0], engine[1] - loaded[1]]
phases["pool_pours"] = pool[:2]
phases["rest_of_step"] = [s - l - e - p for s, l, e, p in zip(step, loaded, phases["engine"], pool[:2])]
print(json.dumps({"phases": phases, "loads": loads, "pool_pours": pool[2]}))
'''

# What each step imports on its way to the engine (lazily, inside the step's functions).
STEP_IMPORTS = {
    "pour_dem_packings": "pidpipe.dem.pouring,pidpipe.dem.pour,pidpipe.cell.packing",
    "simulate_dem_cases": "pidpipe.dem.case,pidpipe.cell.packing,pidpipe.cell.scene,"
                     "pidpipe.measurement.adaptive,pidpipe.measurement.cost_model,pidpipe.liggghts.shake",
}


def timed_run(command: list[str], cwd: Path) -> tuple[float, float, str]:
    """Wall and CPU (s) of one child process, and its stdout."""
    with measured() as run:
        done = subprocess.run(command, cwd=cwd, check=False, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{command[0]} {' '.join(command[1:])[-200:]} failed (exit {done.returncode}):\n"
                 f"{done.stderr[-3000:]}")
    return run.wall_s, run.children_cpu_s, done.stdout


def metadata(work: Path) -> list[dict]:
    """Snakemake's record of every output: rule, start and end (epoch s), job id."""
    rows = []
    for path in (work / ".snakemake" / "metadata").iterdir():
        data = json.loads(path.read_text())
        name = base64.urlsafe_b64decode(path.name + "=" * (-len(path.name) % 4)).decode()
        rows.append({"output": name, "rule": data["rule"], "start": data["starttime"],
                     "end": data["endtime"]})
    return rows


def jobs_of(rows: list[dict]) -> list[dict]:
    """One row per job (outputs of one job share start and end)."""
    seen = {}
    for row in rows:        # a job's outputs are recorded a few ms apart
        seen.setdefault((row["rule"], round(row["start"], 1), round(row["end"], 1)), row)
    return sorted(seen.values(), key=lambda r: r["start"])


def median_pair(values: list[list[float]]) -> tuple[float, float]:
    return statistics.median(v[0] for v in values), statistics.median(v[1] for v in values)


def part_one(repeats: int, cores: int, lines: list[str], figures: dict) -> None:
    with tempfile.TemporaryDirectory(prefix="bench_job_startup_") as scratch:
        work = Path(scratch)

        def one_case(config: dict) -> None:
            config["grid"] = {"freq_hz": [1000], "accel_g": [10], "fill_pct": [25]}
            config["inspection"]["phase_figure_cases"] = []

        scratch_workflow(work, overrides=DEM_ENGINES, edit=one_case)
        wall, cpu, _ = timed_run([SNAKEMAKE, "--cores", str(cores), "--quiet", "rules",
                                  "--skip-script-cleanup", "cases"], work)
        jobs = jobs_of(metadata(work))
        first, last = min(j["start"] for j in jobs), max(j["end"] for j in jobs)
        spans = defaultdict(list)
        for job in jobs:
            spans[job["rule"]].append(job["end"] - job["start"])
        bench = {}
        for tsv in (work / "results" / "benchmarks").rglob("*.tsv"):
            header, values = tsv.read_text().splitlines()[:2]
            row = dict(zip(header.split("\t"), values.split("\t")))
            bench.setdefault(tsv.parent.name, []).append((float(row["s"]), float(row["cpu_time"])))
        lines.append(f"One-case DEM campaign (`snakemake cases`, {len(jobs)} jobs: "
                     f"{len(spans['pour_dem_packings'])} pour job(s), the check, 1 case) on {cores} cores: "
                     f"{wall:.1f} s wall, {cpu:.1f} s CPU; Snakemake before the first job and after "
                     f"the last {wall - (last - first):.1f} s.")
        figures.update({"one_case_campaign_wall_s": round(wall, 2), "one_case_campaign_cpu_s": round(cpu, 2),
                        "snakemake_outside_jobs_s": round(wall - (last - first), 2)})
        for rule in ("pour_dem_packings", "simulate_dem_cases"):
            if rule in bench:
                lines.append(f"- {rule}: job span (Snakemake) median {statistics.median(spans[rule]):.2f} s; "
                             f"its script's process (benchmark file) median wall "
                             f"{statistics.median(b[0] for b in bench[rule]):.2f} s, CPU "
                             f"{statistics.median(b[1] for b in bench[rule]):.2f} s")
        empty = [timed_run([PYTHON, "-c", "pass"], work)[:2] for _ in range(repeats)]
        lines += ["", f"Each job's script run again in a fresh process, {repeats} times (median; wall / CPU s):",
                  "", "| phase | pour_dem_packings wall | CPU | simulate_dem_cases wall | CPU |", "|---|---|---|---|---|"]
        results, outer = {}, {}
        for rule in ("pour_dem_packings", "simulate_dem_cases"):
            script = sorted((work / ".snakemake" / "scripts").glob(f"*.{rule}.py"))[0]
            runs = []
            outer[rule] = []
            for _ in range(repeats):
                w, c, out = timed_run([PYTHON, "-c", HOOK, str(script), STEP_IMPORTS[rule]], work)
                runs.append(json.loads(out.strip().splitlines()[-1]))
                outer[rule].append([w, c])
            results[rule] = runs
        table = {"interpreter start (python -c pass)": {r: [list(median_pair(empty))] for r in results}}
        for phase in ("snakemake_preamble", "imports", "numba_cache_loads", "engine", "pool_pours",
                      "rest_of_step"):
            table[phase] = {r: [run["phases"][phase] for run in results[r]] for r in results}
        for phase, values in table.items():
            cells = []
            for rule in ("pour_dem_packings", "simulate_dem_cases"):
                w, c = median_pair(values[rule])
                cells += [f"{w:.3f}", f"{c:.3f}"]
                key = phase.split(" (")[0].replace(" ", "_")
                figures[f"{rule}_{key}_wall_s"] = round(w, 3)
                figures[f"{rule}_{key}_cpu_s"] = round(c, 3)
            lines.append(f"| {phase} | " + " | ".join(cells) + " |")
        cells = []
        for rule in ("pour_dem_packings", "simulate_dem_cases"):
            w, c = median_pair(outer[rule])
            cells += [f"**{w:.3f}**", f"**{c:.3f}**"]
            figures[f"{rule}_whole_process_wall_s"] = round(w, 3)
            figures[f"{rule}_whole_process_cpu_s"] = round(c, 3)
        lines.append("| whole process (timed from outside) | " + " | ".join(cells) + " |")
        for rule in results:
            loads = defaultdict(list)
            for run in results[rule]:
                for name, value in run["loads"].items():
                    loads[name].append(value)
            lines.append(f"\n{rule}: compiled functions loaded from Numba's cache (first call; median "
                         "wall / CPU s): " + "; ".join(f"{name} {median_pair(v)[0]:.3f} / "
                                                      f"{median_pair(v)[1]:.3f}"
                                                      for name, v in sorted(loads.items())))
        for rule in results:
            script = sorted((work / ".snakemake" / "scripts").glob(f"*.{rule}.py"))[0]
            done = subprocess.run([PYTHON, "-X", "importtime", str(script)], cwd=work, check=True,
                                  capture_output=True, text=True)
            by_package = defaultdict(int)
            for line in done.stderr.splitlines():
                match = re.match(r"import time:\s+(\d+) \|\s+\d+ \|\s+(\S+)", line)
                if match:
                    by_package[match.group(2).split(".")[0]] += int(match.group(1))
            top = sorted(by_package.items(), key=lambda kv: -kv[1])[:8]
            figures[f"{rule}_imports_s"] = round(sum(by_package.values()) / 1e6, 3)
            lines.append(f"\n{rule}: imports (`python -X importtime`, self time summed by top-level package, "
                         f"total {sum(by_package.values()) / 1e6:.2f} s): "
                         + ", ".join(f"{name} {us / 1e6:.2f}" for name, us in top)
                         + "; pandas " + ("imported" if "pandas" in by_package else "not imported")
                         + ", scipy.stats " + ("imported" if re.search(r"\|\s+scipy\.stats$", done.stderr, re.M)
                                               else "not imported")
                         + ", matplotlib " + ("imported" if "matplotlib" in by_package else "not imported"))


def rule_threads(campaign: Path, cores: int) -> dict[str, int]:
    """``threads:`` of each rule in the campaign's workflow/rules (1 where not given; at most cores)."""
    threads = {}
    for smk in (campaign / "workflow" / "rules").glob("*.smk"):
        for match in re.finditer(r"^rule (\w+):\n((?:[ \t]+.*\n|\n)*)", smk.read_text(), re.M):
            given = re.search(r"^\s+threads:\s*(\d+)", match.group(2), re.M)
            threads[match.group(1)] = min(cores, int(given.group(1))) if given else 1
    return threads


def part_two(campaign: Path, cores: int, lines: list[str], figures: dict) -> None:
    jobs = jobs_of(metadata(campaign))
    threads = rule_threads(campaign, cores)
    for job in jobs:
        job["cores"] = threads.get(job["rule"], 1)
    t0 = min(j["start"] for j in jobs)
    end = max(j["end"] for j in jobs)
    stages = {"pours": ["pour_packing", "pour_dem_packings"], "packing check": ["check_packings"],
              "cases": ["simulate_case", "simulate_dem_cases"]}
    figures.update({"campaign_jobs": len(jobs), "campaign_first_to_last_job_s": round(end - t0, 1)})
    lines += ["", f"Campaign {campaign}: {len(jobs)} jobs, first job start to last job end "
              f"{end - t0:.1f} s on {cores} cores; job time {sum(j['end'] - j['start'] for j in jobs):.1f} s.",
              "", "| stage | jobs | from s | to s | span s | job time s | idle core-s in span (a job holds its rule's threads) |",
              "|---|---|---|---|---|---|---|"]
    case_end = max((j["end"] for j in jobs if j["rule"] in stages["cases"]), default=t0)
    after = [j for j in jobs if j["rule"] not in sum(stages.values(), [])]
    groups = {**{name: [j for j in jobs if j["rule"] in rules] for name, rules in stages.items()},
              "after the cases": [j for j in after if j["start"] >= case_end - 1e-6],
              "other (phase figures during the cases)": [j for j in after if j["start"] < case_end - 1e-6]}
    for name, group in groups.items():
        if not group:
            continue
        start, stop = min(j["start"] for j in group), max(j["end"] for j in group)
        busy_in_span = sum(j["cores"] * (min(j["end"], stop) - max(j["start"], start)) for j in jobs
                           if j["end"] > start and j["start"] < stop)
        key = name.split(" (")[0].replace(" ", "_")
        figures[f"campaign_{key}_span_s"] = round(stop - start, 1)
        figures[f"campaign_{key}_idle_core_s"] = round(max(0.0, cores * (stop - start) - busy_in_span), 1)
        lines.append(f"| {name} | {len(group)} | {start - t0:.1f} | {stop - t0:.1f} | {stop - start:.1f} | "
                     f"{sum(j['end'] - j['start'] for j in group):.1f} | "
                     f"{max(0.0, cores * (stop - start) - busy_in_span):.1f} |")
    tail = sorted(groups["after the cases"], key=lambda j: j["end"] - j["start"], reverse=True)
    lines.append("\nAfter the last case (critical path's tail): " + "; ".join(
        f"{j['rule']} {j['end'] - j['start']:.1f} s" for j in tail))
    pours = sorted(groups["pours"], key=lambda j: j["start"])
    if pours:
        spans = sorted(j["end"] - j["start"] for j in pours)
        lines.append(f"Pour jobs: median {statistics.median(spans):.1f} s, longest {spans[-1]:.1f} s "
                     f"(the first {cores}: {', '.join('%.1f' % (j['end'] - j['start']) for j in pours[:cores])} s; "
                     "far above the median when they compiled the kernel)")
    stamp = re.compile(r"^(\S+ \S+) INFO poured packing")
    pool_times, pool_count = [], 0
    for log in (campaign / "logs" / "simulate_case").glob("*.log"):
        times = [datetime.datetime.strptime(m.group(1), "%Y-%m-%d %H:%M:%S,%f").timestamp()
                 for m in map(stamp.match, log.read_text().splitlines()) if m]
        pool_count += len(times)
        pool_times += [b - a for a, b in zip(times, times[1:]) if b - a < 10]
    if pool_count:
        # pool pours of one call (pidpipe.steps.cases.pool_packings) are logged together when it ends
        calls = pool_count - sum(1 for gap in pool_times if gap < 0.05)
        together = [gap for gap in pool_times if gap >= 0.05]
        lines.append(f"Packings poured on demand inside case jobs: {pool_count}, in {calls} calls "
                     "(a call pours every packing a step needs that no other case is pouring)"
                     + (f"; calls one after another in a job {statistics.median(together):.2f} s apart "
                        "(median; in a campaign from before pool pours were batched, the time of one pour)"
                        if together else "") + ".")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--campaign", metavar="DIR", help="a finished campaign folder to analyse (read only)")
    parser.add_argument("--skip-jobs", action="store_true", help="only part 2 (needs --campaign)")
    args = parser.parse_args()
    if args.skip_jobs and not args.campaign:
        parser.error("--skip-jobs needs --campaign")
    lines, figures = [f"Load average before: {load_average()}", ""], {}
    if not args.skip_jobs:
        part_one(args.repeats, args.cores, lines, figures)
    if args.campaign:
        part_two(Path(args.campaign), args.cores, lines, figures)
    lines.append(f"\nLoad average after: {load_average()}")
    print("\n".join(lines))
    record("bench_job_startup", figures, notes=f"{lines[0]}; {lines[-1].strip()}")


if __name__ == "__main__":
    main()
