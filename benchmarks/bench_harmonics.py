"""What the first-harmonic sums (pidpipe.measurement.harmonics, issue 26) cost each engine.

The sums cannot be switched off, so the code before them (``--base``, by default the merge base
with ``main``) is taken from git into a folder of its own and measured against the working tree, in
one run, alternating: two long-lived worker processes, one importing each tree, each
rendering its own shake decks and running its own compiled kernel.

- The compiled DEM: 1 and 7 cells of 19 acrylic spheres (90 % fill, one packing poured by
  LIGGGHTS and repeated in every cell), 500 Hz, 5 g, ``run_cycles`` of ``--dem-cycles`` cycles,
  CPU time of the call; both workers go on from the same state, round after round (the sums
  do not change the trajectory).
- LIGGGHTS: the shake deck of each tree for the same scenes and case, 1 + ``--cycles``
  cycles, motion sampling as configured, CPU time of the process (user + system).

Each round runs the two trees back to back (the base first in odd rounds, the working tree first
in even ones); ``--repeats`` rounds. Reported for each engine and scene: the smallest CPU time of
each tree, their ratio (working tree / base), and the median, lowest and highest ratio of one
round's pair (the machine is shared: a ratio within the spread of the rounds is noise).

Run: .venv/bin/python benchmarks/bench_harmonics.py [--repeats 5] [--cycles 8] [--dem-cycles 20]
     [--base REV]

Writes benchmarks/records/bench_harmonics.json.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RECORD = Path(__file__).resolve().parent / "records" / "bench_harmonics.json"
FREQ_HZ, ACCEL_G, FILL_PCT = 500.0, 5.0, 90.0
CELLS = (1, 7)

WORKER = r"""
import json, sys, time
from pathlib import Path
import numpy as np
from pidpipe.cases import CaseSpec
from pidpipe.cell.packing import load_packing
from pidpipe.cell.scene import CellScene
from pidpipe.config import load_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.dem import run_cycles, start
from pidpipe.dem.from_scene import dem_scene
from pidpipe.liggghts.shake import render_shake_deck

