"""The calibration report: one self-contained HTML page (and its PNGs) for a calibration.

``handeye calibrate poses.csv --setup eye-to-hand --report report/`` writes ``report/index.html``
(inline CSS, the figures embedded as data URIs, no script, nothing fetched) with the PNGs beside it
and ``report.json`` with the numbers. One job per file:

* :mod:`~handeye.report.holdout`: calibrate on all but k poses, predict the rest, against the predicted sigma;
* :mod:`~handeye.report.figures`: residual per pose, hold-out, motion diversity;
* :mod:`~handeye.report.frames3d`: base, camera, target and end-effector frames in 3-D;
* :mod:`~handeye.report.overlays`: detected against predicted corners per image;
* :mod:`~handeye.report.tables`, :mod:`~handeye.report.html`, :mod:`~handeye.report.style`: the page;
* :mod:`~handeye.report.build`: :func:`write_report`; :mod:`~handeye.report.from_command`: the command's glue.

Needs matplotlib (``pip install "handeye[sim]"``).
"""

from handeye.report.build import ImagesPart, ReportData, write_report
from handeye.report.holdout import HoldOutCheck, hold_out_check

__all__ = ["ImagesPart", "ReportData", "write_report", "HoldOutCheck", "hold_out_check"]
