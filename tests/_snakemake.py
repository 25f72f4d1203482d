"""Running the repository's Snakefile from tests: the command, its job table, test configs.

Shared by the workflow tests (``tests/workflow/test_workflow.py``, ``tests/workflow/test_interruption.py``). Every
run uses ``--cores 2`` and its own working directory (``--directory``), so tests never touch the
repository's ``results/``.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parent.parent
SNAKEFILE = REPO / "Snakefile"
TEST_CONFIG = REPO / ".test" / "config.yaml"
SNAKEMAKE = Path(sys.executable).with_name("snakemake")
LIGGGHTS = shutil.which("liggghts")

#: Marks of a module that runs the workflow with LIGGGHTS (use as its ``pytestmark``).
WORKFLOW_MARKS = [
    pytest.mark.engine,
    pytest.mark.slow,
    pytest.mark.skipif(LIGGGHTS is None, reason="LIGGGHTS is not installed (apt-get install -y "
                       "--no-install-recommends liggghts); the workflow runs it for every case"),
    pytest.mark.skipif(not SNAKEMAKE.is_file(),
                       reason=f"snakemake is not installed next to {sys.executable}"),
]


def snakemake_command(workdir: Path, *args: str, cores: int = 2) -> list[str]:
    """The command line that runs the repository's Snakefile in ``workdir``.

    Parameters
    ----------
    workdir : Path
        The run's working directory (it holds ``config.yaml``; outputs go below it).
    *args : str
        Further arguments: targets, flags.
    cores : int, optional
        ``--cores``; at most 2, the machine's share of a test run.

    Returns
    -------
    list of str
    """
    return [str(SNAKEMAKE), "--snakefile", str(SNAKEFILE), "--directory", str(workdir),
            "--cores", str(cores), *args]


def snakemake(workdir: Path, *args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    """Run the repository's Snakefile in ``workdir`` on 2 cores; stdout and stderr together.

    Parameters
    ----------
    workdir : Path
        The run's working directory.
    *args : str
        Further arguments: targets, flags.
    env : dict, optional
        Environment variables added to this process's environment.

    Returns
    -------
    subprocess.CompletedProcess
        With ``returncode`` and the combined output in ``stdout``.
    """
    return subprocess.run(snakemake_command(workdir, *args), cwd=workdir,
                          env={**os.environ, **(env or {})}, text=True,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=900)


def planned_jobs(output: str) -> dict[str, int]:
    """The 'Job stats' table of a (dry) run: rule name -> number of jobs.

    Parameters
    ----------
    output : str
        Snakemake's output.

    Returns
    -------
    dict
        Empty when Snakemake had nothing to do.
    """
    if "Nothing to be done" in output:
        return {}
    table = output.split("Job stats:", 1)[1]
    counts = {}
    for line in table.splitlines()[3:]:
        match = re.fullmatch(r"(\w+)\s+(\d+)", line.strip())
        if match is None:
            break
        counts[match[1]] = int(match[2])
    counts.pop("total", None)
    return counts


def write_config(workdir: Path, **changes) -> dict:
    """The reduced config with top-level sections updated, as workdir/config.yaml.

    Parameters
    ----------
    workdir : Path
        Where ``config.yaml`` is written.
    **changes
        Top-level sections: a dict updates the section of ``.test/config.yaml`` key by key, any
        other value replaces it.

    Returns
    -------
    dict
        The config written (not validated).
    """
    config = yaml.safe_load(TEST_CONFIG.read_text())
    for key, value in changes.items():
        if isinstance(value, dict):
            config.setdefault(key, {}).update(value)
        else:
            config[key] = value
    (workdir / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return config


def copy_campaign(source: Path, target: Path) -> Path:
    """A copy of a campaign folder, Snakemake's metadata and file times included.

    Parameters
    ----------
    source : Path
        A campaign's working directory.
    target : Path
        The copy's path (it must not exist yet).

    Returns
    -------
    Path
        ``target``.
    """
    shutil.copytree(source, target, symlinks=True)
    return target


def sigint_as_from_a_terminal() -> None:
    """``preexec_fn`` of a Snakemake the tests interrupt: SIGINT at its default disposition.

    A shell starts a background job (``cmd &``, as a CI runner or ``nohup ... &`` may) with
    SIGINT ignored, the child inherits that, and Python then installs no KeyboardInterrupt
    handler: Snakemake never sees the signal and the campaign runs to its end. A user's Ctrl-C
    reaches a Snakemake whose SIGINT is at its default, which is what the tests are about."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
