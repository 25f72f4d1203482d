"""The documentation: it builds with warnings as errors, and its generated pages say what they must.

The full build (`python -m sphinx -W --keep-going -b html docs OUT`) imports every module for
autodoc, so a broken docstring, a dead cross-reference or a module that no longer imports fails
here, as it would fail the published docs. Sphinx, myst-parser and numpydoc come with the
`docs` extra; without them the build test fails in CI (CI=true) and is skipped elsewhere with
the reason printed.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "docs" / "_ext"))

from pidpipe_docs import records, schema_reference  # noqa: E402

MISSING = [name for name in ("sphinx", "myst_parser", "numpydoc") if importlib.util.find_spec(name) is None]


@pytest.fixture
def _sphinx():
    if MISSING:
        message = (f"{', '.join(MISSING)} not installed: pip install -e '.[docs]' "
                   "(sphinx, myst-parser, numpydoc)")
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)


@pytest.mark.slow
def test_docs_build_without_warnings(_sphinx, tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    run = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", "-q",
         "-d", str(tmp_path / "doctrees"), str(REPO / "docs"), str(tmp_path / "html")],
        cwd=REPO, env=env, capture_output=True, text=True)
    assert run.returncode == 0, f"sphinx failed ({run.returncode}):\n{run.stdout}\n{run.stderr}"
    html = tmp_path / "html"
    config_page = (html / "reference" / "generated" / "config.html").read_text(encoding="utf-8")
    assert "fidelity.target_relative_sem" in config_page
    assert "pidpipe check-config" in (html / "reference" / "generated" / "cli.html").read_text(encoding="utf-8")
    api = (html / "reference" / "generated" / "api-pidpipe-physics.html").read_text(encoding="utf-8")
    assert "equivalent_viscous_damping" in api or "pidpipe.physics.equivalent_damping" in api


SMALL_SCHEMA = {
    "type": "object",
    "required": ["grid"],
    "$defs": {"length": {"type": "number", "exclusiveMinimum": 0, "maximum": 1.0}},
    "properties": {
        "grid": {
            "type": "object", "description": "The campaign.",
            "required": ["freq_hz"],
            "properties": {
                "freq_hz": {"type": "array", "description": "Frequencies, Hz.", "minItems": 1,
                            "uniqueItems": True,
                            "items": {"type": "number", "exclusiveMinimum": 0, "maximum": 1e5}},
                "replicates": {"type": "integer", "description": "Packings per fill.",
                               "minimum": 1, "maximum": 100, "default": 1},
            },
        },
        "radius_m": {"$ref": "#/$defs/length", "description": "Sphere radius, m.", "default": 0.00125},
        "engine": {"type": "string", "enum": ["liggghts", "dem"], "default": "liggghts",
                   "description": "The solver."},
        "materials": {"type": "object", "description": "Materials by name.",
                      "additionalProperties": {"type": "object", "properties": {
                          "density_kg_m3": {"type": "number", "minimum": 1}}}},
        "pairs": {"type": "array", "description": "Contact pairs.", "items": {
            "type": "object", "properties": {"friction": {"type": "number", "minimum": 0,
                                                          "description": "Friction mu."}}}},
        "target": {"type": ["number", "null"], "description": "Target SEM; null: the pilot.",
                   "exclusiveMinimum": 0, "maximum": 1, "default": None},
    },
}


def _section(markdown: str, path: str) -> str:
    """The text of the key's section, up to the next label."""
    start = markdown.index(f"`{path}`\n")
    end = markdown.find("\n(config-", start)
    return markdown[start:] if end < 0 else markdown[start:end]


def test_schema_reference_has_every_key_with_its_bounds_and_default():
    markdown = schema_reference.schema_to_markdown(SMALL_SCHEMA)
    paths = [key.path for key in schema_reference.schema_keys(SMALL_SCHEMA)]
    assert paths == ["grid", "grid.freq_hz", "grid.replicates", "radius_m", "engine", "materials",
                     "materials.<name>.density_kg_m3", "pairs", "pairs[].friction", "target"]
    for path in paths:
        assert f"`{path}`" in markdown, path
    assert "type: array of number" in _section(markdown, "grid.freq_hz")
    assert "at least 1 items" in _section(markdown, "grid.freq_hz")
    assert "each item > 0" in _section(markdown, "grid.freq_hz")
    assert "each item <= 100000.0" in _section(markdown, "grid.freq_hz")
    assert "required" in _section(markdown, "grid.freq_hz")
    replicates = _section(markdown, "grid.replicates")
    assert "Packings per fill." in replicates and ">= 1; <= 100" in replicates and "default: `1`" in replicates
    radius = _section(markdown, "radius_m")        # the $ref's bounds, the node's own description
    assert "Sphere radius, m." in radius and "> 0; <= 1.0" in radius and "default: `0.00125`" in radius
    assert 'one of `"liggghts"`, `"dem"`' in _section(markdown, "engine")
    target = _section(markdown, "target")
    assert "type: number or null" in target and "default: `null`" in target
    assert "(no description in the schema)" in _section(markdown, "materials.<name>.density_kg_m3")
    assert schema_reference.undescribed(SMALL_SCHEMA) == ["materials.<name>.density_kg_m3"]


def test_schema_reference_shows_what_a_config_sets_beside_the_default():
    config = {"grid": {"freq_hz": [50, 100], "replicates": 1}, "engine": "dem",
              "pairs": [{"friction": 0.5}]}
    markdown = schema_reference.schema_to_markdown(SMALL_SCHEMA, config=config)
    assert "`config.yaml` sets: `[50, 100]`" in _section(markdown, "grid.freq_hz")   # no default
    assert "`config.yaml` sets: `\"dem\"`" in _section(markdown, "engine")
    assert "sets" not in _section(markdown, "grid.replicates")                      # the default
    assert "sets" not in _section(markdown, "pairs[].friction")                     # inside a list
    assert "sets" not in _section(markdown, "grid")                                 # an object


