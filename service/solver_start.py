"""The initializer of a solver process: follow the server first, then import the solvers.

A solver process is spawned (:mod:`service.executor`): a fresh interpreter that
imports what its initializer's module imports before it runs the initializer.
This module imports only the standard library and :mod:`service.lifeline`, so
the process follows its server (:func:`service.lifeline.follow_parent`) a few
hundred milliseconds after it starts; only then does it import NumPy,
Pinocchio, Numba and the solvers (:func:`service.jobs.init_worker`, seconds on
a loaded host). A server killed in those seconds takes the process with it
(the kernel's parent-death signal), instead of leaving it to finish importing
as an orphan first.
"""

from __future__ import annotations

from .lifeline import follow_parent


def start_solver(parent_pid: int, settings_json: str | None = None) -> None:
    """Set up a solver process started by the server of pid ``parent_pid`` (``os.getpid()`` there):
    follow that server (end with it), then set up the solvers with the server's settings (JSON of
    :class:`service.settings.ServiceSettings`, or None for the defaults)."""
    follow_parent(parent_pid)
    from .jobs import init_worker

    init_worker(settings_json)


__all__ = ["start_solver"]
