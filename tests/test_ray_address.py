"""Joining a Ray cluster (``ray_address``) is bounded in time; failing is a kinserve error naming the address.

``ray.init(address=...)`` retries an unanswering address for many minutes, so every call that could hang runs
in a child process with a timeout: a hang fails the test instead of hanging the suite. Each child carries its
own process tag (:mod:`process_leaks`), so a Ray it started and left behind, orphans included, is found.
"""

import gc
import os
import socket
import subprocess
import sys
import tempfile
import threading
import warnings

import pytest

from process_leaks import TAG, carries_tag, leftovers, wait_gone

ray = pytest.importorskip("ray")

from kinserve.ik.batch.ray_backend import split_address  # noqa: E402
from kinserve.kinematics.errors import InputError  # noqa: E402

HINT = "start one with `ray start --head`"
HANG_GUARD = 60  # seconds; a hang guard only, far above the checks' own limits (5 s TCP, 30 s GCS)

CHILD = """import sys
import numpy as np
from kinserve import ik, planners, robots
from kinserve.ik.batch.ray_backend import ensure_ray
from kinserve.kinematics.errors import InputError
try:
    ray = {call}
except InputError as exc:
    print("InputError:", exc, "| argument:", exc.argument)
else:
    print("joined", ray.is_initialized(), ray.cluster_resources().get("CPU"))
    ray.shutdown()
"""


def child_env() -> dict[str, str]:
    """This environment without ``RAY_ADDRESS`` (which Ray reads for "auto"), with a fresh process tag."""
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    return {**env, TAG: f"ray-address-{os.urandom(6).hex()}"}


def run_child(call: str, *args: str, ray_address_env: str | None = None) -> str:
    """Run ``call`` (Python; ``sys.argv[1:]`` are ``args``) in a child process with a fresh process tag (and
    ``RAY_ADDRESS=ray_address_env`` if given); return what it printed. Fails if the child hangs, exits
    non-zero, or leaves a process behind."""
    env = child_env() | ({} if ray_address_env is None else {"RAY_ADDRESS": ray_address_env})
    try:
        done = subprocess.run([sys.executable, "-c", CHILD.format(call=call), *args], env=env,
                              capture_output=True, text=True, timeout=HANG_GUARD)
    finally:
        assert_nothing_left(env[TAG])
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr[-2000:]
    return done.stdout.strip()


def assert_nothing_left(tag: str) -> None:
    """No live process carries ``tag`` (a Ray started and not stopped would); any found is killed."""
    left = {pid: line for pid, line in leftovers(tag).items() if carries_tag(pid, tag)}  # not our children
    still = wait_gone(left, timeout=30.0)
    for pid in still:
        os.kill(pid, 9)
    assert not still, f"processes left behind: {[left[p] for p in still]}"


