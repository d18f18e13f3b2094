"""Ray execution backend of :func:`ik.solve_many` (``backend="ray"``).

The batch is cut into the same chunks as the local backends. One Ray actor
per worker receives the robot **once** (Ray pickles a ``Robot`` as its
kinematic model, without meshes) together with the solve options, builds
its :class:`ik.batch.worker.Job` once, then solves whole chunks
(:func:`ik.batch.worker.solve_chunk`) and returns the same compact arrays
as a local worker, so results are identical, target for target, to the
``"processes"`` backend for the same seed.

Time limits are those of the local pool (:mod:`ik.batch.runners`), with the
actor's start timed apart (:mod:`ik.batch.ray_actors`): an actor not started
after :data:`~ik.batch.ray_actors.ACTOR_START_LIMIT` seconds, or still on its
chunk ``chunk_limit(n)`` seconds after it began, or the overall ``deadline``,
kills every actor and raises
:class:`kinserve.kinematics.errors.WorkerTimeoutError`.

``ray.init(address=...)`` joins an existing cluster when an address is
given (``ray_address="host:port"`` of its GCS, ``"auto"`` for the cluster
``ray start`` left on this machine, or ``"ray://host:10001"`` for Ray
Client); otherwise a local Ray with ``processes`` CPUs is started and left
running for later batches (``ray.shutdown()`` stops it). Install with
``pip install kinserve[ray]``.

Joining is bounded in time (:func:`ensure_ray`): Ray itself retries an
unanswering address for many minutes, so the address is checked first. A
malformed address (no port, a port outside 1..65535), "auto" with no cluster
found, a host that refuses or does not accept a TCP connection within
:data:`TCP_LIMIT` seconds, and a GCS address where no Ray GCS answers within
:data:`JOIN_LIMIT` seconds (probed in a child process that is killed at the
limit, e.g. a port held by some other server) all raise
:class:`~kinserve.kinematics.errors.InputError` naming the address, as does
any error of ``ray.init`` itself. A ``ray://`` address gets the TCP check
only; Ray Client then gives up on its own after a few attempts (about 30 s
with Ray's defaults).
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import TYPE_CHECKING

from kinserve.ik.batch.ray_actors import BatchLabels, run_on_new_actors
from kinserve.ik.batch.worker import Job, limit_blas_threads, solve_chunk
from kinserve.kinematics.errors import InputError
from kinserve.kinematics.validation import describe

if TYPE_CHECKING:  # annotations only
    import numpy as np

    from kinserve.kinematics.robot import Robot


def _ray():
    try:
        import ray
    except ImportError:  # pragma: no cover - depends on the installation
        raise InputError("backend='ray' needs Ray: pip install 'kinserve[ray]'") from None
    return ray


TCP_LIMIT = 5.0  #: seconds a cluster's host has to accept a TCP connection
JOIN_LIMIT = 30.0  #: seconds a Ray GCS has to answer (:func:`ensure_ray`)
_HINT = ("start one with `ray start --head`, or give no address (ray_address=None; no --ray-address on the "
         "command line) to start a local Ray")
# run by a child process: connect to the GCS at argv[1] as Ray's own client does, and ask its cluster id
_GCS_PROBE = """import sys
from ray import _raylet
inner = getattr(_raylet, "InnerGcsClient", None)
if hasattr(inner, "standalone"):
    inner.standalone(sys.argv[1], None, int(sys.argv[2]))
else:
    _raylet.GcsClient(address=sys.argv[1])
"""


def _address_error(message: str) -> InputError:
    """An :class:`InputError` about the argument ``ray_address``."""
    exc = InputError(message)
    exc.argument = "ray_address"
    return exc


def _first_line(exc: BaseException) -> str:
    """The first non-empty line of ``exc``'s message (Ray's can run over many lines), or its class name."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[0] if lines else type(exc).__name__


