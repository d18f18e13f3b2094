"""A progress bar on stderr for a one-time build (the collision model): tqdm, on a terminal, after a delay.

The bar appears only when stderr is a terminal (``sys.stderr.isatty()``) and
only once the build has run for :data:`DELAY` seconds; a build that ends
sooner, or any build whose stderr is a file or a pipe, prints nothing. The bar
is removed when the build ends.
"""

from __future__ import annotations

import sys

from tqdm import tqdm

#: Seconds a build runs before its bar appears.
DELAY = 1.0


def stderr_is_terminal() -> bool:
    """True when ``sys.stderr`` is an open terminal."""
    stream = sys.stderr
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty()) if isatty is not None else False
    except ValueError:  # a closed stream
        return False


def build_progress(total: int, description: str) -> tqdm:
    """A tqdm bar of ``total`` steps on stderr (module docstring; a silent no-op bar off a terminal).
    Use it as a context manager; ``update(k)`` advances it by ``k`` steps."""
    return tqdm(total=int(total), desc=description, delay=DELAY, disable=not stderr_is_terminal(),
                file=sys.stderr, leave=False, unit="step", dynamic_ncols=True)
