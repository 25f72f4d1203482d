"""The package's rooms import only the rooms below them, so the dependency graph has no cycle."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "pidpipe"

#: The rooms from the bottom up: each may import itself and the rooms before it.
ROOMS = ("errors", "files", "physics", "cases", "config", "cell", "measurement", "liggghts",
         "dem", "design", "figures", "loop", "panel", "refine", "studies", "steps", "cli")


def _imports(path: Path) -> list[str]:
    """Every pidpipe module a file imports, at the top or inside a function."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("pidpipe"):
            if node.module == "pidpipe":
                found += [f"pidpipe.{alias.name}" for alias in node.names]
            else:
                found.append(node.module)
        elif isinstance(node, ast.Import):
            found += [alias.name for alias in node.names if alias.name.startswith("pidpipe")]
    return found


def test_every_module_lives_in_a_known_room():
    rooms = {path.relative_to(PACKAGE).with_suffix("").parts[0] for path in PACKAGE.rglob("*.py")}
    assert rooms - {"__init__"} == set(ROOMS)


def test_no_room_imports_a_room_above_it():
    upward = []
    for path in sorted(PACKAGE.rglob("*.py")):
        room = path.relative_to(PACKAGE).with_suffix("").parts[0]
        if room == "__init__":
            continue
        for module in _imports(path):
            other = module.split(".")[1]
            if ROOMS.index(other) > ROOMS.index(room):
                upward.append(f"{path.relative_to(PACKAGE)} imports {module}")
    assert upward == []
