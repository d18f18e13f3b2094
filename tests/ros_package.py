"""A ROS-style package made in a test folder: ``my_pkg/{package.xml, urdf/robot.urdf, meshes/link.stl}``.

The robot: three links whose collision shapes are one STL cube (half edge
:data:`HALF` = 0.05 m, written here as a binary STL of 12 outward triangles)
named by ``package://my_pkg/meshes/link.stl``:

* ``base``: the cube scaled by 2 (half edge 0.1 m), centred at the origin;
* joint ``j1`` about z at ``(0, 0, 0.3)``; ``l1``: the cube at the joint;
* joint ``j2`` about y at the same point; ``l2``: the cube centred at
  ``(0.25, 0, 0)`` in its frame; fixed ``tool`` frame at ``(0.5, 0, 0)``.

At ``q = (0, 0)`` the ``l2`` cube spans ``[0.2, 0.3] x [-0.05, 0.05] x [0.25, 0.35]``
and the base cube ``[-0.1, 0.1]^3``: their distance is ``hypot(0.1, 0.15)``.
At ``q = (0, pi/2)`` ``Ry(pi/2)`` takes ``l2``'s centre to ``(0, 0, 0.05)``,
inside the base cube: ``base`` / ``l2`` collide.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path
from typing import NamedTuple

import numpy as np

#: Half edge (m) of the cube in link.stl.
HALF = 0.05
#: Distance (m) between the l2 and base cubes at q = (0, 0) (see the module docstring).
CLEARANCE_AT_ZERO = math.hypot(0.1, 0.15)
#: A configuration where l2 is inside the base cube.
Q_COLLIDING = (0.0, math.pi / 2)

MESH_URI = "package://my_pkg/meshes/link.stl"


class RosPackage(NamedTuple):
    """Paths of the package made by :func:`make_package`."""

    workspace: Path  #: the folder holding my_pkg (what $ROS_PACKAGE_PATH would list)
    package: Path  #: my_pkg
    urdf: Path  #: my_pkg/urdf/robot.urdf
    stl: Path  #: my_pkg/meshes/link.stl


def write_cube_stl(path: Path, half: float = HALF) -> None:
    """Binary STL of the cube ``[-half, half]^3``: 80-byte header, count, 12 outward triangles."""
    corner = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    out = bytearray(b"kinserve test cube".ljust(80, b"\0"))
    out += struct.pack("<I", len(faces))
    for a, b, c in faces:
        n = np.cross(corner[b] - corner[a], corner[c] - corner[a])
        n /= np.linalg.norm(n)
        assert np.dot(n, corner[a]) > 0  # outward
        out += struct.pack("<12fH", *n, *corner[a], *corner[b], *corner[c], 0)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(bytes(out))


def robot_urdf(uri: str = MESH_URI, l1_uri: str | None = None) -> str:
    """The URDF text of the module docstring's robot (``l1_uri`` overrides the mesh of l1 only)."""
    def collision(link: str, mesh_uri: str, xyz: str = "0 0 0", scale: str = "1 1 1") -> str:
        return (f'<link name="{link}"><collision><origin xyz="{xyz}"/><geometry>'
                f'<mesh filename="{mesh_uri}" scale="{scale}"/></geometry></collision></link>')

    return (
        '<?xml version="1.0"?>\n<robot name="my_bot">\n'
        f'  {collision("base", uri, scale="2 2 2")}\n'
        f'  {collision("l1", l1_uri or uri)}\n'
        f'  {collision("l2", uri, xyz="0.25 0 0")}\n'
        '  <link name="tool"/>\n'
        '  <joint name="j1" type="revolute"><origin xyz="0 0 0.3"/><parent link="base"/><child link="l1"/>'
        '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>\n'
        '  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>'
        '<axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>\n'
        '  <joint name="j3" type="fixed"><origin xyz="0.5 0 0"/><parent link="l2"/><child link="tool"/>'
        '</joint>\n'
        '</robot>\n'
    )


def package_xml(name: str) -> str:
    """A minimal ROS package manifest naming package ``name``."""
    return (f'<?xml version="1.0"?>\n<package format="3"><name>{name}</name>'
            '<version>0.1.0</version></package>\n')


def make_package(root: Path, name: str = "my_pkg") -> RosPackage:
    """``root/<name>/{package.xml, urdf/robot.urdf, meshes/link.stl}`` (the package is named ``name``)."""
    package = root / name
    (package / "urdf").mkdir(parents=True)
    (package / "package.xml").write_text(package_xml(name))
    urdf = package / "urdf" / "robot.urdf"
    urdf.write_text(robot_urdf(MESH_URI.replace("my_pkg", name)))
    stl = package / "meshes" / "link.stl"
    write_cube_stl(stl)
    return RosPackage(root, package, urdf, stl)
