"""robots: URDF / xacro model files, the DH -> URDF builder and the registry (name | path -> Robot).

    from kinserve import robots
    robots.available()                    # {name: description}
    panda = robots.load("panda")          # a kinserve.kinematics.Robot (fresh Data each call)
    arm = robots.load("planar4r", l1=1.2) # parametric seed robot (xacro args)
    r = robots.load("my_arm.urdf.xacro", params={"reach": 0.8})
    mine = robots.load("ws/src/my_robot_description/urdf/my_robot.urdf", package_dirs=["ws/src"])
    dh = robots.from_dh([(0.5, 0, 0, 0), (0.5, 0, 0, 0)], "RR")

``robots`` imports ``kinematics``, never the reverse.
"""

from .dh import check_dh_table, dh_fk, dh_matrix, dh_to_urdf, from_dh
from .mesh_resolver import MeshResolver
from .packages import PackageFinder
from .paths import example_robot_data_dir, example_robot_data_package_dir, models_dir
from .registry import ENTRIES, available, canonical_name, clear_cache, load, parameters
from .srdf import find_srdf, read_srdf
from .urdf_loader import CONTINUOUS_LIMIT, MissingMeshWarning, load_urdf
from .xacro_loader import declared_args, load_xacro, process_xacro

__all__ = [
    "load", "available", "parameters", "clear_cache", "canonical_name", "ENTRIES",
    "PackageFinder", "MeshResolver", "MissingMeshWarning", "find_srdf", "read_srdf",
    "load_urdf", "load_xacro", "process_xacro", "declared_args", "CONTINUOUS_LIMIT",
    "from_dh", "dh_to_urdf", "dh_matrix", "dh_fk", "check_dh_table",
    "example_robot_data_dir", "example_robot_data_package_dir", "models_dir",
]
