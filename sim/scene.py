"""The rendered world: robot meshes, a gripper, a lab with asymmetric context, an optional board.

The environment is deliberately asymmetric (a floor texture with coloured
quadrants and stripes, two walls of different colours, objects of distinct
shapes and colours in different directions): from a single image a learner
must be able to tell the camera's azimuth.
"""

from __future__ import annotations

import numpy as np

from handeye.core.optional import require_package
from handeye.core.se3 import make_transform

__all__ = ["floor_texture", "gripper_meshes", "environment_meshes", "board_mesh", "marker_mesh"]


def _trimesh():
    return require_package("trimesh", extra="sim", purpose="meshes")


def _box(extents, color, T=np.eye(4)):
    trimesh = _trimesh()
    m = trimesh.creation.box(extents=extents, transform=T)
    m.visual.face_colors = np.array(color, dtype=np.uint8)
    return m


def gripper_meshes() -> list:
    """A parallel gripper in the flange frame: palm and two fingers along the flange's z."""
    dark, grey = (40, 40, 45, 255), (150, 150, 160, 255)
    return [
        _box((0.08, 0.03, 0.04), dark, make_transform(np.eye(3), [0, 0, 0.02])),
        _box((0.012, 0.02, 0.07), grey, make_transform(np.eye(3), [0.028, 0, 0.075])),
        _box((0.012, 0.02, 0.07), grey, make_transform(np.eye(3), [-0.028, 0, 0.075])),
    ]


def floor_texture(size_px: int = 512, seed: int = 0) -> np.ndarray:
    """An asymmetric floor image (RGB uint8): four tinted quadrants, stripes along one axis, a disc off-centre."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 1, size_px), np.linspace(0, 1, size_px))
    img = np.zeros((size_px, size_px, 3))
    tints = np.array([[0.75, 0.7, 0.6], [0.55, 0.65, 0.75], [0.6, 0.72, 0.55], [0.72, 0.58, 0.62]])
    quad = (u > 0.5).astype(int) + 2 * (v > 0.5).astype(int)
    img[:] = tints[quad]
    img *= (0.9 + 0.1 * (np.sin(40 * np.pi * u) > 0))[..., None]  # stripes along one axis only
    img[(u - 0.3) ** 2 + (v - 0.75) ** 2 < 0.01] = [0.85, 0.2, 0.2]
    img += rng.normal(scale=0.02, size=img.shape)
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def _textured_quad(width_m: float, height_m: float, image: np.ndarray, T: np.ndarray):
    """A quad in its local x-y plane (z up), centred, with an image texture (row 0 at +y)."""
    trimesh = _trimesh()
    from PIL import Image

    w, h = width_m / 2, height_m / 2
    vertices = np.array([[-w, -h, 0], [w, -h, 0], [w, h, 0], [-w, h, 0]], dtype=float)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    material = trimesh.visual.texture.SimpleMaterial(image=Image.fromarray(image))
    mesh = trimesh.Trimesh(
        vertices=vertices, faces=faces, process=False, visual=trimesh.visual.TextureVisuals(uv=uv, material=material)
    )
    mesh.apply_transform(T)
    return mesh


def environment_meshes(seed: int = 0) -> list:
    """Floor, two walls and objects around the base (lab frame, metres: the base frame of a one-scene preset).

    The objects stand 2.15-2.6 m from the base, beyond the cameras (at most
    about 1.8 m out), so they are background and never hide the robot. A scene
    of a several-scene preset turns and shifts the lab by ``T_base_lab``
    (:mod:`sim.lab`), which keeps them at least 1.95 m out.
    """
    trimesh = _trimesh()
    meshes = [_textured_quad(7.0, 7.0, floor_texture(seed=seed), make_transform(np.eye(3), [0, 0, -0.001]))]
    meshes.append(_box((7.0, 0.05, 2.0), (200, 190, 150, 255), make_transform(np.eye(3), [0, 3.2, 1.0])))
    meshes.append(_box((0.05, 7.0, 1.4), (120, 140, 170, 255), make_transform(np.eye(3), [-3.2, 0, 0.7])))
    meshes.append(_box((0.4, 0.4, 0.4), (200, 40, 40, 255), make_transform(np.eye(3), [2.3, 0.9, 0.2])))
    meshes.append(_box((0.3, 0.6, 0.9), (240, 200, 30, 255), make_transform(np.eye(3), [-2.0, -1.4, 0.45])))
    cyl = trimesh.creation.cylinder(radius=0.18, height=0.8, transform=make_transform(np.eye(3), [-1.0, 2.3, 0.4]))
    cyl.visual.face_colors = np.array([40, 160, 60, 255], dtype=np.uint8)
    meshes.append(cyl)
    cone = trimesh.creation.cone(radius=0.25, height=0.7, transform=make_transform(np.eye(3), [1.2, -2.3, 0.0]))
    cone.visual.face_colors = np.array([150, 60, 190, 255], dtype=np.uint8)
    meshes.append(cone)
    return meshes


def board_mesh(spec, T_ee_target: np.ndarray, pixels_per_metre: float = 4000.0):
    """The ChArUco board as a textured quad, in the flange frame at ``T_ee_target``.

    The board's target frame (OpenCV: origin at the top-left corner, x along
    columns, y down rows, z into the board) is placed so its printed face
    looks along the target's -z, towards a camera that sees it.
    """
    gray = spec.render(pixels_per_metre)
    rgb = np.repeat(gray[..., None], 3, axis=2)
    w, h = spec.size_m
    # quad local frame: x right, y up (texture row 0 at +y), normal +z; target frame: y down, z into the board
    T_target_quad = make_transform(np.diag([1.0, -1.0, -1.0]), [w / 2, h / 2, -0.0005])
    return _textured_quad(w, h, rgb, T_ee_target @ T_target_quad)


def marker_mesh(radius_m: float = 0.01, color=(255, 0, 255, 255)):
    """A small sphere, for locating a frame's origin in an image."""
    trimesh = _trimesh()
    m = trimesh.creation.icosphere(subdivisions=3, radius=radius_m)
    m.visual.face_colors = np.array(color, dtype=np.uint8)
    return m
