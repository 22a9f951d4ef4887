"""Fixtures of the learned tests.

``frames``: the counting tests' frames (:func:`tests.learned._synthetic.count_frames`); a test module that
needs other frames defines its own ``frames`` fixture, which takes precedence. ``paper_labelled``: a copy of
the ``small`` dataset labelled as the paper labels (``handeye label --method tsai --repeats 5``).
"""

from __future__ import annotations

import shutil

import pytest


@pytest.fixture(scope="module")
def frames():
    pytest.importorskip("torch")
    from tests.learned._synthetic import count_frames

    return count_frames()


@pytest.fixture(scope="session")
def paper_labelled(small_dataset, tmp_path_factory):
    """The ``small`` dataset with the paper's labels (Tsai's closed form, 5 repeats averaged): a read-only path."""
    pytest.importorskip("cv2")
    from handeye.labelling import label_dataset

    root = tmp_path_factory.mktemp("paper-labels") / "small"
    shutil.copytree(small_dataset[0], root)
    label_dataset(root, workers=2, method="tsai", repeats=5, progress=False, plot=False)
    return root
