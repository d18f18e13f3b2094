"""Planning problems for the service's tests and benchmark, as HTTP request data (numpy only)."""

from __future__ import annotations

import numpy as np

#: The Panda's "ready" configuration: the hand points down at (0.307, 0, 0.59), fingertips at z 0.478.
READY = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]
#: A configuration 1.2 rad away on joint 1.
ASIDE = [1.2, -0.3, 0.0, -2.2, 0.0, 1.9, 0.785]


def box(lo, hi) -> dict:
    """An axis-aligned box obstacle (HTTP form) with corners ``lo``, ``hi`` (m)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    T = np.eye(4)
    T[:3, 3] = (lo + hi) / 2
    return {"kind": "box", "pose": T.tolist(), "size": (hi - lo).tolist()}


def cage() -> list[dict]:
    """Thin walls around the Panda's hand at READY (clear of it by 8 mm): a floor, four sides and a top with
    a hole that link 7 passes through but the hand (0.2 m wide) does not. A plan from READY to anywhere
    outside searches until its budget is spent."""
    t = 0.012
    x0, x1, y0, y1, z0, z1 = 0.245, 0.37, -0.125, 0.13, 0.455, 0.624
    hx0, hx1, hy0, hy1 = 0.25, 0.365, -0.101, 0.067
    return [box((x0 - t, y0 - t, z0 - t), (x1 + t, y1 + t, z0)),
            box((x0 - t, y0 - t, z0), (x0, y1 + t, z1)), box((x1, y0 - t, z0), (x1 + t, y1 + t, z1)),
            box((x0, y0 - t, z0), (x1, y0, z1)), box((x0, y1, z0), (x1, y1 + t, z1)),
            box((x0 - t, y0 - t, z1), (x1 + t, hy0, z1 + t)),
            box((x0 - t, hy1, z1), (x1 + t, y1 + t, z1 + t)),
            box((x0 - t, hy0, z1), (hx0, hy1, z1 + t)), box((hx1, hy0, z1), (x1 + t, hy1, z1 + t))]
