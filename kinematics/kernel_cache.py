"""Numba's on-disk cache for kinserve's compiled kernels, with one key over every kernel source.

Numba keys a cached function on the content of *its own* source file only (numba#1833): a kernel that
calls a compiled primitive of another file keeps its stale machine code when only that primitive changes.
kinserve's kernels therefore share one source stamp: :class:`KernelSetLocator` finds the cache folder as
Numba would (``__pycache__`` beside the file, or the user-wide cache when that is not writable) and stamps
every function of :data:`KERNEL_FILES` (the files with compiled code and the files whose constants that code
reads) with the SHA-256 of all of those files together. Changing any one of them recompiles every kernel on
the next import.

The decorators :data:`jit`, :data:`inline` and :data:`leaf` (``cache=True``, ``nogil``, NumPy's error model;
``inline`` also inlines at Numba's IR level, ``leaf`` compiles without reference counting) are the ones every
kernel module uses; importing this module installs the locator first, so it is in place before any of them
is decorated. :func:`kernel_set_locator` makes a locator class for another set of files (the tests use it on
files of their own).
"""

from __future__ import annotations

import hashlib
import importlib
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numba
from numba.core import caching

_ROOT = Path(__file__).resolve().parents[1]

#: The files with compiled code of kinserve (relative to the package), and the files whose names that code
#: reads (constants and encodings baked into the machine code), sharing one source stamp.
KERNEL_FILES = tuple(str(_ROOT / p) for p in (
    "kinematics/kernel_primitives.py",
    "kinematics/convex_distance.py",
    "kinematics/precheck_kernels.py",
    "kinematics/hull_verdict.py",
    "kinematics/motion_kernels.py",
    "kinematics/sphere_cover.py",
    "ik/constraints/clearance_kernel.py",
    "ik/lm/kernel.py",
    "ik/lm/screened_kernel.py",
    "ik/qp/line_kernel.py",
    "ik/tasks/null_space_kernel.py",
    "planners/motion/extend_kernel.py",
    "planners/motion/search_kernel.py",
    "planners/two_opt_kernel.py",
    # read by the kernels above: the obstacle table's encoding, the hull table's kinds, the pre-check's
    # verdicts, the bound of every input number, the packed arrays' header and pair kinds, the joint kinds
    # of the chain encoding, the LM's status codes
    "kinematics/obstacle_table.py",
    "kinematics/hull_table.py",
    "kinematics/precheck_verdicts.py",
    "kinematics/magnitude.py",
    "kinematics/precheck_packing.py",
    "kinematics/serial_chain.py",
    "ik/lm/status.py",
))


def set_stamp(files: Iterable[str]) -> bytes:
    """The SHA-256 of the contents of ``files`` (in order, each with its name): one stamp for all."""
    h = hashlib.sha256()
    for path in files:
        h.update(os.path.basename(path).encode())
        with open(path, "rb") as f:
            h.update(hashlib.sha256(f.read()).digest())
    return h.digest()


class KernelSetLocator(caching._CacheLocator):
    """A Numba cache locator for the functions of one set of source files (:attr:`files`): the cache folder
    and disambiguator of the locator Numba would pick, the source stamp of the whole set."""

    files: tuple[str, ...] = KERNEL_FILES

    def __init__(self, inner: caching._CacheLocator) -> None:
        self._inner = inner

    def ensure_cache_path(self) -> None:
        """Make the cache folder (the inner locator's)."""
        self._inner.ensure_cache_path()

    def get_cache_path(self) -> str:
        """The cache folder of the inner locator."""
        return self._inner.get_cache_path()

    def get_disambiguator(self) -> str:
        """The inner locator's (the function's line number)."""
        return self._inner.get_disambiguator()

    def get_source_stamp(self) -> bytes:
        """:func:`set_stamp` of the whole set: any file of it changed, every function's cache is stale."""
        return set_stamp(self.files)

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> KernelSetLocator | None:
        """A locator for ``py_func`` when ``py_file`` is one of :attr:`files`, else None (Numba's own)."""
        if os.path.abspath(py_file) not in cls.files:
            return None
        for other in caching.CacheImpl._locator_classes:
            if issubclass(other, KernelSetLocator):
                continue
            inner = other.from_function(py_func, py_file)
            if inner is not None:
                return cls(inner)
        return None


