"""The seed paper's labels (``handeye label --method tsai --repeats 5``): Tsai's closed form alone, repeated on
random subsets of the views and averaged, beside this project's refined labels."""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.metrics import pose_error
from handeye.core.synthetic import make_problem
from handeye.labelling import PAPER_REPEAT_SHARE, paper_label
from tests.tolerances import ABSOLUTE_ONLY, FLOAT


def test_exact_poses_give_the_truth_and_no_spread():
    p = make_problem(12, "eye_to_hand", np.random.default_rng(0))
    X, spread = paper_label(p.T_base_ee, p.T_cam_target, "tsai", 5)
    rot, trans = pose_error(X, p.X_true)
    assert rot < 1e-8 and trans < 1e-8
    assert spread[0] < 1e-8 and spread[1] < 1e-8


def test_the_label_is_the_mean_of_the_repeats():
    """Each repeat is Tsai on a random 80 % of the views; the label their chordal and arithmetic mean."""
    import classic
    from handeye.core.se3 import project_to_so3

    p = make_problem(15, "eye_to_hand", np.random.default_rng(1), camera_noise=(0.1, 1.0))
    X, _ = paper_label(p.T_base_ee, p.T_cam_target, "tsai", 5, seed=3)
    rng = np.random.default_rng(3)
    k = int(round(PAPER_REPEAT_SHARE * 15))
    Xs = []
    no_refinement = classic.CalibrateOptions(refine=False)
    for _ in range(5):
        pick = np.sort(rng.choice(15, k, replace=False))
        res = classic.calibrate(p.T_base_ee[pick], p.T_cam_target[pick], "eye_to_hand", "tsai", options=no_refinement)
        Xs.append(res.X)
    Xs = np.array(Xs)
    assert np.allclose(X[:3, 3], Xs[:, :3, 3].mean(axis=0), rtol=ABSOLUTE_ONLY, atol=FLOAT)
    assert np.allclose(X[:3, :3], project_to_so3(Xs[:, :3, :3].mean(axis=0)), rtol=ABSOLUTE_ONLY, atol=FLOAT)


def test_label_command_writes_the_papers_labels(small_copy, capsys):
    pytest.importorskip("cv2")
    from handeye.cli import main
    from handeye.core.dataset import Dataset

    assert main(["label", str(small_copy), "--method", "tsai", "--repeats", "5", "--quiet", "--workers", "1"]) == 0
    assert "the seed paper's labels: tsai's closed form, 5 repeats averaged" in capsys.readouterr().out
    cams = Dataset.open(small_copy).cameras()
    assert all(s == "ok" for s in cams["label_status"])
    assert np.isnan(cams["label_sigma_trans_mm"]).all()  # no sigma claimed
    assert np.isfinite(cams["label_error_trans_mm"]).all()
