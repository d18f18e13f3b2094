"""Colours for scenes and plots: one parser, one palette.

A colour may be given as

* an ``int`` ``0xRRGGBB`` (meshcat's native form),
* a string ``"#rrggbb"`` / ``"#rgb"`` or one of the names in :data:`NAMED`,
* an RGB(A) sequence of floats in ``[0, 1]`` (Pinocchio's ``meshColor`` form).

:func:`to_int` turns any of them into ``0xRRGGBB`` for meshcat,
:func:`to_rgb` into an ``(r, g, b)`` float triple for matplotlib.
"""

from __future__ import annotations

from kinserve.kinematics.errors import InputError

#: Named colours (a small, colour-blind friendly set, Okabe-Ito plus greys).
NAMED = {
    "orange": 0xE69F00,
    "sky": 0x56B4E9,
    "green": 0x009E73,
    "yellow": 0xF0E442,
    "blue": 0x0072B2,
    "red": 0xD55E00,
    "purple": 0xCC79A7,
    "black": 0x000000,
    "white": 0xFFFFFF,
    "grey": 0x888888,
    "gray": 0x888888,
    "lightgrey": 0xCCCCCC,
    "darkgrey": 0x444444,
}

#: Colour cycle used for successive series (paths, joints, branches).
PALETTE = ("blue", "orange", "green", "red", "purple", "sky", "yellow", "darkgrey")


def to_int(color) -> int:
    """``0xRRGGBB`` of any accepted colour form (see the module docstring)."""
    if isinstance(color, bool):
        raise InputError("color must be 0xRRGGBB, '#rrggbb', a name or an RGB triple in [0, 1]; "
                         f"got {color!r}")
    if isinstance(color, int):
        if 0 <= color <= 0xFFFFFF:
            return color
        raise InputError(f"color int must be in [0, 0xFFFFFF], got {color:#x}")
    if isinstance(color, str):
        key = color.strip().lower()
        if key in NAMED:
            return NAMED[key]
        if key.startswith("#"):
            digits = key[1:]
            if len(digits) == 3:
                digits = "".join(c * 2 for c in digits)
            if len(digits) == 6:
                try:
                    return int(digits, 16)
                except ValueError:
                    pass
        raise InputError(f"unknown color {color!r}; expected '#rrggbb' or one of {sorted(NAMED)}")
    try:
        values = [float(c) for c in color]
    except (TypeError, ValueError):
        raise InputError("color must be 0xRRGGBB, '#rrggbb', a name or an RGB triple in [0, 1]; "
                         f"got {color!r}") from None
    if len(values) not in (3, 4) or not all(0.0 <= v <= 1.0 for v in values):
        raise InputError(f"color sequence must be RGB or RGBA floats in [0, 1]; got {color!r}")
    r, g, b = (int(round(v * 255)) for v in values[:3])
    return (r << 16) | (g << 8) | b


def to_rgb(color) -> tuple[float, float, float]:
    """``(r, g, b)`` floats in ``[0, 1]`` of any accepted colour form."""
    c = to_int(color)
    return ((c >> 16) / 255.0, ((c >> 8) & 0xFF) / 255.0, (c & 0xFF) / 255.0)


def cycle(i: int):
    """The ``i``-th colour name of :data:`PALETTE` (wrapping around)."""
    return PALETTE[i % len(PALETTE)]
