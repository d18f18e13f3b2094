"""Levenberg-Marquardt: the solver (:mod:`.solver`), its compiled kernel (:mod:`.kernel`), many targets at
once (:mod:`.many`) and the robot's compiled chains (:mod:`.chains`; :func:`warm` builds them)."""

from kinserve.ik.lm.chains import warm

__all__ = ["warm"]
