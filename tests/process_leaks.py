"""Finding processes the tests started and left behind, from ``/proc`` (no psutil needed).

Every process inherits its parent's environment, so ``conftest.py`` puts a
per-session tag into ``os.environ`` (:data:`TAG`) before any test runs; any live
process that carries it in ``/proc/PID/environ`` (other than pytest itself)
was started by this session, even one that was orphaned and re-parented to
``init``, such as a meshcat server whose viewer was killed.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

#: Environment variable holding this pytest process's session tag.
TAG = "KINSERVE_TEST_SESSION"


def alive(pid: int) -> bool:
    """True while ``pid`` exists and is not a zombie (exited, waiting to be reaped)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    state = stat[stat.rindex(")") + 2:].split()[0]  # field 3, after "(comm)" which may hold spaces
    return state not in ("Z", "X")


def parent_of(pid: int) -> int | None:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    return int(stat[stat.rindex(")") + 2:].split()[1])


def command_line(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
    except OSError:
        return "?"


def carries_tag(pid: int, value: str) -> bool:
    try:
        environ = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
    except OSError:  # another user's process, or gone
        return False
    return f"{TAG}={value}".encode() in environ


def leftovers(value: str, me: int | None = None) -> dict[int, str]:
    """Live processes (pid -> command line) that are children of ``me`` or carry session tag ``value``."""
    me = os.getpid() if me is None else me
    found = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == me:
            continue
        pid = int(entry)
        if (parent_of(pid) == me or carries_tag(pid, value)) and alive(pid):
            found[pid] = command_line(pid)
    return found


def wait_gone(pids, timeout: float) -> set[int]:
    """Wait up to ``timeout`` s for ``pids`` to end; returns those still alive."""
    deadline = time.monotonic() + timeout
    left = {p for p in pids if alive(p)}
    while left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = {p for p in left if alive(p)}
    return left
