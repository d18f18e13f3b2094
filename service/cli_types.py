"""argparse ``type=`` converters for the ``kinserve`` sub-commands.

Each converter turns one command-line string into a checked value or raises
``argparse.ArgumentTypeError``; argparse then prints the usage line and
``kinserve CMD: error: argument --port: ...`` and exits with status 2, so a
bad number never reaches the library (or uvicorn) as an ``OverflowError``.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

MAX_PORT = 65535


def port_number(text: str) -> int:
    """A TCP port: an integer in 1..65535, or 0 for "any free port"."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a port number 0..{MAX_PORT}, got {text!r}") from None
    if not 0 <= port <= MAX_PORT:
        raise argparse.ArgumentTypeError(f"expected a port number 0..{MAX_PORT} (0 = any free port), "
                                         f"got {port}")
    return port


def positive_int(text: str) -> int:
    """An integer >= 1 (a count of samples, workers, processes, ...)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    """A finite number > 0 (a time budget in seconds, ...)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text}")
    return value


def non_negative_float(text: str) -> float:
    """A finite number >= 0 (a weight, ...)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text}")
    return value


def file_in_existing_folder(text: str) -> Path:
    """A file path to write whose folder already exists (no folder tree is created behind the user's back)."""
    path = Path(text)
    folder = path.parent
    if path.name in ("", ".", "..") or path.is_dir():
        raise argparse.ArgumentTypeError(f"expected a file path, got the folder {text!r}")
    if not folder.is_dir():
        raise argparse.ArgumentTypeError(f"the folder {str(folder)!r} does not exist (create it first)")
    return path
