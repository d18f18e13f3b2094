"""kinserve.robots.paths: finding example-robot-data and the package dir of its mesh URIs."""

import pytest

from kinserve.kinematics.errors import ModelError
from kinserve.robots import paths


@pytest.fixture(autouse=True)
def fresh_lookup():
    paths._find.cache_clear()
    yield
    paths._find.cache_clear()


def test_installed_data_is_found_and_package_dir_resolves_mesh_uris():
    robots_dir = paths.example_robot_data_dir()
    assert (robots_dir / "panda_description" / "urdf" / "panda.urdf").is_file()
    share = paths.example_robot_data_package_dir()
    assert (share / "example-robot-data" / "robots").resolve() == robots_dir
    uri = "package://example-robot-data/robots/panda_description/meshes/visual/link0.dae"
    assert (share / uri[len("package://"):]).is_file()


@pytest.mark.parametrize("level", ["robots", "erd", "share"])
def test_environment_variable_overrides(tmp_path, monkeypatch, level):
    robots_dir = tmp_path / "share" / "example-robot-data" / "robots"
    (robots_dir / "panda_description" / "urdf").mkdir(parents=True)
    (robots_dir / "panda_description" / "urdf" / "panda.urdf").write_text("<robot name='p'/>")
    target = {"robots": robots_dir, "erd": robots_dir.parent, "share": tmp_path / "share"}[level]
    monkeypatch.setenv(paths.ENV_VAR, str(target))
    assert paths.example_robot_data_dir() == robots_dir.resolve()
    assert paths.example_robot_data_package_dir() == (tmp_path / "share").resolve()


def test_not_found_lists_where_it_looked(tmp_path, monkeypatch):
    monkeypatch.setenv(paths.ENV_VAR, str(tmp_path / "nothing"))
    monkeypatch.setattr(paths, "search_locations", lambda: [
        ("$" + paths.ENV_VAR, tmp_path / "nothing"), ("install prefix", tmp_path / "opt" / "share")])
    with pytest.raises(ModelError) as err:
        paths.example_robot_data_dir()
    msg = str(err.value)
    assert (paths.ENV_VAR in msg and str(tmp_path / "nothing") in msg
            and str(tmp_path / "opt" / "share") in msg)


def test_search_covers_env_module_site_packages_and_prefixes():
    hows = [how for how, _ in paths.search_locations()]
    assert hows[0] == "$" + paths.ENV_VAR
    assert "python module example_robot_data" in hows
    assert "sys.path / site-packages" in hows
    assert any(str(p).startswith("/opt/openrobots") for _, p in paths.search_locations() if p is not None)


def test_erd_file_missing():
    with pytest.raises(ModelError, match="not found"):
        paths.erd_file("nope_description/urdf/nope.urdf")
