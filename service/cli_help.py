"""The help formatter of the ``kinserve`` command line: every option's help line shows its default.

An option whose help text already says ``default`` keeps its text (the text explains what an empty default
means, e.g. "default: the robot's tool frame"); a flag gets ``(default: off)``; any other option gets
``(default: VALUE)``. Options of :class:`~kinserve.service.cli_types.Numbers` show their form (``--box CX CY
CZ SX SY SZ [ROLL PITCH YAW]``) instead of argparse's ``V [V ...]``.
"""

from __future__ import annotations

import argparse

from .cli_types import Numbers


class DefaultsHelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, with the default of every option in its help line (module docstring)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if not action.option_strings or action.default is argparse.SUPPRESS or "default" in text.lower():
            return text
        if action.nargs == 0:  # a flag: store_true
            return f"{text} (default: {'on' if action.default else 'off'})"
        return f"{text} (default: %(default)s)"

    def _format_args(self, action: argparse.Action, default_metavar: str) -> str:
        if isinstance(action, Numbers):
            return action.form
        return super()._format_args(action, default_metavar)
