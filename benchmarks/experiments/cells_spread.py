"""How much the spread between a case's cells adds to its standard error, over a finished campaign.

Reads the case records of a campaign run with ``fidelity.cells_per_run`` > 1 (default:
results/cases, as ``snakemake --cores 2`` leaves them) and reports, over the ok cases, how often
and by how much the between-cells standard error exceeds the cycle-to-cycle one, by frequency;
the reported relative SEM against the cycle part alone; and the worst mismatch between the
cells' ledgers and the mesh's.

Run: .venv/bin/python benchmarks/experiments/cells_spread.py [results/cases]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402


def main() -> None:
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "results/cases")
    records = [json.loads(path.read_text()) for path in sorted(folder.glob("*.json"))]
    ok = [r for r in records if r["status"] == "ok"]
    if not ok or ok[0]["fidelity"].get("cells_per_run", 1) < 2:
        sys.exit(f"{folder}: no ok case of several cells per run; nothing recorded")
    ratio = np.array([r["ceq_cell_between_cells_sem_ns_m"] / r["ceq_cell_cycle_sem_ns_m"] for r in ok])
    reported = np.array([r["ceq_cell_sem_ns_m"] / r["ceq_cell_ns_m"] for r in ok])
    cycle = np.array([r["ceq_cell_cycle_sem_ns_m"] / r["ceq_cell_ns_m"] for r in ok])
    freqs = np.array([r["freq_hz"] for r in ok])
    cells = sorted({r["fidelity"]["cells_per_run"] for r in records})
    lines = [f"{len(records)} cases ({len(ok)} ok), cells per run {cells}.", "",
             "| over the ok cases | value |", "|---|---|",
             f"| between-cells SEM > cycle SEM | {(ratio > 1).sum()} of {len(ok)} |",
             f"| between / cycle, median (quartiles) | {np.median(ratio):.2f} "
             f"({np.percentile(ratio, 25):.2f}, {np.percentile(ratio, 75):.2f}) |",
             *(f"| between / cycle, median at {f:g} Hz | {np.median(ratio[freqs == f]):.2f} |"
               for f in sorted(set(freqs))),
             f"| reported relative SEM, median (largest) | {np.median(reported):.3f} ({reported.max():.3f}) |",
             f"| cycle part alone, median | {np.median(cycle):.3f} |",
             f"| worst cell-ledger mismatch / work exchanged | "
             f"{max(r['ledger_mismatch_of_gross_work'] for r in records if r['status'] != 'failed'):.2g} |"]
    append("Spread between cells over a campaign", f"python benchmarks/experiments/cells_spread.py {folder}", lines)


if __name__ == "__main__":
    main()
