"""What every benchmark shares: a scratch copy of the workflow, child-process CPU, and records.

- :func:`scratch_workflow` copies the Snakefile, ``workflow/`` and ``templates/`` into a folder
  and writes its ``config.yaml``: a given config with ``SECTION.KEY=YAML`` overrides
  (:func:`apply_overrides`), as ``bench_campaign.py --set`` takes them.
- :func:`children_cpu_s` and :func:`measured` give the CPU time of finished child processes
  (``resource.getrusage(RUSAGE_CHILDREN)``: user + system of every child this process waited
  for, and of their own children), the one way the benchmarks measure a subprocess's CPU.
- :func:`record` writes a benchmark's latest result to ``benchmarks/records/<benchmark>.json``
  (atomically: a temporary file in the same folder, then :func:`os.replace`) and appends it as
  one line to ``benchmarks/records/history/<benchmark>.jsonl``. A record reads::

      {"benchmark": "bench_campaign",
       "command": "python benchmarks/bench_campaign.py .test/config.yaml --set engine=dem",
       "machine": {"host": str, "cpus": int, "python": str, "platform": str},
       "date": "2026-12-02T05:10:00Z",
       "figures": {"wall_s": 143.2, "cases": 8, ...},
       "notes": "optional text"}

  ``command`` is the command as typed (the script's path relative to the repository, then
  ``sys.argv[1:]``); each figure's name ends with its unit (``_s``, ``_pct``, ``_ns``...) or
  is a count; its value is a number or a string.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import math
import os
import platform
import resource
import shlex
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Mapping, Sequence

import yaml

REPO = Path(__file__).resolve().parent.parent
"""The repository's root."""

RECORDS = Path(__file__).resolve().parent / "records"
"""Where each benchmark's latest record is written."""

SNAKEMAKE = str(Path(sys.executable).parent / "snakemake")
"""The Snakemake of the interpreter running the benchmark."""

WORKFLOW_ITEMS = ("Snakefile", "workflow", "templates")
"""What a scratch copy of the workflow holds besides its config.yaml."""

DEM_ENGINES = ("engine=dem", "fidelity.pour_engine=dem")
"""Overrides that run a campaign's cases and pours in the compiled DEM."""


# --- the scratch workflow ---------------------------------------------------------------------

def apply_overrides(config: dict, overrides: Sequence[str]) -> dict:
    """Set ``SECTION.KEY=YAML`` overrides in ``config`` (in place; also returned).

    Parameters
    ----------
    config : dict
        A config as loaded from YAML.
    overrides : sequence of str
        ``KEY=YAML`` or ``SECTION.KEY=YAML`` (any depth: ``a.b.c=1``); the value is parsed as
        YAML (``grid.freq_hz=[500,1000]``, ``fidelity.target_relative_sem=null``). Missing
        sections are created.
    """
    for override in overrides:
        path, sep, value = override.partition("=")
        if not sep or not path:
            raise ValueError(f"override {override!r}: expected SECTION.KEY=YAML")
        *sections, key = path.split(".")
        target = config
        for section in sections:
            target = target.setdefault(section, {})
            if not isinstance(target, dict):
                raise ValueError(f"override {override!r}: {section} is not a section")
        target[key] = yaml.safe_load(value)
    return config


def scratch_workflow(work: Path, config: Path | str | Mapping | None = None,
                     overrides: Sequence[str] = (),
                     edit: Callable[[dict], None] | None = None) -> dict:
    """Copy the workflow into ``work`` and write its ``config.yaml``; return that config.

    Parameters
    ----------
    work : Path
        The folder (created if missing) that receives the Snakefile, ``workflow/``,
        ``templates/`` and ``config.yaml``.
    config : path or mapping, optional
        The config to start from: a YAML file, or a mapping (copied); default the repository's
        ``config.yaml``.
    overrides : sequence of str
        ``SECTION.KEY=YAML`` overrides applied next (:func:`apply_overrides`).
    edit : callable, optional
        Called last with the config, to change it in place.
    """
    work = Path(work)
    work.mkdir(parents=True, exist_ok=True)
    for item in WORKFLOW_ITEMS:
        source = REPO / item
        if source.is_dir():
            shutil.copytree(source, work / item)
        else:
            shutil.copy(source, work / item)
    if config is None:
        config = REPO / "config.yaml"
    if isinstance(config, Mapping):
        data = json.loads(json.dumps(config))          # a deep copy of plain data
    else:
        data = yaml.safe_load(Path(config).read_text())
    apply_overrides(data, overrides)
    if edit is not None:
        edit(data)
    (work / "config.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    return data


def export_package(revision: str, folder: Path) -> Path:
    """The package of an older commit (``pidpipe`` and ``workflow/schemas``, exported by ``git
    archive``) in ``folder`` (created), to put first on ``PYTHONPATH``; returns ``folder``."""
    import subprocess

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "archive", revision, "pidpipe", "workflow/schemas"],
                             cwd=REPO, check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return folder


# --- child-process CPU -------------------------------------------------------------------------

def children_cpu_s() -> float:
    """User + system CPU of every finished (waited-for) child process so far, s."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def own_cpu_s() -> float:
    """User + system CPU of this process so far, s."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


