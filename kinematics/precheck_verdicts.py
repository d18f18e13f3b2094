"""The verdicts of the sphere pre-check on one configuration
(:func:`~.precheck_kernels.classify_configuration`), and how an undecided verdict carries its pairs.

Plain integers, in a module of their own so that the compiled kernels (:mod:`.precheck_kernels`, which
return them) and the Python checks that read them (:mod:`.configuration_checks`, :mod:`.collision_scene`)
share one definition without an import circle and without loading Numba. The compiled kernels embed the
values when they are compiled, so this file is one of the kernel cache's files
(:data:`~.kernel_cache.KERNEL_FILES`): changing a value recompiles them
(tests/test_kinematics_collision_precheck.py checks the kernel's verdicts against these names).
"""

#: Certified collision free: every pair's lower bound exceeds the tolerance.
FREE = 0
#: In collision for certain: an inner ball of a robot geometry deep in an obstacle or in another's.
COLLIDING = 1
#: Neither: coal decides on the pairs the spheres do not certify (a larger verdict carries them).
UNDECIDED = 2

#: An undecided verdict of :func:`~.precheck_kernels.classify_configuration` carries up to this many pairs.
PACKED_PAIRS = 3
#: Bits per carried pair: pair ``k`` (0, 1, 2) is stored as ``index + 1`` in bits ``2 + 20 k`` to
#: ``21 + 20 k``; scenes of ``2**20 - 1`` pairs or more carry none.
PAIR_BITS = 20
_PAIR_MASK = (1 << PAIR_BITS) - 1


def carried_pairs(verdict: int) -> list[int]:
    """The scene pair indices an undecided verdict of :func:`~.precheck_kernels.classify_configuration`
    carries (``verdict > UNDECIDED``), in the pair table's order: ``[(verdict >> (2 + 20 k)) & (2**20 - 1)) -
    1 for each nonzero field k]``."""
    out = []
    verdict >>= 2
    while verdict:
        out.append((verdict & _PAIR_MASK) - 1)
        verdict >>= PAIR_BITS
    return out


__all__ = ["COLLIDING", "FREE", "PACKED_PAIRS", "PAIR_BITS", "UNDECIDED", "carried_pairs"]
