"""Render one segment of a stream into one shard: the cell with its occluder and lights, through a depth sensor.

A worker process holds one :class:`StreamShardRenderer` (the OpenGL context lives and dies with it, as in
:mod:`sim.generate`). Per frame it sets the lights (directional and ambient scaled by the frame's factor),
shows or hides the occluder, renders colour and depth, adds the colour noise and the sensor's depth errors
(:func:`sim.sensors.apply_sensor`, the unit's systematic errors drawn once for the stream: one camera,
bumped or not), and writes the frame; a frame whose depth is lost gets no depth image (an empty ``depth``
cell). In an occluded frame it also renders the cell without the occluder and without the arm, and counts
the share of the arm's pixels that the occluder hides (``arm_hidden_fraction`` in ``stream.json``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from handeye.core.engines import require_visible
from handeye.core.shard_writer import ShardWriter
from sim.generate import recorded_robot_columns
from sim.stream_events import BOX_EXTENTS_M, OCCLUDER_SHAPES, PERSON_HEIGHT_M, PERSON_RADIUS_M

__all__ = ["StreamShardRenderer", "SEPARATION_M", "init_worker", "render_segment", "describe_segment"]

#: A pixel belongs to the arm (or is hidden by the occluder) when the arm (occluder) is nearer than what is
#: behind it by more than this: 1 cm, far above the rendered depth's resolution (under 1 mm at 2 m,
#: :data:`sim.render.ZNEAR_M`) and below any of the arm's thicknesses.
SEPARATION_M = 0.01


def _occluder_meshes():
    """Trimesh meshes of the occluders, in :data:`sim.stream_events.OCCLUDER_SHAPES` order, centred."""
    from handeye.core.optional import require_package

    trimesh = require_package("trimesh", extra="sim", purpose="meshes")
    box = trimesh.creation.box(extents=BOX_EXTENTS_M)
    box.visual.face_colors = np.array([170, 120, 70, 255], dtype=np.uint8)  # cardboard
    person = trimesh.creation.cylinder(radius=PERSON_RADIUS_M, height=PERSON_HEIGHT_M)
    person.visual.face_colors = np.array([60, 80, 120, 255], dtype=np.uint8)  # work clothes
    meshes = {"box": box, "person": person}
    return [meshes[s] for s in OCCLUDER_SHAPES]


class StreamShardRenderer:
    """One process's robot, renderer, occluders and sensor.

    Parameters
    ----------
    config : dict
        ``robot``, ``K`` (3x3 list), ``image_size``, ``sensor`` (a
        :class:`handeye.robot.depth_sensors.DepthSensor`), ``sensor_truth`` (the unit's
        :class:`sim.sensors.SensorTruth`), ``pixel_sigma``, ``seed``, ``depth_scale_m``, ``out``.
    """

    def __init__(self, config: dict):
        from handeye.robot.model import load_robot
        from sim.render import Renderer

        self.config = config
        self.robot = load_robot(config["robot"])
        self.K = np.asarray(config["K"], dtype=float)
        self.sensor = config["sensor"]
        self.sensor_truth = config["sensor_truth"]
        self.renderer = Renderer(self.robot, self.K, *config["image_size"])
        pr, scene = self.renderer.pyrender, self.renderer.scene
        self.occluder_nodes = []
        for mesh in _occluder_meshes():
            node = scene.add(pr.Mesh.from_trimesh(mesh, smooth=False))
            node.mesh.is_visible = False
            self.occluder_nodes.append(node)
        self.lights = [(node.light, node.light.intensity) for node in scene.light_nodes]
        self.ambient = np.array(scene.ambient_light, dtype=float)
        self.arm_nodes = list(self.renderer.link_nodes) + [node for node, _ in self.renderer.ee_nodes]

    def _set_light(self, factor: float) -> None:
        for light, base in self.lights:
            light.intensity = base * factor
        self.renderer.scene.ambient_light = self.ambient * factor

    def _show(self, nodes, visible: bool) -> None:
        for node in nodes:
            node.mesh.is_visible = visible

    def _hidden_fraction(self, q: np.ndarray, T_base_cam: np.ndarray, depth: np.ndarray, occluder) -> float:
        """Share of the arm's pixels the occluder hides (NaN when the arm has none in the image)."""
        self._show([occluder], False)
        _, clear = self.renderer.render(q, T_base_cam)
        self._show(self.arm_nodes, False)
        _, background = self.renderer.render(q, T_base_cam)
        self._show(self.arm_nodes, True)
        self._show([occluder], True)
        arm = (clear > 0) & ((background == 0) | (clear < background - SEPARATION_M))
        hidden = arm & (depth > 0) & (depth < clear - SEPARATION_M)
        return float(hidden.sum() / arm.sum()) if arm.any() else float("nan")

    def render_segment(self, task: dict) -> tuple[int, int, dict]:
        """Render a segment's frames into its shard (published atomically).

        Parameters
        ----------
        task : dict
            ``segment``, ``frames`` (global frame numbers), ``T_base_cam`` (4x4), and per frame ``q``,
            ``q_recorded``, ``light``, ``depth_lost``, ``occluder``, ``T_base_occluder``.

        Returns
        -------
        segment : int
        n_frames : int
        hidden : dict
            Global frame number to the share of the arm's pixels hidden, for the occluded frames.
        """
        from sim.sensors import apply_sensor

        segment = int(task["segment"])
        T_base_cam = np.asarray(task["T_base_cam"], dtype=float)
        seed = self.config["seed"]
        rng = np.random.default_rng([seed, segment, 1])
        rgb_names, depth_names, hidden = [], [], {}
        with ShardWriter(
            self.config["out"], segment, n_joints=self.robot.nq, depth_scale_m=self.config["depth_scale_m"]
        ) as shard:
            for i, frame in enumerate(task["frames"]):
                self._set_light(task["light"][i])
                occluder = None
                for k, node in enumerate(self.occluder_nodes):
                    node.mesh.is_visible = k == task["occluder"][i]
                    if k == task["occluder"][i]:
                        occluder = node
                        self.renderer.scene.set_pose(node, np.asarray(task["T_base_occluder"][i]))
                rgb, depth = self.renderer.render(task["q"][i], T_base_cam)
                if occluder is not None:
                    hidden[int(frame)] = self._hidden_fraction(task["q"][i], T_base_cam, depth, occluder)
                name = f"data_{int(frame):06d}"
                noisy = rgb + rng.normal(scale=self.config["pixel_sigma"], size=rgb.shape)
                rgb_names.append(shard.write_rgb(name, np.clip(np.rint(noisy), 0, 255).astype(np.uint8)))
                measured = apply_sensor(depth, self.K, self.sensor, self.sensor_truth, rng, rgb=rgb)
                depth_names.append("" if task["depth_lost"][i] else shard.write_depth(name, measured))
            shard.write_frames(self._frame_table(task, rgb_names, depth_names))
        return segment, len(task["frames"]), hidden

    def _frame_table(self, task: dict, rgb_names: list, depth_names: list) -> dict:
        n = len(task["frames"])
        q_rec = np.asarray(task["q_recorded"], dtype=float).reshape(n, self.robot.nq)
        table = {
            "frame": np.asarray(task["frames"], dtype=int),
            "camera_id": np.full(n, int(task["segment"])),
            "region": np.zeros(n, dtype=int),
            "split": np.array(["train"] * n, dtype=object),
            "recording": np.array(["data"] * n, dtype=object),
            "rgb": np.array(rgb_names, dtype=object),
            "depth": np.array(depth_names, dtype=object),
        }
        table.update(recorded_robot_columns(self.robot, q_rec))
        return table


_WORKER: StreamShardRenderer | None = None


def init_worker(config: dict) -> None:
    """Process initializer: one renderer per worker process."""
    global _WORKER
    os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    _WORKER = StreamShardRenderer(config)


def render_segment(task: dict) -> tuple[int, int, dict]:
    """Render one segment in this worker (:meth:`StreamShardRenderer.render_segment`)."""
    require_visible(Path(_WORKER.config["out"]) / "meta.json")
    return _WORKER.render_segment(task)


def describe_segment(task: dict) -> str:
    """A task named in the message of its failure (not its per-frame arrays)."""
    frames = task["frames"]
    return f"render segment {task['segment']} (frames {frames[0]}..{frames[-1]})"
