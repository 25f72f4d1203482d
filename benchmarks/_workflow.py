"""A scratch copy of the workflow for benchmarks that run Snakemake on a changed config."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Callable

import yaml

REPO = Path(__file__).resolve().parent.parent


def dem_workflow(work: Path, edit: Callable[[dict], None] | None = None) -> dict:
    """Copy the Snakefile, workflow/ and templates/ into ``work`` and write its config.yaml:
    the repository's, with ``engine: dem`` and ``fidelity.pour_engine: dem``, then changed in
    place by ``edit`` if given; returns that config."""
    for item in ("Snakefile", "workflow", "templates"):
        source = REPO / item
        (shutil.copytree if source.is_dir() else shutil.copy)(source, work / item)
    config = yaml.safe_load((REPO / "config.yaml").read_text())
    config["engine"] = "dem"
    config["fidelity"]["pour_engine"] = "dem"
    if edit is not None:
        edit(config)
    (work / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))
    return config
