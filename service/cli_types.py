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
#: Largest magnitude of a number given to a :class:`Numbers` option (the library's bound too).
MAX_ABS = 1e6


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


def seconds_or_none(text: str) -> float | None:
    """A time budget: a finite number of seconds > 0, or ``none`` for no clock (an iteration budget alone)."""
    if text.strip().lower() == "none":
        return None
    return positive_float(text)


def trajectory_file(text: str) -> Path:
    """A trajectory file to write: ``.json`` or ``.csv`` (the format follows the extension), in an existing
    folder."""
    path = file_in_existing_folder(text)
    if path.suffix.lower() not in (".json", ".csv"):
        raise argparse.ArgumentTypeError(f"expected a file ending in .json or .csv, got {text!r}")
    return path


class Numbers(argparse.Action):
    """An option taking a fixed count of finite numbers: ``--box 0.5 0 0.3 0.1 0.2 0.3``.

    Keywords of ``add_argument`` besides argparse's own: ``counts`` (the accepted numbers of values,
    e.g. ``(6, 9)`` for a box with an optional rotation), ``form`` (the values' names, shown in the usage
    and in errors, e.g. ``"CX CY CZ SX SY SZ [ROLL PITCH YAW]"``) and ``kind`` (when given, the option
    appends ``(kind, values)`` to a list shared by several options - ``dest`` - so the items keep the
    order of the command line; otherwise the option stores its ``numpy`` array). The values may also be
    one token separated by commas (``0.5,0,0.3,0.1``) or a JSON list (brackets are ignored). A wrong count
    or a value that is not a finite number (or above 1e6 in magnitude, :data:`MAX_ABS`) is a usage error
    naming the option and the form.
    """

    def __init__(self, option_strings, dest, *, counts: tuple[int, ...], form: str, kind: str | None = None,
                 **kwargs) -> None:
        kwargs.setdefault("metavar", form)
        super().__init__(option_strings, dest, nargs="+", **kwargs)
        self.counts = tuple(counts)
        self.form = form
        self.kind = kind

    def values_of(self, tokens: list[str]):
        """The tokens as a float array (``argparse.ArgumentError`` if they do not fit the form)."""
        import numpy as np

        text = " ".join(tokens).replace(",", " ").replace("[", " ").replace("]", " ")
        counts = " or ".join(str(n) for n in self.counts)
        try:
            values = np.array([float(part) for part in text.split()])
        except ValueError:
            raise argparse.ArgumentError(self, f"expected {counts} numbers {self.form}, "
                                               f"got {' '.join(tokens)!r}") from None
        if values.size not in self.counts:
            raise argparse.ArgumentError(self, f"expected {counts} numbers {self.form}, got {values.size}")
        if not np.all(np.isfinite(values)):
            raise argparse.ArgumentError(self, f"expected finite numbers {self.form}, "
                                               f"got {' '.join(tokens)!r}")
        if np.any(np.abs(values) > MAX_ABS):
            raise argparse.ArgumentError(self, f"expected numbers {self.form} with |x| <= {MAX_ABS:g}, "
                                               f"got {' '.join(tokens)!r}")
        return values

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        """Store (or, with ``kind``, append) the checked numbers."""
        array = self.values_of(list(values))
        if self.kind is None:
            setattr(namespace, self.dest, array)
            return
        items = list(getattr(namespace, self.dest, None) or [])
        setattr(namespace, self.dest, [*items, (self.kind, array)])


def number_up_to(maximum: float, *, above: float = 0.0, unit: str = ""):
    """A converter to a finite number in ``(above, maximum]`` (a time in seconds, a size in MiB, ...).

    NaN, infinite values and numbers above ``maximum`` are refused with a message giving the range.
    """
    def convert(text: str) -> float:
        accepted = f"a finite number > {above:g} and <= {maximum:g}{unit}"
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {accepted}, got {text!r}") from None
        if not (math.isfinite(value) and above < value <= maximum):
            raise argparse.ArgumentTypeError(f"expected {accepted}, got {text}")
        return value

    return convert


def whole_number(minimum: int, maximum: int):
    """A converter to an integer in ``minimum..maximum`` (a count, a seed, ...); anything else is refused."""
    def convert(text: str) -> int:
        accepted = f"a whole number {minimum}..{maximum}"
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {accepted}, got {text!r}") from None
        if not minimum <= value <= maximum:
            raise argparse.ArgumentTypeError(f"expected {accepted}, got {value}")
        return value

    return convert


#: Largest seed accepted by ``--seed`` (numpy accepts any integer >= 0; 2**63 - 1 keeps it one word).
MAX_SEED = 2**63 - 1


def seed_number(text: str) -> int:
    """A random seed: an integer >= 0 (and at most 2**63 - 1)."""
    return whole_number(0, MAX_SEED)(text)