def split_address(address: str) -> tuple[str, int]:
    """``(host, port)`` of ``"host:port"``, ``"[ipv6]:port"`` or ``"ray://host:port"``.

    Raises :class:`InputError` naming ``address`` when the host is missing or the
    port is not a whole number in 1..65535."""
    rest = address.split("://", 1)[1] if "://" in address else address
    host, colon, port = rest.rpartition(":")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    elif ":" in host:  # an IPv6 address needs its brackets to be told from its port
        host = ""
    port_ok = port.isascii() and port.isdigit() and 1 <= int(port) <= 65535
    if not colon or not host or host != host.strip() or not port_ok:
        raise _address_error(f"ray_address {describe(address)} is not a Ray address: expected 'host:port' "
                             "(port 1..65535), '[ipv6]:port', 'ray://host:port', 'auto' or 'local'")
    return host, int(port)


def _cluster_address(address: str) -> str:
    """The address ``ray.init(address=address)`` would join: ``RAY_ADDRESS`` replaces ``"auto"``, and
    ``"auto"`` finds the cluster that ``ray start`` left on this machine (:class:`InputError` if none)."""
    if address != "auto":
        return address
    if os.environ.get("RAY_ADDRESS"):
        return os.environ["RAY_ADDRESS"]
    try:
        from ray._private.services import canonicalize_bootstrap_address
    except ImportError:  # pragma: no cover - another Ray layout: leave "auto" to ray.init
        return address
    try:
        return canonicalize_bootstrap_address("auto") or address
    except (ConnectionError, ValueError) as exc:
        raise _address_error(f"ray_address 'auto' found no running Ray cluster on this machine "
                             f"({_first_line(exc)}); {_HINT}") from None


def _check_tcp(shown: str, host: str, port: int, limit: float) -> None:
    """Raise :class:`InputError` (about the address ``shown``) unless ``host:port`` accepts a TCP
    connection within ``limit`` seconds."""
    try:
        with socket.create_connection((host, port), timeout=limit):
            pass
    except socket.gaierror as exc:
        why = f"unknown host {host!r}: {exc.strerror}"
    except TimeoutError:
        why = f"no TCP connection within {limit:g} s"
    except OSError as exc:
        why = (exc.strerror or _first_line(exc)).lower()
    else:
        return
    raise _address_error(f"no Ray cluster answers at {shown} ({why}); {_HINT}")


