"""HTTP service benchmark, against a bare FastAPI app served the same way, plus batch IK scale-out.

1. Latency: p50 / p95 of ``GET /health``, ``POST /fk`` (Panda flange) and ``POST /ik``
   (Panda flange, reachable targets = FK of uniform random q) with 1 keep-alive
   client and with 8 and 32 concurrent keep-alive clients, for servers with 1 and
   2 worker processes (``kinserve serve --workers``). The reference in the same
   run is ``benchmarks/bare_app.py``: FastAPI routes returning a constant,
   served by the same code (uvicorn, same protocol and options).
   Target: ``/fk`` p50 <= 1.5 x the bare route's p50 (1 client).
2. Starvation: ``/health`` p95 while 45 unreachable ``/ik`` requests run at once,
   and while 20 ``/plan/motion`` requests that search for their whole ``max_time``
   run at once (target <= 50 ms each), and how long those took against their ``max_time``.
3. ``ik.solve_many`` targets/s at 1 and 2 processes (and on a local Ray when the
   optional ``ray`` extra is installed; skipped with a message otherwise).

The clients are raw HTTP/1.1 keep-alive sockets (one per thread), so the figures
are the server's, not an HTTP library's.

    python benchmarks/bench_service.py [--requests 400] [--batch 4000] [--out bench-out/service.json]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from kinserve import ik, robots

from _common import load_test_helper, machine, write_json

HERE = Path(__file__).resolve().parent
helpers = load_test_helper("service_server")
# the tests' raw keep-alive client: one HTTP/1.1 connection, cheap enough on the client side to time the
# server
Server, free_port, KeepAliveClient = helpers.Server, helpers.free_port, helpers.KeepAliveClient
scenes = load_test_helper("service_scenes")  # planning problems as request data


def tree_cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` and all its descendants (from /proc; 0 elsewhere)."""
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    stats = {}
    for entry in os.listdir("/proc") if os.path.isdir("/proc") else []:
        if entry.isdigit():
            try:
                fields = Path(f"/proc/{entry}/stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            stats[int(entry)] = (int(fields[1]), int(fields[11]) + int(fields[12]))  # ppid, utime + stime
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        total += stats.get(p, (0, 0))[1]
        todo.extend(c for c, (pp, _) in stats.items() if pp == p)
    return total / tick


def percentiles(lat: list[float]) -> dict:
    lat = sorted(lat)
    return {"n": len(lat), "p50_ms": 1e3 * lat[len(lat) // 2],
            "p95_ms": 1e3 * lat[int(0.95 * (len(lat) - 1))], "mean_ms": 1e3 * statistics.fmean(lat)}


def load_test(port: int, method: str, path: str, bodies: list[bytes], clients: int,
              pid: int | None = None) -> dict:
    """Send every body once from ``clients`` threads, each on its own keep-alive connection.

    With the server's ``pid``, also its CPU time per request (load-robust where latency is not).
    """
    latencies: list[float] = []
    failures = 0
    lock = threading.Lock()
    it = iter(bodies)

    def worker():
        nonlocal failures
        c = KeepAliveClient(port)
        try:
            while True:
                with lock:
                    body = next(it, None)
                if body is None:
                    return
                t0 = time.perf_counter()
                status, _, _ = c.request(method, path, body)
                dt = time.perf_counter() - t0
                with lock:
                    latencies.append(dt)
                    failures += status != 200
        finally:
            c.close()

    cpu0 = tree_cpu_seconds(pid) if pid else 0.0
    t0 = time.perf_counter()
    threads = [threading.Thread(target=worker) for _ in range(clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    row = percentiles(latencies)
    row.update(clients=clients, failures=failures, requests_per_s=len(latencies) / (time.perf_counter() - t0))
    if pid:
        row["server_cpu_us_per_request"] = 1e6 * (tree_cpu_seconds(pid) - cpu0) / max(1, len(latencies))
    return row


# ---------------------------------------------------------------- the servers
class BareServer:
    """``benchmarks/bare_app.py`` in a subprocess (the same uvicorn set-up as ``kinserve serve``)."""

    def __init__(self, workers: int):
        self.port = free_port()
        self.proc = subprocess.Popen([sys.executable, str(HERE / "bare_app.py"), "--port", str(self.port),
                                      "--workers", str(workers)], cwd=HERE, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                c = KeepAliveClient(self.port)
                c.request("GET", "/health")
                c.close()
                return
            except OSError:
                if self.proc.poll() is not None:
                    raise RuntimeError("bare_app exited early")
                time.sleep(0.2)
        self.stop()
        raise RuntimeError("bare_app did not start within 60 s")

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def panda_bodies(n: int) -> tuple[list[bytes], list[bytes]]:
    panda = robots.load("panda", geometry=False)
    Q = panda.random_q(0, n=n)
    fk = [json.dumps({"robot": "panda", "q": q.tolist(), "frame": "panda_link8"}).encode() for q in Q]
    ik_ = [json.dumps({"robot": "panda", "target": panda.fk(q, "panda_link8").tolist(),
                       "frame": "panda_link8", "seed": i}).encode() for i, q in enumerate(Q)]
    return fk, ik_


def bench_latency(n: int, client_counts=(1, 8, 32)) -> list[dict]:
    fk_bodies, ik_bodies = panda_bodies(n)
    health = [b""] * n
    rows = []
    for workers in (1, 2):
        for server_name in ("bare", "kinserve"):
            srv = (BareServer(workers) if server_name == "bare"
                   else Server("--workers", str(workers), max_time_cap=1.0))
            try:
                cases = [("GET", "/health", health), ("POST", "/fk", fk_bodies)]
                if server_name == "kinserve":
                    cases.append(("POST", "/ik", ik_bodies))
                    # warm every worker (model, seed table)
                    load_test(srv.port, "POST", "/ik", ik_bodies[:50], 8)
                for method, path, bodies in cases:
                    load_test(srv.port, method, path, bodies[:50], 4)  # warm up
                    for clients in client_counts:
                        row = load_test(srv.port, method, path, bodies, clients, pid=srv.proc.pid)
                        row.update(server=server_name, workers=workers, endpoint=path)
                        rows.append(row)
                        print(f"  {server_name:<8} workers={workers} {path:<8} clients={clients:>2}: "
                              f"p50 {row['p50_ms']:7.3f} ms  p95 {row['p95_ms']:7.3f} ms  "
                              f"{row['requests_per_s']:8.0f} req/s  server CPU "
                              f"{row['server_cpu_us_per_request']:6.0f} us/req  failures {row['failures']}")
            finally:
                srv.stop()
    return rows


def health_under_load(path: str, body: bytes, n: int, max_time: float, label: str) -> dict:
    """``/health`` latency sampled every 20 ms while ``n`` requests ``POST path`` with ``body`` (each running
    its whole ``max_time``) run at once, on a server capped at ``max_time``."""
    srv = Server(max_time_cap=max_time)
    try:
        warm = KeepAliveClient(srv.port)
        warm.request("POST", path, body)  # model, seed table, collision model loaded
        warm.close()
        times, statuses, health = [], [], []
        lock = threading.Lock()
        done = threading.Event()

        def one():
            c = KeepAliveClient(srv.port)
            t0 = time.perf_counter()
            status, _, _ = c.request("POST", path, body)
            with lock:
                times.append(time.perf_counter() - t0)
                statuses.append(status)
            c.close()

        def sample_health():
            c = KeepAliveClient(srv.port)
            while not done.is_set():
                t0 = time.perf_counter()
                c.request("GET", "/health")
                health.append(time.perf_counter() - t0)
                time.sleep(0.02)
            c.close()

        sampler = threading.Thread(target=sample_health)
        sampler.start()
        t0 = time.perf_counter()
        threads = [threading.Thread(target=one) for _ in range(n)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        wall = time.perf_counter() - t0
        done.set()
        sampler.join()
    finally:
        srv.stop()
    out = {"requests": n, "endpoint": path, "max_time": max_time, "wall_s": wall,
           "health": percentiles(health), "request": percentiles(times),
           "status_counts": {str(s): statuses.count(s) for s in sorted(set(statuses))}}
    print(f"  /health while {n} {label} run: p50 {out['health']['p50_ms']:.2f} ms  p95 "
          f"{out['health']['p95_ms']:.2f} ms (n={out['health']['n']}); "
          f"{path} statuses {out['status_counts']}, p95 {out['request']['p95_ms']:.0f} ms, wall {wall:.1f} s")
    return out


def bench_starvation(n_ik: int = 45, max_time: float = 0.5) -> dict:
    """``/health`` latency while ``n_ik`` unreachable ``/ik`` run at once."""
    far = np.eye(4)
    far[:3, 3] = (3.0, 0.0, 0.5)  # 3 m away: out of the Panda's reach
    body = json.dumps({"robot": "panda", "target": far.tolist(), "max_time": max_time}).encode()
    return health_under_load("/ik", body, n_ik, max_time, "unreachable /ik")


def bench_planning_load(n_plans: int = 20, max_time: float = 0.5) -> dict:
    """``/health`` latency while ``n_plans`` ``/plan/motion`` run at once, each searching for its whole
    ``max_time`` (the Panda's hand caged: ``tests/service_scenes.py``)."""
    body = json.dumps({"robot": "panda", "start": scenes.READY, "goal": scenes.ASIDE,
                       "obstacles": scenes.cage(), "max_time": max_time}).encode()
    return health_under_load("/plan/motion", body, n_plans, max_time, "caged /plan/motion")


def bench_batch(n: int, with_ray: bool) -> dict:
    panda = robots.load("panda", geometry=False)
    targets = panda.fk_batch(panda.random_q(1, n=n), "panda_link8")
    out: dict = {"targets": n}
    runs = [("processes", 1), ("processes", 2)]
    if with_ray:
        if importlib.util.find_spec("ray") is not None:
            runs.append(("ray", 2))
        else:
            out["ray"] = "skipped: the optional extra 'ray' is not installed (pip install kinserve[ray])"
            print(f"  {out['ray']}")
    else:
        out["ray"] = "skipped: --no-ray"
    for backend, procs in runs:
        label = f"{backend}_{procs}"
        try:
            if backend == "ray":
                import ray

                ray.init(num_cpus=procs, include_dashboard=False, log_to_driver=False)
            ik.solve_many(panda, targets[:200], frame="panda_link8", backend=backend, processes=procs, seed=0,
                          progress=False)
            t0 = time.perf_counter()
            res = ik.solve_many(panda, targets, frame="panda_link8", backend=backend, processes=procs, seed=0,
                                progress=False)
            dt = time.perf_counter() - t0
            out[label] = {"seconds": dt, "targets_per_s": n / dt, "success": sum(r.success for r in res) / n}
            print(f"  solve_many {backend} x{procs}: {n / dt:9.0f} targets/s  success "
                  f"{100 * out[label]['success']:.1f} %")
        except Exception as exc:  # noqa: BLE001 - an optional backend must not sink the whole benchmark
            out[label] = f"failed: {type(exc).__name__}: {exc}"
            print(f"  solve_many {backend} x{procs}: {out[label]}")
        finally:
            if backend == "ray":
                import ray

                ray.shutdown()
    if isinstance(out.get("processes_1"), dict) and isinstance(out.get("processes_2"), dict):
        out["speedup_2_over_1"] = out["processes_2"]["targets_per_s"] / out["processes_1"]["targets_per_s"]
        print(f"  2 processes / 1 process: {out['speedup_2_over_1']:.2f}x (target >= 1.8x)")
    return out


def summary(rows: list[dict], starvation: dict, planning: dict, batch: dict) -> dict:
    def p50(server, path, workers=1, clients=1):
        return next(r["p50_ms"] for r in rows if (r["server"], r["endpoint"], r["workers"], r["clients"]) ==
                    (server, path, workers, clients))

    ratio = p50("kinserve", "/fk") / p50("bare", "/fk")
    out = {
        "fk_p50_over_bare": {"value": ratio, "target": 1.5, "met": ratio <= 1.5},
        "health_p95_ms_under_45_unreachable_ik": {"value": starvation["health"]["p95_ms"], "target": 50.0,
                                                  "met": starvation["health"]["p95_ms"] <= 50.0},
        "health_p95_ms_under_20_plans": {"value": planning["health"]["p95_ms"], "target": 50.0,
                                         "met": planning["health"]["p95_ms"] <= 50.0},
    }
    if "speedup_2_over_1" in batch:
        out["solve_many_2_over_1"] = {"value": batch["speedup_2_over_1"], "target": 1.8,
                                      "met": batch["speedup_2_over_1"] >= 1.8}
    for k, v in out.items():
        print(f"  {k}: {v['value']:.3g} (target {v['target']}) {'met' if v['met'] else 'NOT met'}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--requests", type=int, default=400, help="requests per (server, endpoint, client count)")
    ap.add_argument("--batch", type=int, default=4000, help="targets for solve_many")
    ap.add_argument("--no-ray", action="store_true", help="skip the Ray backend even when installed")
    ap.add_argument("--out", default="bench-out/service.json")
    args = ap.parse_args()
    m = machine()
    print(f"machine: {m['cpu']} ({m['cores']} cores), Python {m['python']}")
    print("latency, raw keep-alive clients (bare FastAPI reference vs kinserve)")
    rows = bench_latency(args.requests)
    print("starvation")
    starvation = bench_starvation()
    planning = bench_planning_load()
    print("batch IK")
    batch = bench_batch(args.batch, with_ray=not args.no_ray)
    print("targets")
    targets = summary(rows, starvation, planning, batch)
    write_json(args.out, {"machine": m, "latency": rows, "starvation": starvation, "planning_load": planning,
                          "batch": batch, "targets": targets})


if __name__ == "__main__":
    main()
