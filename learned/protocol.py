"""The two protocol modes of the continual-learning experiment: the seed paper's, and this project's.

A mode is a set of :class:`learned.presets.Preset` fields (:data:`PROTOCOLS`); ``Preset.with_protocol``
applies one. :data:`DEPARTURES` names every field where the modes differ, with the paper's words, this
project's choice and the reason, and is the table the documentation prints
(``docs/reproduce-paper.md``).

The paper's choices, and how its words are read where they leave a choice open:

- **metric**: root-mean-squared error over a subset's test frames ("The Root Mean Squared Error (RMSE)
  ... was employed for performance evaluation"); both metrics are recorded in either mode, the mode
  decides which the tables lead with.
- **sampling**: the reservoir and the 10 % novelty sample are drawn "using a normal distribution". Read
  here as a draw without replacement in which a pose's frames, in recording order, are weighed by a normal
  density centred on the middle frame with a standard deviation of a quarter of the frame count
  (:func:`learned.replay.draw`). The share ``c3`` of the current data is drawn uniformly, as the paper says.
- **c2**: 14 past camera poses in simulation; "all observed" on the real rig (``--c2 all``).
- **selection's replay**: "four samples are taken from past novel camera observations": the whole buffer
  (``c1`` = 4 per pose) of up to ``c2`` past poses, at every novel pose.
- **baseline**: "trained without Continual Learning each time step ... the current dataset and all
  observed camera poses from past time steps": batch retrained from scratch at every time step.
- **naive**: "uses a small batch size"; read as 8 (a quarter of the presets' 32).
- **selection's time steps**: every camera pose after the first subset is a time step, with the error on
  every test subset after it (the paper's Tables 17-18).
- **labels**: "Tsai's hand-eye calibration approach, repeated at least five times": the dataset labelled by
  ``handeye label --method tsai --repeats 5`` (:func:`handeye.labelling.paper_label`); the command line refuses
  a paper-mode run on this project's labels (:func:`learned.label_kind.check_labels`).
"""

from __future__ import annotations

__all__ = ["PROTOCOLS", "DEPARTURES", "PAPER_NAIVE_BATCH"]

#: The naive strategy's batch size in the paper's mode (its "small batch size").
PAPER_NAIVE_BATCH = 8

#: Preset fields per mode. ``handeye`` is the default of every preset but ``paper``.
PROTOCOLS: dict[str, dict] = {
    "paper": {
        "metric": "rmse",
        "sampling": "normal",
        "c2": 14,
        "selection_replay": "all",
        "batch_every_step": True,
        "naive_batch_size": PAPER_NAIVE_BATCH,
        "pose_steps": True,
        "label_method": "tsai",
        "label_repeats": 5,
    },
    "handeye": {
        "metric": "mean",
        "sampling": "uniform",
        "c2": None,
        "selection_replay": "region",
        "batch_every_step": False,
        "naive_batch_size": None,
        "pose_steps": False,
        "label_method": "park",
        "label_repeats": 0,
    },
}

#: One row per departure: (what, the paper, this project, why).
DEPARTURES: list[tuple[str, str, str, str]] = [
    (
        "metric",
        "RMSE over a subset's test frames",
        "mean per-frame error (and, for the keypoint model, the median placement error)",
        "the mean is less dominated by a few bad frames; a placement is what a user calibrates",
    ),
    (
        "sampling",
        "reservoir and novelty sample drawn 'using a normal distribution'",
        "uniform draws without replacement",
        "a pose's frames are exchangeable (random robot configurations), so weighing them by their "
        "recording order has no reason; uniform is the reservoir sampling of the literature",
    ),
    (
        "c2",
        "14 past poses in simulation, all on the real rig",
        "all past poses",
        "the buffer holds 4 samples per pose, so replaying every past pose costs little; the ablation "
        "('handeye learned ablation') measures what c2 changes",
    ),
    (
        "selection's replay",
        "four samples of every past novel pose at every novel pose",
        "a region's share of the buffer per novel pose (a region costs one reservoir step)",
        "the paper's rule made a region of 14 poses cost about five reservoir steps",
    ),
    (
        "baseline",
        "batch retrained from scratch at every time step",
        "batch trained once, at the last step",
        "only its last step enters the comparison; the others cost time",
    ),
    (
        "naive batch size",
        "'a small batch size'",
        "the preset's batch size, as every strategy",
        "one training setting for all strategies isolates the strategy's effect",
    ),
    (
        "selection's time steps",
        "one per camera pose, each with the error on every test subset",
        "one row per region",
        "the per-pose rows cost an evaluation of every test frame per pose",
    ),
    (
        "labels",
        "Tsai's method, repeated at least five times",
        "Park, Levenberg-Marquardt and corner reprojection ('handeye label'); "
        "'handeye label --method tsai --repeats 5' gives the paper's",
        "ten times closer to the truth on the same views (docs/reproduce-paper.md)",
    ),
]
