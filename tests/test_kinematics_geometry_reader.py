"""GeometryReader and the Robot's geometry models read on first use: read once (threads and copies included),
a failed read kept for no one, the models the same as Pinocchio's own build of the same URDF, and a load that
reads no mesh file."""

import pickle
import threading

import numpy as np
import pinocchio as pin
import pytest

from kinserve import robots
from kinserve.kinematics import ModelError, Robot
from kinserve.kinematics.geometry_reader import GeometryReader


class CountingRead:
    """A read that counts its calls and returns ``model`` (once ``wait`` is set, when given) or raises
    ``error``."""

    def __init__(self, model=None, error=None, wait=None):
        self.model, self.error, self.wait, self.calls = model, error, wait, 0

    def __call__(self):
        self.calls += 1
        if self.wait is not None:
            self.wait.wait(5)
        if self.error is not None:
            raise self.error
        return self.model


def test_threads_asking_together_share_one_read():
    read = CountingRead(pin.GeometryModel(), wait=threading.Event())
    reader = GeometryReader(read)
    assert not reader.is_read and "not read yet" in repr(reader)
    got = []
    threads = [threading.Thread(target=lambda: got.append(reader.get())) for _ in range(8)]
    for t in threads:
        t.start()
    read.wait.set()
    for t in threads:
        t.join(10)
    assert read.calls == 1 and len(got) == 8 and all(g is read.model for g in got)
    assert reader.is_read and reader.get() is read.model and read.calls == 1


def test_a_failed_read_is_kept_for_no_one():
    read = CountingRead(error=ModelError("r.urdf: cannot build the visual geometry: bad mesh"))
    reader = GeometryReader(read)
    for calls in (1, 2):
        with pytest.raises(ModelError, match="bad mesh"):
            reader.get()
        assert read.calls == calls and not reader.is_read


def test_copies_share_the_read_and_own_what_they_set(panda_model):
    read = CountingRead(pin.GeometryModel())
    robot = Robot(panda_model, visual_model=GeometryReader(read), tip="panda_link8")
    copy = robot.copy()
    assert read.calls == 0
    assert copy.visual_model is robot.visual_model is read.model and read.calls == 1
    mine = pin.GeometryModel()
    copy.visual_model = mine
    assert copy.visual_model is mine and robot.visual_model is read.model
    assert robot.collision_model is None
    again = pickle.loads(pickle.dumps(robot))  # meshes do not travel (Robot.__getstate__)
    assert again.visual_model is None and again.collision_model is None and read.calls == 1


def _same_geometry(a: pin.GeometryModel, b: pin.GeometryModel) -> None:
    assert a.ngeoms == b.ngeoms
    for x, y in zip(a.geometryObjects, b.geometryObjects):
        assert (x.name, x.parentJoint, x.parentFrame, x.meshPath) == (y.name, y.parentJoint, y.parentFrame,
                                                                      y.meshPath)
        assert np.array_equal(x.placement.homogeneous, y.placement.homogeneous)
        assert np.array_equal(x.meshScale, y.meshScale) and type(x.geometry) is type(y.geometry)


def test_the_panda_reads_no_mesh_at_load_and_its_models_are_pinocchios(monkeypatch):
    """robots.load builds no geometry model; the first use of each builds that one only, and it is the
    model Pinocchio builds from the same URDF text with its own mesh loader."""
    built = []
    real = pin.buildGeomFromUrdfString

    def counting(model, xml, kind, *args, **kwargs):
        built.append(kind)
        return real(model, xml, kind, *args, **kwargs)

    robots.clear_cache()
    monkeypatch.setattr(pin, "buildGeomFromUrdfString", counting)
    panda = robots.load("panda")
    assert built == []
    visual = panda.visual_model
    assert built == [pin.GeometryType.VISUAL]
    collision = panda.collision_model
    assert built == [pin.GeometryType.VISUAL, pin.GeometryType.COLLISION]
    assert panda.copy().visual_model is visual and len(built) == 2
    monkeypatch.undo()
    robots.clear_cache()
    for kind, mine in ((pin.GeometryType.VISUAL, visual), (pin.GeometryType.COLLISION, collision)):
        theirs = pin.buildGeomFromUrdfString(panda.model, panda.source, kind,
                                             package_dirs=list(panda.package_dirs))
        _same_geometry(mine, theirs)
