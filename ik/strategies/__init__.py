"""The IK strategies: each a small named function of a validated request (:mod:`kinserve.ik.request`).

:mod:`kinserve.ik.plan` picks one from its table; none of them calls back into the dispatcher.
"""
