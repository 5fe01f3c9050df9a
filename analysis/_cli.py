"""Helpers shared by the command lines: the sweep parser, one-line errors and warnings on stderr.

This module imports nothing from the package: each command passes its record loader in
(:func:`analysis.aggregate.load_records`), so the commands depend on it and never the other way round.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Callable, Sequence

import pandas as pd


def fail(err: BaseException | str) -> int:
    """Print ``error: ...`` on one line to stderr; returns the exit status 2."""
    text = err if isinstance(err, str) else str(err) or type(err).__name__
    print("error: " + " ".join(text.split()), file=sys.stderr)
    return 2


def load_for_cli(
    dirs: Sequence[str], load: Callable[..., pd.DataFrame], record_name: str
) -> pd.DataFrame | None:
    """``load(*dirs)`` for a command line.

    Skipped records (the loader's warnings) are reported as ``warning: ...`` lines; a missing
    directory (an ``OSError`` of the loader), or no record at all, as one ``error: ...`` line.

    Args:
        dirs: the directories to read.
        load: the loader, e.g. :func:`~analysis.aggregate.load_records` with its options bound.
        record_name: the record file name, for the error when there is none.

    Returns:
        The table, or ``None`` after an error was printed.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            df = load(*dirs)
        except OSError as err:
            fail(err)
            return None
    for w in caught:
        print("warning: " + " ".join(str(w.message).split()), file=sys.stderr)
    if not len(df):
        fail(f"no readable {record_name} records under {', '.join(map(str, dirs))}")
        return None
    return df


def sweep_parser(prog: str, description: str) -> argparse.ArgumentParser:
    """An argument parser with the ``SWEEP_DIR ...`` positional every analysis command takes."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    parser.add_argument("sweep_dirs", nargs="+", metavar="SWEEP_DIR", help="sweep directories to read")
    return parser


def run(
    sweep_dirs: Sequence[str],
    action: Callable[[pd.DataFrame], str],
    errors: tuple[type[BaseException], ...],
    *,
    load: Callable[..., pd.DataFrame],
    record_name: str,
) -> int:
    """Load the records, run ``action`` on the table and print the line it returns.

    Args:
        sweep_dirs: the directories to read.
        action: writes the command's output from the table; returns the line to print.
        errors: exceptions of ``action`` reported as one ``error: ...`` line.
        load: ``load(*sweep_dirs)`` -> the table (see :func:`load_for_cli`).
        record_name: the record file name, for the error when there is none.

    Returns:
        The exit status: 0, or 2 after an error.
    """
    df = load_for_cli(sweep_dirs, load, record_name)
    if df is None:
        return 2
    try:
        message = action(df)
    except errors as err:
        return fail(err)
    print(message)
    return 0
