"""The robot and the cell's sensors as a real calibration needs them, without the simulator.

Modules: :mod:`handeye.robot.model` (a UR from example-robot-data or any URDF through Pinocchio: forward and
inverse kinematics, the flange and reference frames, keypoints, each part's twist per joint, the inverse
kinematics' seeds), :mod:`handeye.robot.meshes` (the link meshes, read once), :mod:`handeye.robot.surface`
(the arm's surface as points with normals, posed by the joints), :mod:`handeye.robot.look_at` (a camera's pose
from where it is and what it looks at), :mod:`handeye.robot.depth_sensors` (the depth cameras' errors as data).

The layer sits above the foundation (:mod:`handeye.core`) and the solvers (:mod:`classic`) and below the
simulator (:mod:`sim`) and the front: calibrating a real cell imports it, never the renderer
(``tests/test_layers.py``). Pinocchio, example-robot-data, trimesh and pycollada come with ``handeye[robot]``;
nothing here is imported with the package itself.
"""
