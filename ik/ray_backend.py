"""Ray execution backend of :func:`ik.solve_many` (``backend="ray"``).

The batch is cut into the same chunks as the local backends. One Ray actor
per worker receives the robot **once** (Ray pickles a ``Robot`` as its
kinematic model, without meshes) together with the solve options, then
solves whole chunks and returns the same compact arrays as a local worker,
so results are identical, target for target, to the ``"processes"`` backend
for the same seed.

``ray.init(address=...)`` joins an existing cluster when an address is
given (``ray_address="auto"`` or ``"ray://host:10001"``); otherwise a local
Ray with ``processes`` CPUs is started and left running for later batches
(``ray.shutdown()`` stops it). Install with ``pip install kinserve[ray]``.
"""

from __future__ import annotations

from kinserve.kinematics.errors import InputError


def _ray():
    try:
        import ray
    except ImportError:  # pragma: no cover - depends on the installation
        raise InputError("backend='ray' needs Ray: pip install 'kinserve[ray]'") from None
    return ray


def ensure_ray(address: str | None = None, num_cpus: int | None = None):
    """Connect to Ray (``address``) or start a local instance with ``num_cpus`` CPUs; return the module."""
    ray = _ray()
    if not ray.is_initialized():
        kwargs = {"include_dashboard": False, "log_to_driver": False, "ignore_reinit_error": True}
        if address:
            ray.init(address=address, **kwargs)
        else:
            ray.init(num_cpus=num_cpus, **kwargs)
    return ray


def run_ray(robot, chunks, common, options, keep_history, processes, on_done, address: str | None = None):
    """Runner with the signature of :data:`ik.batch.BACKENDS` entries (plus ``address``)."""
    from .batch import _solve_chunk
    from .seeds import seed_table

    ray = ensure_ray(address, processes)

    @ray.remote(num_cpus=1)
    class ChunkSolver:
        def __init__(self, robot, common, options, keep_history, frame):
            self.robot = robot
            self.args = (common, options, keep_history)
            seed_table(robot, frame)  # once per actor, as a forked worker inherits it

        def solve(self, start, poses, q0s):
            common, options, keep_history = self.args
            return _solve_chunk(self.robot, common, options, keep_history, start, poses, q0s)

    workers = max(1, min(processes, int(ray.available_resources().get("CPU", processes)) or 1, len(chunks)))
    robot_ref = ray.put(robot)
    actors = [ChunkSolver.remote(robot_ref, common, options, keep_history, common["frame"]) for _ in range(workers)]
    try:
        pending = {}
        queue = list(chunks)
        for actor in actors:
            if queue:
                start, poses, q0s = queue.pop(0)
                pending[actor.solve.remote(start, poses, q0s)] = actor
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            ref = done[0]
            actor = pending.pop(ref)
            on_done(ray.get(ref))
            if queue:
                start, poses, q0s = queue.pop(0)
                pending[actor.solve.remote(start, poses, q0s)] = actor
    finally:
        for actor in actors:
            ray.kill(actor)
