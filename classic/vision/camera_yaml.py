"""Camera intrinsics in YAML: ROS ``camera_info`` files and OpenCV FileStorage files.

ROS ``camera_info`` (what ``camera_calibration`` writes and a driver's
``camera_info_url`` loads)::

    image_width: 640
    image_height: 480
    camera_name: narrow_stereo
    camera_matrix: {rows: 3, cols: 3, data: [fx, 0, cx, 0, fy, cy, 0, 0, 1]}
    distortion_model: plumb_bob
    distortion_coefficients: {rows: 1, cols: 5, data: [k1, k2, p1, p2, k3]}
    rectification_matrix: ...
    projection_matrix: ...

(the ``CameraInfo`` message as ROS 1 ``rostopic echo -n 1`` prints it, with
``width``, ``height``, ``K``, ``D`` in brackets, is read too).
``plumb_bob`` and ``rational_polynomial`` are OpenCV's model with 5 and 8
coefficients; ``equidistant`` (fisheye) is not the pinhole model of
:class:`CameraIntrinsics` and is refused.

OpenCV FileStorage YAML (first line ``%YAML:1.0``, matrices tagged
``!!opencv-matrix``), as ``cv2.FileStorage`` writes it and OpenCV's
calibration samples save: the camera matrix under ``camera_matrix``,
``cameraMatrix``, ``K`` or ``M``, the distortion under
``distortion_coefficients``, ``dist_coeffs``, ``distCoeffs``, ``D`` or ``dist``,
the size as ``image_width``/``image_height`` or ``image_size``/``imageSize``, and the one-sigma of
``fx, fy, cx, cy, k1, k2, p1, p2, k3`` as ``intrinsics_std`` (1 x 9, what :func:`write_opencv_yaml` writes
of :attr:`CameraIntrinsics.std <classic.vision.camera.CameraIntrinsics.std>`; OpenCV's own files have none).
A camera_info file carries no one-sigma: :meth:`~classic.vision.camera.CameraIntrinsics.std_vector` then
takes its stated default.

Both are parsed with ``cv2.FileStorage`` (OpenCV's YAML subset: sequences
indented or in brackets). A malformed file raises
:class:`~classic.vision.camera.IntrinsicsError` naming the file and the line.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from handeye.core.errors import IntrinsicsError
from handeye.core.optional import require_package
from handeye.core.safe_write import write_text_atomic

__all__ = ["YAML_SUFFIXES", "load_intrinsics_yaml", "write_camera_info_yaml", "write_opencv_yaml"]

YAML_SUFFIXES = (".yaml", ".yml")
#: camera_info distortion models that are OpenCV's pinhole model, and their coefficient counts.
ROS_DISTORTION_MODELS = {"plumb_bob": (4, 5), "rational_polynomial": (8,)}
_K_KEYS = ("camera_matrix", "cameraMatrix", "K", "M")
_D_KEYS = ("distortion_coefficients", "dist_coeffs", "distCoeffs", "D", "dist")
_STD_KEY = "intrinsics_std"
_STD_NAMES = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")  # classic.vision.camera.STD_NAMES
_MAX_BYTES = 1024 * 1024


def _cv2():
    return require_package("cv2", extra="vision", purpose="reading intrinsics YAML")


def _line_of(text: str, key: str) -> int:
    """The 1-based line of the first ``key:`` in the text, 0 if absent."""
    pattern = re.compile(rf"^\s*{re.escape(key)}\s*:")
    return next((k for k, line in enumerate(text.splitlines(), start=1) if pattern.match(line)), 0)


#: Integers OpenCV's YAML parser reads in another base (``strtol`` base 0): ``0612`` is 394, ``0x264`` is 612.
_OTHER_BASE = re.compile(r"(?<![\w.+-])[+-]?0(?:[xX][0-9a-fA-F]+|[0-7]+)(?![\w.])")
_QUOTED = re.compile(r"\"[^\"]*\"|'[^']*'")


def _check_number_forms(path: Path, text: str) -> None:
    """Refuse the integers OpenCV would read as octal or hexadecimal, naming the line (:mod:`handeye.core.numbers`
    reads decimal only: a camera matrix entry ``0612`` must not become 394 pixels).

    Raises
    ------
    IntrinsicsError
    """
    for number, line in enumerate(text.splitlines(), start=1):
        body = _QUOTED.sub("", line.split("#", 1)[0])
        found = _OTHER_BASE.search(body)
        if found:
            raise IntrinsicsError(
                f"{path}, line {number}: {found.group(0)!r} is not a decimal number (OpenCV would read it as "
                "octal or hexadecimal); write it in decimal without leading zeros"
            )


def _error(path: Path, text: str, key: str | None, message: str) -> IntrinsicsError:
    line = _line_of(text, key) if key else 0
    return IntrinsicsError(f"{path}{f', line {line}' if line else ''}: {message}")


def _open(path: Path, text: str):
    """A FileStorage of the text; a header ``%YAML:1.0`` is added to a camera_info file (line numbers kept)."""
    cv2 = _cv2()
    opencv = text.lstrip().startswith("%YAML")
    body = text if opencv else "%YAML:1.0\n" + _first_document(text)
    try:
        fs = cv2.FileStorage(body, cv2.FILE_STORAGE_READ | cv2.FILE_STORAGE_MEMORY)
    except (cv2.error, SystemError) as exc:
        raise _unreadable(path, exc, 0 if opencv else 1) from None
    if not fs.isOpened():
        raise IntrinsicsError(f"{path}: OpenCV cannot open it as YAML")
    return fs, opencv


def _first_document(text: str) -> str:
    """rostopic echo brackets the message with '---' lines: they are dropped (a blank line keeps the numbering),
    and the text stops at the next message; OpenCV reads one document."""
    kept, content = [], False
    for line in text.splitlines(keepends=True):
        if line.strip() in ("---", "..."):
            if content:
                break
            line = "\n"
        content = content or bool(line.strip() and not line.lstrip().startswith("#"))
        kept.append(line)
    return "".join(kept)


def _unreadable(path: Path, exc: Exception, added_lines: int) -> IntrinsicsError:
    """The error of a text OpenCV's YAML reader refused, at the file's line where OpenCV names one."""
    cause = str(exc.__cause__ or exc)
    found = re.search(r"\((\d+)\): ([^\n]*)", cause)
    if found is None:
        return IntrinsicsError(f"{path}: not a YAML file OpenCV can read ({cause.strip()})")
    line = int(found.group(1)) - added_lines
    problem = found.group(2).strip("' ")
    return IntrinsicsError(
        f"{path}, line {line}: not a YAML file OpenCV can read ({problem}; "
        f"OpenCV's YAML needs sequences indented or in brackets)"
    )


def _numbers(node) -> np.ndarray | None:
    """A node's numbers: an ``!!opencv-matrix``, a sequence, or a camera_info ``{rows, cols, data}`` mapping."""
    if node.empty():
        return None
    if node.isMap() and not node.getNode("dt").empty():
        return np.asarray(node.mat(), dtype=float).ravel()
    if node.isMap() and not node.getNode("data").empty():
        node = node.getNode("data")
    if node.isSeq():
        return _sequence_numbers(node)
    if node.isReal() or node.isInt():
        return np.array([node.real()])
    raise ValueError("not a list of numbers")


