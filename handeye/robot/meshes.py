"""The robot's link meshes, read once.

Trimesh reads the visual meshes a URDF names (``.stl``, ``.obj``; ``.dae`` needs pycollada); the surface sampler
(:mod:`handeye.robot.surface`) and the simulator's renderer share the cache.
"""

from __future__ import annotations

from functools import lru_cache

from handeye.core.optional import require_package

__all__ = ["load_link_mesh"]


def _trimesh():
    return require_package("trimesh", extra="robot", purpose="meshes")


@lru_cache(maxsize=64)
def load_link_mesh(path: str):
    """A robot link's visual mesh (``.dae`` needs pycollada), merged into one trimesh, cached."""
    return _trimesh().load(path, force="mesh")
