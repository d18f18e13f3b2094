"""The check of every ``<collision>`` / ``<visual>`` element of a URDF, before Pinocchio sees it.

urdfdom (inside Pinocchio) drops a ``<collision>`` or ``<visual>`` it cannot
parse with a line on stderr and nothing else: an obstacle placed exactly on
that part would then be "free" (``in_collision`` False, ``min_distance`` inf),
and a link whose only collision element was dropped has no collision geometry
at all. Numbers it does parse are taken as they are: a negative radius or box
size, or one of 1e300, gives geometry that answers nonsense. So
:func:`validate_geometry` refuses, with a :class:`ModelError` naming the file,
the line, the link, the element and the attribute:

* an element without one ``<geometry>`` holding exactly one of ``<box>``,
  ``<sphere>``, ``<cylinder>``, ``<mesh>`` (urdfdom knows no other shape);
* ``<origin xyz rpy>`` that are not 3 finite numbers with ``|x| <=`` :data:`MAX_ABS`;
* ``<box size>`` (3 numbers), ``<sphere radius>``, ``<cylinder radius length>``
  missing, not finite, not positive or above :data:`MAX_ABS`;
* ``<mesh scale>`` (optional) not 3 finite non-zero numbers with ``|x| <=``
  :data:`MAX_ABS` (a negative factor mirrors the mesh, as URDFs do for left / right parts).

The mesh file itself is checked by the mesh resolver, when meshes are wanted.

:func:`validate_inertial` checks each ``<link>/<inertial>`` the same way (urdfdom prints an error on
stderr and Pinocchio takes the numbers as they are): ``<origin xyz rpy>`` as above, ``<mass value>``
finite, ``>= 0`` and ``<=`` :data:`MAX_ABS`, ``<inertia ixx ixy ixz iyy iyz izz>`` each finite with
``|x| <=`` :data:`MAX_ABS`.
"""

from __future__ import annotations

import math

from lxml import etree

from kinserve.kinematics.errors import ModelError
from kinserve.kinematics.validation import MAX_ABS

from .urdf_elements import describe, where

#: The geometry elements of a ``<link>`` that this module checks.
GEOMETRY_ELEMENTS = ("collision", "visual")

#: Each shape urdfdom reads: ``{tag: ((attribute, count), ...)}``, every attribute required and positive.
SHAPES = {
    "box": (("size", 3),),
    "sphere": (("radius", 1),),
    "cylinder": (("radius", 1), ("length", 1)),
    "mesh": (),
}


def validate_geometry(root: etree._Element, label: str) -> None:
    """Check every ``<link>/<collision>`` and ``<link>/<visual>`` of ``root`` (see the module docstring);
    :class:`ModelError` for the first bad one, naming ``label`` (the file), the line, the link, the element
    and the attribute."""
    for link in root.findall("link"):
        for kind in GEOMETRY_ELEMENTS:
            for element in link.findall(kind):
                _check_element(element, link, label)


#: The attributes of ``<inertial>/<inertia>``, all required by urdfdom.
INERTIA_ATTRIBUTES = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def validate_inertial(root: etree._Element, label: str) -> None:
    """Check every ``<link>/<inertial>`` of ``root`` (see the module docstring); :class:`ModelError` for the
    first bad origin, mass (not finite, negative or above :data:`MAX_ABS`) or inertia entry (not finite or
    of magnitude above :data:`MAX_ABS`), naming the file, the line, the link and the attribute."""
    for link in root.findall("link"):
        for inertial in link.findall("inertial"):
            owner = f"{describe(inertial)} of {describe(link)}"
            _check_origin(inertial, label, owner)
            mass = inertial.find("mass")
            if mass is not None:
                value = _numbers(mass, "value", 1, label, owner, positive=False, required=True)
                if value[0] < 0:
                    raise ModelError(f"{where(label, mass)}: {owner}: <mass value={mass.get('value')!r}> "
                                     "must be >= 0 (kg)")
            inertia = inertial.find("inertia")
            if inertia is not None:
                for attr in INERTIA_ATTRIBUTES:
                    _numbers(inertia, attr, 1, label, owner, positive=False, required=True)


def _check_element(element: etree._Element, link: etree._Element, label: str) -> None:
    owner = f"{describe(element)} of {describe(link)}"
    _check_origin(element, label, owner)
    geometries = element.findall("geometry")
    if len(geometries) != 1:
        raise ModelError(f"{where(label, element)}: {owner} must hold one <geometry> element, found "
                         f"{len(geometries)}")
    shapes = [child for child in geometries[0] if isinstance(child.tag, str)]
    if len(shapes) != 1 or shapes[0].tag not in SHAPES:
        found = ", ".join(f"<{s.tag}>" for s in shapes) or "nothing"
        raise ModelError(f"{where(label, geometries[0])}: {owner}: <geometry> must hold exactly one of "
                         f"{', '.join(f'<{t}>' for t in SHAPES)}, found {found}")
    shape = shapes[0]
    for attr, n in SHAPES[shape.tag]:
        _numbers(shape, attr, n, label, owner, positive=True, required=True)
    if shape.tag == "mesh":
        scale = _numbers(shape, "scale", 3, label, owner, positive=False, required=False)
        if scale is not None and 0.0 in scale:
            raise ModelError(f"{where(label, shape)}: {owner}: <mesh scale={shape.get('scale')!r}> must be 3 "
                             "non-zero numbers (a zero factor flattens the mesh)")


def _check_origin(element: etree._Element, label: str, owner: str) -> None:
    """``element``'s ``<origin xyz rpy>`` (optional, each optional): 3 finite numbers of magnitude at most
    :data:`MAX_ABS` each; else :class:`ModelError` naming ``owner``."""
    origin = element.find("origin")
    if origin is not None:
        for attr in ("xyz", "rpy"):
            _numbers(origin, attr, 3, label, owner, positive=False, required=False)


def _numbers(el: etree._Element, attr: str, n: int, label: str, owner: str, *, positive: bool,
             required: bool) -> list[float] | None:
    """The ``n`` numbers of ``el``'s attribute ``attr`` (None when absent and not ``required``), each finite
    with magnitude at most :data:`MAX_ABS` (and ``> 0`` when ``positive``); else :class:`ModelError`."""
    text = el.get(attr)
    place = f"{where(label, el)}: {owner}"
    if text is None:
        if required:
            kind = "positive" if positive else "finite"
            raise ModelError(f"{place}: <{el.tag}> needs a {attr}= attribute ({n} {kind} number(s))")
        return None
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    kind = "positive" if positive else "finite"
    if (len(values) != n or not all(math.isfinite(v) and abs(v) <= MAX_ABS for v in values)
            or (positive and not all(v > 0 for v in values))):
        raise ModelError(f"{place}: <{el.tag} {attr}={text!r}> must be {n} {kind} number(s) with magnitude "
                         f"<= {MAX_ABS:g}")
    return values
