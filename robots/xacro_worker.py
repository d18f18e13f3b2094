"""Expand one xacro file in a separate process (run as a script by :mod:`robots.xacro_loader`).

Reads one JSON request on stdin::

    {"path": FILE, "mappings": {arg: text}, "packages_module": PATH_OF_packages.py,
     "package_dirs": [...], "model_dir": DIR, "extra_dirs": [...], "environ": {...},
     "memory_limit": BYTES}

and writes one JSON answer on stdout: ``{"ok": true, "xml": TEXT, "found": {pkg: dir}}``
or ``{"ok": false, "error": TYPE, "message": TEXT, "reads_other_files": BOOL, "file": FILE}``.

Running xacro in its own process is what makes its time limit real: an
expression such as ``${10**10**8}`` runs in C without returning to Python,
so no thread can interrupt it; the parent kills this process instead. The
process also caps its own address space (``memory_limit``) and has its own
copy of xacro's global state, so no lock is held across calls.

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


def _caused_by_memory(exc: BaseException) -> bool:
    """True when ``exc`` or what it wraps (xacro's ``exc.exc``, the cause chain) is a MemoryError."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, MemoryError):
            return True
        seen.add(id(exc))
        exc = getattr(exc, "exc", None) or exc.__cause__ or exc.__context__
    return False


def expand(req: dict) -> dict:
    """The answer to one request (see the module docstring)."""
    import xacro
    import xacro.substitution_args as substitution_args

    finder = _finder(req)

    def eval_find(pkg: str) -> str:
        folder = finder.find(pkg)
        if folder is None:
            raise xacro.XacroException(f"$(find {pkg}): package {pkg!r} not found; searched: " + "; ".join(finder.searched()))
        return str(folder)

    substitution_args._eval_find = eval_find
    try:
        doc = xacro.process_file(req["path"], mappings=req["mappings"], verbosity=0)
        return {"ok": True, "xml": doc.toprettyxml(indent="  "), "found": {k: str(v) for k, v in finder.found.items()}}
    except BaseException as exc:  # noqa: BLE001 - every failure is reported, the parent decides what to show
        stack = list(xacro.filestack or [])
        return {
            "ok": False,
            "error": "MemoryError" if _caused_by_memory(exc) else type(exc).__name__,
            "message": str(exc),
            "reads_other_files": bool(xacro.all_includes),
            "file": str(stack[-1]) if stack and stack[-1] else req["path"],
        }


def main() -> int:
    req = json.loads(sys.stdin.read())
    _limit_memory(int(req.get("memory_limit", 0)))
    try:
        answer = expand(req)
    except MemoryError:
        answer = {"ok": False, "error": "MemoryError", "message": "", "reads_other_files": False, "file": req["path"]}
    sys.stdout.write(json.dumps(answer))
    return 0


if __name__ == "__main__":
    sys.exit(main())
