"""run_on_actors: an actor's start is timed apart from its chunks, on a simulated clock that the fake Ray's
``wait`` moves from event to event (no Ray, no real time: what is checked cannot depend on how busy the
machine is)."""

from types import SimpleNamespace

import pytest
from fake_clock import clock_replaced

from kinserve.ik.batch import ray_actors
from kinserve.ik.batch.ray_actors import ACTOR_START_LIMIT, BatchLabels, run_on_actors, run_on_new_actors
from kinserve.kinematics.errors import InputError, WorkerError, WorkerTimeoutError

LABELS = BatchLabels("ik.solve_many:", "targets")


class FakeRayError(Exception):
    pass


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


class Ref:
    """A result that is ready at simulated time ``at`` (or raises ``error`` when read)."""

    def __init__(self, at: float, value=None, error: Exception | None = None) -> None:
        self.at, self.value, self.error = at, value, error


class Method:
    def __init__(self, fn) -> None:
        self.remote = fn


class FakeActor:
    """Starts ``start_s`` after it is made (time 0), then runs its calls one after the other, each chunk
    taking ``chunk_s``; ``init_error`` makes its set-up fail, ``chunk_error`` its chunks."""

    def __init__(self, start_s: float, chunk_s: float, init_error=None, chunk_error=None) -> None:
        self.free_at, self.chunk_s = start_s, chunk_s
        self.init_error, self.chunk_error = init_error, chunk_error
        self.chunks: list[tuple[int, int]] = []
        self.ready = Method(lambda: Ref(start_s, True, init_error))
        self.plan = Method(self._plan)

    def _plan(self, start: int, stop: int) -> Ref:
        self.chunks.append((start, stop))
        error = self.init_error or self.chunk_error
        self.free_at += self.chunk_s
        return Ref(self.free_at, [start, stop], error)


class FakeRay:
    """``wait`` returns the first ready reference in the order given, else advances the clock to the next
    result or by ``timeout``, whichever is sooner (as Ray's returns early)."""

    exceptions = SimpleNamespace(RayError=FakeRayError)

    def __init__(self, clock: Clock, cpus: int = 2) -> None:
        self.clock, self.cpus = clock, cpus
        self.made: list[FakeActor] = []
        self.killed: list[FakeActor] = []

    def wait(self, refs, num_returns, timeout):
        assert num_returns == 1
        if not any(r.at <= self.clock.t for r in refs):
            self.clock.t = min(self.clock.t + timeout, min(r.at for r in refs))
        ready = [r for r in refs if r.at <= self.clock.t]
        return ready[:1], [r for r in refs if not ready or r is not ready[0]]

    def remote(self, num_cpus):  # ray.remote(num_cpus=1)(body): the class, whose remote() makes an actor
        assert num_cpus == 1

        def actor_class(body):
            def make(*args):
                self.made.append(body(*args))
                return self.made[-1]
            return SimpleNamespace(remote=make)
        return actor_class

    def available_resources(self):
        return {"CPU": self.cpus}

    def kill(self, actor):
        self.killed.append(actor)

    def get(self, ref):
        assert ref.at <= self.clock.t, "a result read before it is ready"
        if ref.error is not None:
            raise ref.error
        return ref.value


@pytest.fixture
def clock():
    with clock_replaced(Clock()) as c:  # time.monotonic, as ray_actors reads it
        yield c


def run(clock, actors, chunks, chunk_limit=lambda n: 10.0, deadline=None, **kw):
    done = []
    run_on_actors(FakeRay(clock), actors, chunks, lambda a, start, stop: a.plan.remote(start, stop),
                  lambda start, result: done.append((start, result, clock.t)), chunk_limit, deadline, LABELS,
                  **kw)
    return done


def test_a_slow_start_does_not_count_against_the_chunk(clock):
    # each actor takes 100 s to start, ten times its chunks' limit; every chunk takes 6 s of its 10
    actors = [FakeActor(100.0, 6.0), FakeActor(120.0, 6.0)]
    chunks = [(0, 5), (5, 10), (10, 15), (15, 20), (20, 23)]
    done = run(clock, actors, chunks)
    assert sorted(start for start, _, _ in done) == [0, 5, 10, 15, 20]  # each chunk once
    assert all(result == [start, stop] for (start, result, _), (_, stop) in zip(sorted(done), chunks))
    assert sorted(actors[0].chunks + actors[1].chunks) == chunks
    assert actors[0].chunks[0] == (0, 5) and actors[1].chunks[0] == (5, 10)  # one each at once
    assert done[0][2] == pytest.approx(106.0)  # first result: start + one chunk