@dataclass
class Timing:
    """Wall time and CPU of what ran inside :func:`measured`, s (filled in on exit)."""

    wall_s: float = float("nan")
    children_cpu_s: float = float("nan")
    own_cpu_s: float = float("nan")

    @property
    def cpu_s(self) -> float:
        """This process's CPU and its finished children's, s."""
        return self.children_cpu_s + self.own_cpu_s


@contextlib.contextmanager
def measured() -> Iterator[Timing]:
    """Time a block: wall, this process's CPU and its children's (those waited for inside)."""
    timing = Timing()
    wall, own, children = time.perf_counter(), own_cpu_s(), children_cpu_s()
    try:
        yield timing
    finally:
        timing.wall_s = time.perf_counter() - wall
        timing.own_cpu_s = own_cpu_s() - own
        timing.children_cpu_s = children_cpu_s() - children


def load_average() -> str:
    """The 1, 5 and 15 minute load averages, e.g. ``"1.52 1.10 0.95"``."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


# --- records -----------------------------------------------------------------------------------

def machine() -> dict:
    """The machine a record was measured on: host, CPU count, Python and platform."""
    return {"host": platform.node(), "cpus": os.cpu_count() or 0,
            "python": platform.python_version(), "platform": platform.platform()}


def machine_line() -> str:
    """The machine in one line, CPU model included (the cost models store it so)."""
    cpu = platform.processor() or "unknown CPU"
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    return f"{platform.node()}, {cpu}, {os.cpu_count()} cores, Python {platform.python_version()}"


def command_line(argv: Sequence[str] | None = None) -> str:
    """The command as typed: ``python <script relative to the repository> <arguments>``, an
    absolute path among the arguments shown relative to the repository, or as ``DIR`` when it
    lies outside (a record names no folder of the machine it ran on)."""
    argv = list(sys.argv if argv is None else argv)
    script = Path(argv[0]).resolve() if argv else Path("?")
    try:
        shown = script.relative_to(REPO).as_posix()
    except ValueError:
        shown = argv[0] if argv else "?"
    return shlex.join(["python", shown, *(_portable(arg) for arg in argv[1:])])


def _portable(argument: str) -> str:
    """An argument without the machine's folders (``--opt=/abs`` too)."""
    option, equals, value = argument.partition("=") if argument.startswith("--") else ("", "", argument)
    if not value.startswith("/"):
        return argument
    try:
        value = Path(value).resolve().relative_to(REPO).as_posix()
    except ValueError:
        value = "DIR"
    return f"{option}{equals}{value}"


def _figure(name: str, value):
    """A figure as JSON holds it: int, float or str (NumPy scalars converted; NaN and inf as
    strings, which JSON lacks; True and False as "yes" and "no")."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        value = value.item()                           # NumPy scalar
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, str):
        return value
    raise TypeError(f"figure {name!r}: {value!r} is not a number or a string")


def _write_atomically(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and os.replace."""
    handle = tempfile.NamedTemporaryFile("w", encoding="utf-8", dir=path.parent,
                                         prefix=f".{path.name}.", suffix=".tmp", delete=False)
    try:
        with handle:
            handle.write(text)
        os.replace(handle.name, path)
    except BaseException:
        Path(handle.name).unlink(missing_ok=True)
        raise


def record(benchmark: str, figures: Mapping[str, object], notes: str = "",
           command: str | None = None, directory: Path | None = None) -> Path:
    """Write ``benchmark``'s latest record, append it to its history, print the figures.

    Parameters
    ----------
    benchmark : str
        The record's name: the script's stem, or the stem and its mode
        (``bench_cells_cost_dem``); the file is ``<directory>/<benchmark>.json``.
    figures : mapping of str to number or str
        The measured figures, each name ending with its unit.
    notes : str
        Optional text: the conditions (load average, what was run).
    command : str, optional
        The command that printed the figures; default the command as typed
        (:func:`command_line`).
    directory : Path, optional
        Default :data:`RECORDS`.

    Returns
    -------
    Path
        The record's file.
    """
    directory = RECORDS if directory is None else Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    data = {"benchmark": benchmark,
            "command": command_line() if command is None else command,
            "machine": machine(),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "figures": {str(name): _figure(str(name), value) for name, value in figures.items()}}
    if notes:
        data["notes"] = notes
    path = directory / f"{benchmark}.json"
    _write_atomically(path, json.dumps(data, indent=2, ensure_ascii=False) + "\n")
    history = directory / "history"
    history.mkdir(exist_ok=True)
    with open(history / f"{benchmark}.jsonl", "a", encoding="utf-8") as handle:
        handle.write(json.dumps(data, ensure_ascii=False) + "\n")
    print(f"\n{data['command']}")
    for name, value in data["figures"].items():
        print(f"  {name}: {value}")
    print(f"recorded in {path.relative_to(REPO) if path.is_relative_to(REPO) else path}")
    return path


def record_text(title: str, command: str, lines: Sequence[str]) -> Path:
    """Print a Markdown section and record it as the notes of a record without figures: the
    experiments' way (``benchmarks/experiments/``; a maintained benchmark records figures).

    Parameters
    ----------
    title : str
        The section's heading.
    command : str
        The command that printed it, as the experiment spells it.
    lines : sequence of str
        The section's Markdown lines (tables, notes).
    """
    text = "\n".join([f"## {title}", "", *lines])
    print(text)
    return record(Path(sys.argv[0]).stem, {}, notes=text, command=command)
