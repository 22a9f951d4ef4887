"""Pinhole camera intrinsics with OpenCV's distortion model."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from handeye.core.errors import IntrinsicsError
from handeye.core.limits import FOV_RANGE_DEG
from handeye.core.safe_write import write_text_atomic

__all__ = ["CameraIntrinsics", "IntrinsicsError", "STD_NAMES", "DEFAULT_STD_RULE"]

#: The parameters whose one-sigma ``CameraIntrinsics.std`` holds, in the reprojection refinement's order.
STD_NAMES = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")
#: The one-sigma taken for intrinsics that come without their own (a ROS camera_info, a vendor's YAML, a
#: factory calibration): 0.5 % of the focal lengths and 3 px of the principal point, the size by which a
#: factory or one-off ``calibrateCamera`` calibration is typically off (an assumed size, not a measured
#: one: give the file its ``std`` where you know better); each distortion coefficient's is the value that
#: moves the image's corner by 1 px.
DEFAULT_FOCAL_STD = 0.005
DEFAULT_CENTRE_STD_PX = 3.0
DEFAULT_DISTORTION_EFFECT_PX = 1.0
DEFAULT_STD_RULE = (
    f"{100 * DEFAULT_FOCAL_STD:g} % of f, {DEFAULT_CENTRE_STD_PX:g} px of the principal point, distortion "
    f"coefficients {DEFAULT_DISTORTION_EFFECT_PX:g} px at the image corner"
)


@dataclass
class CameraIntrinsics:
    """Camera matrix, distortion and image size.

    Attributes
    ----------
    K : array, shape (3, 3)
        ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` in pixels; pixel centres at integers (OpenCV).
    dist : array, shape (5,)
        OpenCV's ``(k1, k2, p1, p2, k3)``.
    width, height : int
        Image size in pixels.
    std : dict or None
        One-sigma of ``fx, fy, cx, cy`` (pixels) and ``k1, k2, p1, p2, k3`` (:data:`STD_NAMES`), as the
        calibration that gave them estimated it; None when unknown (:meth:`std_vector` then takes
        :data:`DEFAULT_STD_RULE`).
    """

    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))
    width: int = 0
    height: int = 0
    std: dict | None = None

    def __post_init__(self):
        self.K = np.asarray(self.K, dtype=float)
        self.dist = np.asarray(self.dist, dtype=float).ravel()
        if self.K.shape != (3, 3) or not np.isfinite(self.K).all():
            raise IntrinsicsError(f"K must be a finite 3x3 matrix, got shape {self.K.shape}")
        K = self.K
        if K[0, 0] <= 0 or K[1, 1] <= 0 or abs(K[2, 2] - 1) > 1e-9 or np.any(K[[1, 2, 2], [0, 0, 1]]):
            raise IntrinsicsError(f"K is not a camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]]: {self.K.tolist()}")
        lo, hi = FOV_RANGE_DEG
        for name, f, side in (("fx", K[0, 0], self.width), ("fy", K[1, 1], self.height)):
            fov_deg = np.degrees(2 * np.arctan2(side / 2, f)) if side > 0 else None
            if fov_deg is not None and not lo <= fov_deg <= hi:
                raise IntrinsicsError(
                    f"{name} = {f:.6g} pixels gives a {fov_deg:.3g}-degree field of view over {side} pixels, "
                    f"outside {lo:g}-{hi:g} degrees: not a camera's focal length"
                )
        if self.dist.size not in (4, 5, 8, 12, 14) or not np.isfinite(self.dist).all():
            raise IntrinsicsError(f"distortion must hold 4, 5, 8, 12 or 14 finite coefficients, got {self.dist.size}")
        if self.std is not None:
            self.std = _checked_std(self.std)

    def std_vector(self) -> tuple[np.ndarray, str]:
        """One-sigma of ``(fx, fy, cx, cy, k1, k2, p1, p2, k3)`` and where it comes from.

        Returns
        -------
        std : array, shape (9,)
            The file's own (:attr:`std`), or :data:`DEFAULT_STD_RULE`'s for this camera.
        source : str
            ``"their own, from their calibration"`` or the default's rule.
        """
        if self.std is not None:
            return np.array([self.std[n] for n in STD_NAMES]), "their own, from their calibration"
        K = self.K
        w = self.width or 2 * K[0, 2] + 1
        h = self.height or 2 * K[1, 2] + 1
        # the image corner farthest from the principal point, normalised
        x = max(K[0, 2], w - 1 - K[0, 2]) / K[0, 0]
        y = max(K[1, 2], h - 1 - K[1, 2]) / K[1, 1]
        r2 = x * x + y * y
        f = max(K[0, 0], K[1, 1])
        effect = f * np.array([np.hypot(x, y) * r2, np.hypot(x, y) * r2**2, r2 + 2 * y * y, r2 + 2 * x * x])
        effect = np.append(effect, f * np.hypot(x, y) * r2**3)  # px per unit of k1, k2, p1, p2, k3
        std = np.concatenate(
            [
                DEFAULT_FOCAL_STD * K[[0, 1], [0, 1]],
                [DEFAULT_CENTRE_STD_PX] * 2,
                DEFAULT_DISTORTION_EFFECT_PX / effect,
            ]
        )
        return std, f"not in the intrinsics file; taken as {DEFAULT_STD_RULE}"

    def to_dict(self) -> dict:
        """JSON-serialisable dictionary."""
        return {
            "K": self.K.tolist(),
            "dist": self.dist.tolist(),
            "width": int(self.width),
            "height": int(self.height),
            "distortion_model": "opencv (k1, k2, p1, p2, k3)",
        } | ({"std": dict(self.std)} if self.std is not None else {})

    def save(self, path: str | Path) -> None:
        """Write as JSON, or as OpenCV FileStorage YAML when the name ends in ``.yaml``/``.yml`` (what :meth:`load`
        reads back from such a name)."""
        if Path(path).suffix.lower() in (".yaml", ".yml"):
            from classic.vision.camera_yaml import write_opencv_yaml

            write_opencv_yaml(path, self)
            return
        write_text_atomic(path, json.dumps(self.to_dict(), indent=2) + "\n")

    @classmethod
    def from_dict(cls, doc: dict) -> "CameraIntrinsics":
        """Inverse of :meth:`to_dict`; numbers in the grammar of :mod:`handeye.core.numbers`.

        Raises
        ------
        IntrinsicsError
            A value that is not a number (``"0_2"``, ``true``), a size that is not a whole number of pixels.
        """
        from handeye.core.numbers import as_int, float_array

        def pixels(name: str) -> int:
            value = as_int(doc.get(name, 0), name, IntrinsicsError)
            if value < 0:
                raise IntrinsicsError(f"{name} is {value}, not a number of pixels")
            return value

        return cls(
            float_array(doc["K"], "K", IntrinsicsError),
            float_array(doc.get("dist", [0.0] * 5), "dist", IntrinsicsError),
            pixels("width"),
            pixels("height"),
            doc.get("std"),
        )

    @classmethod
    def load(cls, path: str | Path) -> "CameraIntrinsics":
        """Read intrinsics written by :meth:`save`, or a ROS camera_info / OpenCV YAML file (``.yaml``, ``.yml``).

        YAML formats: :mod:`classic.vision.camera_yaml`.

        Raises
        ------
        IntrinsicsError
            Naming the file (and, for YAML, the line).
        """
        path = Path(path)
        if path.suffix.lower() in (".yaml", ".yml"):
            from classic.vision.camera_yaml import load_intrinsics_yaml

            return load_intrinsics_yaml(path, cls)
        from handeye.core.jsonfile import read_json_file

        doc = read_json_file(path, IntrinsicsError, "intrinsics file")
        try:
            return cls.from_dict(doc)
        except FileNotFoundError:
            raise IntrinsicsError(f"{path}: no such intrinsics file") from None
        except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            raise IntrinsicsError(f"{path}: not a valid intrinsics file ({exc})") from None


def _checked_std(std) -> dict:
    """The one-sigma dictionary of :data:`STD_NAMES`, each a finite number >= 0.

    Raises
    ------
    IntrinsicsError
    """
    from handeye.core.numbers import float_array

    if not isinstance(std, dict) or set(std) != set(STD_NAMES):
        got = sorted(std) if isinstance(std, dict) else type(std).__name__
        raise IntrinsicsError(f"std must give the one-sigma of {', '.join(STD_NAMES)}, got {got}")
    out = {n: float(float_array(std[n], f"std {n}", IntrinsicsError)) for n in STD_NAMES}
    bad = [n for n, v in out.items() if not v >= 0]
    if bad:
        raise IntrinsicsError(f"std of {', '.join(bad)} is negative")
    return out