def test_the_whole_run_waits_for_a_late_actor_only_as_long_as_the_start_limit(clock):
    # the second actor never starts: its chunk fails when the start limit has passed since the actors
    # were made, not before (the first actor's results keep coming meanwhile)
    actors = [FakeActor(1.0, 2.0), FakeActor(float("inf"), 2.0)]
    with pytest.raises(WorkerTimeoutError) as err:
        run(clock, actors, [(0, 4), (4, 8), (8, 12)], start_limit=50.0)
    message = str(err.value)
    assert message.startswith("ik.solve_many: a Ray actor has not started after")
    assert "(start limit 50.0 s), so targets[4:8] never ran; every actor was killed" in message
    assert 50.0 < clock.t <= 50.0 + ray_actors.POLL + 1e-9
    assert actors[0].chunks == [(0, 4), (8, 12)]


def test_a_chunk_late_after_its_actor_started_is_named(clock):
    actors = [FakeActor(30.0, 25.0)]  # starts in 30 s (fine), then a chunk takes 25 s of its 10
    with pytest.raises(WorkerTimeoutError, match=r"has not finished targets\[0:3\] after 10\.\d s "
                                                 r"\(chunk limit 10\.0 s\)"):
        run(clock, actors, [(0, 3)])
    assert 40.0 < clock.t <= 40.0 + ray_actors.POLL + 1e-9  # limit counted from the start at 30 s


def test_the_deadline_bounds_the_start_too(clock):
    actors = [FakeActor(100.0, 1.0)]
    with pytest.raises(WorkerTimeoutError, match=r"has not started after 5\.\d s \(overall timeout\), so "
                                                 r"targets\[0:2\] never ran"):
        run(clock, actors, [(0, 2)], deadline=5.0)
    assert clock.t < 6.0


def test_the_default_start_limit_is_generous():
    assert ACTOR_START_LIMIT >= 120.0


def test_a_failed_set_up_or_chunk_is_a_worker_error_with_the_reason(clock):
    actors = [FakeActor(1.0, 1.0, init_error=FakeRayError("ActorDiedError\nModelError: no meshes"))]
    with pytest.raises(WorkerError, match=r"^ik\.solve_many: a Ray actor failed on its set-up: "
                                          r"ModelError: no meshes; every actor was killed$"):
        run(clock, actors, [(0, 2)])
    clock.t = 0.0
    actors = [FakeActor(1.0, 1.0, chunk_error=FakeRayError("RayTaskError\nValueError: bad"))]
    with pytest.raises(WorkerError, match=r"failed on targets\[0:2\]: ValueError: bad"):
        run(clock, actors, [(0, 2)])


class FakeTaskError(InputError):
    """As Ray raises a kinserve error of a task: an instance of its class, Ray's traceback as its text, the
    error itself as ``cause``."""

    def __init__(self, cause: Exception) -> None:
        super().__init__("ray::Actor.plan() (pid=1)\n  File ..., in plan\n" + str(cause))
        self.cause = cause


def test_a_kinserve_error_on_the_actor_is_raised_as_it_is(clock):
    actors = [FakeActor(1.0, 1.0, chunk_error=InputError("targets[1]: not a pose"))]
    with pytest.raises(InputError, match=r"^targets\[1\]: not a pose$"):
        run(clock, actors, [(0, 2)])
    clock.t = 0.0
    error = InputError("targets[3]: not a pose")
    actors = [FakeActor(1.0, 1.0, chunk_error=FakeTaskError(error))]
    with pytest.raises(InputError, match=r"^targets\[3\]: not a pose$") as raised:
        run(clock, actors, [(2, 4)])
    assert raised.value is error  # Ray's wrapper unwrapped: the error as the actor raised it


@pytest.mark.parametrize("processes, cpus, n_chunks, made", [(4, 2, 5, 2), (2, 8, 5, 2), (4, 4, 1, 1),
                                                               (3, 0, 5, 1)])
def test_new_actors_as_many_as_allowed_and_every_one_killed(clock, processes, cpus, n_chunks, made):
    ray = FakeRay(clock, cpus)
    chunks = [(2 * k, 2 * k + 2) for k in range(n_chunks)]
    done = []
    run_on_new_actors(ray, FakeActor, (1.0, 1.0), processes, chunks, lambda a, s, t: a.plan.remote(s, t),
                      lambda start, result: done.append(start), lambda n: 10.0, None, LABELS)
    assert len(ray.made) == made and ray.killed == ray.made
    assert sorted(done) == [start for start, _ in chunks]
    clock.t = 0.0
    ray = FakeRay(clock, cpus)  # a run that raises kills its actors too
    with pytest.raises(WorkerTimeoutError):
        run_on_new_actors(ray, FakeActor, (1.0, 50.0), processes, chunks, lambda a, s, t: a.plan.remote(s, t),
                          lambda start, result: None, lambda n: 10.0, None, LABELS)
    assert len(ray.made) == made and ray.killed == ray.made