@pytest.fixture
def silent_port():
    """A loopback port that accepts TCP connections and never answers (not a Ray GCS)."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.1)  # accept() wakes up to see `stop`
    accepted, stop = [], threading.Event()

    def accept():
        while not stop.is_set():
            try:
                accepted.append(server.accept()[0])
            except TimeoutError:
                pass

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield server.getsockname()[1]
    stop.set()
    thread.join(5)
    server.close()
    for conn in accepted:
        conn.close()


def test_a_refused_port_is_an_input_error_naming_the_address():
    out = run_child("ensure_ray(sys.argv[1])", "127.0.0.1:1")
    assert out.startswith("InputError: no Ray cluster answers at 127.0.0.1:1 (connection refused);"), out
    assert HINT in out and out.endswith("| argument: ray_address")


def test_solve_many_and_plan_many_on_a_refused_port_raise_input_error():
    scara = "robots.load('scara', geometry=False)"
    refused = "InputError: no Ray cluster answers at 127.0.0.1:1 (connection refused);"
    call = f"ik.solve_many({scara}, [np.eye(4)], backend='ray', ray_address=sys.argv[1], progress=False)"
    assert run_child(call, "127.0.0.1:1").startswith(refused)
    call = (f"planners.plan_many(r := {scara}, [(r.random_q(1), r.random_q(2))], backend='ray', "
            "ray_address=sys.argv[1])")
    assert run_child(call, "127.0.0.1:1").startswith(refused)


def test_a_port_that_is_not_a_ray_gcs_gives_up_at_the_limit(silent_port):
    address = f"127.0.0.1:{silent_port}"
    out = run_child("ensure_ray(sys.argv[1], join_limit=2.0)", address)
    assert out.startswith(f"InputError: no Ray cluster answered at {address} within 2 s "
                          "(the port accepts connections but no Ray GCS replied);"), out


def test_an_http_server_is_not_a_ray_gcs_either():
    from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

    class Quiet(BaseHTTPRequestHandler):
        def log_message(self, *args):  # the gRPC probe's HTTP/2 preface is a bad request to it
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Quiet)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        address = f"127.0.0.1:{server.server_address[1]}"
        out = run_child("ensure_ray(sys.argv[1], join_limit=2.0)", address)
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)
    assert out.startswith(f"InputError: no Ray cluster answered at {address} within 2 s"), out


def test_a_ray_client_address_gets_the_tcp_check():
    out = run_child("ensure_ray(sys.argv[1])", "ray://127.0.0.1:1")
    assert out.startswith("InputError: no Ray cluster answers at ray://127.0.0.1:1 (connection refused);"), \
        out


def test_an_unknown_host_is_named():
    out = run_child("ensure_ray(sys.argv[1])", "no-such-host.invalid:6379")
    assert out.startswith("InputError: no Ray cluster answers at no-such-host.invalid:6379 "
                          "(unknown host 'no-such-host.invalid'"), out


def _ray_cluster_running() -> bool:
    return subprocess.run(["pgrep", "-f", "gcs_server"], capture_output=True).returncode == 0


def test_auto_without_a_cluster_is_an_input_error():
    if _ray_cluster_running():
        pytest.skip("a Ray cluster runs on this machine: 'auto' would find it")
    out = run_child("ensure_ray('auto')")
    if out.startswith("joined"):
        pytest.skip("a Ray cluster started on this machine meanwhile")
    assert out.startswith("InputError: ray_address 'auto' found no running Ray cluster on this machine"), out
    assert HINT in out


def test_ray_address_in_the_environment_is_named():
    """Ray reads RAY_ADDRESS for "auto" and for no address: both fail naming it, neither waits."""
    out = run_child("ensure_ray('auto')", ray_address_env="127.0.0.1:1")
    assert out.startswith("InputError: no Ray cluster answers at auto (127.0.0.1:1) (connection refused);"), \
        out
    out = run_child("ensure_ray(None, 2)", ray_address_env="127.0.0.1:1")
    assert out.startswith("InputError: cannot start a local Ray (RAY_ADDRESS=127.0.0.1:1 is set: Ray joins "
                          "that cluster instead): "), out


@pytest.mark.parametrize("address", ["127.0.0.1", "127.0.0.1:", ":6379", "host:0", "host:65536", "host:http",
                                     "host:6379x", "::1:6379", "ray://", "ray://host", " host:6379"])
def test_malformed_addresses_are_refused_at_once(address):
    with pytest.raises(InputError, match=r"ray_address .* is not a Ray address: expected 'host:port' "
                                         r"\(port 1\.\.65535\)") as info:
        split_address(address)
    assert info.value.argument == "ray_address"


@pytest.mark.parametrize("address, expected", [("127.0.0.1:6379", ("127.0.0.1", 6379)),
                                               ("[::1]:6379", ("::1", 6379)),
                                               ("ray://head.example:10001", ("head.example", 10001)),
                                               ("h:65535", ("h", 65535)), ("h:1", ("h", 1))])
def test_well_formed_addresses_split(address, expected):
    assert split_address(address) == expected


@pytest.mark.parametrize("address", [5, "", "   ", b"127.0.0.1:1"])
def test_a_non_text_or_empty_address_is_refused_before_ray(address):
    from kinserve.ik.batch.ray_backend import ensure_ray

    with pytest.raises(InputError, match=r"ray_address must be a Ray address such as 'host:6379', 'auto' or "
                                         r"'ray://host:10001', or None for a local Ray; got "):
        ensure_ray(address)
    assert not ray.is_initialized()


def test_the_cli_exits_2_with_one_line_naming_the_address(tmp_path):
    exe = os.path.join(os.path.dirname(sys.executable), "kinserve")
    env = child_env()
    try:
        done = subprocess.run([exe, "reach", "panda", "--samples", "10", "--backend", "ray", "--ray-address",
                               "127.0.0.1:1", "--out", str(tmp_path / "reach")], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=HANG_GUARD)
    finally:
        assert_nothing_left(env[TAG])
    assert done.returncode == 2, (done.stdout, done.stderr)
    assert "Traceback" not in done.stdout + done.stderr
    assert done.stderr.strip().splitlines() == [
        "error: no Ray cluster answers at 127.0.0.1:1 (connection refused); start one with "
        "`ray start --head`, or give no address (ray_address=None; no --ray-address on the command line) to "
        "start a local Ray"]
    assert not list(tmp_path.iterdir())  # nothing written


def test_a_running_cluster_is_joined():
    """The checks let a real cluster through: a child joins this process's local Ray by its GCS address, as
    Ray gives it and on loopback. ('auto' is not tried: it could find another Ray running on this machine.)"""
    if ray.is_initialized():
        pytest.skip("Ray already runs in this process")
    with tempfile.TemporaryDirectory(prefix="kr") as temp:  # short: Ray's socket paths live under it
        with warnings.catch_warnings():  # Ray's own probe socket, collected here (as in test_ik_ray_backend)
            warnings.simplefilter("ignore", ResourceWarning)
            ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False, _temp_dir=temp)
            gc.collect()
        try:
            gcs = ray.get_runtime_context().gcs_address
            port = gcs.rsplit(":", 1)[1]
            for address in (gcs, f"127.0.0.1:{port}"):
                assert run_child("ensure_ray(sys.argv[1])", address) == "joined True 1.0"
        finally:
            ray.shutdown()

