"""Expand one xacro file in a separate process (run as a script by :mod:`robots.xacro_loader`).

Reads one JSON request on stdin::

    {"path": FILE, "mappings": {arg: text}, "packages_module": PATH_OF_packages.py,
     "package_dirs": [...], "model_dir": DIR, "extra_dirs": [...], "environ": {...},
     "memory_limit": BYTES, "allow_outside": BOOL}

and writes one JSON answer on stdout: ``{"ok": true, "xml": TEXT, "found": {pkg: dir}}``
or ``{"ok": false, "error": TYPE, "message": TEXT, "reads_other_files": BOOL, "file": FILE}``.

Running xacro in its own process is what makes its time limit real: an
expression such as ``${10**10**8}`` runs in C without returning to Python,
so no thread can interrupt it; the parent kills this process instead. The
process also caps its own address space (``memory_limit``) and has its own
copy of xacro's global state, so no lock is held across calls. Unless
``allow_outside``, a file xacro is about to read (``xacro:include``,
``xacro.load_yaml``) must lie in the model's folders or the package folders.

It imports only the standard library, xacro and (by file path)
:mod:`robots.packages`, whose ``PackageFinder`` answers ``$(find PKG)``.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path


def _limit_memory(nbytes: int) -> None:
    try:
        import resource
    except ImportError:  # pragma: no cover - not POSIX
        return
    if nbytes > 0:
        resource.setrlimit(resource.RLIMIT_AS, (nbytes, nbytes))


def _finder(req: dict):
    spec = importlib.util.spec_from_file_location("_kinserve_packages", req["packages_module"])
    packages = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = packages  # dataclasses look their module up there
    spec.loader.exec_module(packages)
    model_dir = Path(req["model_dir"]) if req.get("model_dir") else None
    return packages.PackageFinder(tuple(req["package_dirs"]), model_dir, tuple(req["extra_dirs"]),
                                  environ=req["environ"])


class OutsideError(Exception):
    """xacro was about to read a file outside the folders the model may read from."""


def _cause(exc: BaseException, kind: type) -> BaseException | None:
    """``exc`` or what it wraps (xacro's ``exc.exc``, the cause chain) when it is a ``kind``."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, kind):
            return exc
        seen.add(id(exc))
        exc = getattr(exc, "exc", None) or exc.__cause__ or exc.__context__
    return None


def _guard_file_access(xacro, finder, is_within) -> None:
    """Make every file xacro reads (``xacro:include``, ``load_yaml``) pass through a check of its path.

    Both call ``xacro.abs_filename_spec`` before touching the file system,
    so the refusal does not depend on whether the file exists.
    """
    absolute = xacro.abs_filename_spec

    def checked(spec):
        path = absolute(spec)
        if not is_within(path, finder.roots()):
            raise OutsideError(str(spec))
        return path

    xacro.abs_filename_spec = checked


def expand(req: dict) -> dict:
    """The answer to one request (see the module docstring)."""
    import xacro
    import xacro.substitution_args as substitution_args

    finder = _finder(req)

    def eval_find(pkg: str) -> str:
        folder = finder.find(pkg)
        if folder is None:
            raise xacro.XacroException(f"$(find {pkg}): package {pkg!r} not found; searched: "
                                       + "; ".join(finder.searched()))
        return str(folder)

    substitution_args._eval_find = eval_find
    if not req.get("allow_outside"):
        _guard_file_access(xacro, finder, sys.modules["_kinserve_packages"].is_within)
    try:
        doc = xacro.process_file(req["path"], mappings=req["mappings"], verbosity=0)
        return {"ok": True, "xml": doc.toprettyxml(indent="  "),
                "found": {k: str(v) for k, v in finder.found.items()}}
    except BaseException as exc:  # noqa: BLE001 - every failure is reported, the parent decides what to show
        stack = list(xacro.filestack or [])
        outside = _cause(exc, OutsideError)
        if outside is not None:
            return {"ok": False, "error": "OutsideError", "message": str(outside),
                    "roots": [str(r) for r in finder.roots()],
                    "reads_other_files": len(stack) > 1 or bool(xacro.all_includes), "file": req["path"]}
        return {
            "ok": False,
            "error": "MemoryError" if _cause(exc, MemoryError) else type(exc).__name__,
            "message": str(exc),
            "reads_other_files": bool(xacro.all_includes),
            "file": str(stack[-1]) if stack and stack[-1] else req["path"],
        }


def main() -> int:
    """Read one request (JSON) from stdin, write its answer (JSON) to stdout; returns 0."""
    req = json.loads(sys.stdin.read())
    _limit_memory(int(req.get("memory_limit", 0)))
    try:
        answer = expand(req)
    except MemoryError:
        answer = {"ok": False, "error": "MemoryError", "message": "", "reads_other_files": False,
                  "file": req["path"]}
    sys.stdout.write(json.dumps(answer))
    return 0


if __name__ == "__main__":
    sys.exit(main())
