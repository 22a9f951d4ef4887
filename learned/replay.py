"""The replay buffer of the continual-learning strategies and of :class:`~learned.calibrator.ContinualCalibrator`.

One class, :class:`ReplayBuffer`: class-balanced by camera pose (the paper's classes), up to
``per_class`` (the paper's ``c1``) entries per camera pose, at most ``max_size`` in all (``None``:
unbounded, the paper's ``c2 = all``). Insertion is a reservoir per class: the entries of a pose are a
uniform random sample of the frames of that pose seen so far. All draws come from the
``numpy.random.Generator`` passed in; there is no global random state.

What it holds is chosen at construction (``keep_samples``):

- ``False`` (the strategies of :mod:`learned.strategies`): frame indices into the experiment's
  :class:`~learned.data.FrameSet`, which stays in memory for the whole protocol; replay is an
  index array.
- ``True`` (:class:`~learned.calibrator.ContinualCalibrator`): the samples themselves (images,
  reference poses, targets), so an online calibrator keeps learning after a restart without its
  past data; replay is a :class:`~learned.data.FrameSet`.

:meth:`ReplayBuffer.state_dict` gives tensors and JSON only, saved through :mod:`learned.safe_io`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict

import numpy as np
import torch

from learned.data import FrameSet, concat
from learned.safe_io import arrays_to_tensors, tensors_to_arrays

__all__ = ["ReplayBuffer", "per_camera_sample", "random_fraction", "draw", "SAMPLINGS"]

#: How entries are drawn: ``uniform``, or ``normal`` (the seed paper's words, read as in :func:`draw`).
SAMPLINGS = ("uniform", "normal")


def draw(index: np.ndarray, k: int, rng: np.random.Generator, sampling: str = "uniform") -> np.ndarray:
    """``k`` entries of ``index`` drawn without replacement (unsorted).

    ``uniform``: every entry equally likely (``rng.choice``). ``normal``: the seed paper samples "using a
    normal distribution" without saying of what; read here as entries weighed, in their order in
    ``index`` (a pose's frames in recording order), by a normal density centred on the middle entry with a
    standard deviation of a quarter of their count, then drawn without replacement in proportion to it.
    """
    index = np.asarray(index)
    if sampling == "uniform":
        return rng.choice(index, k, replace=False)
    if sampling != "normal":
        raise ValueError(f"unknown sampling {sampling!r}: use {', '.join(SAMPLINGS)}")
    n = len(index)
    z = (np.arange(n) - (n - 1) / 2.0) / max(n / 4.0, 1e-9)
    w = np.exp(-0.5 * z**2)
    return rng.choice(index, k, replace=False, p=w / w.sum())


def random_fraction(
    index: np.ndarray, fraction: float, rng: np.random.Generator, sampling: str = "uniform"
) -> np.ndarray:
    """A random share of ``index`` (at least one), sorted; all of it for ``fraction >= 1`` (no draw)."""
    index = np.asarray(index)
    if fraction >= 1.0:
        return index
    return np.sort(draw(index, max(1, int(round(fraction * len(index)))), rng, sampling))


def per_camera_sample(
    index: np.ndarray, camera: np.ndarray, c1: int, rng: np.random.Generator, sampling: str = "uniform"
) -> dict:
    """Class balance: up to ``c1`` random entries of ``index`` per camera pose (``camera[index]``), sorted."""
    index = np.asarray(index)
    out = {}
    for c in np.unique(camera[index]):
        idx = index[camera[index] == c]
        out[int(c)] = np.sort(draw(idx, min(c1, len(idx)), rng, sampling))
    return out


def _take(item, pos):
    return item.subset(pos) if isinstance(item, FrameSet) else np.asarray(item)[pos]


def _join(a, b):
    return concat([a, b]) if isinstance(a, FrameSet) else np.concatenate([a, b])


class ReplayBuffer(Mapping):
    """Class-balanced reservoir of frames: camera id -> its stored entries (indices, or a FrameSet).

    Parameters
    ----------
    per_class : int
        Entries kept per camera pose (the paper's ``c1``).
    max_size : int, optional
        Entries kept in all; beyond it, entries of the largest classes are dropped at random. ``None``:
        unbounded.
    keep_samples : bool
        Hold the frames themselves (a :class:`~learned.data.FrameSet` per pose) rather than indices.
    sampling : {"uniform", "normal"}
        How a new pose's entries are drawn (:func:`draw`); a pose seen again merges uniformly.

    Notes
    -----
    As a mapping it reads like the paper's buffer: ``buffer[c]`` is camera ``c``'s entries, iteration is
    in insertion order, ``len(buffer)`` counts camera poses and :attr:`size` counts entries.
    """

    def __init__(
        self, per_class: int, max_size: int | None = None, keep_samples: bool = False, sampling: str = "uniform"
    ):
        if sampling not in SAMPLINGS:
            raise ValueError(f"unknown sampling {sampling!r}: use {', '.join(SAMPLINGS)}")
        self.sampling = sampling
        self.per_class = int(per_class)
        self.max_size = None if max_size is None else int(max_size)
        self.keep_samples = bool(keep_samples)
        self._items: dict[int, np.ndarray | FrameSet] = {}
        self._seen: dict[int, int] = {}

    def __getitem__(self, camera: int):
        return self._items[camera]

    def __iter__(self):
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    @property
    def size(self) -> int:
        """Entries held, all camera poses together."""
        return int(sum(len(v) for v in self._items.values()))

    def update(self, frames: FrameSet, index: np.ndarray, rng: np.random.Generator) -> None:
        """Insert the frames at ``index``, class-balanced by ``frames.camera``.

        A camera pose seen for the first time keeps ``per_class`` of its frames drawn without
        replacement; one seen before merges its new frames reservoir-wise, so that its entries stay a
        uniform sample of all its frames seen (a hypergeometric draw of how many old entries stay).
        """
        for c, idx in per_camera_sample(index, frames.camera, self.per_class, rng, self.sampling).items():
            n_new = int(np.sum(frames.camera[np.asarray(index)] == c))
            new = frames.subset(idx) if self.keep_samples else idx
            if c not in self._items:
                self._items[c], self._seen[c] = new, n_new
            else:
                self._merge(c, new, n_new, rng)
        self._shrink(rng)

    def _merge(self, c: int, new, n_new: int, rng: np.random.Generator) -> None:
        # old entries: a uniform sample of `seen` frames; new ones: of n_new frames. A uniform sample of
        # the union takes a hypergeometric number from the old ones, the rest from the new ones.
        old, seen = self._items[c], self._seen[c]
        k = min(self.per_class, seen + n_new)
        k_old = int(rng.hypergeometric(seen, n_new, k)) if n_new else k
        keep_old = np.sort(rng.choice(len(old), k_old, replace=False))
        keep_new = np.sort(rng.choice(len(new), k - k_old, replace=False))
        self._items[c], self._seen[c] = _join(_take(old, keep_old), _take(new, keep_new)), seen + n_new

    def _shrink(self, rng: np.random.Generator) -> None:
        while self.max_size is not None and self.size > self.max_size:
            c = max(self._items, key=lambda k: len(self._items[k]))
            keep = np.flatnonzero(np.arange(len(self._items[c])) != int(rng.integers(len(self._items[c]))))
            self._items[c] = _take(self._items[c], keep)

    def classes(self, rng: np.random.Generator, max_classes: int | None = None) -> list[int]:
        """The camera poses to replay: all, or ``max_classes`` of them at random (the paper's ``c2``)."""
        past = list(self._items)
        if max_classes is not None and len(past) > max_classes:
            past = list(rng.choice(past, max_classes, replace=False))
        return past

    def replay(self, rng: np.random.Generator, max_classes: int | None = None):
        """The entries of :meth:`classes`, concatenated: an index array, or a FrameSet (``None`` if empty)."""
        past = self.classes(rng, max_classes)
        if self.keep_samples:
            return concat([self._items[c] for c in past]) if past else None
        return np.concatenate([self._items[c] for c in past]) if past else np.zeros(0, int)

    def frames(self) -> FrameSet | None:
        """All held samples in insertion order (``keep_samples`` only); ``None`` when empty."""
        if not self.keep_samples:
            raise TypeError("this buffer holds frame indices, not samples")
        return concat(list(self._items.values())) if self._items else None

    def state_dict(self) -> dict:
        """Tensors (under ``"tensors"``: a flat dict) and JSON values (under ``"meta"``), for safe_io."""
        meta = {
            "per_class": self.per_class,
            "max_size": self.max_size,
            "keep_samples": self.keep_samples,
            "sampling": self.sampling,
            "order": list(self._items),
            "seen": {str(c): n for c, n in self._seen.items()},
            "other": {},
        }
        tensors = {}
        for c, item in self._items.items():
            if not self.keep_samples:
                tensors[f"{c}"] = torch.from_numpy(np.asarray(item, np.int64))
                continue
            fields = asdict(item)
            scalars = {"label_source": fields.pop("label_source"), "image_size": list(fields.pop("image_size"))}
            t, other = arrays_to_tensors(fields)
            tensors.update({f"{c}.{k}": v for k, v in t.items()})
            meta["other"][str(c)] = {"scalars": scalars, "arrays": other}
        return {"meta": meta, "tensors": tensors}

    def load_state_dict(self, state: dict) -> None:
        """Restore what :meth:`state_dict` gave (after a round trip through :mod:`learned.safe_io`)."""
        meta, tensors = state["meta"], state.get("tensors") or {}
        self.per_class, self.max_size, self.keep_samples = meta["per_class"], meta["max_size"], meta["keep_samples"]
        self.sampling = meta.get("sampling", "uniform")  # buffers saved before the paper's mode drew uniformly
        self._seen = {int(c): int(n) for c, n in meta["seen"].items()}
        self._items = {}
        for c in meta["order"]:
            if not self.keep_samples:
                self._items[int(c)] = tensors[f"{c}"].numpy()
                continue
            own = {k.split(".", 1)[1]: v for k, v in tensors.items() if k.split(".", 1)[0] == str(c)}
            other = meta["other"][str(c)]
            self._items[int(c)] = FrameSet(
                **tensors_to_arrays(own, other["arrays"]),
                label_source=other["scalars"]["label_source"],
                image_size=tuple(other["scalars"]["image_size"]),
            )