def test_schema_reference_headings_never_skip_a_level():
    """MyST warns (and -W fails) when a heading skips a level: nested keys sit one level down."""
    markdown = schema_reference.schema_to_markdown(SMALL_SCHEMA)
    levels = [len(m.group(1)) for m in re.finditer(r"^(#+) ", markdown, flags=re.MULTILINE)]
    assert all(b - a <= 1 for a, b in zip(levels, levels[1:])), levels


def test_the_real_schema_has_a_description_for_every_key():
    import yaml

    schema = yaml.safe_load((REPO / "workflow" / "schemas" / "config.schema.yaml").read_text())
    keys = list(schema_reference.schema_keys(schema))
    assert len(keys) > 50
    assert schema_reference.undescribed(schema) == []


def _write_record(folder: Path, name: str, **fields) -> None:
    record = {"benchmark": "bench_campaign",
              "command": "python benchmarks/bench_campaign.py config.yaml --workdir DIR",
              "machine": {"host": "node1", "cpus": 2, "python": "3.11.2", "platform": "Linux-x86_64"},
              "date": "2026-12-02T06:10:00Z", "figures": {"wall_s": 229.0, "ok_at_target": "41 of 43"}}
    record.update(fields)
    (folder / name).write_text(json.dumps(record), encoding="utf-8")


def test_records_page_says_no_record_yet_without_records(tmp_path):
    assert records.load_records(tmp_path / "absent") == []
    assert records.NO_RECORD in records.records_to_markdown([])


def test_records_page_has_a_section_and_a_table_per_record(tmp_path):
    _write_record(tmp_path, "b.json", date="2026-12-02T07:00:00Z", notes="idle machine")
    _write_record(tmp_path, "a.json", benchmark="bench_dem", figures={"speedup_one_cell": 16.6})
    found = records.load_records(tmp_path)
    assert [r["benchmark"] for r in found] == ["bench_campaign", "bench_dem"]
    markdown = records.records_to_markdown(found)
    assert "## bench_campaign, 2026-12-02T07:00:00Z" in markdown
    assert "## bench_dem, 2026-12-02T06:10:00Z" in markdown
    assert "| wall_s | 229.0 |" in markdown and "| ok_at_target | 41 of 43 |" in markdown
    assert "| speedup_one_cell | 16.6 |" in markdown
    assert "Command: `python benchmarks/bench_campaign.py config.yaml --workdir DIR`" in markdown
    assert "host node1, 2 CPUs, Python 3.11.2, Linux-x86_64" in markdown
    assert "idle machine" in markdown


def test_records_in_subfolders_are_found(tmp_path):
    (tmp_path / "bench_dem").mkdir()
    _write_record(tmp_path / "bench_dem", "run1.json", benchmark="bench_dem")
    found = records.load_records(tmp_path)
    assert [r["_file"] for r in found] == ["bench_dem/run1.json"]
    assert "Record: `benchmarks/records/bench_dem/run1.json`" in records.records_to_markdown(found)


def test_records_refuse_a_record_without_its_command(tmp_path):
    (tmp_path / "bad.json").write_text(json.dumps({"benchmark": "x", "date": "d", "figures": {}}))
    with pytest.raises(records.RecordError, match="bad.json: missing command"):
        records.load_records(tmp_path)
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(records.RecordError, match="not a JSON record"):
        records.load_records(tmp_path)


def test_readme_is_short_and_names_no_machine_path():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    assert not re.search(r"(?<![\w.])/(work|tmp|home|root)/", text), "an absolute machine path in README.md"
    assert "bash install.sh && .venv/bin/python -m pytest" in text       # .ci/run runs exactly this
    assert "bash install.sh && .venv/bin/snakemake --cores 2" in text


def test_docs_name_no_machine_path():
    for page in sorted((REPO / "docs").rglob("*.md")):
        if "generated" in page.parts or "_build" in page.parts:
            continue
        text = page.read_text(encoding="utf-8")
        assert not re.search(r"(?<![\w.])/(work|tmp|home)/", text), f"an absolute machine path in {page}"


def test_outputs_reference_names_every_column_of_the_ceq_table():
    from pidpipe.design.records import TABLE_COLUMNS

    text = (REPO / "docs" / "reference" / "outputs.md").read_text(encoding="utf-8")
    missing = [column for column in TABLE_COLUMNS if f"`{column}`" not in text]
    assert not missing, f"docs/reference/outputs.md does not describe {missing}"


def test_readme_links_point_at_files_that_exist():
    text = (REPO / "README.md").read_text(encoding="utf-8")
    targets = re.findall(r"\]\(((?:docs|workflow)/[^)#\s]+)\)", text)
    assert targets, "the README links into docs/"
    missing = [target for target in targets if not (REPO / target).exists()]
    assert not missing, f"README.md links to missing files: {missing}"


def test_readme_figure_is_drawn_by_its_committed_command(tmp_path):
    """The README cites `python docs/figures/pipeline.py`; it must still draw the figure."""
    assert "python docs/figures/pipeline.py" in (REPO / "README.md").read_text(encoding="utf-8")
    out = tmp_path / "pipeline.png"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    run = subprocess.run([sys.executable, str(REPO / "docs" / "figures" / "pipeline.py"), str(out)],
                         cwd=REPO, env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
