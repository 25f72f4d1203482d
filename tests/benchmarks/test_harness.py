"""The benchmarks' harness (benchmarks/harness.py) and the maintained scripts' command lines."""

from __future__ import annotations

import datetime
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "benchmarks"))
import harness  # noqa: E402

MAINTAINED = sorted(path for path in (REPO / "benchmarks").glob("*.py") if path.name != "harness.py")
"""Every script left in benchmarks/ (the experiments are in benchmarks/experiments/)."""

SPIN = "import time\nstart = time.process_time()\nwhile time.process_time() - start < 0.3:\n    pass\n"
"""A child that spins for 0.3 s of its own CPU."""


def test_scratch_workflow_holds_the_workflow_and_the_overridden_config(tmp_path):
    config = harness.scratch_workflow(
        tmp_path / "work", REPO / ".test" / "config.yaml",
        ["engine=dem", "fidelity.pour_engine=dem", "grid.freq_hz=[500, 750]",
         "fidelity.target_relative_sem=null", "new_section.key=3"])
    work = tmp_path / "work"
    assert (work / "Snakefile").read_text() == (REPO / "Snakefile").read_text()
    rules = sorted(p.name for p in (REPO / "workflow" / "rules").glob("*.smk"))
    assert rules and sorted(p.name for p in (work / "workflow" / "rules").glob("*.smk")) == rules
    templates = sorted(p.name for p in (REPO / "templates").iterdir())
    assert sorted(p.name for p in (work / "templates").iterdir()) == templates
    written = yaml.safe_load((work / "config.yaml").read_text())
    assert written == config
    original = yaml.safe_load((REPO / ".test" / "config.yaml").read_text())
    assert written["engine"] == "dem"
    assert written["fidelity"]["pour_engine"] == "dem"
    assert written["fidelity"]["target_relative_sem"] is None
    assert written["grid"]["freq_hz"] == [500, 750]
    assert written["grid"]["accel_g"] == original["grid"]["accel_g"]       # untouched
    assert written["new_section"] == {"key": 3}
    assert written["materials"] == original["materials"]


def test_scratch_workflow_edit_runs_after_the_overrides(tmp_path):
    seen = []
    config = harness.scratch_workflow(tmp_path, {"grid": {"freq_hz": [1]}}, ["grid.freq_hz=[2]"],
                                      edit=lambda c: seen.append(list(c["grid"]["freq_hz"])))
    assert seen == [[2]] and config["grid"]["freq_hz"] == [2]


def test_an_override_without_a_value_is_refused():
    with pytest.raises(ValueError, match="SECTION.KEY=YAML"):
        harness.apply_overrides({}, ["engine"])


def test_the_cpu_measurement_sees_a_child_s_cpu():
    with harness.measured() as timing:
        subprocess.run([sys.executable, "-c", SPIN], check=True)
    assert timing.children_cpu_s >= 0.3
    assert timing.wall_s >= timing.children_cpu_s / (os.cpu_count() or 1)
    assert timing.own_cpu_s < timing.children_cpu_s     # the spin was the child's, not ours


def test_children_cpu_grows_by_the_child_s_cpu():
    before = harness.children_cpu_s()
    subprocess.run([sys.executable, "-c", SPIN], check=True)
    assert harness.children_cpu_s() - before >= 0.3


def test_the_record_has_the_documented_format(tmp_path, monkeypatch):
    monkeypatch.setattr(sys, "argv", [str(REPO / "benchmarks" / "bench_campaign.py"),
                                      ".test/config.yaml", "--set", "engine=dem"])
    import numpy as np

    path = harness.record("bench_campaign", {"wall_s": 12.5, "cases": np.int64(8),
                                             "ratio": np.float64(1.25), "engine": "dem",
                                             "missing_s": float("nan"), "reached": True},
                          notes="a toy run", directory=tmp_path)
    assert path == tmp_path / "bench_campaign.json"
    data = json.loads(path.read_text())
    assert list(data) == ["benchmark", "command", "machine", "date", "figures", "notes"]
    assert data["benchmark"] == "bench_campaign"
    assert data["command"] == "python benchmarks/bench_campaign.py .test/config.yaml --set engine=dem"
    assert set(data["machine"]) == {"host", "cpus", "python", "platform"}
    assert isinstance(data["machine"]["cpus"], int) and data["machine"]["cpus"] >= 1
    assert all(isinstance(data["machine"][key], str) for key in ("host", "python", "platform"))
    assert data["date"].endswith("Z")
    when = datetime.datetime.strptime(data["date"], "%Y-%m-%dT%H:%M:%SZ")
    assert abs((datetime.datetime.utcnow() - when).total_seconds()) < 600
    assert data["figures"] == {"wall_s": 12.5, "cases": 8, "ratio": 1.25, "engine": "dem",
                               "missing_s": "nan", "reached": "yes"}
    assert data["notes"] == "a toy run"
    history = (tmp_path / "history" / "bench_campaign.jsonl").read_text().splitlines()
    assert [json.loads(line) for line in history] == [data]


