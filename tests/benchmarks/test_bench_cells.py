"""benchmarks/bench_cells.py builds its line and figures from the case runner's CaseRecords."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from pidpipe.cases import CaseSpec
from pidpipe.measurement.case_record import CaseRecord

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import bench_cells  # noqa: E402


def run(ceq, sem, cpu, cells=None, cycle_sem=None, between_sem=None):
    """A record as run_case returns it (the attributes bench_cells reads)."""
    case = CaseSpec(500.0, 5.0, 50.0)
    return CaseRecord.of_run("liggghts", case, 11, [], ceq_cell_ns_m=ceq, ceq_cell_sem_ns_m=sem,
                             cells=cells, ceq_cell_cycle_sem_ns_m=cycle_sem,
                             ceq_cell_between_cells_sem_ns_m=between_sem,
                             engine={"name": "liggghts", "liggghts_cpu_time_s": cpu})


def test_the_comparison_reads_the_records_attributes():
    cells = [{"ceq_cell_ns_m": 10.0, "ceq_cell_sem_ns_m": 0.3},
             {"ceq_cell_ns_m": 12.0, "ceq_cell_sem_ns_m": 0.3}]
    together = run(11.0, 1.0, 4.0, cells=cells, cycle_sem=0.2, between_sem=1.0)
    alone = [run(10.0, 0.4, 3.0), run(11.2, 0.4, 3.5)]
    line, figures = bench_cells.compare_cells(500.0, together, alone)
    z = (12.0 - 11.2) / math.hypot(0.3, 0.4)                 # the moved cell against itself alone
    assert figures == {"f500Hz_cpu_together_s": 4.0, "f500Hz_cpu_alone_s": 6.5,
                       "f500Hz_cpu_ratio": round(4.0 / 6.5, 3), "f500Hz_ceq_cell_ns_m": 11.0,
                       "f500Hz_cycle_sem_pct": round(100 * 0.2 / 11.0, 2),
                       "f500Hz_between_cells_sem_pct": round(100 * 1.0 / 11.0, 2),
                       "f500Hz_max_abs_z": round(z, 2)}
    assert line.startswith("| 500 | 4.0 | 6.5 | 0.62 | 11 |")
    assert line.endswith(f"| 5.00 | {z:.2f} |")
    assert pytest.approx(z) == 1.6
