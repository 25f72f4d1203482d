"""Sphinx extension: the pages of pidpipe's reference that are made from the code.

At ``builder-inited`` it writes, into ``docs/reference/generated/``:

- ``config.md`` from ``workflow/schemas/config.schema.yaml`` (:mod:`.schema_reference`);
- ``cli.md`` from the ``pidpipe`` command's argparse parser (:mod:`.cli_reference`);
- ``api.md`` and one ``api-<subpackage>.md`` per subpackage (:mod:`.api_pages`);
- ``benchmark-records.md`` from ``benchmarks/records/*.json`` (:mod:`.records`).

A file is rewritten only when its text changes, so an incremental build stays incremental.
Keys of the schema without a description are logged (not warned: the schema is checked by
its own tests).
"""

from __future__ import annotations

import re
from pathlib import Path

import yaml

from . import api_pages, cli_reference, records, schema_reference

# Sphinx is imported inside the functions that Sphinx calls, so that the generators above can be
# imported (and tested) where Sphinx is not installed.


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _cli_parser():
    from sphinx.errors import ExtensionError

    from pidpipe import cli

    for name in ("_parser", "build_parser", "parser"):
        factory = getattr(cli, name, None)
        if callable(factory):
            return factory()
    raise ExtensionError("pidpipe.cli has no parser factory (_parser, build_parser or parser)")


def write_generated(app) -> None:
    """Write every generated page (see the module's docstring)."""
    from sphinx.errors import ExtensionError
    from sphinx.util import logging

    docs = Path(app.srcdir)
    repo = docs.parent
    out = docs / "reference" / "generated"

    schema_path = repo / "workflow" / "schemas" / "config.schema.yaml"
    schema = yaml.safe_load(schema_path.read_text(encoding="utf-8"))
    campaign = yaml.safe_load((repo / "config.yaml").read_text(encoding="utf-8"))
    _write(out / "config.md", schema_reference.schema_to_markdown(schema, config=campaign))
    missing = schema_reference.undescribed(schema)
    if missing:
        logging.getLogger(__name__).info("pidpipe_docs: schema keys without a description: %s", ", ".join(missing))

    _write(out / "cli.md", cli_reference.cli_to_markdown(_cli_parser()))

    groups = api_pages.package_modules("pidpipe")
    _write(out / "api.md", api_pages.index_page(groups))
    for group, modules in groups.items():
        _write(out / f"api-{group.replace('.', '-')}.md", api_pages.group_page(group, modules))

    try:
        found = records.load_records(repo / "benchmarks" / "records")
    except records.RecordError as exc:
        raise ExtensionError(f"benchmark record: {exc}") from None
    _write(out / "benchmark-records.md", records.records_to_markdown(found))


#: ``|x|`` (an absolute value) in a docstring, which reST would read as a substitution.
_PIPES = re.compile(r"\|")


def prepare_docstring(app, what, name, obj, options, lines) -> None:
    """Make a plain-text docstring safe for reST before numpydoc reads it.

    Every ``|`` is escaped: the package writes |X| for absolute values, which reST reads as
    substitution references (the docstrings hold no reST tables). The docstrings named in the
    config value ``pidpipe_verbatim_docstrings`` (whose sections are not numpydoc's) keep their
    first line as the summary and show the rest verbatim.
    """
    if name in app.config.pidpipe_verbatim_docstrings and len(lines) > 1:
        body = [f"    {line}" if line.strip() else "" for line in lines[1:]]
        lines[:] = [lines[0], "", "::", "", *body, ""]
        return
    lines[:] = [_PIPES.sub(r"\\|", line) for line in lines]


def setup(app):
    app.connect("builder-inited", write_generated)
    app.add_config_value("pidpipe_verbatim_docstrings", frozenset(), "env")
    app.connect("autodoc-process-docstring", prepare_docstring, priority=400)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
