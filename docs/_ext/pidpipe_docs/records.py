"""The benchmark records page, written from ``benchmarks/records/*.json``.

A record is one run of a benchmark script, with the machine and the date it ran on::

    {"benchmark": "bench_campaign",
     "command": "python benchmarks/bench_campaign.py ...",
     "machine": {"host": "...", "cpus": 2, "python": "3.11.2", "platform": "Linux-..."},
     "date": "2026-12-02T06:10:00Z",
     "figures": {"wall_s": 229.0, "ok_cases_at_target": "41 of 43"},
     "notes": "optional text"}

The prose of the explanation pages cites the command; the date and the machine live here.
"""

from __future__ import annotations

import json
from pathlib import Path

#: Keys every record must have.
REQUIRED = ("benchmark", "command", "date", "figures")

NO_RECORD = "No record yet: the benchmark scripts write their records into `benchmarks/records/`."


class RecordError(ValueError):
    """A record file that cannot be rendered (not JSON, or a required key missing)."""


def load_records(folder: Path) -> list[dict]:
    """Every ``*.json`` record under ``folder`` (subfolders included), by benchmark, then date.

    Parameters
    ----------
    folder : Path
        ``benchmarks/records``; a missing folder holds no record.

    Returns
    -------
    list of dict
        Each record with ``_file``, its path under ``folder``, added.

    Raises
    ------
    RecordError
        A file that is not a JSON object with the keys of :data:`REQUIRED`.
    """
    records = []
    folder = Path(folder)
    for path in sorted(folder.rglob("*.json")):
        name = path.relative_to(folder).as_posix()
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            raise RecordError(f"{name}: not a JSON record ({exc})") from None
        if not isinstance(record, dict):
            raise RecordError(f"{name}: a record is a JSON object")
        missing = [key for key in REQUIRED if key not in record]
        if missing:
            raise RecordError(f"{name}: missing {', '.join(missing)}")
        if not isinstance(record["figures"], dict):
            raise RecordError(f"{name}: figures must be an object of name: value")
        records.append({**record, "_file": name})
    return sorted(records, key=lambda r: (str(r["benchmark"]), str(r["date"]), r["_file"]))


def _cell(value) -> str:
    text = value if isinstance(value, str) else json.dumps(value, ensure_ascii=False)
    return text.replace("|", "\\|").replace("\n", " ")


def _machine(machine) -> str:
    if not isinstance(machine, dict):
        return _cell(machine) if machine else "not recorded"
    parts = []
    if "host" in machine:
        parts.append(f"host {machine['host']}")
    if "cpus" in machine:
        parts.append(f"{machine['cpus']} CPUs")
    if "python" in machine:
        parts.append(f"Python {machine['python']}")
    if "platform" in machine:
        parts.append(str(machine["platform"]))
    parts += [f"{k} {v}" for k, v in machine.items() if k not in ("host", "cpus", "python", "platform")]
    return ", ".join(parts) if parts else "not recorded"


def records_to_markdown(records: list[dict]) -> str:
    """The benchmark records page, in MyST Markdown.

    Parameters
    ----------
    records : list of dict
        As :func:`load_records` returns them.

    Returns
    -------
    str
        One section per record: its benchmark and date, the command, the machine, a table of
        its figures and its notes; :data:`NO_RECORD` when there is none.
    """
    lines = [
        "# Benchmark records",
        "",
        "Generated from `benchmarks/records/*.json` at every build of these pages. Each record is",
        "one run of a benchmark script: the command, the machine and the date it ran on, and the",
        "figures it printed. The explanation pages cite the commands; the dates and machines are here.",
        "",
    ]
    if not records:
        return "\n".join(lines + [NO_RECORD, ""])
    for record in records:
        lines += [f"## {_cell(record['benchmark'])}, {_cell(record['date'])}", "",
                  f"Command: `{record['command']}`", "",
                  f"Machine: {_machine(record.get('machine'))}", "",
                  f"Record: `benchmarks/records/{record['_file']}`", ""]
        figures = record["figures"]
        if figures:
            lines += ["| figure | value |", "|---|---|"]
            lines += [f"| {_cell(name)} | {_cell(value)} |" for name, value in figures.items()]
            lines.append("")
        else:
            lines += ["No figures.", ""]
        if record.get("notes"):
            lines += [_cell(record["notes"]), ""]
    return "\n".join(lines)
