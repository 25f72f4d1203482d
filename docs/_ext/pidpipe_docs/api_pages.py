"""The API pages: one page per subpackage of ``pidpipe``, one ``automodule`` per module.

The modules are found by walking the package at build time, so a new module appears without
editing the docs. A module that does not import is not rendered; the page names it and why
(autodoc would otherwise fail the whole build on it).
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass


@dataclass(frozen=True)
class Module:
    """A module of the package and, if it failed to import, why."""

    name: str
    error: str = ""


def package_modules(package: str = "pidpipe") -> dict[str, list[Module]]:
    """The modules of ``package`` grouped by subpackage (top-level modules under ``package``).

    Returns
    -------
    dict of str to list of Module
        Subpackage name (e.g. ``pidpipe.dem``) -> its modules, the subpackage itself first.
    """
    root = importlib.import_module(package)
    groups: dict[str, list[Module]] = {package: []}
    for info in sorted(pkgutil.walk_packages(root.__path__, prefix=f"{package}."), key=lambda i: i.name):
        parts = info.name.split(".")
        if any(part.startswith("_") for part in parts[1:]):
            continue
        group = package if (len(parts) == 2 and not info.ispkg) else ".".join(parts[:2])
        try:
            importlib.import_module(info.name)
            module = Module(info.name)
        except Exception as exc:  # noqa: BLE001 - any import failure is reported on the page
            module = Module(info.name, f"{type(exc).__name__}: {exc}".splitlines()[0])
        groups.setdefault(group, []).append(module)
    return groups


def group_page(group: str, modules: list[Module]) -> str:
    """The Markdown page of one subpackage."""
    title = "Top-level modules" if group == "pidpipe" else f"`{group}`"
    lines = [f"# {title}", ""]
    failed = [m for m in modules if m.error]
    for module in modules:
        if module.error:
            continue
        # :ignore-module-all: documents what a module defines, not what its __all__ re-exports
        # (a subpackage's __init__ re-exports its modules' names, documented there).
        heading = [] if module.name == group else [f"## `{module.name}`", ""]
        lines += [*heading, "```{eval-rst}", f".. automodule:: {module.name}",
                  "   :ignore-module-all:", "```", ""]
    if failed:
        lines += ["## Not rendered", "", "These modules did not import when the pages were built:", ""]
        lines += [f"- `{m.name}`: {m.error}" for m in failed] + [""]
    return "\n".join(lines)


def index_page(groups: dict[str, list[Module]]) -> str:
    """The API index page, with a toctree of the subpackage pages."""
    lines = ["# API", "",
             "Generated from the package's numpy-style docstrings at every build of these pages,",
             "one page per stage of the pipeline (each subpackage imports only those before it).", "",
             "```{toctree}", ":maxdepth: 1", ""]
    lines += [f"api-{group.replace('.', '-')}" for group in groups] + ["```", ""]
    return "\n".join(lines)