def _sequence_numbers(node) -> np.ndarray:
    """The numbers of a sequence node, refusing any item that is not one."""
    values = [node.at(k) for k in range(node.size())]
    if not all(v.isReal() or v.isInt() for v in values):
        raise ValueError("not all numbers")
    return np.array([v.real() for v in values], dtype=float)


def _get(path: Path, text: str, fs, keys: tuple[str, ...], what: str, required: bool = True):
    """``(key, numbers)`` of the first key present, or ``(None, None)`` when not required and absent."""
    for key in keys:
        node = fs.getNode(key)
        if node.empty():
            continue
        try:
            values = _numbers(node)
        except (ValueError, SystemError, _cv2().error) as exc:  # cv2.error: a malformed !!opencv-matrix
            cause = str(getattr(exc, "__cause__", None) or exc).strip().splitlines()[-1]
            cause = "its data does not hold rows x cols numbers" if "nelems" in cause else cause
            raise _error(path, text, key, f"{key} ({what}) is not a matrix of numbers ({cause})") from None
        return key, values
    if required:
        raise _error(path, text, None, f"no {what}: expected one of {', '.join(keys)}")
    return None, None


def _size(path: Path, text: str, fs) -> tuple[int, int]:
    """The image size: ``image_width``/``image_height``, ``width``/``height`` or ``image_size``; ``(0, 0)``: none."""
    size = _width_height(path, text, fs)
    if size is not None:
        return size
    key, values = _get(path, text, fs, ("image_size", "imageSize"), "image size", required=False)
    if key is None:
        return 0, 0
    if values.shape != (2,) or np.any(values < 0) or np.any(values != np.round(values)):
        raise _error(path, text, key, f"{key} must be [width, height] in whole pixels, got {values.tolist()}")
    return int(values[0]), int(values[1])


