"""A ROS 2 launch file that publishes one static transform (tf2_ros ``static_transform_publisher``).

The file written::

    from launch import LaunchDescription
    from launch_ros.actions import Node


    def generate_launch_description():
        return LaunchDescription([
            Node(
                package="tf2_ros",
                executable="static_transform_publisher",
                name="handeye_base_to_cam",
                arguments=["--x", "0.1", "--y", "0.2", "--z", "0.3",
                           "--qx", "0.0", "--qy", "0.0", "--qz", "0.0", "--qw", "1.0",
                           "--frame-id", "base", "--child-frame-id", "cam"],
            ),
        ])

publishes ``T_parent_child`` (the pose of ``--child-frame-id`` in ``--frame-id``,
what ``tf2_echo parent child`` prints): translation in metres, quaternion
``(x, y, z, w)``, with the named arguments of ROS 2 Humble and later. Numbers
are written with Python's ``repr``, which reads back to the same double.
:func:`read_static_tf_launch` reads such a file back without running it (it
parses the Python, it never executes it).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np

from handeye.core.errors import PoseFileError
from handeye.core.numbers import parse_float
from handeye.core.safe_write import write_text_atomic
from handeye.core.se3 import make_transform, matrix_from_quat_xyzw, pos_quat_xyzw_from_transform

__all__ = ["check_frame_name", "read_static_tf_launch", "write_static_tf_launch"]

_NUMBER_ARGS = ("--x", "--y", "--z", "--qx", "--qy", "--qz", "--qw")
_FRAME_ARGS = ("--frame-id", "--child-frame-id")
_QUAT_NORM_TOL = 1e-3

_TEMPLATE = '''"""ROS 2 launch file written by handeye: the hand-eye calibration as a static transform.

{x_name}: the pose of '{child}' in '{parent}'; translation in metres, quaternion (x, y, z, w).
Run it with ``ros2 launch <this file>``, or include it in your own launch file.
"""

from launch import LaunchDescription
from launch_ros.actions import Node


def generate_launch_description():
    return LaunchDescription([
        Node(
            package="tf2_ros",
            executable="static_transform_publisher",
            name="{node_name}",
            arguments=[
                {numbers}
                "--frame-id", "{parent}",
                "--child-frame-id", "{child}",
            ],
        ),
    ])
'''


def check_frame_name(name: str) -> str:
    """A tf frame name: non-empty, no spaces or quotes; a leading ``/`` is dropped (tf2 refuses it)."""
    name = str(name).lstrip("/")
    if not name or not re.fullmatch(r"[A-Za-z0-9_/.\-]+", name):
        raise PoseFileError(f"frame name {name!r}: use letters, digits, '_', '-', '.' and '/' only")
    return name


def write_static_tf_launch(
    path: str | Path, T_parent_child: np.ndarray, parent: str, child: str, x_name: str | None = None
) -> None:
    """Write a ROS 2 Python launch file publishing ``T_parent_child`` as a static transform.

    Parameters
    ----------
    path : str or Path
        Conventionally ``*.launch.py``.
    T_parent_child : array, shape (4, 4)
        The pose of ``child`` in ``parent``, metres.
    parent, child : str
        tf frame names (``--frame-id``, ``--child-frame-id``).
    x_name : str, optional
        The project's name of the transform for the file's docstring, e.g. ``T_base_cam``.
    """
    parent, child = check_frame_name(parent), check_frame_name(child)
    t, q = pos_quat_xyzw_from_transform(np.asarray(T_parent_child, dtype=float))
    pairs = [f'"{arg}", "{float(v)!r}",' for arg, v in zip(_NUMBER_ARGS, [*t, *q])]
    node_name = "handeye_" + re.sub(r"[^A-Za-z0-9_]", "_", f"{parent}_to_{child}")
    write_text_atomic(
        path,
        _TEMPLATE.format(
            x_name=x_name or f"T_{parent}_{child}",
            parent=parent,
            child=child,
            node_name=node_name,
            numbers="\n                ".join(pairs),
        ),
    )


def _arguments(path: Path, tree: ast.AST) -> ast.List:
    """The ``arguments=[...]`` list of the one tf2_ros static_transform_publisher Node."""
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        kw = {k.arg: k.value for k in node.keywords if k.arg}
        executable = kw.get("executable")
        if isinstance(executable, ast.Constant) and executable.value == "static_transform_publisher":
            found.append((node, kw))
    if len(found) != 1:
        raise PoseFileError(f"{path}: {len(found)} static_transform_publisher nodes; expected one")
    node, kw = found[0]
    package = kw.get("package")
    if not (isinstance(package, ast.Constant) and package.value == "tf2_ros"):
        raise PoseFileError(f"{path}, line {node.lineno}: the static_transform_publisher is not from package tf2_ros")
    args = kw.get("arguments")
    if not isinstance(args, ast.List):
        raise PoseFileError(f"{path}, line {node.lineno}: the node has no literal 'arguments=[...]' list")
    return args


def read_static_tf_launch(path: str | Path) -> tuple[np.ndarray, str, str]:
    """Read the static transform of a launch file written by :func:`write_static_tf_launch`.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    T_parent_child : array, shape (4, 4)
    parent, child : str

    Raises
    ------
    PoseFileError
        Naming the file and line: not Python, no single static_transform_publisher,
        an argument missing, repeated or not a number, a quaternion that is not unit,
        old-style positional arguments.
    """
    path = Path(path)
    if not path.is_file():
        raise PoseFileError(f"{path}: no such file")
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    except (SyntaxError, UnicodeDecodeError, ValueError) as exc:
        line = getattr(exc, "lineno", None)
        raise PoseFileError(f"{path}{f', line {line}' if line else ''}: not a Python launch file ({exc})") from None
    args = _arguments(path, tree)
    items = args.elts
    for item in items:
        if not (isinstance(item, ast.Constant) and isinstance(item.value, str)):
            raise PoseFileError(f"{path}, line {item.lineno}: arguments must be string literals")
    values = {}
    k = 0
    while k < len(items):
        flag, line = items[k].value, items[k].lineno
        if flag not in _NUMBER_ARGS + _FRAME_ARGS:
            raise PoseFileError(
                f"{path}, line {line}: argument {flag!r} not understood; expected the named "
                f"arguments {' '.join(_NUMBER_ARGS + _FRAME_ARGS)} (ROS 2 Humble and later)"
            )
        if flag in values:
            raise PoseFileError(f"{path}, line {line}: {flag} given twice")
        if k + 1 >= len(items):
            raise PoseFileError(f"{path}, line {line}: {flag} has no value")
        values[flag] = (items[k + 1].value, items[k + 1].lineno)
        k += 2
    missing = [a for a in _NUMBER_ARGS + _FRAME_ARGS if a not in values]
    if missing:
        raise PoseFileError(f"{path}, line {args.lineno}: missing {', '.join(missing)}")
    numbers = []
    for flag in _NUMBER_ARGS:
        text, line = values[flag]
        numbers.append(parse_float(text, f"{path}, line {line}: {flag}", PoseFileError))
    q = np.array(numbers[3:])
    if abs(np.linalg.norm(q) - 1.0) > _QUAT_NORM_TOL:
        raise PoseFileError(
            f"{path}, line {values['--qx'][1]}: quaternion (x, y, z, w) {q.tolist()} has norm "
            f"{np.linalg.norm(q):.4f}, not 1"
        )
    T = make_transform(matrix_from_quat_xyzw(q), np.array(numbers[:3]))
    return T, values["--frame-id"][0], values["--child-frame-id"][0]
