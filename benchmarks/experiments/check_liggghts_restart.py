"""Can a LIGGGHTS 3.8 shake run be continued exactly, as the compiled DEM's is (issue 13)?

From a rendered shake deck (a campaign's ``results/work/cases/<case>/shake.lmp`` with its
``cell.stl``), the spheres, the cell mesh, the contact law and the wall's ``move/mesh viblin``
are kept (no bookkeeping fixes) and the spheres' end state (positions, velocities, spins) is
compared between:

- one run of 2 N steps (N = one cycle);
- two ``run`` commands of N steps in one input;
- N steps, ``write_restart``, and a new LIGGGHTS process that ``read_restart``s, defines the
  mesh, walls and wall motion again and runs N steps;
- and one step past a run boundary: ``run N+1`` against ``run N`` + ``run 1``.

Printed: the largest difference of each against the unbroken run, over the largest value.

Run: .venv/bin/python benchmarks/experiments/check_liggghts_restart.py CASE_WORKDIR
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

COLUMNS = "id x y z vx vy vz omegax omegay omegaz"
KEEP_AFTER_RESTART = ("communicate", "hard_particles", "neighbor", "neigh_modify", "pair_style",
                      "pair_coeff", "timestep")


def deck_parts(deck: str) -> tuple[list[str], list[str], list[str], int]:
    """The deck's set-up (to the mesh), its walls/integration/gravity/motion, what a restart
    must be told again, and the steps per cycle."""
    lines = [line for line in deck.splitlines() if line.strip() and not line.startswith("#")]
    mesh = next(i for i, line in enumerate(lines) if "mesh/surface" in line)
    setup = lines[:mesh + 1]
    dynamics = [line for line in lines if re.match(r"fix\s+(walls|integrate|gravity)\s", line)
                or "move/mesh" in line]
    again = ["newton off"] + [line for line in setup if line.split()[0] in KEEP_AFTER_RESTART
                              or "property/global" in line or "mesh/surface" in line]
    steps = int(re.search(r"fix\s+cycle_power\s+all\s+ave/time\s+1\s+(\d+)", deck).group(1))
    return setup, dynamics, again, steps


def dump(name: str) -> str:
    fmt = '"%d' + " %.17g" * 9 + '"'
    return f"write_dump all custom {name} {COLUMNS} modify sort id format {fmt}"


def run(folder: Path, name: str, lines: list[str]) -> np.ndarray | None:
    """Run one input; the dump it writes (``<name>.dump``), or None."""
    (folder / f"{name}.lmp").write_text("\n".join(lines) + "\n")
    with open(folder / f"{name}.screen", "w") as screen:
        subprocess.run(["liggghts", "-in", f"{name}.lmp"], cwd=folder, stdout=screen,
                       stderr=subprocess.STDOUT, check=True)
    path = folder / f"{name}.dump"
    return np.loadtxt(path, skiprows=9) if path.is_file() else None


def differences(mine: np.ndarray, reference: np.ndarray) -> str:
    out = []
    for label, cols in (("x", slice(1, 4)), ("v", slice(4, 7)), ("omega", slice(7, 10))):
        diff = np.abs(mine[:, cols] - reference[:, cols]).max()
        out.append(f"{label} {diff:.2g} ({diff / np.abs(reference[:, cols]).max():.1e} of max)")
    return ", ".join(out) + ("; bit for bit" if np.array_equal(mine, reference) else "")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("workdir", type=Path)
    args = parser.parse_args()
    setup, dynamics, again, n = deck_parts((args.workdir / "shake.lmp").read_text())
    with tempfile.TemporaryDirectory(prefix="liggghts_restart_") as scratch:
        folder = Path(scratch)
        shutil.copy(args.workdir / "cell.stl", folder)
        base = setup + dynamics
        whole = run(folder, "whole", base + [f"run {2 * n}", dump("whole.dump")])
        split = run(folder, "split", base + [f"run {n}", f"run {n}", dump("split.dump")])
        run(folder, "first", base + [f"run {n}", "write_restart half.restart"])
        restarted = run(folder, "restarted", ["read_restart half.restart", *again, *dynamics,
                                              f"run {n}", dump("restarted.dump")])
        step = run(folder, "step", base + [f"run {n + 1}", dump("step.dump")])
        split_step = run(folder, "split_step", base + [f"run {n}", "run 1", dump("split_step.dump")])
        restored = [line.strip() for line in (folder / "restarted.screen").read_text().splitlines()
                    if line.startswith("Resetting")]
    lines = [f"{args.workdir}: {len(whole)} spheres, one cycle N = {n} steps; the spheres' end "
             "state against one unbroken run (largest difference):", "",
             f"- 2 N steps as two `run` commands: {differences(split, whole)}",
             f"- N steps, write_restart, read_restart in a new process, N steps: "
             f"{differences(restarted, whole)}",
             f"- the restarted run against the two `run` commands: {differences(restarted, split)}",
             f"- one step past a run boundary (`run N` + `run 1` against `run N+1`): "
             f"{differences(split_step, step)}",
             f"- read_restart restored: {'; '.join(restored)}"]
    append("LIGGGHTS 3.8: continuing a shake run", f"python benchmarks/experiments/check_liggghts_restart.py {args.workdir}",
           lines)


if __name__ == "__main__":
    main()