def _width_height(path: Path, text: str, fs) -> tuple[int, int] | None:
    """The first pair of width and height keys the file holds, checked; None: neither pair."""
    for wkey, hkey in (("image_width", "image_height"), ("width", "height")):
        w, h = fs.getNode(wkey), fs.getNode(hkey)
        if not w.empty() and not h.empty():
            if not (w.isInt() and h.isInt() and w.real() >= 0 and h.real() >= 0):
                raise _error(path, text, wkey, f"{wkey}/{hkey} must be whole numbers of pixels")
            return int(w.real()), int(h.real())
    return None


def load_intrinsics_yaml(path: str | Path, build):
    """Read intrinsics from a ROS camera_info or an OpenCV FileStorage YAML file.

    Parameters
    ----------
    path : str or Path
    build : callable
        ``build(K, dist, width, height[, std])`` makes the result (:meth:`CameraIntrinsics.load` passes the
        class, so that this module needs not import it); ``std`` only where the file has ``intrinsics_std``;
        its :class:`IntrinsicsError` gets the file and line.

    Returns
    -------
    What ``build`` returns, of ``K`` ``(3, 3)`` in pixels, ``dist`` (OpenCV's order), the image size (0 when
    the file has none).

    Raises
    ------
    IntrinsicsError
        Naming the file and the line: not readable YAML, no camera matrix, a
        matrix of the wrong size, a distortion model other than OpenCV's, distortion coefficients (or no
        distortion key) of a count the model does not take.
    """
    path = Path(path)
    text = _read_text(path)
    _check_number_forms(path, text)
    fs, _ = _open(path, text)
    try:
        k_key, K = _get(path, text, fs, _K_KEYS, "camera matrix")
        if K.size != 9:
            raise _error(path, text, k_key, f"{k_key} holds {K.size} numbers; a camera matrix has 9")
        dist = _distortion(path, text, fs)
        width, height = _size(path, text, fs)
        s_key, std = _get(path, text, fs, (_STD_KEY,), "one-sigma of the intrinsics", required=False)
        if std is not None and std.size != len(_STD_NAMES):
            raise _error(path, text, s_key, f"{s_key} holds {std.size} numbers; it has one per {', '.join(_STD_NAMES)}")
        extra = [] if std is None else [dict(zip(_STD_NAMES, map(float, std)))]
        try:
            return build(K.reshape(3, 3), dist, width, height, *extra)
        except IntrinsicsError as exc:
            raise _error(path, text, k_key, str(exc)) from None
    finally:
        fs.release()


def _read_text(path: Path) -> str:
    """The file's text (UTF-8, a byte-order mark dropped), refusing a missing, too large or undecodable file."""
    if not path.is_file():
        raise IntrinsicsError(f"{path}: no such intrinsics file")
    if path.stat().st_size > _MAX_BYTES:
        raise IntrinsicsError(f"{path}: {path.stat().st_size:,} bytes, too large for an intrinsics file")
    try:
        return path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise IntrinsicsError(f"{path}: not UTF-8 text (byte {exc.start})") from None


