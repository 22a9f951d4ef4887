r"""A ROS tf tree: the pose of one frame in another over time, chained through the tree.

Every child frame has one parent and its pose in it, ``T_parent_child`` (a
``geometry_msgs/TransformStamped``: ``header.frame_id`` is the parent, ``child_frame_id`` the
child, ``p_parent = T_parent_child @ p_child``), static (``/tf_static``: one value) or sampled over
time (``/tf``). The pose of ``ee`` in ``base`` goes up from both frames to their nearest common
ancestor ``c``:

.. math:: T_{base\_ee}(t) = T_{c\_base}(t)^{-1} \, T_{c\_ee}(t),
          \quad T_{c\_f}(t) = T_{c\_x_1}(t) \cdots T_{x_n\_f}(t)

evaluated at every stamp of the chain's moving transforms inside the time span all of them cover.
A moving transform with no sample at such a stamp is interpolated between its samples around it
(rotation along the geodesic, translation linear: :class:`classic.RobotStream`), as tf2's
``lookupTransform`` does, also across a gap in its samples. Where the moving transforms are stamped
alike (``robot_state_publisher`` stamps every joint with the joint state's stamp) nothing is
interpolated and the chain is the product of the published transforms.
"""

from __future__ import annotations

from collections import defaultdict, deque
from dataclasses import dataclass

import numpy as np

from handeye.core.errors import BagError, FramesNotConnectedError
from handeye.core.se3 import invert_transform, transform_from_pos_quat_xyzw

__all__ = ["TfEdge", "TfTree", "TfChain"]

#: A quaternion whose norm is further than this from 1 is refused, as in pose files (an all-zero
#: orientation, a message left at its defaults, is the usual case).
QUAT_NORM_TOL = 1e-3


@dataclass
class TfEdge:
    """One parent-child transform of the tree, static or over time.

    Attributes
    ----------
    parent, child : str
    stamps_ns : array of int64, shape (K,)
        Strictly increasing header stamps, nanoseconds (a static edge: its one stamp).
    T_parent_child : array, shape (K, 4, 4)
        Pose of the child in the parent at each stamp, metres.
    static : bool
    """

    parent: str
    child: str
    stamps_ns: np.ndarray
    T_parent_child: np.ndarray
    static: bool

    def at(self, query_ns: np.ndarray) -> np.ndarray:
        """``T_parent_child`` at stamps inside the edge's span (any stamp for a static edge).

        Parameters
        ----------
        query_ns : array of int64, shape (Q,)

        Returns
        -------
        T_parent_child : array, shape (Q, 4, 4)
            The sample where one has the stamp, else interpolated between the samples around it.
        """
        from classic.robot_stream import RobotStream

        q = np.asarray(query_ns, dtype=np.int64)
        if self.static:
            return np.broadcast_to(self.T_parent_child[-1], (len(q), 4, 4)).copy()
        s = self.stamps_ns
        k = np.minimum(np.searchsorted(s, q), len(s) - 1)
        exact = s[k] == q
        out = np.empty((len(q), 4, 4))
        out[exact] = self.T_parent_child[k[exact]]
        if not exact.all():
            stream = RobotStream((s - s[0]) * 1e-9, self.T_parent_child)
            out[~exact] = stream.at((q[~exact] - s[0]) * 1e-9)[0]
        return out


@dataclass
class TfChain:
    """``T_base_ee`` over time, chained through the tf tree.

    Attributes
    ----------
    stamps_ns : array of int64, shape (M,)
        Strictly increasing.
    T_base_ee : array, shape (M, 4, 4)
        Pose of the end frame in the base frame at each stamp, metres.
    frames : list of str
        The path from the base frame to the end frame through the tree.
    """

    stamps_ns: np.ndarray
    T_base_ee: np.ndarray
    frames: list


