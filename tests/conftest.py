"""Shared fixtures: every random draw in the suite comes from a seeded generator; datasets rendered once."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from tests.shared_renders import shared_build
from tests.tiers import (  # noqa: F401  (the tiers' hooks: --full, the slow tests counted, the work units)
    pytest_addoption,
    pytest_collection_modifyitems,
    pytest_configure,
    pytest_terminal_summary,
    pytest_testnodedown,
    pytest_xdist_auto_num_workers,
    pytest_xdist_make_scheduler,
)


@pytest.fixture
def rng() -> np.random.Generator:
    """A fresh, seeded generator per test (reproducible, independent of test order)."""
    return np.random.default_rng(0)


MARKER_RADIUS_M = 0.03


def _have_sim() -> bool:
    try:
        import pinocchio  # noqa: F401
        import pyrender  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.fixture(scope="session")
def small_dataset(tmp_path_factory):
    """The ``small`` preset, generated on 2 processes and labelled: a read-only path (copy before changing it)."""
    if not _have_sim():
        pytest.skip("needs handeye[sim]")
    from handeye.core.engine_protocol import EngineOptions
    from handeye.labelling import label_dataset
    from sim.generate import Recipe, generate

    def build(folder):
        report = generate(folder / "small", Recipe("small", seed=0), options=EngineOptions(workers=2, progress=False))
        label_dataset(folder / "small", workers=2, progress=False)
        return report

    folder, report = shared_build(tmp_path_factory, "small", build)  # one render for all the run's workers
    return folder / "small", report


@pytest.fixture
def small_copy(small_dataset, tmp_path):
    """A private copy of the small dataset, to damage."""
    root = tmp_path / "small"
    shutil.copytree(small_dataset[0], root)
    return root


@pytest.fixture(scope="session")
def marker_dataset(tmp_path_factory):
    """Data recordings of a sphere on the flange origin (robot hidden) at 320x320, 3 camera poses."""
    if not _have_sim():
        pytest.skip("needs handeye[sim]")
    from handeye.core.engine_protocol import EngineOptions
    from sim.cameras import CameraPreset
    from sim.generate import Recipe, generate

    preset = CameraPreset("marker", "ur5", ((0.0, 360.0),), (3,), (0,), 4, image_size=(320, 320))
    recipe = Recipe(preset, seed=3, recordings=("data",), marker_radius_m=MARKER_RADIUS_M)
    folder, _ = shared_build(
        tmp_path_factory,
        "marker",
        lambda f: generate(f / "marker", recipe, options=EngineOptions(workers=1, progress=False)),
    )
    return folder / "marker"
