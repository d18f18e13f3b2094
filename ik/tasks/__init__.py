"""IK tasks: the :class:`Task` protocol (error ``e(q)``, Jacobian ``J(q)``, weight, priority) and its implementations."""

from .base import Task, check_priority, check_weight

__all__ = ["Task", "check_priority", "check_weight"]
