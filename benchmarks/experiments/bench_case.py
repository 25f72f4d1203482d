"""Cost of one case through the pipeline against LIGGGHTS' own run time (issue 2).

For a 500 Hz and a 50 Hz case (5 g, 50 % fill, the default fidelity) it reports the wall time,
the steps per second, and the ratio of the pipeline's wall time (rendering, running, parsing,
summarising: ``pidpipe.liggghts.shake.run_case``) to the wall time of the LIGGGHTS process and to
LIGGGHTS' own loop time. Target: pipeline overhead under 5 % of the LIGGGHTS process.

Run: .venv/bin/python benchmarks/experiments/bench_case.py
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # benchmarks/: the harness
from harness import record_text as append  # noqa: E402

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.settings import PourSettings, ShakeSettings
from pidpipe.liggghts.pour import pour
from pidpipe.liggghts.shake import run_case


def main() -> None:
    config = load_config()
    lines = ["| case | steps | pipeline wall s | LIGGGHTS process s | LIGGGHTS loop s | steps/s (loop) | pipeline / process | pipeline / loop |",
             "|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as scratch:
        packing = pour(PourSettings.from_config(config), 50, 0, Path(scratch) / "pour")
        for freq in (500.0, 50.0):
            case = CaseSpec(freq, 5.0, 50.0)
            start = time.perf_counter()
            record = run_case(ShakeSettings.from_config(config), case, packing, Path(scratch) / case.case_id)
            pipeline = time.perf_counter() - start
            engine = record.engine
            lines.append(
                f"| {case.case_id} | {engine['steps']} | {pipeline:.2f} | {engine['liggghts_wall_time_s']:.2f} | "
                f"{engine['liggghts_loop_time_s']:.2f} | {engine['steps'] / engine['liggghts_loop_time_s']:.3g} | "
                f"{pipeline / engine['liggghts_wall_time_s']:.3f} | {pipeline / engine['liggghts_loop_time_s']:.3f} |")
    lines.append("")
    lines.append("Pipeline = render + run + parse + summarise in one Python process; process = the "
                 "LIGGGHTS subprocess (start-up, mesh reading, run); loop = LIGGGHTS' own 'Loop time'.")
    append("One case: pipeline against LIGGGHTS", "python benchmarks/experiments/bench_case.py", lines)


if __name__ == "__main__":
    main()
