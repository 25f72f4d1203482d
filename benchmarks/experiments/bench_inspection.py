"""Cost of looking inside a case: motion sampling (every run, for the regime) and the movie.

For 500 Hz / 5 g / 50 % and 1000 Hz / 10 g / 50 % at the default fidelity (7 cells per run) it
runs each case three ways, interleaved and twice: plain (``inspection.phase_windows_per_cycle:
0``), with the motion sampled (20 windows a cycle, forces sampled every 10 steps: the default),
and with the motion and a movie (20 frames a cycle over the last 3 cycles). It also prints how
closely the phase profile's dissipation over a cycle matches the record's E_d. It reports LIGGGHTS' CPU time (the smaller of the two
repetitions) and its ratio to the plain run, the time to write the VTK series and its size.

Run: .venv/bin/python benchmarks/experiments/bench_inspection.py

With ``--engine dem`` it measures instead what the motion sampling costs the compiled DEM (its
kernel samples the motion in the same call): the same cases and packings, plain and with the
motion sampled, interleaved :data:`DEM_REPETITIONS` times (the smaller CPU time of each), with
the profile's closure on E_d and the regime.
"""

from __future__ import annotations

import copy
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.inspection import MovieSettings
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.shake import run_case

REPETITIONS = 2
DEM_REPETITIONS = 5
CASES = ((500.0, 5.0), (1000.0, 10.0))


def _closure(record: dict) -> float:
    """The phase profile's dissipation over a cycle over the record's E_d."""
    profile = record.motion["profile"]
    return (sum(profile["dissipation_w"]["mean"]) / len(profile["phase"]) * profile["period_s"]
            / record.ed_cycle_mean_j)


def main_dem() -> None:
    """The compiled DEM's cost of the motion sampling (``--engine dem``)."""
    from pidpipe.dem.case import run_dem_case

    config = load_config()
    plain = copy.deepcopy(config)
    plain["inspection"]["phase_windows_per_cycle"] = 0
    cells = int(config["fidelity"]["cells_per_run"])
    lines = ["| case | plain CPU s | + motion CPU s (ratio) | profile E_d / E_d | regime |",
             "|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        packings = [pour(PourSettings.from_config(config), 50, k, scratch / f"pour{k}") for k in range(cells)]
        for freq, accel in CASES:
            case = CaseSpec(freq, accel, 50.0)
            run_dem_case(ShakeSettings.from_config(config), case, packings)     # compiles
            cpu = {"plain": [], "motion": []}
            for _ in range(DEM_REPETITIONS):
                cpu["plain"].append(run_dem_case(ShakeSettings.from_config(plain), case, packings).engine["cpu_time_s"])
                seen = run_dem_case(ShakeSettings.from_config(config), case, packings)
                cpu["motion"].append(seen.engine["cpu_time_s"])
            best = {k: min(v) for k, v in cpu.items()}
            lines.append(f"| {case.case_id}, {cells} cells | {best['plain']:.2f} | {best['motion']:.2f} "
                         f"({best['motion'] / best['plain']:.3f}) | {_closure(seen):.3f} | {seen.regime} "
                         f"({', '.join(seen.motion['cell_regimes'])}) |")
            print(lines[-1], flush=True)
    lines += ["", f"CPU = the DEM case's process CPU time (run_dem_case, whole case), the smaller of "
              f"{DEM_REPETITIONS} interleaved repetitions; ratio against the plain run of the same "
              "case. Default fidelity and sampling (20 windows a cycle, forces every 10 steps; the "
              "walls' power from every step's work)."]
    append("Looking inside a case in the compiled DEM: the cost of motion sampling",
           "python benchmarks/experiments/bench_inspection.py --engine dem", lines)


def main() -> None:
    config = load_config()
    plain = copy.deepcopy(config)
    plain["inspection"]["phase_windows_per_cycle"] = 0
    cells = int(config["fidelity"]["cells_per_run"])
    lines = ["| case | plain CPU s | + motion CPU s (ratio) | + motion + movie CPU s (ratio) | movie frames | "
             "movie run wall s (whole run_case) | movie size MB | profile E_d / E_d | regime |",
             "|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        packings = [pour(PourSettings.from_config(config), 50, k, scratch / f"pour{k}") for k in range(cells)]
        for freq, accel in CASES:
            case = CaseSpec(freq, accel, 50.0)
            cpu = {"plain": [], "motion": [], "movie": []}
            for repetition in range(REPETITIONS):
                cpu["plain"].append(run_case(ShakeSettings.from_config(plain), case, packings, scratch / "p").engine["liggghts_cpu_time_s"])
                seen = run_case(ShakeSettings.from_config(config), case, packings, scratch / "m")
                cpu["motion"].append(seen.engine["liggghts_cpu_time_s"])
                start = time.perf_counter()
                movie = run_case(ShakeSettings.from_config(config), case, packings, scratch / "v", movie=MovieSettings(20, 3),
                                 movie_dir=scratch / "movie")
                movie_wall = time.perf_counter() - start
                cpu["movie"].append(movie.engine["liggghts_cpu_time_s"])
            best = {k: min(v) for k, v in cpu.items()}
            size = sum(p.stat().st_size for p in (scratch / "movie").iterdir()) / 1e6
            closure = _closure(seen)
            lines.append(
                f"| {case.case_id}, {cells} cells | {best['plain']:.2f} | {best['motion']:.2f} "
                f"({best['motion'] / best['plain']:.3f}) | {best['movie']:.2f} ({best['movie'] / best['plain']:.3f}) | "
                f"{movie.movie['frames']} | {movie_wall:.2f} | {size:.2f} | {closure:.3f} | {seen.regime} "
                f"({', '.join(seen.motion['cell_regimes'])}) |")
    lines.append("")
    lines.append(f"CPU = LIGGGHTS' CPU time, the smaller of {REPETITIONS} interleaved repetitions; "
                 "ratios against the plain run of the same case. Default fidelity otherwise.")
    append("Looking inside a case: motion sampling and movie", "python benchmarks/experiments/bench_inspection.py", lines)


if __name__ == "__main__":
    if sys.argv[1:] == ["--engine", "dem"]:
        main_dem()
    else:
        main()