def _check_gcs(shown: str, target: str, limit: float) -> None:
    """Raise :class:`InputError` (about the address ``shown``) unless a Ray GCS answers at ``target``
    (``host:port``) within ``limit`` seconds; asked by a child process, killed at the limit (Ray's own
    client retries for minutes)."""
    try:
        done = subprocess.run([sys.executable, "-c", _GCS_PROBE, target, str(int(limit * 1000))],
                              capture_output=True, text=True, timeout=limit, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        raise _address_error(f"no Ray cluster answered at {shown} within {limit:g} s (the port accepts "
                             f"connections but no Ray GCS replied); {_HINT}") from None
    if done.returncode != 0:
        lines = [line.strip() for line in done.stderr.splitlines() if line.strip()]
        why = lines[-1] if lines else f"the probe exited with status {done.returncode}"
        raise _address_error(f"no Ray cluster answers at {shown} ({why}); {_HINT}")


def check_cluster(address: str, limit: float = JOIN_LIMIT) -> None:
    """Check, within about ``TCP_LIMIT + limit`` seconds, that ``ray.init(address=address)`` has a
    cluster to join; raise :class:`InputError` naming ``address`` and what was expected if not.

    ``"local"`` (Ray starts its own) is not checked; a ``ray://`` address (Ray Client) gets the TCP
    check only."""
    target = _cluster_address(address)
    if target in ("local", "auto"):
        return
    host, port = split_address(target)
    shown = address if target == address else f"{address} ({target})"
    _check_tcp(shown, host, port, min(TCP_LIMIT, limit))
    if "://" not in target:
        _check_gcs(shown, target, limit)


def refuse_unused_address(ray_address: object, backend: str) -> None:
    """:class:`InputError` when a ``ray_address`` is given with a ``backend`` other than ``"ray"``, which
    would ignore it (``ik.solve_many``, ``plan_many``)."""
    if ray_address is not None and backend != "ray":
        raise InputError(f"ray_address is for backend='ray' only (backend={backend!r} would ignore it), got "
                         f"ray_address={ray_address!r:.80}")


def ensure_ray(address: str | None = None, num_cpus: int | None = None,
               join_limit: float = JOIN_LIMIT) -> ModuleType:
    """Connect to Ray (``address``) or start a local instance with ``num_cpus`` CPUs; return the module.

    A given ``address`` is checked first (:func:`check_cluster`, bounded by ``join_limit`` seconds for
    the GCS to answer), so joining a cluster that is not there fails in bounded time instead of
    waiting on Ray's retries. Raises :class:`InputError` naming the address for a malformed or
    unanswering address and for any error of ``ray.init``; does nothing if Ray is already initialised.
    """
    if address is not None and (not isinstance(address, str) or not address.strip()):
        raise _address_error(f"ray_address must be a Ray address such as 'host:6379', 'auto' or "
                             f"'ray://host:10001', or None for a local Ray; got {describe(address)}")
    ray = _ray()
    if ray.is_initialized():
        return ray
    kwargs = {"include_dashboard": False, "log_to_driver": False, "ignore_reinit_error": True}
    if address:
        check_cluster(address, join_limit)
        what, kwargs = f"cannot join the Ray cluster at {address}", {"address": address, **kwargs}
    else:
        what, kwargs = "cannot start a local Ray", {"num_cpus": num_cpus, **kwargs}
        if os.environ.get("RAY_ADDRESS"):
            what += f" (RAY_ADDRESS={os.environ['RAY_ADDRESS']} is set: Ray joins that cluster instead)"
    try:
        ray.init(**kwargs)
    except (OSError, RuntimeError, ValueError, ray.exceptions.RayError) as exc:
        raise _address_error(f"{what}: {_first_line(exc)}") from None
    return ray


class _ChunkSolver:
    """Body of the Ray actor: holds the job (robot, keywords, options) built once, solves its chunks."""

    def __init__(self, robot, common, options, keep_history):
        limit_blas_threads()
        # the request built here warms the robot's IK state (seed table, compiled chains) once per actor
        self.job = Job(robot, common["kwargs"], options, keep_history, common["frame"])

    def ready(self) -> bool:
        """Answers once ``__init__`` has run (:func:`~ik.batch.ray_actors.run_on_actors` times the start)."""
        return True

    def solve(self, start, poses, q0s):
        return solve_chunk(self.job, start, poses, q0s)


def run_ray_chunks(robot: Robot, chunks: Sequence[tuple[int, int]],
                   chunk_data: Callable[[int, int], tuple[np.ndarray, np.ndarray | None]], common: dict,
                   options: dict, keep_history: bool, processes: int, on_done: Callable[[dict], None],
                   chunk_limit: Callable[[int], float], address: str | None = None,
                   deadline: float | None = None) -> None:
    """Solve ``chunks`` (``(start, stop)`` target indices; ``chunk_data(start, stop)`` gives their
    ``(poses, q0s)``) on ``processes`` actors; ``on_done(result)`` for each. The actors' start and each
    chunk are timed apart (:mod:`ik.batch.ray_actors`)."""
    ray = ensure_ray(address, processes)
    run_on_new_actors(ray, _ChunkSolver, (ray.put(robot), common, options, keep_history), processes, chunks,
                      lambda actor, start, stop: actor.solve.remote(start, *chunk_data(start, stop)),
                      lambda _, result: on_done(result), chunk_limit, deadline,
                      BatchLabels("ik.solve_many:", "targets"))
