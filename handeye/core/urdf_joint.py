"""A URDF ``<joint>`` snippet that fixes a child link (the camera) to a parent link.

The snippet written::

    <joint name="base_to_cam" type="fixed">
      <parent link="base"/>
      <child link="cam"/>
      <origin xyz="0.1 0.2 0.3" rpy="0.0 0.0 1.5707963267948966"/>
    </joint>

``<origin>`` is the pose of the child link in the parent link, ``T_parent_child``:
``xyz`` in metres and ``rpy`` in radians, fixed axes (roll about X, then pitch
about Y, then yaw about Z): ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)``
(:func:`handeye.core.robot_angles.matrix_from_urdf_rpy`). Paste it inside the
``<robot>`` of the cell's URDF (xacro alike); the child link needs its own
``<link name="cam"/>``, which the snippet does not add. Numbers are written with
Python's ``repr``, which reads back to the same double.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from handeye.core.errors import PoseFileError
from handeye.core.numbers import parse_float
from handeye.core.robot_angles import matrix_from_urdf_rpy, urdf_rpy_from_matrix
from handeye.core.ros_launch import check_frame_name
from handeye.core.safe_write import write_text_atomic
from handeye.core.se3 import make_transform

__all__ = ["read_urdf_joint", "write_urdf_joint"]


def write_urdf_joint(
    path: str | Path,
    T_parent_child: np.ndarray,
    parent: str,
    child: str,
    joint_name: str | None = None,
    x_name: str | None = None,
) -> None:
    """Write a fixed URDF joint placing ``child`` at ``T_parent_child``.

    Parameters
    ----------
    path : str or Path
    T_parent_child : array, shape (4, 4)
        The pose of link ``child`` in link ``parent``, metres.
    parent, child : str
        Link names.
    joint_name : str, optional
        Default ``<parent>_to_<child>``.
    x_name : str, optional
        The project's name of the transform for the comment, e.g. ``T_base_cam``.
    """
    parent, child = check_frame_name(parent), check_frame_name(child)
    T = np.asarray(T_parent_child, dtype=float)
    xyz = " ".join(repr(float(v)) for v in T[:3, 3])
    rpy = " ".join(repr(float(v)) for v in urdf_rpy_from_matrix(T[:3, :3]))
    name = joint_name or f"{parent}_to_{child}"
    label = x_name or f"T_{parent}_{child}"
    write_text_atomic(
        path,
        f"<!-- written by handeye: {label}, the pose of link '{child}' in link '{parent}'; "
        f"xyz in metres, rpy in radians (fixed axes X, Y, Z) -->\n"
        f'<joint name={quoteattr(name)} type="fixed">\n'
        f"  <parent link={quoteattr(parent)}/>\n"
        f"  <child link={quoteattr(child)}/>\n"
        f'  <origin xyz="{xyz}" rpy="{rpy}"/>\n'
        f"</joint>\n",
    )


def _triple(path: Path, origin: ET.Element, key: str, line: int) -> np.ndarray:
    text = origin.get(key, "0 0 0")  # URDF: a missing xyz or rpy is zero
    where = f"{path}, line {line}: origin {key}"
    values = np.array([parse_float(v, where, PoseFileError) for v in text.split()])
    if values.shape != (3,):
        raise PoseFileError(f"{path}, line {line}: origin {key}={text!r} is not three finite numbers")
    return values


def _line_of(text: str, element: str, name: str | None) -> int:
    """Line of the first ``<element`` (with ``name="..."``, if given) in the text, for messages; 0 if not found."""
    for k, line in enumerate(text.splitlines(), start=1):
        if f"<{element}" in line and (name is None or f'"{name}"' in line or f"'{name}'" in line):
            return k
    return 0


def read_urdf_joint(path: str | Path, joint_name: str | None = None) -> tuple[np.ndarray, str, str]:
    """Read a joint's origin from a URDF snippet or a whole URDF.

    Parameters
    ----------
    path : str or Path
        A file holding one ``<joint>`` (as :func:`write_urdf_joint` writes it)
        or a ``<robot>`` with several.
    joint_name : str, optional
        Which joint; needed when the file holds more than one.

    Returns
    -------
    T_parent_child : array, shape (4, 4)
    parent, child : str

    Raises
    ------
    PoseFileError
        Naming the file and line: not XML, no such joint, no parent or child
        link, an origin that is not three numbers.
    """
    path = Path(path)
    text, root = _parse_xml(path)
    joint = _the_joint(path, root, joint_name)
    line = _line_of(text, "joint", joint.get("name"))
    parent, child = _joint_link(path, joint, "parent", line), _joint_link(path, joint, "child", line)
    origin = joint.find("origin")
    if origin is None:  # URDF: no origin is the identity
        return np.eye(4), parent, child
    origin_line = _line_of(text, "origin", None) if root.tag == "joint" else line
    xyz = _triple(path, origin, "xyz", origin_line)
    rpy = _triple(path, origin, "rpy", origin_line)
    return make_transform(matrix_from_urdf_rpy(rpy), xyz), parent, child


def _parse_xml(path: Path) -> tuple[str, ET.Element]:
    """The file's text and its parsed XML root."""
    if not path.is_file():
        raise PoseFileError(f"{path}: no such file")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise PoseFileError(f"{path}: not UTF-8 text (byte {exc.start}); a URDF is XML text") from None
    try:
        return text, ET.fromstring(text)
    except ET.ParseError as exc:
        raise PoseFileError(f"{path}, line {exc.position[0]}: not valid XML ({exc})") from None


def _the_joint(path: Path, root: ET.Element, joint_name: str | None) -> ET.Element:
    """The file's one joint, or its one joint named ``joint_name``."""
    joints = [root] if root.tag == "joint" else root.findall(".//joint")
    chosen = joints if joint_name is None else [j for j in joints if j.get("name") == joint_name]
    if len(chosen) != 1:
        names = ", ".join(str(j.get("name")) for j in joints)
        which = f"named {joint_name!r}" if joint_name else "in all"
        raise PoseFileError(f"{path}: {len(chosen)} joints {which} (joints: {names or 'none'}); name the joint")
    return chosen[0]


def _joint_link(path: Path, joint: ET.Element, role: str, line: int) -> str:
    """The link the joint's ``<parent>`` or ``<child>`` (``role``) names."""
    element = joint.find(role)
    if element is None or not element.get("link"):
        raise PoseFileError(f'{path}, line {line}: joint {joint.get("name")!r} has no <{role} link="..."/>')
    return element.get("link")
