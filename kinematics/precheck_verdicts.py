"""The verdicts of the sphere pre-check on one configuration
(:func:`~.precheck_kernels.classify_configuration`).

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
#: Neither: coal decides on the pairs the spheres do not certify.
UNDECIDED = 2

__all__ = ["COLLIDING", "FREE", "UNDECIDED"]
