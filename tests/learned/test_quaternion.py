"""The 10-D quaternion layer and the chordal loss."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from learned.losses import chordal_loss, translation_loss  # noqa: E402
from learned.quaternion import quaternion_from_10, symmetric_from_10  # noqa: E402
from tests.tolerances import ABSOLUTE_ONLY, FLOAT  # noqa: E402


def test_unit_quaternions_in_the_w_half_space_minimising_the_quadratic_form():
    g = torch.Generator().manual_seed(0)
    a = torch.randn(200, 10, generator=g, dtype=torch.float64)
    q = quaternion_from_10(a)
    assert torch.allclose(q.norm(dim=1), torch.ones(200, dtype=torch.float64), rtol=ABSOLUTE_ONLY, atol=FLOAT)
    assert torch.all(q[:, 3] >= 0)
    A = symmetric_from_10(a)
    assert torch.equal(A, A.transpose(1, 2))
    # q^T A q is the smallest eigenvalue: no unit vector does better
    value = torch.einsum("ni,nij,nj->n", q, A, q)
    np.testing.assert_allclose(value.numpy(), np.linalg.eigvalsh(A.numpy())[:, 0], atol=FLOAT)


def test_a_matrix_built_from_a_quaternion_returns_it():
    q_true = torch.tensor([[0.1, -0.5, 0.3, 0.8]], dtype=torch.float64)
    q_true = q_true / q_true.norm()
    A = torch.eye(4, dtype=torch.float64) - q_true.T @ q_true  # q_true spans the null space
    rows, cols = torch.triu_indices(4, 4)
    q = quaternion_from_10(A[rows, cols][None])
    assert torch.allclose(q, q_true, rtol=ABSOLUTE_ONLY, atol=FLOAT)


def test_chordal_loss_is_zero_at_the_truth_and_symmetric_in_sign():
    g = torch.Generator().manual_seed(1)
    q_true = torch.nn.functional.normalize(torch.randn(50, 4, generator=g, dtype=torch.float64), dim=1)
    q = torch.nn.functional.normalize(torch.randn(50, 4, generator=g, dtype=torch.float64), dim=1)
    assert chordal_loss(q_true, q_true) == 0
    assert chordal_loss(-q_true, q_true) == 0
    assert torch.isclose(chordal_loss(q, q_true), chordal_loss(-q, q_true))
    assert torch.isclose(chordal_loss(q, q_true), chordal_loss(q, -q_true))
    assert chordal_loss(q, q_true) > 0


def test_gradients_flow_through_the_layer():
    a = torch.randn(8, 10, dtype=torch.float64, requires_grad=True)
    q_true = torch.nn.functional.normalize(torch.randn(8, 4, dtype=torch.float64), dim=1)
    chordal_loss(quaternion_from_10(a), q_true).backward()
    assert torch.isfinite(a.grad).all() and a.grad.abs().sum() > 0


def test_translation_loss_is_the_mean_squared_error_in_mm():
    t = torch.tensor([[0.0, 0.0, 0.0], [1.0, 2.0, 2.0]])
    assert translation_loss(t, torch.zeros(2, 3)) == pytest.approx((0 + 9) / 6)
