"""The solver processes (and multiprocessing's resource tracker) end with the server, however it ends.

A real ``kinserve serve`` is killed while busy - SIGTERM then SIGKILL 2 s later, or SIGKILL alone - right
after it answers ``/health`` (its solver processes are then still starting: the race that left orphans)
and while slow plans run; every process that descended from it (seen in ``/proc`` while it lived) must
be gone within :data:`GONE_WITHIN`. A server stopped with SIGTERM prints no warning (issue 24: no "leaked
semaphore").
"""

from __future__ import annotations

import os
import pickle
import signal
import threading
import time

import httpx
import pytest

from import_probe import imported_after
from process_leaks import alive, command_line, parent_of, wait_gone
from service_scenes import ASIDE, READY, cage
from service_server import Server

#: Seconds the server's descendants get to end after it. A solver process spawned just before the kill ends
#: when its interpreter reaches its first line (:func:`service.lifeline.follow_parent`), after importing
#: the command line and NumPy (not the solvers: see the last test of this file): a fraction of a second on a
#: quiet host, seconds on a loaded one, and
#: multiprocessing's resource tracker ends with it. The orphans of the bug this guards against lived for ever;
#: a bound of seconds made the test depend on how busy the machine was (a fresh clone's CI failed on it).
GONE_WITHIN = 60.0
#: A plan that searches for its whole max_time (the hand is caged).
SLOW_PLAN = {"robot": "panda", "start": READY, "goal": ASIDE, "obstacles": cage(), "max_time": 1.0}


def descendants(root: int) -> set[int]:
    """Live processes below ``root`` (children, grandchildren, ...), from ``/proc``."""
    parents = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            ppid = parent_of(int(entry))
            if ppid is not None:
                parents[int(entry)] = ppid
    found, frontier = set(), {root}
    while frontier:
        frontier = {p for p, pp in parents.items() if pp in frontier and p not in found}
        found |= frontier
    return {p for p in found if alive(p)}


class Watcher:
    """Records every descendant of ``pid`` while it lives (a thread looking at ``/proc`` every 20 ms)."""

    def __init__(self, pid: int):
        self.pid, self.seen, self.done = pid, set(), threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self.done.is_set() and alive(self.pid):
            self.seen |= descendants(self.pid)
            time.sleep(0.02)

    def stop(self) -> set[int]:
        self.done.set()
        self.thread.join(5)
        return self.seen


def send_slow_requests(url: str, count: int) -> list[threading.Thread]:
    def one():
        try:
            httpx.post(url + "/plan/motion", json=SLOW_PLAN, timeout=30)
        except httpx.HTTPError:
            pass  # the server was killed under it

    threads = [threading.Thread(target=one, daemon=True) for _ in range(count)]
    for t in threads:
        t.start()
    return threads


def kill_server(srv: Server, how: str) -> None:
    if how == "term-then-kill":
        srv.proc.send_signal(signal.SIGTERM)
        try:
            srv.proc.wait(2.0)
        except Exception:
            srv.proc.kill()
    else:
        srv.proc.kill()
    srv.proc.wait(10)
    srv.proc.stdout.close()


def wait_for_solvers(watcher: Watcher, count: int, timeout: float = 20.0) -> None:
    """Until ``count`` solver processes have been seen (the resource tracker is one more descendant)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        solvers = [p for p in watcher.seen if "multiprocessing" in command_line(p)
                   and "resource_tracker" not in command_line(p)]
        if len(solvers) >= count:
            return
        time.sleep(0.05)


@pytest.mark.parametrize("how", ["term-then-kill", "kill"])
@pytest.mark.parametrize("when", ["starting", "busy"])
def test_no_process_outlives_a_killed_server(how, when):
    srv = Server("--solver-threads", "2", max_time_cap=1.0)
    watcher = Watcher(srv.proc.pid)
    try:
        if when == "starting":  # the solver processes are being spawned by the warm-up right now
            wait_for_solvers(watcher, 1)
            send_slow_requests(srv.url, 4)
            time.sleep(0.1)
        else:  # both solvers run slow requests, more queue behind them
            send_slow_requests(srv.url, 6)
            wait_for_solvers(watcher, 2)
            time.sleep(0.5)
    finally:
        kill_server(srv, how)
    seen = watcher.stop()
    assert seen, "the server started no child process: nothing was tested"
    left = wait_gone(seen, GONE_WITHIN)
    leftovers = {p: command_line(p) for p in left}
    for p in left:  # the test leaves nothing behind either way
        os.kill(p, signal.SIGKILL)
    assert not leftovers, f"processes outlived the server ({how}, {when}): {leftovers}"


def test_sigterm_stops_cleanly_without_warnings():
    srv = Server("--solver-threads", "2", max_time_cap=1.0)
    watcher = Watcher(srv.proc.pid)
    q = [0.0, -0.5, 0.0, -2.0, 0.0, 1.6, 0.8]
    target = httpx.post(srv.url + "/fk", json={"robot": "panda", "q": q}, timeout=30).json()["pose"]
    r = httpx.post(srv.url + "/ik", json={"robot": "panda", "target": target}, timeout=60)
    assert r.status_code == 200
    wait_for_solvers(watcher, 2)
    solvers = {p for p in watcher.seen if "resource_tracker" not in command_line(p)}
    assert len(solvers) >= 2, {p: command_line(p) for p in watcher.seen}
    out = srv.stop()
    seen = watcher.stop()
    assert srv.proc.returncode is not None
    assert "leaked semaphore" not in out and "resource_tracker" not in out, out
    assert "Traceback" not in out and "Warning" not in out, out
    left = wait_gone(seen, GONE_WITHIN)
    assert not left, {p: command_line(p) for p in left}


#: Modules a solver process must not have imported when it starts following its server: the solvers and
#: what they import (seconds of imports on a loaded host, during which an orphan would live on).
SOLVER_IMPORTS = ("numba", "pinocchio", "scipy", "kinserve.service.jobs", "kinserve.kinematics.robot",
                  "kinserve.ik")


def test_a_solver_follows_its_server_before_importing_the_solvers():
    """A spawned solver process runs what multiprocessing's spawn runs before the initializer: the server's
    main module prepared as ``__mp_main__`` (``python -m kinserve.service.cli serve``), then the initializer
    unpickled. Neither may import the solvers; the initializer imports them after it follows the server."""
    from kinserve.service.solver_start import start_solver  # the server's pool's initializer (app.py)

    code = ("import pickle\n"
            "import multiprocessing.spawn as spawn\n"
            "spawn.prepare({'init_main_from_name': 'kinserve.service.cli'})\n"
            f"pickle.loads(bytes.fromhex({pickle.dumps(start_solver).hex()!r}))\n"
            "print(sys.modules['__mp_main__'].__spec__.name)")
    imported, printed = imported_after("import sys\n" + code, SOLVER_IMPORTS)
    assert printed == "kinserve.service.cli", printed  # the main module was prepared: the test tested it
    assert imported == [], f"imported before the solver follows its server: {imported}"
