"""What the registration finds in the depth frames alone, before any camera matrix enters: the depth noise, the
mixed pixels at depth edges, and the pixels the robot moved through.

A second registration of the same frames under another camera matrix (the second pass of the shared intrinsics,
:func:`classic.markerless.shared_intrinsics.second_passes`) takes this from the first
(:attr:`classic.markerless.MarkerlessResult.depth_analysis`) instead of finding it again: about a second of CPU
per placement of 100 frames at 256x256. It is used only for the frames it was found on (:func:`depth_key`: their
shape, a checksum of their bytes and the noise option); for any other frames it is found again.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from classic.markerless.depth import depth_noise_curve, mixed_pixels, moving_mask, static_depth

__all__ = ["DepthAnalysis", "analyse_depth", "depth_key", "noise_sigma_z", "FALLBACK_SIGMA_M_AT_1M"]

#: Depth noise taken when it can be neither measured nor was given: 1 mm at 1 m, growing with depth squared.
FALLBACK_SIGMA_M_AT_1M = 0.001


def depth_key(depth_m: np.ndarray, depth_sigma_m_at_1m: float | None) -> tuple:
    """What a :class:`DepthAnalysis` holds for: the frames' shape, a CRC-32 of their bytes, the noise given (a guard
    against handing one placement's analysis to another's frames, not a cryptographic check).

    Parameters
    ----------
    depth_m : array of float, shape (N, H, W)
    depth_sigma_m_at_1m : float or None
        :attr:`MarkerlessOptions.depth_sigma_m_at_1m`.

    Returns
    -------
    tuple
    """
    depth_m = np.ascontiguousarray(depth_m)
    return depth_m.shape, str(depth_m.dtype), zlib.crc32(depth_m.data), depth_sigma_m_at_1m


@dataclass(frozen=True, eq=False)
class DepthAnalysis:
    """The depth frames' own findings (:func:`analyse_depth`).

    Attributes
    ----------
    key : tuple
        :func:`depth_key` of the frames and the noise option it was found with.
    noise_z, noise_sigma : array, shape (K,), or None
        The depth noise measured on the static background: sigma (m) at depth (m); None where it was given.
    noise_source : str
        ``"given"``, ``"measured on the static background"`` or ``"fallback 1 mm at 1 m"``.
    mixed_bits, moving_bits : array of uint8
        ``np.packbits`` of the mixed pixels (treated as missing) and of the moving ones (nearer than the static
        depth, opened), each of shape (N, H, W).
    """

    key: tuple
    noise_z: np.ndarray | None
    noise_sigma: np.ndarray | None
    noise_source: str
    mixed_bits: np.ndarray
    moving_bits: np.ndarray

    def _unpacked(self, bits: np.ndarray) -> np.ndarray:
        shape = self.key[0]
        return np.unpackbits(bits, count=int(np.prod(shape))).reshape(shape).astype(bool)

    @property
    def mixed(self) -> np.ndarray:
        """Mixed pixels, bool, shape (N, H, W)."""
        return self._unpacked(self.mixed_bits)

    @property
    def moving(self) -> np.ndarray:
        """Moving pixels, bool, shape (N, H, W)."""
        return self._unpacked(self.moving_bits)

    def sigma_z(self, z, given: float | None):
        """Depth noise sigma at depth ``z`` (metres): :func:`noise_sigma_z` with this analysis's curve."""
        return noise_sigma_z(z, given, self.noise_z, self.noise_sigma)


def noise_sigma_z(z, given: float | None, noise_z: np.ndarray | None, noise_sigma: np.ndarray | None):
    """Depth noise sigma at depth ``z`` (metres): ``given`` (m at 1 m, times z^2), else the measured curve
    (``noise_sigma`` at ``noise_z``, interpolated), else :data:`FALLBACK_SIGMA_M_AT_1M` times z^2."""
    if given is not None:
        return given * np.asarray(z) ** 2
    if noise_z is None or len(noise_z) == 0:
        return FALLBACK_SIGMA_M_AT_1M * np.asarray(z) ** 2
    if len(noise_z) == 1:
        return np.full(np.shape(z), noise_sigma[0])
    return np.interp(z, noise_z, noise_sigma)


def analyse_depth(depth_m: np.ndarray, depth_sigma_m_at_1m: float | None) -> DepthAnalysis:
    """The depth frames' noise, mixed pixels and moving pixels.

    Pixels that straddle a depth edge report a depth between its two surfaces (:func:`mixed_pixels`: within four
    noise sigmas, at least 5 mm, of no pair of opposite neighbours): they are treated as missing. A pixel moved
    where it is nearer than the static depth by 2 cm or six noise sigmas, whichever is larger; the arm moves as a
    body, many pixels wide, and what moves in a line a pixel or two wide is the sensor's (flying pixels along
    static edges, holes that come and go): an opening keeps bodies only.

    Parameters
    ----------
    depth_m : array of float, shape (N, H, W)
        Metres, 0 where missing.
    depth_sigma_m_at_1m : float or None
        The depth noise given (:attr:`MarkerlessOptions.depth_sigma_m_at_1m`); None: measured on the frames.

    Returns
    -------
    DepthAnalysis
    """
    if depth_sigma_m_at_1m is not None:
        noise_z, noise_sigma, source = None, None, "given"
    else:
        noise_z, noise_sigma = depth_noise_curve(depth_m)
        source = "measured on the static background" if len(noise_z) else "fallback 1 mm at 1 m"
    key = depth_key(depth_m, depth_sigma_m_at_1m)  # of the frames as given, before the mixed pixels are dropped
    curve = (depth_sigma_m_at_1m, noise_z, noise_sigma)
    sigma = noise_sigma_z(np.where(depth_m > 0, depth_m, 1.0), *curve)  # taken at 1 m where missing
    mixed = mixed_pixels(depth_m, np.maximum(0.005, 4 * sigma))
    depth_m = np.where(mixed, 0.0, depth_m)
    sigma = np.where(mixed, noise_sigma_z(1.0, *curve), sigma)  # the mixed ones now missing
    moving = moving_mask(depth_m, static_depth(depth_m), np.maximum(0.02, 6 * sigma))
    moving = ndimage.binary_opening(moving, structure=np.ones((1, 3, 3), bool))
    return DepthAnalysis(key, noise_z, noise_sigma, source, np.packbits(mixed), np.packbits(moving))
