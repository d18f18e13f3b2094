"""benchmarks/memory_latency.py: the ring is one cycle through every cache line, the compiled chase follows it
as a plain Python walk does, and the probe gives a latency per load."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmark_scripts import load_benchmark

ml = load_benchmark("memory_latency")


@pytest.mark.parametrize("n_lines, seed", [(2, 0), (3, 1), (64, 2), (1000, 3)])
def test_the_ring_is_one_cycle_through_every_line(n_lines, seed):
    links = ml.ring(n_lines, seed)
    assert links.dtype == np.int64 and links.shape == (n_lines * ml.LINE_SLOTS,)
    first_slots = np.arange(n_lines) * ml.LINE_SLOTS
    others = np.setdiff1d(np.arange(len(links)), first_slots)
    assert not links[others].any()  # only each line's first slot links
    seen, i = [], 0
    for _ in range(n_lines):
        seen.append(i)
        i = int(links[i])
    assert i == 0 and sorted(seen) == list(first_slots)  # back at the start after visiting each line once


def test_rings_of_two_seeds_differ_and_one_seed_repeats():
    assert not np.array_equal(ml.ring(500, 0), ml.ring(500, 1))
    assert np.array_equal(ml.ring(500, 4), ml.ring(500, 4))


def test_a_ring_needs_two_lines():
    with pytest.raises(ValueError, match="at least 2 lines"):
        ml.ring(1)


def test_the_compiled_chase_follows_the_ring():
    links = ml.ring(257, 5)
    for start, steps in [(0, 0), (0, 1), (8 * 17, 5), (8 * 256, 1000)]:
        i = start
        for _ in range(steps):
            i = int(links[i])
        assert ml.chase(links, start, steps) == i


def test_the_probe_gives_a_finite_time_per_load_for_each_size(monkeypatch):
    monkeypatch.setattr(ml, "SIZES", {"small": 64 * 1024, "larger": 1 << 20})
    figures = ml.probe(steps=2000, rounds=3)
    assert set(figures) == {"small", "larger"}
    assert all(math.isfinite(ns) and ns > 0 for ns in figures.values())
