"""Append benchmark figures, with the machine and the date, to benchmarks/results.md."""

from __future__ import annotations

import datetime
import os
import platform
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results.md"


def machine() -> str:
    """One line naming the machine: host, CPU model, cores, Python."""
    cpu = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{platform.node()}, {cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def append(title: str, command: str, lines: list[str]) -> None:
    """Append one dated section to the results file and print it."""
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    text = "\n".join([f"\n## {title} ({stamp})", f"Machine: {machine()}", f"Command: `{command}`", "",
                      *lines, ""])
    print(text)
    with open(RESULTS, "a", encoding="utf-8") as handle:
        handle.write(text)
