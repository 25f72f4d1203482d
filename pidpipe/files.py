"""Writing result files atomically: a temporary file, flushed to disk, then renamed.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable


def write_atomic(path: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)``, flush it to disk and rename the temporary file to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
    try:
        write(tmp)
        sync_file(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def sync_file(path: str | os.PathLike) -> None:
    """Flush a written file to disk (so that a power loss after the rename cannot leave it empty)."""
    with open(path, "rb") as handle:
        os.fsync(handle.fileno())
