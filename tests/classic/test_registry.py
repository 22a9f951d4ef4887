"""The solver registry (classic/registry.py): every closed form by name, listed as before, read by the front."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from classic import registry
from classic.calibrate import AXXB_METHODS, AXYB_METHODS, METHODS, initial_estimate
from classic.registry import Solver, register, solver, solvers
from handeye.core.errors import HandEyeInputError
from handeye.core.setups import robot_side_poses
from handeye.core.synthetic import make_problem
from tests.tolerances import EXACT


def test_methods_listed_as_before():
    """The CLI's ``--method`` choices and their order (the order of the table before the registry)."""
    assert METHODS == ("auto", "tsai", "park", "horaud", "andreff", "daniilidis", "shah", "li")
    assert list(AXXB_METHODS) == ["tsai", "park", "horaud", "andreff", "daniilidis"]
    assert list(AXYB_METHODS) == ["shah", "li"]


@pytest.mark.parametrize("entry", solvers(), ids=lambda s: s.name)
def test_each_module_registers_its_public_parts(entry):
    module = importlib.import_module(f"classic.{entry.name}")
    if entry.kind == "AX=XB":
        assert entry.stats is getattr(module, f"{entry.name}_stats")
        assert entry.finish is getattr(module, f"{entry.name}_finish")
        assert AXXB_METHODS[entry.name] == (entry.stats, entry.finish)
    else:
        assert entry.solve is getattr(module, f"{entry.name}_solve")
        assert AXYB_METHODS[entry.name] is entry.solve
    assert entry.description and "\n" not in entry.description


@pytest.mark.parametrize("name", METHODS[1:])
def test_registered_solve_recovers_the_truth(name):
    """Noise-free poses: the front, reading the registry, returns the true ``(X, Y)`` by every method."""
    p = make_problem(12, "eye_to_hand", np.random.default_rng(0))
    X, Y = initial_estimate(robot_side_poses(p.T_base_ee, "eye_to_hand"), p.T_cam_target, name)
    np.testing.assert_allclose(X, p.X_true, atol=EXACT)
    np.testing.assert_allclose(Y, p.Y_true, atol=EXACT)


def test_unknown_names_are_refused_with_the_choices():
    with pytest.raises(HandEyeInputError, match="unknown method 'nope': use one of auto, tsai, park, horaud"):
        initial_estimate(np.tile(np.eye(4), (3, 1, 1)), np.tile(np.eye(4), (3, 1, 1)), "nope")
    with pytest.raises(HandEyeInputError, match="unknown method 'nope': use one of tsai, park, .*, shah, li$"):
        solver("nope")


def test_a_second_solver_under_a_registered_name_is_refused(monkeypatch):
    monkeypatch.setattr(registry, "_SOLVERS", dict(registry._SOLVERS))
    tsai = solver("tsai")
    assert register(tsai) is tsai  # the same entry again (a module imported twice): no change
    with pytest.raises(ValueError, match="already registered"):
        register(Solver("tsai", "AX=YB", "another", 1, solve=lambda A, B: (A[0], B[0])))
    extra = register(Solver("first", "AX=YB", "listed by rank", -1, solve=lambda A, B: (A[0], B[0])))
    assert solvers()[0] is extra  # listed by rank, whatever the order of registration
    assert [s.name for s in solvers("AX=XB")] == list(AXXB_METHODS)


def test_a_record_needs_the_parts_of_its_kind():
    with pytest.raises(ValueError, match="needs stats and finish"):
        Solver("x", "AX=XB", "no parts", 1, solve=lambda A, B: None)
    with pytest.raises(ValueError, match="needs solve"):
        Solver("x", "AX=YB", "no parts", 1, stats=len, finish=len)
    with pytest.raises(ValueError, match="kind must be one of"):
        Solver("x", "AX=ZB", "no such kind", 1, solve=len)
