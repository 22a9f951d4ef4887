"""The closed-form solvers by name: each solver module registers itself here at import.

Two kinds, one signature each; every solver's docstring points here for it.

AX=XB (``kind="AX=XB"``): ``A_k X = X B_k`` on motion pairs. The plain solver ``f(A, B) -> X`` takes

    A : array, shape (K, 4, 4)
        Robot motions, e.g. from :func:`classic.motion_pairs`.
    B : array, shape (K, 4, 4)
        Camera motions, paired one to one with ``A``.

and returns ``X : array, shape (4, 4)``. Its registered parts work in one pass over chunks of motions
(:func:`classic.motions.accumulate`): ``stats(m: Motions) -> dict`` of arrays that add over chunks, and
``finish(summed: dict) -> X``.

AX=YB (``kind="AX=YB"``): ``A_i X = Y B_i`` on absolute poses. The plain solver ``f(A, B) -> (X, Y)`` takes
``A, B : array, shape (N, 4, 4)`` and returns ``X, Y : array, shape (4, 4)``; for hand-eye data, which of
``X``, ``Y`` is the camera and which the target: :func:`classic.shah`. Its registered ``solve(A, B)`` is the
same solve on inputs already validated (no checks: for callers that solve many subsets).

Motions near a half turn: the closed forms on quaternions (Tsai, Horaud, Daniilidis) need a motion's robot and
camera quaternions with the same sign. Below 150 degrees (:data:`classic.motions.NEAR_HALF_TURN_DEG`) both are
taken with ``w >= 0``; beyond, where noise sets the sign of ``w ~ 0`` on each side independently, the camera
side's is aligned to a sign-free first estimate (:mod:`classic._linear`). Those on rotation matrices (Andreff,
Shah, Li) need no such care. Every solver is checked up to 180 degrees (tests/classic/test_half_turn.py).

Listed in the order of their ``rank`` (the CLI's ``--method`` choices, :data:`classic.calibrate.METHODS`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from handeye.core.errors import HandEyeInputError

__all__ = ["KINDS", "Solver", "register", "solver", "solvers"]

#: The two kinds of closed form (see the module).
KINDS = ("AX=XB", "AX=YB")


@dataclass(frozen=True)
class Solver:
    """One registered closed form.

    Parameters
    ----------
    name : str
        The method's name (``calibrate(..., method=name)``, ``--method name``).
    kind : {"AX=XB", "AX=YB"}
    description : str
        One line: the authors and the algebra.
    rank : int
        Place in listings, lowest first.
    stats, finish : callable, optional
        AX=XB: ``Motions -> dict`` and ``dict -> X`` (see the module).
    solve : callable, optional
        AX=YB: ``(A, B) -> (X, Y)`` on validated poses.
    """

    name: str
    kind: str
    description: str
    rank: int
    stats: Callable | None = None
    finish: Callable | None = None
    solve: Callable | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"solver {self.name!r}: kind must be one of {KINDS}, got {self.kind!r}")
        parts = (self.stats, self.finish) if self.kind == "AX=XB" else (self.solve,)
        if any(p is None for p in parts):
            need = "stats and finish" if self.kind == "AX=XB" else "solve"
            raise ValueError(f"solver {self.name!r} ({self.kind}) needs {need}")


_SOLVERS: dict[str, Solver] = {}


def register(entry: Solver) -> Solver:
    """Add a solver; a second solver under a registered name is refused.

    Parameters
    ----------
    entry : Solver

    Returns
    -------
    Solver
        ``entry``.
    """
    if entry.name in _SOLVERS and _SOLVERS[entry.name] != entry:
        raise ValueError(f"a solver named {entry.name!r} is already registered")
    _SOLVERS[entry.name] = entry
    return entry


def solvers(kind: str | None = None) -> tuple[Solver, ...]:
    """The registered solvers of one kind (all when None), by rank.

    Parameters
    ----------
    kind : {"AX=XB", "AX=YB"}, optional

    Returns
    -------
    tuple of Solver
    """
    return tuple(sorted((s for s in _SOLVERS.values() if kind in (None, s.kind)), key=lambda s: s.rank))


def solver(name: str) -> Solver:
    """The solver registered under ``name``.

    Parameters
    ----------
    name : str

    Returns
    -------
    Solver

    Raises
    ------
    HandEyeInputError
        When none is, naming those that are.
    """
    if name not in _SOLVERS:
        raise HandEyeInputError(f"unknown method {name!r}: use one of {', '.join(s.name for s in solvers())}")
    return _SOLVERS[name]
