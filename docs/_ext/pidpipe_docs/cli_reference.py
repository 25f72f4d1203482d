"""The command-line reference, written from the ``pidpipe`` command's own argparse parser."""

from __future__ import annotations

import argparse
import os
from contextlib import contextmanager


@contextmanager
def _columns(width: int):
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(width)
    try:
        yield
    finally:
        if old is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = old


def subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The sub-parsers of ``parser`` by name, in the order they were added."""
    out: dict[str, argparse.ArgumentParser] = {}
    for action in parser._actions:  # argparse keeps its sub-parsers only here
        if isinstance(action, argparse._SubParsersAction):
            out.update(action.choices)
    return out


def cli_to_markdown(parser: argparse.ArgumentParser, width: int = 96) -> str:
    """The CLI reference page: ``--help`` of the command and of each subcommand, verbatim.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The ``pidpipe`` command's parser.
    width : int
        Line width of the help text (argparse reads it from ``COLUMNS``).

    Returns
    -------
    str
        MyST Markdown.
    """
    with _columns(width):
        lines = ["# Command line", "",
                 "Generated from the `pidpipe` command's parser at every build of these pages: what",
                 "follows is exactly what `pidpipe --help` and `pidpipe <subcommand> --help` print.",
                 "User errors print one line and exit with status 2.", "",
                 "## `pidpipe`", "", "```text", parser.format_help().rstrip(), "```", ""]
        for name, sub in subcommands(parser).items():
            lines += [f"## `pidpipe {name}`", "", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(lines)