freq, accel, fill = float(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
config = load_config()
config["fidelity"].update(json.loads(sys.argv[4]))
packing = load_packing(sys.argv[5])
settings = ShakeSettings.from_config(config)
runs = {}
for line in sys.stdin:
    command = json.loads(line)
    cells = command["cells"]
    if command["do"] == "render":
        render_shake_deck(settings, CaseSpec(freq, accel, fill), [packing] * cells,
                          Path(command["dir"]))
        reply = {}
    else:
        if cells not in runs:
            scene = dem_scene(CellScene.of(settings), freq, [accel] * cells)
            scene, state, ws = start(scene, np.stack([packing.centres()] * cells))
            run_cycles(scene, state, ws, 1)          # compiles, or loads the cache
            runs[cells] = (scene, state, ws)
        scene, state, ws = runs[cells]
        began = time.process_time()
        out = run_cycles(scene, state, ws, command["cycles"])
        reply = {"cpu_s": time.process_time() - began,
                 "harmonics": "harmonic_cos_n_s" in out,
                 "work_j": float(out["wall_work_j"].sum())}
    print(json.dumps(reply), flush=True)
"""


class Worker:
    """One tree's worker process: ``ask`` sends a command and waits for its reply."""

    def __init__(self, tree: Path, fidelity: dict, packing: Path):
        env = dict(os.environ, PYTHONPATH=str(tree))
        self.process = subprocess.Popen(
            [sys.executable, "-c", WORKER, str(FREQ_HZ), str(ACCEL_G), str(FILL_PCT),
             json.dumps(fidelity), str(packing)],
            cwd=tree, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def ask(self, **command) -> dict:
        self.process.stdin.write(json.dumps(command) + "\n")
        self.process.stdin.flush()
        line = self.process.stdout.readline()
        if not line:
            raise SystemExit(f"a worker died on {command}")
        return json.loads(line)

    def close(self) -> None:
        self.process.stdin.close()
        self.process.wait()


def export_tree(revision: str) -> tuple[Path, str]:
    """The package, templates and config of ``revision`` in a folder of the system's temporary
    directory named by its hash (kept, so that its compiled kernel is cached for the next run).

    Returns
    -------
    folder : Path
    commit : str
        The revision's full hash.
    """
    commit = subprocess.run(["git", "rev-parse", revision], cwd=REPO, capture_output=True,
                            text=True, check=True).stdout.strip()
    folder = Path(tempfile.gettempdir()) / f"pidpipe_tree_{commit[:12]}"
    if not (folder / "pidpipe").is_dir():
        archive = subprocess.run(["git", "archive", commit, "pidpipe", "templates", "config.yaml",
                                  "workflow/schemas"], cwd=REPO, capture_output=True,
                                 check=True).stdout
        with tarfile.open(fileobj=BytesIO(archive)) as tar:
            tar.extractall(folder, filter="data")
    return folder, commit


def liggghts_cpu_s(deck: Path) -> float:
    """CPU seconds (user + system) of one LIGGGHTS run of ``deck`` in its folder."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(deck.parent / "screen.txt", "w") as screen:
        done = subprocess.run(["liggghts", "-in", deck.name, "-log", "log.liggghts"],
                              cwd=deck.parent, stdout=screen, stderr=subprocess.STDOUT)
    if done.returncode != 0:
        raise SystemExit(f"LIGGGHTS failed on {deck} (see {deck.parent / 'screen.txt'})")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def summary(pairs: list[tuple[float, float]]) -> dict:
    """Smallest CPU of each tree, their ratio, and the spread of the rounds' ratios."""
    base, mine = [p[0] for p in pairs], [p[1] for p in pairs]
    ratios = [m / b for b, m in pairs]
    return {"base_min_cpu_s": min(base), "harmonics_min_cpu_s": min(mine),
            "ratio_of_minima": min(mine) / min(base), "ratio_median": statistics.median(ratios),
            "ratio_lowest": min(ratios), "ratio_highest": max(ratios),
            "base_cpu_s": base, "harmonics_cpu_s": mine}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--cycles", type=int, default=8, help="measured cycles of each LIGGGHTS run")
    parser.add_argument("--dem-cycles", type=int, default=20, help="cycles of each timed DEM call")
    parser.add_argument("--base", default=None, help="the revision before the sums (default: "
                        "the merge base of HEAD and main)")
    args = parser.parse_args()
    sys.path.insert(0, str(REPO))
    from pidpipe.cell.packing import save_packing
    from pidpipe.config import load_config
    from pidpipe.config.settings import PourSettings
    from pidpipe.liggghts.pour import pour

    base_rev = args.base or subprocess.run(["git", "merge-base", "HEAD", "main"], cwd=REPO,
                                           capture_output=True, text=True, check=True).stdout.strip()
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True, text=True,
                          check=True).stdout.strip()
    fidelity = {"transient_cycles": 1, "transient_min_time_s": 0.0,
                "measured_cycles": args.cycles}
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        base_tree, base_commit = export_tree(base_rev)
        packing = pour(PourSettings.from_config(load_config()), FILL_PCT, 0, scratch / "pour")
        packing_file = save_packing(packing, scratch / "packing.json")
        trees = {"base": Worker(base_tree, fidelity, packing_file),
                 "harmonics": Worker(REPO, fidelity, packing_file)}
        decks = {}
        for name, worker in trees.items():
            for cells in CELLS:
                folder = scratch / f"{name}_{cells}"
                folder.mkdir()
                worker.ask(do="render", cells=cells, dir=str(folder))
                decks[name, cells] = folder / "shake.lmp"
        if "cycle_harmonics" in decks["base", 1].read_text() or \
                "cycle_harmonics" not in decks["harmonics", 1].read_text():
            raise SystemExit("the base deck already sums the harmonics, or the working tree's does not")
        timings = {("dem", c): [] for c in CELLS} | {("liggghts", c): [] for c in CELLS}
        for cells in CELLS:                        # compile or load the kernels before timing
            for worker in trees.values():
                worker.ask(do="dem", cells=cells, cycles=1)
        for round_ in range(args.repeats):
            order = ["base", "harmonics"] if round_ % 2 == 0 else ["harmonics", "base"]
            for cells in CELLS:
                dem, lig = {}, {}
                for name in order:
                    reply = trees[name].ask(do="dem", cells=cells, cycles=args.dem_cycles)
                    if reply["harmonics"] != (name == "harmonics"):
                        raise SystemExit(f"the {name} kernel's output is not what it should be")
                    dem[name] = reply
                if dem["base"]["work_j"] != dem["harmonics"]["work_j"]:
                    raise SystemExit("the two kernels' trajectories differ")
                for name in order:
                    lig[name] = liggghts_cpu_s(decks[name, cells])
                timings["dem", cells].append((dem["base"]["cpu_s"], dem["harmonics"]["cpu_s"]))
                timings["liggghts", cells].append((lig["base"], lig["harmonics"]))
                print(f"round {round_ + 1}, {cells} cell(s): DEM {dem['base']['cpu_s']:.3f} -> "
                      f"{dem['harmonics']['cpu_s']:.3f} s, LIGGGHTS {lig['base']:.2f} -> "
                      f"{lig['harmonics']:.2f} s", flush=True)
        for worker in trees.values():
            worker.close()
    figures = {f"{engine}_{cells}_cells": summary(pairs) for (engine, cells), pairs in timings.items()}
    figures["scene"] = {"freq_hz": FREQ_HZ, "accel_g": ACCEL_G, "fill_pct": FILL_PCT,
                        "spheres_per_cell": packing.n_spheres, "cells": list(CELLS),
                        "liggghts_cycles": 1 + args.cycles, "dem_cycles_per_call": args.dem_cycles,
                        "repeats": args.repeats, "base_commit": base_commit, "head_commit": head}
    record = {
        "benchmark": "bench_harmonics",
        "command": "python benchmarks/bench_harmonics.py " + " ".join(sys.argv[1:]),
        "machine": {"host": platform.node(), "cpus": os.cpu_count(),
                    "python": platform.python_version(), "platform": platform.platform()},
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "figures": figures,
    }
    RECORD.parent.mkdir(exist_ok=True)
    RECORD.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    print(f"\nCPU time with the harmonic sums / without (base {base_commit[:8]}), "
          f"{args.repeats} rounds:")
    for key, value in figures.items():
        if key != "scene":
            print(f"  {key:18s} ratio of minima {value['ratio_of_minima']:.3f}, rounds "
                  f"{value['ratio_lowest']:.3f}-{value['ratio_highest']:.3f} (median "
                  f"{value['ratio_median']:.3f}); min {value['base_min_cpu_s']:.3f} -> "
                  f"{value['harmonics_min_cpu_s']:.3f} s")
    print(f"written: {RECORD.relative_to(REPO)}")


if __name__ == "__main__":
    main()
