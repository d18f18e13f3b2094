"""Status codes of one LM start and of one target (shared by the compiled and the Python iteration)."""

#: One start (:func:`kinserve.ik.lm.kernel.run_start`, :func:`kinserve.ik.lm.solver.python_start`).
CONVERGED, STALLED, ITERATION_LIMIT = 0, 1, 2
#: One target of :func:`kinserve.ik.lm.kernel.run_many` when no start converged: the start limit, the
#: iteration budget, or the prepared starts ran out (the caller goes on with its own start sequence).
START_LIMIT, BUDGET_EXHAUSTED, STARTS_EXHAUSTED = 3, 4, 5
#: The screen's flag of one start (:func:`kinserve.ik.lm.screened_kernel.run_screened_start`): the start
#: was not certified (the run's other rows were), the run's rows and start are all certified, or one of the
#: rows after the start is not.
START_UNCERTIFIED, ROWS_CERTIFIED, ROWS_UNCERTIFIED = 0, 1, 2
