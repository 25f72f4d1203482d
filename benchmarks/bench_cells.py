"""k cells in one LIGGGHTS run against k single-cell runs: cost, and what the spread between
cells adds to the standard error (fidelity.cells_per_run, issue 5).

For each frequency (5 g, 50 % fill, the default fidelity) it shakes replicate packings 0..k-1
once together (one run, :mod:`pidpipe.replicate_cells`) and once each alone, and reports:
LIGGGHTS CPU time of the run of k cells against the sum of the k single runs; the mean cell's
C_eq with its cycle-to-cycle standard error and the between-cells one (std / sqrt(k)); and, for
each moved cell, how far its C_eq lies from the same packing shaken alone in units of their
combined standard errors (the cells' trajectories part by chaos: a check that a cell's own
standard error covers run-to-run noise).

Run: .venv/bin/python benchmarks/bench_cells.py [k] [freq_hz ...]   (default 7 cells, 100 500 1000 Hz)
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np
from _record import append

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.liggghts.pour import replicate_packings
from pidpipe.liggghts.shake import run_case

ACCEL_G, FILL_PCT = 5.0, 50.0


def main() -> None:
    cells = int(sys.argv[1]) if len(sys.argv) > 1 else 7
    freqs = [float(f) for f in sys.argv[2:]] or [100.0, 500.0, 1000.0]
    config = load_config()
    lines = [f"| f Hz | CPU s, {cells} cells in one run | CPU s, {cells} single runs | ratio | "
             "C_eq per cell N s/m | cycle SEM | between-cells SEM | between / cycle | "
             "moved cells vs alone: max abs z |",
             "|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as scratch:
        packings, _ = replicate_packings(PourSettings.from_config(config), FILL_PCT, cells, Path(scratch) / "packings")
        for freq in freqs:
            case = CaseSpec(freq, ACCEL_G, FILL_PCT)
            together = run_case(ShakeSettings.from_config(config), case, packings, Path(scratch) / f"together_{freq:g}")
            alone = [run_case(ShakeSettings.from_config(config), case, packing, Path(scratch) / f"alone_{freq:g}_{k}")
                     for k, packing in enumerate(packings)]
            cpu_alone = sum(r["engine"]["liggghts_cpu_time_s"] for r in alone)
            cpu_together = together["engine"]["liggghts_cpu_time_s"]
            z = [(cell["ceq_cell_ns_m"] - single["ceq_cell_ns_m"])
                 / math.hypot(cell["ceq_cell_sem_ns_m"], single["ceq_cell_sem_ns_m"])
                 for cell, single in zip(together["cells"][1:], alone[1:])]
            cycle = together["ceq_cell_cycle_sem_ns_m"]
            between = together["ceq_cell_between_cells_sem_ns_m"]
            lines.append(f"| {freq:g} | {cpu_together:.1f} | {cpu_alone:.1f} | "
                         f"{cpu_together / cpu_alone:.2f} | {together['ceq_cell_ns_m']:.4g} | "
                         f"{cycle:.2g} ({cycle / together['ceq_cell_ns_m']:.1%}) | "
                         f"{between:.2g} ({between / together['ceq_cell_ns_m']:.1%}) | "
                         f"{between / cycle:.2f} | {np.max(np.abs(z)):.2f} |")
            print(lines[-1], flush=True)
    lines += ["", f"{ACCEL_G:g} g, {FILL_PCT:g} % fill, default fidelity; replicate packings "
              f"0..{cells - 1} (seeds fidelity.seed + k). CPU = LIGGGHTS process CPU time. "
              "z = (moved cell - same packing alone) / combined SEM."]
    append(f"{cells} cells in one run against {cells} single runs",
           "python benchmarks/bench_cells.py " + " ".join(sys.argv[1:]), lines)


if __name__ == "__main__":
    main()
