"""profiles/slurm: what it keeps of profiles/default and what it asks SLURM for (no SLURM needed).

``snakemake --workflow-profile profiles/slurm`` reads that profile *instead of*
profiles/default (Snakemake reads one workflow profile), so every setting of profiles/default
must be repeated in it.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from pidpipe.cases import CaseSpec
from pidpipe.config import load_config
from pidpipe.config.settings import ShakeSettings
from pidpipe.steps import resources as cluster_resources
from pidpipe.steps.params import workflow_config
from tests._snakemake import SNAKEFILE, SNAKEMAKE, TEST_CONFIG

PROFILES = Path(__file__).resolve().parents[2] / "profiles"


def _profile(name: str) -> dict:
    return yaml.safe_load((PROFILES / name / "config.yaml").read_text())


def test_the_slurm_profile_keeps_every_setting_of_the_default_profile():
    default, slurm = _profile("default"), _profile("slurm")
    assert default, "profiles/default has no settings"
    assert {key: slurm.get(key) for key in default} == default


def test_the_slurm_profile_needs_no_accounting_database():
    slurm = _profile("slurm")
    assert slurm["executor"] == "slurm"
    assert slurm["slurm-status-command"] == "squeue"
    text = (PROFILES / "slurm" / "config.yaml").read_text()
    assert not re.search(r"^\s*slurm_account\s*:", text, re.MULTILINE)
    assert not slurm.get("slurm-efficiency-report")
    assert slurm["retries"] == 1


@pytest.mark.skipif(not SNAKEMAKE.is_file(), reason=f"no snakemake next to {SNAKEMAKE.parent}")
def test_every_case_job_asks_for_its_planned_runtime_and_measured_memory(tmp_path):
    shutil.copy(TEST_CONFIG, tmp_path / "config.yaml")
    run = subprocess.run([str(SNAKEMAKE), "--snakefile", str(SNAKEFILE), "--directory",
                          str(tmp_path), "--workflow-profile", str(PROFILES / "slurm"), "-n",
                          "cases"], cwd=tmp_path, text=True, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, timeout=300)
    assert run.returncode == 0, run.stdout[-4000:]
    config = workflow_config(load_config(TEST_CONFIG))
    jobs = re.findall(r"rule simulate_case:\n(?:\s+\w+: .*\n)*?\s+output: results/cases/(\S+)\.json\n"
                      r"(?:\s+\w+: .*\n)*?\s+resources: (.*)\n", run.stdout)
    assert len(jobs) == 8, run.stdout[-4000:]
    for case_id, resources in jobs:
        values = dict(item.split("=", 1) for item in resources.split(", "))
        expected = cluster_resources.case_runtime_min(ShakeSettings.from_config(config),
                                                      CaseSpec.from_id(case_id))
        assert int(values["runtime"]) == expected, (case_id, resources)
        assert int(values["mem_mb"]) == 1000