def test_a_record_without_notes_has_no_notes_key(tmp_path):
    data = json.loads(harness.record("x", {"a_s": 1}, command="python benchmarks/x.py",
                                     directory=tmp_path).read_text())
    assert "notes" not in data and data["command"] == "python benchmarks/x.py"


def test_a_figure_that_is_neither_number_nor_string_is_refused(tmp_path):
    with pytest.raises(TypeError, match="not a number or a string"):
        harness.record("x", {"table": [1, 2]}, command="c", directory=tmp_path)
    assert not (tmp_path / "x.json").exists()


def test_the_record_is_written_atomically(tmp_path, monkeypatch):
    """A write that fails before the rename leaves the previous record whole and no temporary."""
    first = harness.record("x", {"a_s": 1}, command="c", directory=tmp_path)
    before = first.read_text()
    replaced = []

    def failing_replace(source, target):
        replaced.append((Path(source), Path(target)))
        assert Path(source).parent == Path(target).parent == tmp_path   # same file system
        assert json.loads(Path(source).read_text())["figures"] == {"a_s": 2}  # written in full
        raise OSError("disk gone")

    monkeypatch.setattr(harness.os, "replace", failing_replace)
    with pytest.raises(OSError, match="disk gone"):
        harness.record("x", {"a_s": 2}, command="c", directory=tmp_path)
    assert replaced and replaced[0][1] == first
    assert first.read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["history", "x.json"]


def test_the_command_is_relative_to_the_repository():
    assert harness.command_line([str(REPO / "benchmarks" / "bench_dem.py"), "--cycles", "2",
                                 "--note", "two words"]) == \
        "python benchmarks/bench_dem.py --cycles 2 --note 'two words'"


def test_the_command_names_no_folder_of_the_machine():
    assert harness.command_line([str(REPO / "benchmarks" / "bench_campaign.py"), "config.yaml",
                                 "--workdir", "/scratch/runs/u1", "--out=/tmp/x.csv",
                                 str(REPO / "config.yaml")]) == \
        "python benchmarks/bench_campaign.py config.yaml --workdir DIR --out=DIR config.yaml"


@pytest.mark.parametrize("script", MAINTAINED, ids=lambda p: p.name)
def test_every_maintained_script_answers_help(script):
    done = subprocess.run([sys.executable, str(script), "--help"], capture_output=True, text=True,
                          cwd=REPO, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("usage:"), done.stdout[:500]
    docstring = script.read_text().split('"""')[1]
    assert f"benchmarks/{script.name}" in docstring, f"{script.name}: its docstring names no command"


EXPERIMENTS = sorted((REPO / "benchmarks" / "experiments").glob("*.py"))


@pytest.mark.parametrize("script", EXPERIMENTS, ids=lambda p: p.name)
def test_every_experiment_still_imports(script):
    """The experiments are not maintained, but moving them must not break their imports."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"experiment_{script.stem}", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert callable(getattr(module, "main", None))
    assert script.name in (REPO / "benchmarks" / "experiments" / "README.md").read_text()


def test_record_text_records_the_markdown_as_notes(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(harness, "RECORDS", tmp_path)
    monkeypatch.setattr(sys, "argv", ["benchmarks/experiments/bench_case.py"])
    path = harness.record_text("One case", "python benchmarks/experiments/bench_case.py",
                               ["| a | b |", "|---|---|", "| 1 | 2 |"])
    data = json.loads(path.read_text())
    assert path == tmp_path / "bench_case.json"
    assert data["figures"] == {} and data["notes"] == "## One case\n\n| a | b |\n|---|---|\n| 1 | 2 |"
    assert "| 1 | 2 |" in capsys.readouterr().out
