"""HTTP service and batch scale-out benchmark.

1. ``/ik`` (Panda flange, random reachable targets = FK of uniform random q):
   requests/s and p50/p95 latency at 1, 8 and 32 concurrent clients, for a
   server with 1 and with 2 worker processes (``kinserve serve --workers``),
   all on loopback.
2. Batch IK throughput: ``ik.solve_many`` on local processes vs on a local
   Ray (same targets, same core count).

    python benchmarks/bench_service.py [--requests 400] [--batch 4000] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import threading
import time

import httpx
import numpy as np

ROOT = os.path.join(os.path.dirname(__file__), "..")

from kinserve import robots  # noqa: E402
from _common import load_test_helper, machine, write_json  # noqa: E402
Server = load_test_helper("service_server").Server


def load_test(url: str, bodies: list[str], clients: int) -> dict:
    """Send every body once, ``clients`` threads each with its own keep-alive connection."""
    latencies: list[float] = []
    failures = 0
    lock = threading.Lock()
    it = iter(bodies)

    def worker():
        nonlocal failures
        with httpx.Client(base_url=url, timeout=60) as c:
            while True:
                with lock:
                    body = next(it, None)
                if body is None:
                    return
                t0 = time.perf_counter()
                r = c.post("/ik", content=body, headers={"content-type": "application/json"})
                dt = time.perf_counter() - t0
                ok = r.status_code == 200 and r.json()["success"]
                with lock:
                    latencies.append(dt)
                    failures += not ok

    t0 = time.perf_counter()
    threads = [threading.Thread(target=worker) for _ in range(clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    wall = time.perf_counter() - t0
    lat = sorted(latencies)
    return {
        "clients": clients, "requests": len(lat), "failures": failures, "requests_per_s": len(lat) / wall,
        "p50_ms": 1e3 * lat[len(lat) // 2], "p95_ms": 1e3 * lat[int(0.95 * (len(lat) - 1))],
        "mean_ms": 1e3 * statistics.fmean(lat),
    }


def bench_http(n_requests: int) -> list[dict]:
    panda = robots.load("panda", geometry=False)
    Q = panda.random_q(0, n=n_requests)
    bodies = [json.dumps({"robot": "panda", "target": panda.fk(q, "panda_link8").tolist(), "frame": "panda_link8",
                          "seed": i}) for i, q in enumerate(Q)]
    rows = []
    for workers in (1, 2):
        srv = Server("--workers", str(workers), max_time_cap=1.0)
        try:
            load_test(srv.url, bodies[:50], 8)  # warm up every worker (robot load, seed table)
            for clients in (1, 8, 32):
                row = load_test(srv.url, bodies, clients)
                row["server_workers"] = workers
                rows.append(row)
                print(f"  workers={workers} clients={clients:>2}: {row['requests_per_s']:8.1f} req/s  "
                      f"p50 {row['p50_ms']:6.2f} ms  p95 {row['p95_ms']:6.2f} ms  failures {row['failures']}")
        finally:
            srv.stop()
    return rows


def bench_batch(n: int) -> dict:
    import ray

    from kinserve.ik import solve_many

    panda = robots.load("panda", geometry=False)
    targets = panda.fk_batch(panda.random_q(1, n=n), "panda_link8")
    out = {"targets": n}
    for backend in ("processes", "ray"):
        if backend == "ray":
            ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        solve_many(panda, targets[:200], frame="panda_link8", backend=backend, processes=2, seed=0, progress=False)
        t0 = time.perf_counter()
        res = solve_many(panda, targets, frame="panda_link8", backend=backend, processes=2, seed=0, progress=False)
        dt = time.perf_counter() - t0
        out[backend] = {"seconds": dt, "targets_per_s": n / dt, "success": sum(r.success for r in res) / n}
        print(f"  solve_many backend={backend:<9}: {n / dt:9.0f} targets/s  success {100 * out[backend]['success']:.1f} %")
    ray.shutdown()
    out["ray_over_processes"] = out["ray"]["targets_per_s"] / out["processes"]["targets_per_s"]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--requests", type=int, default=400)
    ap.add_argument("--batch", type=int, default=4000)
    ap.add_argument("--out")
    args = ap.parse_args()
    m = machine()
    print(f"machine: {m['cpu']} ({m['cores']} cores), Python {m['python']}")
    print("POST /ik, Panda flange, random reachable targets")
    http = bench_http(args.requests)
    print("batch IK, 2 workers")
    batch = bench_batch(args.batch)
    write_json(args.out, {"machine": m, "http_ik": http, "batch": batch})


if __name__ == "__main__":
    main()
