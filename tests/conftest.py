"""Shared fixtures: models built straight from Pinocchio so kinematics tests do not depend on robots/."""

import contextlib
import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

os.environ.setdefault("MPLBACKEND", "Agg")
# computed collision pairs are cached on disk: keep the tests' cache out of the user's ~/.cache
if "KINSERVE_CACHE_DIR" not in os.environ:
    import atexit
    import shutil
    import tempfile

    os.environ["KINSERVE_CACHE_DIR"] = tempfile.mkdtemp(prefix="kinserve-test-cache-")
    atexit.register(shutil.rmtree, os.environ["KINSERVE_CACHE_DIR"], True)


def erd_share_dir() -> Path:
    """The `share` dir of example-robot-data inside this interpreter's site-packages."""
    for entry in sys.path:
        cand = Path(entry) / "cmeel.prefix" / "share"
        if (cand / "example-robot-data" / "robots").is_dir():
            return cand
    pytest.skip("example-robot-data not installed")


@pytest.fixture(scope="session")
def panda_model():
    import pinocchio as pin

    share = erd_share_dir()
    path = share / "example-robot-data/robots/panda_description/urdf/panda.urdf"
    model = pin.buildModelFromUrdf(str(path))
    lock = [model.getJointId("panda_finger_joint1"), model.getJointId("panda_finger_joint2")]
    return pin.buildReducedModel(model, lock, pin.neutral(model))


@pytest.fixture
def panda(panda_model):
    from kinserve.kinematics import Robot

    return Robot(panda_model, tip="panda_link8", name="panda")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture
def fresh_registry():
    """The robot registry's parsed models dropped before and after the test (each load parses again).
    A module takes it for every test with ``pytestmark = pytest.mark.usefixtures("fresh_registry")``."""
    from kinserve import robots

    robots.clear_cache()
    yield
    robots.clear_cache()



# ------------------------------------------------------------ no process left behind
# A per-session tag in the environment: every process started by this pytest process (or by an
# xdist worker: each worker re-imports this file and sets its own) inherits it, orphans included.
from process_leaks import TAG, leftovers, wait_gone  # noqa: E402

os.environ[TAG] = f"{os.getpid()}-{os.urandom(6).hex()}"


def _shut_down_persistent_pools() -> None:
    """Worker pools the library keeps on purpose between calls are stopped through their public API."""
    for module_name in ("kinserve.ik.batch.solve_many",):
        shutdown = getattr(sys.modules.get(module_name), "shutdown_pool", None)
        if shutdown is not None:
            shutdown()


def _resource_tracker_pid() -> int | None:
    """multiprocessing's resource tracker of this interpreter (started with the first spawned process).

    It is not a leftover: it ends when this interpreter exits (its pipe closes), after the interpreter's
    own finalizers have released the semaphores and shared memory it tracks. Stopping it earlier made it
    unlink those resources while still in use, and the finalizers then printed FileNotFoundError
    tracebacks at exit.
    """
    tracker = sys.modules.get("multiprocessing.resource_tracker")
    return None if tracker is None else getattr(tracker._resource_tracker, "_pid", None)


def _report_leftovers(session, message: str) -> None:
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if reporter is not None:
        reporter.ensure_newline()
        reporter.write_sep("!", "LEFTOVER PROCESSES", red=True, bold=True)
        reporter.write_line(message)
    else:
        print(message, file=sys.stderr)
    session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_testnodedown(node, error):
    """xdist controller: collect what each worker found (see pytest_sessionfinish)."""
    message = getattr(node, "workeroutput", {}).get("leftover_processes")
    if message:
        node.config._kinserve_leftovers = [*getattr(node.config, "_kinserve_leftovers", []), message]


def pytest_sessionfinish(session, exitstatus):
    """Fail the session if a process the tests started is still alive (checked per xdist worker); kill it.

    A worker hands its finding to the controller through ``workeroutput``
    (an xdist worker's own exit status does not fail the run).
    """
    config = session.config
    if getattr(config.option, "dist", "no") != "no" and not hasattr(config, "workerinput"):
        for message in getattr(config, "_kinserve_leftovers", []):  # the xdist controller
            _report_leftovers(session, message)
        return
    _shut_down_persistent_pools()
    left = leftovers(os.environ[TAG])
    left.pop(_resource_tracker_pid(), None)
    # give just-stopped servers (ray, uvicorn, chromium) a moment - on a busy machine a long one (polled:
    # no cost when they are gone)
    still = wait_gone(left, timeout=30.0)
    if not still:
        return
    worker = getattr(config, "workerinput", {}).get("workerid", "")
    lines = [f"  pid {pid}: {left[pid][:200]}" for pid in sorted(still)]
    message = (f"processes started by the tests{' on xdist worker ' + worker if worker else ''} were still "
               "alive at the end of the session (now killed):\n" + "\n".join(lines))
    for pid in still:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)
    if hasattr(config, "workeroutput"):
        config.workeroutput["leftover_processes"] = message
    _report_leftovers(session, message)
