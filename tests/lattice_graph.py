"""The 8-connected occupancy lattice as a networkx graph: the independent reference for A* costs.

Nodes are ``i * nx + j`` (row i, column j of ``grid.free``); edges join free
neighbours with weight ``resolution`` (axis moves) or ``resolution * sqrt 2``
(diagonals), and a diagonal is only allowed when both cells it cuts past are
free (no corner cutting), the rule of ``planners.mobile.astar``. Built through
a SciPy sparse matrix so the 481 x 481 mall takes well under a second. Used by
tests/test_mobile_astar.py and benchmarks/bench_planners.py.
"""

import math

import networkx as nx
import numpy as np

SQ2 = math.sqrt(2.0)


def sparse_lattice_graph(grid):
    """networkx.Graph of the free cells of ``grid`` (see the module docstring)."""
    from scipy import sparse

    F = grid.free
    ny, nx_ = F.shape
    idx = np.arange(ny * nx_).reshape(ny, nx_)
    rows, cols, ws = [], [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        j0, j1 = max(0, -dj), nx_ - max(0, dj)
        a = F[: ny - di, j0:j1] & F[di:, j0 + dj : j1 + dj]
        if di and dj:
            a &= F[di:, j0:j1] & F[: ny - di, j0 + dj : j1 + dj]
        ii, jj = np.nonzero(a)
        jj += j0
        rows.append(idx[ii, jj])
        cols.append(idx[ii + di, jj + dj])
        ws.append(np.full(len(ii), grid.resolution * (SQ2 if di and dj else 1.0)))
    M = sparse.coo_array((np.concatenate(ws), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(ny * nx_,) * 2)
    G = nx.from_scipy_sparse_array(M)
    G.remove_nodes_from(np.flatnonzero(~F.ravel()).tolist())
    return G
