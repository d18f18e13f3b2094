"""The host's memory latency at one moment: a dependent-load chase through a random ring of cache lines.

A cold check (the first one in a new scene) spends most of its time waiting on memory, so its figure follows
the latency of the caches beyond the core's own and of the memory, which the host's other guests share. This
probe measures that latency next to such a figure, so that a run states the state of the host it met.

The ring: ``n`` cache lines of 64 bytes (8 int64 slots each, only the first used) in one random cycle
(:func:`ring`), so every load depends on the one before and the hardware prefetcher cannot guess the next
address. :func:`latency_ns` times ``steps`` loads of the chase (compiled with Numba, compiled and run once
before the clock starts) and gives the median over ``rounds`` of the nanoseconds per load. A ring larger than
the core's L2 and smaller than the L3 measures the L3; one much larger than the L3 measures memory.
"""

from __future__ import annotations

import statistics
import time

import numba
import numpy as np

#: int64 slots per 64-byte cache line.
LINE_SLOTS = 8
#: The probe's ring sizes (bytes): beyond this machine type's 1 MiB L2 and within its 32 MiB L3; then far
#: beyond the L3.
SIZES = {"8MiB": 8 << 20, "256MiB": 256 << 20}


def ring(n_lines: int, seed: int = 0) -> np.ndarray:
    """An int64 array of ``n_lines`` cache lines (``n_lines * LINE_SLOTS`` slots) whose first slots link the
    lines in one random cycle: ``ring[i]`` is the slot index of the next line for every line's first slot
    ``i``, and following it from any line visits every line once before coming back."""
    if n_lines < 2:
        raise ValueError(f"a ring needs at least 2 lines, got {n_lines}")
    order = np.random.default_rng(seed).permutation(n_lines).astype(np.int64) * LINE_SLOTS
    out = np.zeros(n_lines * LINE_SLOTS, dtype=np.int64)
    out[order] = np.roll(order, -1)
    return out


@numba.njit(cache=False)
def chase(links: np.ndarray, start: int, steps: int) -> int:
    """The slot reached after ``steps`` loads from ``start`` (each load's address is the previous load's
    value)."""
    i = start
    for _ in range(steps):
        i = links[i]
    return i


def latency_ns(size_bytes: int, steps: int = 200_000, rounds: int = 5, seed: int = 0) -> float:
    """Median over ``rounds`` of the time (ns) of one dependent load in a :func:`ring` of ``size_bytes``."""
    links = ring(max(2, size_bytes // (LINE_SLOTS * 8)), seed)
    position = chase(links, 0, min(steps, len(links) // LINE_SLOTS))  # compiles, and brings the ring in
    samples = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        position = chase(links, position, steps)
        samples.append((time.perf_counter() - t0) / steps * 1e9)
    return statistics.median(samples)


def probe(steps: int = 200_000, rounds: int = 5) -> dict[str, float]:
    """:func:`latency_ns` for each ring of :data:`SIZES`, by its name."""
    return {name: latency_ns(size, steps, rounds) for name, size in SIZES.items()}
