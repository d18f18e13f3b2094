"""The service's limits: one frozen record, set by ``kinserve serve`` options, passed to worker processes.

Every request is bounded in time and memory (ARCHITECTURE.md). The knobs:

=====================  =========================  ==========================================================
field                  ``kinserve serve`` option  meaning
=====================  =========================  ==========================================================
max_time_cap           ``--max-time-cap``         upper bound (s) on one IK solve's ``max_time``
request_time_cap       ``--request-time-cap``     upper bound (s) on a whole ``/ik/batch`` or
``/plan/cartesian``
                                                  request, queueing included
max_body               ``--max-body``             request bodies above this many bytes get 413
body_timeout           ``--body-timeout``         a body not fully received within this many s gets 408
header_timeout         ``--header-timeout``       a connection that has not sent complete request headers
                                                  within this many s (after connecting or after its last
                                                  response's keep-alive gap began) is closed
keep_alive             ``--keep-alive``           idle keep-alive connections are closed after this many s
max_connections        ``--max-connections``      sockets beyond this are closed right after accept;
                                                  requests beyond it (tasks) get 503
solver_threads         ``--solver-threads``       solver processes of the heavy-work executor (default: the
                                                  cores, divided among ``--workers``)
queue                  ``--queue``                heavy requests waiting for a solver thread; more get 503
robot_cache            ``--robot-cache``          robot variants (name + params) kept in memory
robot_cache_bytes      ``--robot-cache-mb``       their estimated memory, seed tables included
access_log             ``--access-log``           one log line per request (off by default: it costs
                                                  0.02-0.16 ms per request)
=====================  =========================  ==========================================================

With ``--workers N`` each worker process reads the settings from the
environment variable :data:`ENV_VAR` (JSON), since uvicorn imports
``kinserve.service.app:app`` afresh in every worker.

Every field has an upper bound (:data:`MAXIMUM`): times at most one day, ``max_body`` at most 1 GiB,
``robot_cache_bytes`` at most 64 GiB, counts at most 10**6 (``solver_threads`` 1024, ``robot_cache``
10**4). A value above it, NaN, infinite, negative, a bool or text is refused with ``ValueError``.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, fields

#: Environment variable carrying :class:`ServiceSettings` as JSON to worker processes.
ENV_VAR = "KINSERVE_SERVICE_SETTINGS"


#: Largest accepted value of each numeric setting.
MAXIMUM: dict[str, float] = {
    "max_time_cap": 86400.0, "request_time_cap": 86400.0, "body_timeout": 86400.0,
    "header_timeout": 86400.0, "keep_alive": 86400.0,
    "max_body": 1 << 30, "max_connections": 10**6, "solver_threads": 1024, "queue": 10**6,
    "robot_cache": 10**4, "robot_cache_bytes": 64 << 30,
}

#: Unit of each setting in messages.
UNIT: dict[str, str] = {name: " s" for name in ("max_time_cap", "request_time_cap", "body_timeout",
                                                 "header_timeout", "keep_alive")}
UNIT.update(max_body=" bytes", robot_cache_bytes=" bytes")


@dataclass(frozen=True)
class ServiceSettings:
    """Limits of one service process (see the module docstring for each field)."""

    max_time_cap: float = 5.0
    request_time_cap: float = 60.0
    max_body: int = 1 << 20
    body_timeout: float = 10.0
    header_timeout: float = 10.0
    keep_alive: float = 5.0
    max_connections: int = 1000
    solver_threads: int = 0  #: solver processes; 0 = ``os.cpu_count()``
    queue: int = 256
    robot_cache: int = 64
    robot_cache_bytes: int = 256 << 20
    access_log: bool = False

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if f.type == "bool":
                continue
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and v == v and v >= 0
                                           and v != float("inf")):
                raise ValueError(f"service setting {f.name} must be a finite number >= 0, got {v!r}")
            if v > MAXIMUM[f.name]:
                raise ValueError(f"service setting {f.name} must be at most {MAXIMUM[f.name]:g}"
                                 f"{UNIT.get(f.name, '')}, got {v!r}")
        for name in ("max_time_cap", "request_time_cap", "body_timeout", "header_timeout", "keep_alive"):
            if getattr(self, name) <= 0:
                raise ValueError(f"service setting {name} must be > 0 s, got {getattr(self, name)!r}")
        for name in ("max_body", "max_connections", "robot_cache", "robot_cache_bytes"):
            if getattr(self, name) < 1:
                raise ValueError(f"service setting {name} must be >= 1, got {getattr(self, name)!r}")

    @property
    def threads(self) -> int:
        """Solver processes actually used: ``solver_threads`` or the number of cores."""
        return self.solver_threads or max(1, os.cpu_count() or 1)

    def to_env(self) -> str:
        """The settings as JSON text, the form :meth:`from_env` reads."""
        return json.dumps(asdict(self))

    @classmethod
    def from_env(cls, environ=None) -> "ServiceSettings":
        """Settings from :data:`ENV_VAR` (defaults when unset)."""
        text = (os.environ if environ is None else environ).get(ENV_VAR)
        return cls(**json.loads(text)) if text else cls()