def kernel_set_locator(files: Iterable[str]) -> type[KernelSetLocator]:
    """A :class:`KernelSetLocator` class for ``files``, installed ahead of Numba's locators."""
    locator = type("KernelSetLocator", (KernelSetLocator,),
                   {"files": tuple(os.path.abspath(f) for f in files)})
    install(locator)
    return locator


def install(locator: type[KernelSetLocator]) -> None:
    """Put ``locator`` first among Numba's cache locators (once)."""
    classes = caching.CacheImpl._locator_classes
    if locator not in classes:
        classes.insert(0, locator)


install(KernelSetLocator)

#: The array types of the kernels' signatures, defined once: read-only float arrays of 1 to 3 dimensions,
#: C-contiguous (``F1``, ``F2``, ``F3``) or of any layout (``F1_ANY``, ``F2_ANY``: views such as reversed
#: rows), read-only int64 (``I1``, ``I2``) and boolean (``B1``) arrays. A writable array converts to its
#: read-only type.
F1, F2, F3 = (numba.types.Array(numba.types.float64, d, "C", readonly=True) for d in (1, 2, 3))
F1_ANY, F2_ANY = (numba.types.Array(numba.types.float64, d, "A", readonly=True) for d in (1, 2))
I1, I2 = (numba.types.Array(numba.types.int64, d, "C", readonly=True) for d in (1, 2))
B1 = numba.types.Array(numba.types.boolean, 1, "C", readonly=True)

#: ``numba.njit`` as kinserve's kernels use it (cached under the kernel set's stamp).
jit = numba.njit(cache=True, nogil=True, error_model="numpy")
#: :data:`jit`, inlined into its callers at Numba's IR level (a call passes whole array structures).
inline = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
#: :data:`jit` without Numba's reference counting (its ``_nrt`` option off), for a helper that a kernel calls
#: in its hot loop, once per configuration or pair: a compiled function may increment the reference count of
#: each array it receives on entry and decrement it on exit, an atomic operation each, which Numba's pruning
#: does not remove from a loop that calls other compiled code and returns early (docs/benchmarks.md measures
#: the pre-check's). A leaf neither allocates nor returns an array (Numba refuses to compile one that
#: allocates), so its callers' references keep its arguments alive and it need not count them; it may call
#: kernels that count their own.
leaf = numba.njit(cache=True, nogil=True, error_model="numpy", _nrt=False)


def compiled(signature: Any) -> Callable[[Callable[..., Any]], Any]:
    """:data:`jit` with an explicit ``signature`` (a Numba signature: a ``numba.types`` return type called on
    the argument types): compiled (or loaded from the cache) when its module is imported."""
    return numba.njit(signature, cache=True, nogil=True, error_model="numpy")


def entry_point(kernel: Any) -> Callable[..., Any]:
    """The machine code of ``kernel`` (a :func:`compiled` kernel: one signature) as Python calls it, without
    Numba's dispatch. A dispatcher call types each argument and selects the overload on every call, and on
    a first call in a new scene its code and tables have left the caches (docs/benchmarks.md, "The kernels
    called without dispatch"); the entry point only converts the arguments.

    The caller guarantees the signature's types: the entry point converts an array by its item size and
    reads it with the signature's dimensions and layout, so an array of another dtype of the same size (an
    int64 array for a float64 one), of other dimensions or not C-contiguous where the signature says ``C`` is
    misread, where the dispatcher would raise ``TypeError``. Use it for arrays the caller made itself or
    checked (:meth:`~.collision_scene.CollisionScene.in_collision` checks the configuration's type first).
    ``kernel`` itself when the compiled result has no ``entry_point`` (a Numba that no longer offers it):
    slower, and stricter."""
    overloads = list(kernel.overloads.values())
    if len(overloads) != 1:  # (every compiled kernel has its one signature)
        raise RuntimeError(f"{kernel} has {len(overloads)} compiled signatures, expected one")
    return getattr(overloads[0], "entry_point", None) or kernel


def compile_all() -> list[str]:
    """Import every module of :data:`KERNEL_FILES` (``kinserve.`` + its path) and return their names. Each
    kernel compiles, or loads from the cache, when its module is imported, so after this call the cache holds
    every kernel: later processes load them and compile nothing (``make test`` calls it once before the
    suite, whose workers would otherwise each compile the kernels at the same time)."""
    names = []
    for path in KERNEL_FILES:
        name = ".".join(("kinserve", *Path(path).relative_to(_ROOT).with_suffix("").parts))
        importlib.import_module(name)
        names.append(name)
    return names