def _distortion(path: Path, text: str, fs) -> np.ndarray:
    """The distortion coefficients (five zeros when none), checked against a ``distortion_model`` if given."""
    d_key, dist = _get(path, text, fs, _D_KEYS, "distortion", required=False)
    model_node = fs.getNode("distortion_model")
    model = model_node.string() if not model_node.empty() else ""
    held = 0 if dist is None else dist.size
    if held == 0:
        dist = np.zeros(5)
    if model and model not in ROS_DISTORTION_MODELS:
        pinhole = " or ".join(ROS_DISTORTION_MODELS)
        message = f"distortion_model {model!r} is not OpenCV's pinhole model ({pinhole}); handeye needs one of those"
        raise _error(path, text, "distortion_model", message)
    if model and dist.size not in ROS_DISTORTION_MODELS[model]:
        raise _error(path, text, d_key or "distortion_model", _count_message(model, d_key, held))
    return dist


def _count_message(model: str, d_key: str | None, held: int) -> str:
    """Why the distortion does not fit ``model``: the count it takes, and the key's count or its absence."""
    counts = " or ".join(map(str, ROS_DISTORTION_MODELS[model]))
    if d_key is None:
        others = ", ".join(key for key in _D_KEYS if key != "D")
        return f"distortion_model {model} takes {counts} coefficients, but the file has no D key (nor {others})"
    return f"{model} takes {counts} coefficients, {d_key} holds {held}"


def _flow(values) -> str:
    return "[" + ", ".join(repr(float(v)) for v in np.ravel(values)) + "]"


def write_camera_info_yaml(path: str | Path, intrinsics, camera_name: str = "camera") -> None:
    """Write a ROS camera_info YAML file (``camera_calibration``'s format, ``camera_info_url``).

    Parameters
    ----------
    path : str or Path
    intrinsics : classic.vision.camera.CameraIntrinsics
        Or anything with its ``K``, ``dist``, ``width`` and ``height``.
        5 coefficients (or 4, written with ``k3 = 0``) give ``plumb_bob``, 8 ``rational_polynomial``.
    camera_name : str

    Raises
    ------
    IntrinsicsError
        12 or 14 coefficients: camera_info has no model for them.
    """
    dist = intrinsics.dist
    if dist.size == 4:
        dist = np.append(dist, 0.0)
    model = {5: "plumb_bob", 8: "rational_polynomial"}.get(dist.size)
    if model is None:
        raise IntrinsicsError(f"{dist.size} distortion coefficients: camera_info has no model for them (5 or 8)")
    P = np.hstack([intrinsics.K, np.zeros((3, 1))])
    write_text_atomic(
        path,
        f"image_width: {int(intrinsics.width)}\n"
        f"image_height: {int(intrinsics.height)}\n"
        f"camera_name: {camera_name}\n"
        f"camera_matrix:\n  rows: 3\n  cols: 3\n  data: {_flow(intrinsics.K)}\n"
        f"distortion_model: {model}\n"
        f"distortion_coefficients:\n  rows: 1\n  cols: {dist.size}\n  data: {_flow(dist)}\n"
        f"rectification_matrix:\n  rows: 3\n  cols: 3\n  data: {_flow(np.eye(3))}\n"
        f"projection_matrix:\n  rows: 3\n  cols: 4\n  data: {_flow(P)}\n",
    )


def write_opencv_yaml(path: str | Path, intrinsics) -> None:
    """Write an OpenCV FileStorage YAML file with ``cv2.FileStorage``.

    Keys ``camera_matrix``, ``distortion_coefficients`` (``!!opencv-matrix``,
    1 x n), ``image_width``, ``image_height``, as OpenCV's calibration sample writes them, and
    ``intrinsics_std`` (1 x 9) when the intrinsics have their one-sigma.

    Parameters
    ----------
    path : str or Path
    intrinsics : classic.vision.camera.CameraIntrinsics
        Or anything with its ``K``, ``dist``, ``width`` and ``height``.
    """
    cv2 = _cv2()
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    try:
        fs.write("image_width", int(intrinsics.width))
        fs.write("image_height", int(intrinsics.height))
        fs.write("camera_matrix", np.asarray(intrinsics.K, dtype=np.float64))
        fs.write("distortion_coefficients", np.asarray(intrinsics.dist, dtype=np.float64).reshape(1, -1))
        std = getattr(intrinsics, "std", None)
        if std is not None:
            fs.write(_STD_KEY, np.array([[std[n] for n in _STD_NAMES]], dtype=np.float64))
    finally:
        fs.release()
