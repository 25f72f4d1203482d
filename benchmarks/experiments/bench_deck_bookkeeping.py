"""What the shake deck's energy bookkeeping costs LIGGGHTS, by CPU time, in one run (issue 13).

A 7-cell shake deck (19 spheres a cell, 90 % fill, 500 Hz / 5 g, motion sampling as configured)
is rendered as a campaign case renders it, then run by LIGGGHTS in three variants, interleaved,
each ``--repeats`` times (the smallest CPU time of each counts: the machine is shared):

- ``deck``: the deck as rendered (each cell's wall power from one per-sphere pass a step,
  summed per cell where it is written);
- ``deck + fcm() per cell``: the same, plus each cell's power as an equal-style variable of
  ``fcm(cell,z)`` evaluated every step, as the deck did before 2026-12-01 (the cost that change
  removed);
- ``no bookkeeping``: every ``fix ave/time``, ``fix ave/atom``, dump and the timestep check
  removed, the floor that the mesh wall, the contacts and the integration cost alone.

Run: .venv/bin/python benchmarks/experiments/bench_deck_bookkeeping.py [--cycles 8] [--repeats 5]
"""

from __future__ import annotations

import argparse
import re
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.shake import render_shake_deck

FREQ_HZ, ACCEL_G, FILL_PCT, CELLS = 500.0, 5.0, 90.0, 7


def former_cell_powers(deck: str, weights_n: list[float]) -> str:
    """``deck`` plus each cell's power as an equal-style ``fcm()`` variable averaged every step."""
    steps = re.search(r"^fix\s+cycle_power all ave/time 1 (\d+) ", deck, flags=re.MULTILINE).group(1)
    lines = [f"variable        old_power_cell{k} equal (fcm(cell{k},z)+{w!r})*v_wall_velocity"
             for k, w in enumerate(weights_n)]
    lines.append(f"fix             old_cell_power all ave/time 1 {steps} {steps} "
                 + " ".join(f"v_old_power_cell{k}" for k in range(len(weights_n)))
                 + " file old_cell_power.txt")
    return deck.replace("\nrun ", "\n" + "\n".join(lines) + "\nrun ", 1)


def without_bookkeeping(deck: str) -> str:
    """``deck`` without its averaging fixes (and the sums that read them), dumps and timestep check."""
    pattern = (r"^(fix\s+\S+\s+all\s+(ave/time|ave/atom|check/timestep/gran)|compute\s+\S+\s+\S+\s+reduce"
               r"|dump|dump_modify)\s.*$")
    return re.sub(pattern, "", deck, flags=re.MULTILINE)


def cpu_of_run(deck: Path) -> float:
    """CPU seconds (user + system) of one LIGGGHTS run of ``deck`` in its own folder."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(["liggghts", "-in", deck.name, "-log", "log.liggghts"], cwd=deck.parent,
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"LIGGGHTS failed on {deck}:\n{done.stdout[-2000:]}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--cycles", type=int, default=8, help="measured cycles of each run")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    config = load_config()
    config["fidelity"]["measured_cycles"] = args.cycles
    settings = ShakeSettings.from_config(config)
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        packing = pour(PourSettings.from_config(config), FILL_PCT, 0, scratch / "pour")
        base = scratch / "deck"
        base.mkdir()
        plan = render_shake_deck(settings, CaseSpec(FREQ_HZ, ACCEL_G, FILL_PCT),
                                 [packing] * CELLS, base)
        deck = plan["deck"].read_text()
        variants = {"deck": deck,
                    "deck + fcm() per cell": former_cell_powers(deck, [c["weight_n"] for c in plan["cells"]]),
                    "no bookkeeping": without_bookkeeping(deck)}
        folders = {}
        for index, (name, text) in enumerate(variants.items()):
            folder = scratch / f"variant{index}"
            folder.mkdir()
            (folder / "cell.stl").write_bytes((base / "cell.stl").read_bytes())
            (folder / "shake.lmp").write_text(text)
            folders[name] = folder / "shake.lmp"
        cpu = {name: [] for name in variants}
        for _ in range(args.repeats):
            for name, path in folders.items():
                cpu[name].append(cpu_of_run(path))
    steps = plan["steps_per_cycle"] * plan["cycles"]
    best = {name: min(times) for name, times in cpu.items()}
    scene = (f"{CELLS} cells x {packing.n_spheres} spheres, {FREQ_HZ:g} Hz / {ACCEL_G:g} g / "
             f"{FILL_PCT:g} %, {plan['cycles']} cycles ({steps} steps), motion sampling "
             f"{'on' if plan['motion'] else 'off'}; smallest CPU of {args.repeats} interleaved runs")
    lines = [scene, "", "| variant | CPU s | us per step | x deck |", "|---|---|---|---|"]
    for name, value in best.items():
        lines.append(f"| {name} | {value:.2f} | {1e6 * value / steps:.1f} | {value / best['deck']:.2f} |")
    command = ("python benchmarks/experiments/bench_deck_bookkeeping.py "
               f"--cycles {args.cycles} --repeats {args.repeats}")
    append("Shake deck bookkeeping cost", command, lines)


if __name__ == "__main__":
    main()
