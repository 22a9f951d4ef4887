"""Offscreen rendering of the robot cell with pyrender (headless EGL).

``PYOPENGL_PLATFORM`` defaults to ``egl`` here, before OpenGL is imported.
Camera poses come in as OpenCV ``T_base_cam`` and are converted once
(:mod:`sim.opengl`). Depth is the z coordinate in the camera frame, metres,
0 where nothing was hit (the convention of RGB-D sensors). The lab stands
where :meth:`Renderer.set_environment_pose` puts it (``T_base_lab``, the
identity unless set: :mod:`sim.lab`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from handeye.core.optional import require_package
from handeye.robot.meshes import load_link_mesh
from sim.opengl import gl_camera_pose, gl_principal_point
from sim.scene import board_mesh, environment_meshes, gripper_meshes, marker_mesh

__all__ = ["Renderer", "SceneContents", "ZNEAR_M", "ZFAR_M"]

#: Clipping planes. The depth buffer's resolution at depth z is about z^2 / (znear 2^bits): a near plane
#: at 10 cm keeps it well under a millimetre at the cell's distances (nothing is rendered closer).
ZNEAR_M = 0.1
ZFAR_M = 10.0


def _single_sample_framebuffers(pyrender) -> None:
    """Make pyrender's framebuffers single-sample.

    pyrender renders into a 4x multisample framebuffer and blits it; colour is
    averaged over the samples, but depth comes from one sample, which Mesa
    places 0.125 px left of and 0.375 px below the pixel centre: depth (and any
    mask made from it) would be shifted against the camera model by that much.
    With one sample, every pixel is sampled at its centre.
    """
    module = pyrender.renderer
    if getattr(module, "_handeye_single_sample", False):
        return
    original = module.glRenderbufferStorageMultisample

    def single_sample(target, samples, internal_format, width, height):
        return original(target, 0, internal_format, width, height)

    module.glRenderbufferStorageMultisample = single_sample
    module._handeye_single_sample = True


def _matte(mesh):
    """Paper-like surfaces: trimesh's textured materials arrive in pyrender metallic and darkened (0.4)."""
    for primitive in mesh.primitives:
        material = primitive.material
        material.metallicFactor = 0.0
        material.roughnessFactor = 1.0
        if material.baseColorTexture is not None:
            material.baseColorFactor = np.ones(4)
    return mesh


@dataclass(frozen=True)
class SceneContents:
    """What a :class:`Renderer` draws; by default the lab, the robot and its gripper.

    Attributes
    ----------
    environment, gripper : bool
        Draw the lab and the gripper.
    board : (BoardSpec, array (4, 4)), optional
        A ChArUco board and its pose ``T_ee_target`` on the flange.
    marker_radius_m : float, optional
        Draw a sphere of this radius centred on the flange origin.
    robot_visible : bool
        Draw the robot's links.
    """

    environment: bool = True
    gripper: bool = True
    board: tuple | None = None
    marker_radius_m: float | None = None
    robot_visible: bool = True


class Renderer:
    """A pyrender scene of one robot, its tool, the lab, and optionally a board or a flange marker.

    Parameters
    ----------
    robot : handeye.robot.model.Robot
    K : array, shape (3, 3)
        OpenCV camera matrix (pixel centres at integers).
    width, height : int
    contents : SceneContents, optional
        What is drawn: the lab, the robot's links, the gripper, a board or a flange marker; None:
        ``SceneContents()`` (the lab, the robot and its gripper).
    """

    def __init__(self, robot, K, width, height, contents: SceneContents | None = None):
        os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
        self.pyrender = require_package("pyrender", extra="sim", purpose="rendering")
        pr = self.pyrender
        _single_sample_framebuffers(pr)
        self.robot = robot
        contents = contents or SceneContents()
        self.scene = pr.Scene(ambient_light=np.array([0.35, 0.35, 0.35]), bg_color=np.array([0.8, 0.85, 0.9, 1.0]))
        self.environment_nodes = []  # posed by T_base_lab, the identity until set_environment_pose
        if contents.environment:
            for m in environment_meshes():
                self.environment_nodes.append(self.scene.add(_matte(pr.Mesh.from_trimesh(m, smooth=False))))
        self.link_nodes = []
        if contents.robot_visible:
            for name, path, _ in robot.link_poses(np.zeros(robot.nq)):
                self.link_nodes.append(self.scene.add(pr.Mesh.from_trimesh(load_link_mesh(path)), name=name))
        self.ee_nodes = []  # (node, T_ee_mesh)
        if contents.gripper:
            for m in gripper_meshes():
                self.ee_nodes.append((self.scene.add(pr.Mesh.from_trimesh(m, smooth=False)), np.eye(4)))
        if contents.board is not None:
            spec, T_ee_target = contents.board
            board_node = self.scene.add(_matte(pr.Mesh.from_trimesh(board_mesh(spec, T_ee_target))))
            self.ee_nodes.append((board_node, np.eye(4)))
        if contents.marker_radius_m is not None:
            marker = marker_mesh(contents.marker_radius_m)
            self.ee_nodes.append((self.scene.add(pr.Mesh.from_trimesh(marker, smooth=False)), np.eye(4)))
        cx, cy = gl_principal_point(K[0, 2], K[1, 2])
        camera = pr.IntrinsicsCamera(fx=K[0, 0], fy=K[1, 1], cx=cx, cy=cy, znear=ZNEAR_M, zfar=ZFAR_M)
        self.camera_node = self.scene.add(camera)
        self.light_node = self.scene.add(pr.DirectionalLight(color=np.ones(3), intensity=3.0))
        self.scene.add(
            pr.DirectionalLight(color=np.ones(3), intensity=1.5),
            pose=np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 2], [0, 0, 0, 1]], dtype=float),
        )
        self.renderer = pr.OffscreenRenderer(int(width), int(height))

    def set_environment_pose(self, T_base_lab: np.ndarray) -> None:
        """Pose the lab (floor, walls, objects) in the base frame for the next renders.

        Parameters
        ----------
        T_base_lab : array, shape (4, 4)
            The lab frame the environment meshes are built in, in the base frame
            (:func:`sim.lab.T_base_lab`); the identity is the lab of a preset with one scene.
        """
        T_base_lab = np.asarray(T_base_lab, dtype=float)
        for node in self.environment_nodes:
            self.scene.set_pose(node, T_base_lab)

    def render(self, q: np.ndarray, T_base_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Colour and depth of the cell with the robot at ``q`` seen from ``T_base_cam``.

        Parameters
        ----------
        q : array, shape (nq,)
        T_base_cam : array, shape (4, 4)
            OpenCV camera pose in the base frame.

        Returns
        -------
        rgb : array of uint8, shape (H, W, 3)
        depth_m : array of float32, shape (H, W)
            Camera-frame z, 0 where nothing was hit.
        """
        for node, (_, _, T) in zip(self.link_nodes, self.robot.link_poses(q)):
            self.scene.set_pose(node, T)
        T_base_ee = self.robot.fk(q)
        for node, T_ee_mesh in self.ee_nodes:
            self.scene.set_pose(node, T_base_ee @ T_ee_mesh)
        T_base_glcam = gl_camera_pose(T_base_cam)
        self.scene.set_pose(self.camera_node, T_base_glcam)
        self.scene.set_pose(self.light_node, T_base_glcam)
        rgb, depth = self.renderer.render(self.scene)
        return rgb, depth.astype(np.float32)

    def close(self) -> None:
        """Release the OpenGL context."""
        self.renderer.delete()
