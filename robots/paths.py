"""Where robot model files live: example-robot-data and kinserve's own models.

example-robot-data (ERD) ships URDF files under ``<share>/example-robot-data/robots``
and refers to meshes with ``package://example-robot-data/robots/...`` URIs, so
the *package directory* that resolves them is ``<share>`` (the parent of the
``example-robot-data`` directory).

The robots directory is looked up, first hit wins, in:

1. the environment variable ``EXAMPLE_ROBOT_DATA_DIR`` (the ``robots``
   directory itself, or a directory holding ``robots/`` or
   ``example-robot-data/robots/``);
2. the Python module ``example_robot_data`` (ERD 4.x wheels) if importable,
   through its ``getModelPath``;
3. ``cmeel.prefix/share/example-robot-data/robots`` under every ``sys.path``
   entry, every site-packages directory and ``sys.prefix`` (the layout of the
   ``example-robot-data`` wheel >= 5, which has no Python module);
4. ``share/example-robot-data/robots`` under ``sys.prefix``, ``/opt/openrobots``,
   ``/usr/local`` and ``/usr`` (robotpkg / system installs).

If nothing is found, :class:`kinematics.errors.ModelError` lists every place
that was searched.
"""

from __future__ import annotations

import functools
import os
import site
import sys
from pathlib import Path

from kinserve.kinematics.errors import ModelError

#: Environment variable that overrides the search for example-robot-data.
ENV_VAR = "EXAMPLE_ROBOT_DATA_DIR"

#: Name of the ROS package used in ERD mesh URIs (``package://example-robot-data/...``).
ERD_PACKAGE = "example-robot-data"

#: A file every ERD install contains; used to recognise a robots directory.
_PROBE = Path("panda_description") / "urdf" / "panda.urdf"


def models_dir() -> Path:
    """Directory of kinserve's own model files (``robots/models``: xacro and URDF)."""
    return Path(__file__).resolve().parent / "models"


def _as_robots_dir(path: Path) -> Path | None:
    """``path`` normalised to an ERD ``robots`` directory, or None if it is not one."""
    for cand in (path, path / "robots", path / ERD_PACKAGE / "robots",
                 path / "share" / ERD_PACKAGE / "robots"):
        if cand.is_dir() and ((cand / _PROBE).is_file() or any(cand.glob("*_description"))):
            return cand.resolve()
    return None


def _site_dirs() -> list[Path]:
    dirs: list[str] = list(sys.path)
    try:
        dirs += site.getsitepackages()
    except AttributeError:  # pragma: no cover - virtualenv without site.getsitepackages
        pass
    try:
        dirs.append(site.getusersitepackages())
    except AttributeError:  # pragma: no cover
        pass
    out, seen = [], set()
    for d in dirs:
        if d and d not in seen:
            seen.add(d)
            out.append(Path(d))
    return out


def search_locations() -> list[tuple[str, Path | None]]:
    """Every ``(how, candidate path)`` pair searched, in order (for messages and debugging)."""
    locations: list[tuple[str, Path | None]] = []
    env = os.environ.get(ENV_VAR)
    locations.append((f"${ENV_VAR}", Path(env).expanduser() if env else None))
    locations.append(("python module example_robot_data", _module_robots_dir()))
    for d in _site_dirs():
        locations.append(("sys.path / site-packages", d / "cmeel.prefix" / "share" / ERD_PACKAGE / "robots"))
    locations.append(("sys.prefix", Path(sys.prefix) / "cmeel.prefix" / "share" / ERD_PACKAGE / "robots"))
    for prefix in (Path(sys.prefix), Path("/opt/openrobots"), Path("/usr/local"), Path("/usr")):
        locations.append(("install prefix", prefix / "share" / ERD_PACKAGE / "robots"))
    return locations


def _module_robots_dir() -> Path | None:
    """The robots directory reported by the ``example_robot_data`` module (ERD 4.x), if any."""
    try:
        import example_robot_data  # type: ignore[import-not-found]
    except Exception:  # noqa: BLE001 - absent or broken module: try the other locations
        return None
    get = getattr(example_robot_data, "getModelPath", None)
    if get is None:
        return None
    try:
        return Path(get(str(_PROBE)))
    except Exception:  # noqa: BLE001 - getModelPath raises IOError when it finds nothing
        return None


@functools.lru_cache(maxsize=None)
def _find(env_value: str | None) -> Path:
    tried = []
    for how, cand in search_locations():
        if cand is None:
            tried.append(f"{how}: (not set / not available)")
            continue
        found = _as_robots_dir(cand)
        if found is not None:
            return found
        tried.append(f"{how}: {cand}")
    raise ModelError(
        "example-robot-data not found; set $" + ENV_VAR + " to its 'robots' directory or install the "
        "'example-robot-data' package. Looked in:\n  " + "\n  ".join(tried)
    )


def example_robot_data_dir() -> Path:
    """The ERD ``robots`` directory (holding ``panda_description/``, ``ur_description/``, ...)."""
    return _find(os.environ.get(ENV_VAR))


def example_robot_data_package_dir() -> Path:
    """The directory that resolves ``package://example-robot-data/...`` URIs (ERD's ``share``).

    For a robots directory ``<x>/example-robot-data/robots`` this is ``<x>``.
    """
    robots_dir = example_robot_data_dir()
    parent = robots_dir.parent
    if parent.name != ERD_PACKAGE:
        raise ModelError(
            f"example-robot-data robots directory {robots_dir} is not inside a directory named "
            f"{ERD_PACKAGE!r}, so package://{ERD_PACKAGE}/... mesh URIs cannot be resolved; point "
            f"${ENV_VAR} at <share>/{ERD_PACKAGE}/robots"
        )
    return parent.parent


def erd_file(relative: str | Path) -> Path:
    """Absolute path of a file inside the ERD robots directory; ModelError if it is missing."""
    path = example_robot_data_dir() / relative
    if not path.is_file():
        raise ModelError(f"example-robot-data file {relative} not found (looked for {path})")
    return path
