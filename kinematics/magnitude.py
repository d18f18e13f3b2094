"""The one bound of every number kinserve accepts: finite, with ``|x| <=`` :data:`MAX_ABS`.

In a module of its own (no imports) so that the input checks (:mod:`.validation`) and the compiled
kernels that screen a configuration themselves (:func:`~.precheck_kernels.classify_configuration`) read
one definition. The kernels embed the value when they are compiled, so this file is one of the kernel
cache's files (:data:`~.kernel_cache.KERNEL_FILES`).
"""

#: Magnitudes beyond this are rejected as non-physical (metres or radians).
MAX_ABS = 1e6

__all__ = ["MAX_ABS"]
