"""How a URDF element is named in messages, and its numeric attributes read with a check.

Every message about a model element starts with :func:`where` (the file and
the element's line) and names the element with :func:`describe`
(``<joint name='j1'>``), so the user can find it in the file.
"""

from __future__ import annotations

import numpy as np
from lxml import etree

from kinserve.kinematics.errors import ModelError
from kinserve.kinematics.validation import MAX_ABS, is_bounded


def where(label: str, el: etree._Element) -> str:
    """``"<label>, line <n>"`` for an element parsed with line numbers, else ``label``."""
    line = getattr(el, "sourceline", None)
    return f"{label}, line {line}" if line else label


def describe(el: etree._Element) -> str:
    """``<tag name='...'>`` (or ``<tag>`` for an element without a name)."""
    name = el.get("name")
    return f"<{el.tag} name={name!r}>" if name is not None else f"<{el.tag}>"


def attribute_floats(el: etree._Element, attr: str, n: int, label: str, owner: etree._Element,
                     default: list[float] | None = None) -> np.ndarray | None:
    """The ``n`` numbers of attribute ``attr`` of ``el`` (``default``, or None, when it is absent).

    Raises :class:`ModelError` naming the file, line, ``owner`` element and the
    attribute when the text is not ``n`` finite numbers of magnitude at most
    :data:`kinematics.validation.MAX_ABS`.
    """
    text = el.get(attr)
    if text is None:
        return None if default is None else np.array(default, dtype=float)
    try:
        vals = np.array([float(v) for v in text.split()], dtype=float)
    except ValueError:
        vals = None
    if vals is None or vals.shape != (n,) or not is_bounded(vals):
        raise ModelError(
            f"{where(label, el)}: {describe(owner)}: <{el.tag} {attr}={text!r}> must be {n} finite number(s) "
            f"with magnitude <= {MAX_ABS:g}"
        )
    return vals
