"""Solver processes that end with the server that started them.

A solver process is spawned (:mod:`service.executor`): a fresh interpreter that
imports the server's main module (the command line) and its initializer's module
(:mod:`service.solver_start`) before it runs the initializer; both are light
(NumPy, no Pinocchio or Numba), so that takes a few hundred milliseconds, and
the solvers are imported after :func:`follow_parent`. If the server dies in that
window (``kill -9``, or SIGTERM and then SIGKILL while requests arrive), the
process is re-parented (to ``init`` or a sub-reaper) before it could set up any
watch, and a watch that took "my parent" from ``os.getppid()`` at that point
watched the new parent for ever: the process lived on as an orphan (and with it
multiprocessing's resource tracker, whose pipe it holds). So the server passes
its own pid, and :func:`follow_parent`, the first thing a solver process runs:

1. asks Linux to SIGKILL it when its parent dies (``prctl(PR_SET_PDEATHSIG)``;
   the kernel sends it when the *thread* that started the process ends: the
   service starts its solvers from the event-loop thread, which lives as long as
   the server);
2. then compares ``os.getppid()`` with the pid it was given and exits at once if
   they differ: the parent died before step 1 (closes the race between the
   spawn and the ``prctl``);
3. keeps a watch thread comparing ``os.getppid()`` with that pid every ``poll``
   seconds (where ``prctl`` is missing, or the starting thread is not the
   server's main one).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time

#: Linux ``prctl`` option: the signal the kernel sends a process when the thread that started it ends.
PR_SET_PDEATHSIG = 1


def set_parent_death_signal(sig: int = signal.SIGKILL) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent (thread) ends; False where it cannot
    (not Linux, no libc ``prctl``)."""
    if not sys.platform.startswith("linux"):
        return False
    with contextlib.suppress(OSError, AttributeError):
        return ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(sig)) == 0
    return False


def follow_parent(parent_pid: int, poll: float = 0.5) -> None:
    """End this process (``os._exit(0)``, no clean-up: nothing of it is wanted any more) as soon as
    ``parent_pid`` is not its parent: now, or later when the parent dies (see the module docstring).

    ``parent_pid``: the pid of the process that started this one, as that process saw itself
    (``os.getpid()`` there); ``poll``: seconds between two looks of the watch thread.
    """
    parent_pid = int(parent_pid)
    set_parent_death_signal(signal.SIGKILL)
    if os.getppid() != parent_pid:  # the parent died before the kernel could be told
        os._exit(0)

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(poll)
        os._exit(0)

    threading.Thread(target=watch, name="kinserve-parent-watch", daemon=True).start()


__all__ = ["PR_SET_PDEATHSIG", "follow_parent", "set_parent_death_signal"]
