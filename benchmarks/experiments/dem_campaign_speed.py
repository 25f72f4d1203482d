"""How much of a DEM campaign's wall is the machine's speed? (issue 28)

The machine is shared and its speed drifts: the same 100 grid pilots of the default DEM
campaign (the same spheres, cells and cycles in every run since the pilots' length was set)
took from under 100 to about 200 engine CPU-s in runs of ``benchmarks/bench_campaign.py
config.yaml --set engine=dem --set fidelity.pour_engine=dem``. Their engine CPU is the
machine's clock for the work that never changes, so each run's wall over it (measured in the
same run) compares runs made on the machine at different speeds.

Reads ``benchmarks/records/history/bench_campaign.jsonl`` (every such run with a wall and the
pilots' engine CPU, the cases' far pilots short (``f50Hz_measured_cycles`` 9-12): the pilots'
work of the current default) and prints, per run: date, wall, the pilots' engine CPU, the
loop's runs and engine CPU, the CPU of every process, and wall / pilots' engine CPU. Records
the table (``harness.record_text``).

Run: .venv/bin/python benchmarks/experiments/dem_campaign_speed.py [--since DATE]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from harness import RECORDS, record_text  # noqa: E402

COMMAND = "python benchmarks/bench_campaign.py config.yaml --set engine=dem --set fidelity.pour_engine=dem --workdir DIR"


def runs(since: str) -> list[dict]:
    """The DEM default campaign's records with the current pilots, oldest first."""
    out = []
    with open(RECORDS / "history" / "bench_campaign.jsonl", encoding="utf-8") as stream:
        for line in stream:
            data = json.loads(line)
            figures = data["figures"]
            if (data["command"] != COMMAND or data["date"] < since
                    or figures.get("f50Hz_measured_cycles") != "9-12"
                    or not isinstance(figures.get("wall_s"), (int, float))):
                continue
            out.append({"date": data["date"], **figures})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--since", default="", help="only runs on or after this UTC date (ISO)")
    args = parser.parse_args()
    lines = ["| date (UTC) | wall s | pilots' engine CPU s | loop runs | loop engine CPU s | "
             "CPU of every process s | wall / pilots' engine CPU |", "|---|---|---|---|---|---|---|"]
    for run in runs(args.since):
        lines.append(f"| {run['date'][:16]} | {run['wall_s']:.1f} | {run['engine_cpu_s']:.1f} | "
                     f"{run.get('refine_runs', '-')} | {run.get('refine_engine_cpu_s', '-')} | "
                     f"{run['cpu_all_processes_s']:.1f} | {run['wall_s'] / run['engine_cpu_s']:.2f} |")
    lines += ["", f"Runs of `{COMMAND}` in `benchmarks/records/history/bench_campaign.jsonl` whose "
              "far pilots are short (the current default)."]
    record_text("A DEM campaign's wall against its pilots' engine CPU",
                "python benchmarks/experiments/dem_campaign_speed.py"
                + (f" --since {args.since}" if args.since else ""), lines)


if __name__ == "__main__":
    main()
