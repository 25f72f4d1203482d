"""Running LIGGGHTS: finding the binary, running a deck in its own folder, reporting failures.

The screen output is kept unbuffered in ``screen.txt`` (LIGGGHTS' error messages go there and
may be missing from its log). Any failure — binary missing, non-zero exit, an ``ERROR`` line,
lost atoms, a signal — raises :class:`~pidpipe.errors.EngineError` naming the case and the
file to read.
"""

from __future__ import annotations

import os
import re
import resource
import shutil
import signal
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from pidpipe.errors import EngineError

INSTALL_HINT = ("install it with: apt-get install -y --no-install-recommends liggghts "
                "(as root, after apt-get update), or set PIDPIPE_LIGGGHTS to the binary's path")
SCREEN_FILE = "screen.txt"
LOG_FILE = "log.liggghts"
_LOOP_TIME = re.compile(r"^Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps", re.MULTILINE)


@dataclass(frozen=True)
class EngineRun:
    """What one LIGGGHTS run cost.

    Attributes
    ----------
    wall_time_s : float
        Wall time of the LIGGGHTS process, s.
    cpu_time_s : float
        CPU time (user + system) of the LIGGGHTS process, s: the cost measure that a shared,
        busy machine disturbs least.
    loop_time_s : float
        Sum of LIGGGHTS' own "Loop time" of every ``run``, s.
    steps : int
        Time steps run.
    screen_path : Path
        The kept screen output.
    version : str
        LIGGGHTS' version, as the run printed it.
    timestep_warnings : tuple of str
        The distinct warnings of ``fix check/timestep/gran`` (timestep too large), if any.
    """

    wall_time_s: float
    cpu_time_s: float
    loop_time_s: float
    steps: int
    screen_path: Path
    version: str
    timestep_warnings: tuple[str, ...] = ()


def find_liggghts() -> str:
    """Path of the LIGGGHTS binary (``$PIDPIPE_LIGGGHTS``, else ``liggghts`` on the PATH)."""
    configured = os.environ.get("PIDPIPE_LIGGGHTS")
    if configured:
        if not (os.path.isfile(configured) and os.access(configured, os.X_OK)):
            raise EngineError(f"PIDPIPE_LIGGGHTS={configured} is not an executable file; {INSTALL_HINT}")
        return configured
    found = shutil.which("liggghts")
    if found is None:
        raise EngineError(f"LIGGGHTS was not found on the PATH; {INSTALL_HINT}")
    return found


_VERSION = re.compile(r"LIGGGHTS \(Version ([^)]*)\)")


def screen_version(screen_text: str) -> str:
    """The version LIGGGHTS prints at the top of its screen output, or "unknown"."""
    match = _VERSION.search(screen_text)
    return match.group(1) if match else "unknown"


#: Variables of a SLURM job step that make Open MPI take a process for one rank of an ``srun``
#: launch and look for SLURM's PMI server; without one (SLURM's default ``MpiDefault=none``)
#: LIGGGHTS aborts in MPI_Init ("OPAL ERROR: Unreachable"). LIGGGHTS runs as one process here,
#: also inside the ``srun`` that runs every job of the SLURM executor plugin.
SLURM_STEP_VARIABLES = ("SLURM_STEP_ID", "SLURM_STEPID")


def liggghts_environment(environ) -> dict[str, str]:
    """The environment LIGGGHTS runs in: ``environ`` without :data:`SLURM_STEP_VARIABLES`."""
    return {key: value for key, value in environ.items() if key not in SLURM_STEP_VARIABLES}


def run_deck(deck_path: str | Path, case_label: str, timeout_s: float | None = None) -> EngineRun:
    """Run a rendered deck with LIGGGHTS in the deck's folder.

    Parameters
    ----------
    deck_path : path
        The deck; it runs in its own folder, where it finds its mesh and writes its output.
    case_label : str
        Names the case in error messages.
    timeout_s : float, optional
        Kill the run after this many seconds.

    Raises
    ------
    EngineError
        On any failure, naming the case and the screen file.
    """
    deck_path = Path(deck_path).resolve()
    folder = deck_path.parent
    screen = folder / SCREEN_FILE
    command = [find_liggghts(), "-in", deck_path.name, "-echo", "screen", "-log", LOG_FILE]
    if shutil.which("stdbuf"):
        command = ["stdbuf", "-o0", "-e0", *command]
    env = {**liggghts_environment(os.environ), "OMPI_ALLOW_RUN_AS_ROOT": "1",
           "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1", "OMPI_MCA_btl_vader_single_copy_mechanism": "none"}
    start = time.perf_counter()
    cpu_before = _children_cpu_s()
    with open(screen, "w", encoding="utf-8") as screen_handle:
        process = subprocess.Popen(command, cwd=folder, stdout=screen_handle,
                                   stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=env)
        try:
            returncode = process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            raise EngineError(f"LIGGGHTS run of case {case_label} exceeded {timeout_s} s and was "
                              f"killed; see {screen}") from None
        except BaseException:
            process.kill()
            process.wait()
            raise
    wall = time.perf_counter() - start
    cpu = _children_cpu_s() - cpu_before
    text = screen.read_text(encoding="utf-8", errors="replace")
    problem = _failure(text, returncode)
    if problem:
        raise EngineError(f"LIGGGHTS failed for case {case_label}: {problem}; see {screen}")
    loops = _LOOP_TIME.findall(text)
    return EngineRun(wall_time_s=wall, cpu_time_s=cpu, loop_time_s=sum(float(t) for t, _, _ in loops),
                     steps=sum(int(n) for _, _, n in loops), screen_path=screen,
                     version=screen_version(text), timestep_warnings=timestep_warnings(text))


_TIMESTEP_WARNING = re.compile(r"^WARNING: time[- ]step.*$", re.MULTILINE)


def timestep_warnings(screen_text: str) -> tuple[str, ...]:
    """The distinct timestep warnings (``fix check/timestep/gran``) of a screen output, in order."""
    return tuple(dict.fromkeys(line.strip() for line in _TIMESTEP_WARNING.findall(screen_text)))


def _children_cpu_s() -> float:
    """User + system CPU time of this process's finished children so far, s."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _failure(screen_text: str, returncode: int) -> str | None:
    """Why a run failed, from its exit code and screen output; None if it did not."""
    error_lines = [line.strip() for line in screen_text.splitlines() if "ERROR" in line]
    if error_lines:
        return error_lines[0]
    if returncode < 0:
        return f"killed by signal {signal.Signals(-returncode).name}"
    if returncode != 0:
        return f"exit code {returncode}"
    if "Loop time of" not in screen_text:
        return "it ended without completing a run"
    return None
