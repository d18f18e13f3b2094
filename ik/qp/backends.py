"""Names of the QP solvers the differential IK can use (``ik.solve(..., backend=...)``).

The QPs themselves are solved by :func:`kinserve.ik.qp.dense_qp.solve_dense`:
DAQP (the default) through its own interface, any other name through
``qpsolvers.solve_qp``. Both are called statelessly, so the same problem
always gives the same answer (issue 10's determinism); a persistent solver
workspace (an OSQP object updated and warm-started per step) was tried and
dropped for that reason: OSQP's warm start made answers differ run to run by
up to 2.6e-7 rad.
"""

from __future__ import annotations


def available_backends() -> list[str]:
    """Backend names usable on this machine: osqp, daqp, proxqp, quadprog first when installed, then the
    rest."""
    import qpsolvers

    names = []
    for name in ("osqp", "daqp", "proxqp", "quadprog"):
        if name in qpsolvers.available_solvers:
            names.append(name)
    names += [s for s in qpsolvers.available_solvers if s not in names]
    return names