class TfTree:
    """The tf tree: one :class:`TfEdge` per child frame.

    Parameters
    ----------
    edges : dict of str to TfEdge
        By child frame.
    source : str
        Where the transforms come from (bag and topics), for messages.
    """

    def __init__(self, edges: dict, source: str = "tf"):
        self.edges = edges
        self.source = source

    @classmethod
    def from_transforms(
        cls, parents, children, stamps_ns, translations, quats_xyzw, static, source: str = "tf"
    ) -> TfTree:
        """Build the tree from published transforms, in any order.

        Parameters
        ----------
        parents, children : sequence of str, length K
            ``header.frame_id`` and ``child_frame_id`` of each transform (a leading ``/`` is dropped).
        stamps_ns : array of int, shape (K,)
        translations : array, shape (K, 3)
            Metres.
        quats_xyzw : array, shape (K, 4)
            Rotation of each transform, (x, y, z, w), scalar last.
        static : array of bool, shape (K,)
            Published on ``/tf_static``.
        source : str

        Returns
        -------
        TfTree
            Per child: its samples sorted by stamp, the last one kept where a stamp repeats; a child
            with moving samples ignores static ones.

        Raises
        ------
        BagError
            A frame with two parents, or a quaternion that is not unit.
        """
        stamps = np.asarray(stamps_ns, dtype=np.int64).reshape(-1)
        t = np.asarray(translations, dtype=float).reshape(-1, 3)
        q = np.asarray(quats_xyzw, dtype=float).reshape(-1, 4)
        static = np.asarray(static, dtype=bool).reshape(-1)
        norm = np.linalg.norm(q, axis=1)
        bad = np.flatnonzero(~(np.abs(norm - 1.0) <= QUAT_NORM_TOL))
        if len(bad):
            i = bad[0]
            raise BagError(
                f"{source}: transform {parents[i]} -> {children[i]} at stamp {stamps[i]} ns has a "
                f"quaternion of norm {norm[i]:.4g}, not 1 ({len(bad)} such transforms)"
            )
        by_child = defaultdict(list)
        parent_of = {}
        for k, (parent, child) in enumerate(zip(parents, children)):
            parent, child = parent.lstrip("/"), child.lstrip("/")
            if parent_of.setdefault(child, parent) != parent:
                raise BagError(
                    f"{source}: frame {child!r} has two parents, {parent_of[child]!r} and {parent!r}; "
                    "a tf tree gives each frame one parent"
                )
            by_child[child].append(k)
        edges = {}
        for child, idx in by_child.items():
            idx = np.asarray(idx)
            moving = idx[~static[idx]]
            use = moving if len(moving) else idx
            use = use[np.argsort(stamps[use], kind="stable")]
            last = np.append(stamps[use][1:] != stamps[use][:-1], True)  # the last sample of each stamp
            use = use[last]
            edges[child] = TfEdge(
                parent_of[child],
                child,
                stamps[use],
                transform_from_pos_quat_xyzw(t[use], q[use]),
                static=not len(moving),
            )
        return cls(edges, source)

    def frames(self) -> list:
        """Every frame of the tree, sorted."""
        return sorted(set(self.edges) | {e.parent for e in self.edges.values()})

    def reachable_from(self, frame: str) -> list:
        """The frames connected to ``frame`` (itself included), sorted; empty if it is not in the tree."""
        neighbours = defaultdict(set)
        for e in self.edges.values():
            neighbours[e.parent].add(e.child)
            neighbours[e.child].add(e.parent)
        if frame not in neighbours:
            return []
        seen, todo = {frame}, deque([frame])
        while todo:
            for f in neighbours[todo.popleft()] - seen:
                seen.add(f)
                todo.append(f)
        return sorted(seen)

    def _up(self, frame: str) -> list:
        """``[frame, parent, grandparent, ..., root]``."""
        path = [frame]
        while path[-1] in self.edges:
            path.append(self.edges[path[-1]].parent)
            if len(path) > len(self.edges) + 1:
                raise BagError(f"{self.source}: the tf transforms form a loop through {path[-1]!r}")
        return path

    def _pose_in_ancestor(self, up: list, query_ns: np.ndarray) -> np.ndarray:
        """``T_c_f`` at the stamps, ``up = [f, ..., c]``."""
        T = np.broadcast_to(np.eye(4), (len(query_ns), 4, 4)).copy()
        for child in reversed(up[:-1]):
            T = T @ self.edges[child].at(query_ns)
        return T

    def chain(self, base: str, ee: str) -> TfChain:
        """The pose of ``ee`` in ``base`` at every stamp the chain's moving transforms give.

        Parameters
        ----------
        base, ee : str
            Frame names (a leading ``/`` is dropped).

        Returns
        -------
        TfChain
            ``T_base_ee`` of shape (M, 4, 4) at M stamps (see the module docstring).

        Raises
        ------
        FramesNotConnectedError
            A frame not in the tree, or the two frames in different trees; names the frames
            reachable from ``base``.
        BagError
            No moving transform on the chain, or their time spans do not overlap.
        """
        base, ee = base.lstrip("/"), ee.lstrip("/")
        frames = self.frames()
        reach = self.reachable_from(base)
        if ee not in reach:
            missing = [f for f in (base, ee) if f not in frames]
            what = (
                f"frame {' and '.join(map(repr, missing))} not in the tf tree"
                if missing
                else f"frames {base!r} and {ee!r} are not connected in the tf tree"
            )
            near = (
                f"frames reachable from {base!r}: {', '.join(reach)}" if reach else f"all frames: {', '.join(frames)}"
            )
            raise FramesNotConnectedError(f"{self.source}: {what}; {near}")
        up_base, up_ee = self._up(base), self._up(ee)
        common = next(f for f in up_ee if f in set(up_base))
        up_base, up_ee = up_base[: up_base.index(common) + 1], up_ee[: up_ee.index(common) + 1]
        path = up_base + up_ee[-2::-1]
        moving = [self.edges[f] for f in up_base[:-1] + up_ee[:-1] if not self.edges[f].static]
        if not moving:
            raise BagError(
                f"{self.source}: the chain {' -> '.join(path)} holds only static transforms: "
                "the robot does not move in this recording"
            )
        start = max(int(e.stamps_ns[0]) for e in moving)
        stop = min(int(e.stamps_ns[-1]) for e in moving)
        stamps = np.unique(np.concatenate([e.stamps_ns for e in moving]))
        stamps = stamps[(stamps >= start) & (stamps <= stop)]
        if not len(stamps):
            spans = "; ".join(f"{e.parent} -> {e.child}: {e.stamps_ns[0]}..{e.stamps_ns[-1]} ns" for e in moving)
            raise BagError(
                f"{self.source}: the moving transforms of {' -> '.join(path)} never cover a common time ({spans})"
            )
        T = invert_transform(self._pose_in_ancestor(up_base, stamps)) @ self._pose_in_ancestor(up_ee, stamps)
        return TfChain(stamps, T, path)
