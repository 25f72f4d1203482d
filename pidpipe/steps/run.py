"""Running one workflow step: logging to the rule's log, and a PidpipeError as one message and exit status 1.
"""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path
from typing import Callable

from pidpipe.errors import PidpipeError

logger = logging.getLogger("pidpipe.campaign")


def run_step(func: Callable, log_path: str | os.PathLike, /, **kwargs) -> None:
    """Run one workflow step, logging to ``log_path`` and stderr.

    A :class:`~pidpipe.errors.PidpipeError` is written (message only) to the log and to stderr,
    and the process exits with status 1; any other exception is a bug and keeps its traceback.

    Parameters
    ----------
    func : callable
        The step; called as ``func(**kwargs)``.
    log_path : path
        The rule's log file.
    """
    Path(log_path).parent.mkdir(parents=True, exist_ok=True)
    root = logging.getLogger("pidpipe")
    root.setLevel(logging.INFO)
    file_handler = logging.FileHandler(log_path, mode="a", encoding="utf-8")
    file_handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
    stderr_handler = logging.StreamHandler(sys.stderr)
    stderr_handler.setLevel(logging.WARNING)
    stderr_handler.setFormatter(logging.Formatter("pidpipe %(levelname)s: %(message)s"))
    root.addHandler(file_handler)
    root.addHandler(stderr_handler)
    try:
        func(**kwargs)
    except PidpipeError as exc:
        logger.error("%s (log: %s)", exc, log_path)
        raise SystemExit(1) from None
    finally:
        root.removeHandler(file_handler)
        root.removeHandler(stderr_handler)
        file_handler.close()
