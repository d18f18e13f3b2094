"""S7 mall: our grid A* vs networkx's A* on the same 8-connected grid graph.

Five queries (start -> 1 -> 2 -> 3 -> 4 -> end) on the 481 x 481 lattice of
the S7 mall (obstacles inflated by 10, 1-unit grid, diagonal moves only past
two free orthogonal neighbours).

* ours: ``planners.mobile.astar`` - the map build (rasterising the shapes)
  is INCLUDED in the time, from a fresh grid each repetition (so every cache
  it keeps is rebuilt too);
* networkx: ``networkx.astar_path`` with the Euclidean heuristic on a
  ``networkx.Graph`` of the same lattice; building that graph is EXCLUDED.

The path costs must agree (asserted to 1e-9). Target: ours >= 10x faster.
Also timed, for information: plain A* (no jump points), our Euclidean
heuristic, S7 in the best order, Held-Karp on 12 points, S8 coverage.

    python benchmarks/bench_planners.py [--out FILE.json] [--repeats N]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from kinserve.planners.checkpoint_order import shortest_order
from kinserve.planners.mobile import mall
from kinserve.planners.mobile.astar import astar
from kinserve.planners.mobile.coverage import boustrophedon_coverage
from kinserve.planners.mobile.sequencing import plan_waypoints

from _common import load_test_helper, machine, write_json

sparse_lattice_graph = load_test_helper("lattice_graph").sparse_lattice_graph


def timed(fn, repeats):
    out, times = None, []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, statistics.median(times), min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out")
    ap.add_argument("--repeats", type=int, default=15)
    args = ap.parse_args()
    import networkx as nx

    wp = mall.s7_waypoints()
    legs = list(zip(wp[:-1], wp[1:]))

    def ours(**kw):
        grid = mall.s7_map()  # map build included
        return [astar(grid, a, b, **kw).cost for a, b in legs]

    ours_costs, ours_t, ours_min = timed(ours, args.repeats)
    _, ours_eu_t, _ = timed(lambda: ours(heuristic="euclidean"), args.repeats)
    plain_costs, plain_t, _ = timed(lambda: ours(method="plain"), max(3, args.repeats // 3))

    grid = mall.s7_map()
    t0 = time.perf_counter()
    G = sparse_lattice_graph(grid)
    build_nx = time.perf_counter() - t0
    nxc = grid.shape[1]
    nodes = [(int(i) * nxc + int(j)) for i, j in zip(*grid.world_to_index(wp))]

    def euclid(u, v):
        return math.dist(divmod(u, nxc), divmod(v, nxc))

    def nx_run():
        costs = []
        for u, v in zip(nodes[:-1], nodes[1:]):
            path = nx.astar_path(G, u, v, heuristic=euclid, weight="weight")
            costs.append(sum(G[a][b]["weight"] for a, b in zip(path[:-1], path[1:])))
        return costs

    nx_costs, nx_t, nx_min = timed(nx_run, max(3, args.repeats // 3))
    for a, b, c in zip(ours_costs, nx_costs, plain_costs):
        assert abs(a - b) <= 1e-9 * max(1.0, b) and abs(c - b) <= 1e-9 * max(1.0, b), (a, b, c)

    # for information
    _, order_t, _ = timed(lambda: plan_waypoints(mall.s7_map(), wp, order="optimal"), 3)
    pts12 = np.random.default_rng(0).uniform(0, 1, (12, 2))
    _, hk_t, _ = timed(lambda: shortest_order(pts12), 3)
    cov, cov_t, _ = timed(lambda: boustrophedon_coverage(mall.s8_map(), mall.S8_START, lane_spacing=20.0), 2)

    ratio = nx_t / ours_t
    res = {
        "machine": machine(),
        "s7_five_astar_queries": {
            "ours_s_median": ours_t,
            "ours_s_min": ours_min,
            "ours_includes": "map build + 5 queries (jump point search, octile heuristic)",
            "ours_euclidean_heuristic_s": ours_eu_t,
            "ours_plain_astar_s": plain_t,
            "networkx_s_median": nx_t,
            "networkx_s_min": nx_min,
            "networkx_excludes": f"graph build ({build_nx:.2f} s)",
            "ratio_networkx_over_ours": ratio,
            "costs": ours_costs,
            "total_cost": float(sum(ours_costs)),
            "target_ratio_min": 10.0,
        },
        "info": {
            "s7_optimal_order_s": order_t,
            "held_karp_12_points_s": hk_t,
            "s8_coverage_s": cov_t,
            "s8_covered_fraction": cov.covered_fraction,
            "s8_path_length": cov.length,
        },
    }
    m = res["machine"]
    print(f"machine: {m['cpu']} ({m['cores']} cores), Python {m['python']}")
    print("S7 mall, 5 A* queries (start->1->2->3->4->end), 481x481 lattice, same 8-connected graph")
    print(f"{'':44}{'median s':>10}{'min s':>10}")
    print(f"{'ours: map build + 5 queries (JPS, octile)':44}{ours_t:10.4f}{ours_min:10.4f}")
    print(f"{'ours: same, Euclidean heuristic':44}{ours_eu_t:10.4f}")
    print(f"{'ours: same, plain A* (no jump points)':44}{plain_t:10.4f}")
    print(f"{'networkx astar_path (graph build excluded)':44}{nx_t:10.4f}{nx_min:10.4f}")
    print(f"ratio networkx / ours: {ratio:.1f}x   (target >= 10x)")
    print(f"path costs: {[round(c, 4) for c in ours_costs]}  total {sum(ours_costs):.4f}  (equal to "
          "networkx)")
    print(f"info: best order of S7 {order_t:.3f} s, Held-Karp 12 points {hk_t:.3f} s, "
          f"S8 coverage {cov_t:.2f} s ({cov.covered_fraction:.1%} of the free floor, path {cov.length:.0f})")
    write_json(args.out, res)


if __name__ == "__main__":
    main()
