"""The banded Cholesky solve, with and without a low-rank term, against dense linear algebra."""

import numpy as np
import pytest

from dresspack_gym.rod.band import band_matvec, cholesky, pin, solve, solve_low_rank


def random_band(n, kd, rng):
    dense = np.zeros((n, n))
    for d in range(kd + 1):
        v = rng.normal(size=n - d)
        dense += np.diag(v, -d) + (np.diag(v, d) if d else 0)
    dense += np.eye(n) * (2 * kd + 2) * 3  # diagonally dominant: positive definite
    band = np.array([np.concatenate([np.diag(dense, -d), np.zeros(d)]) for d in range(kd + 1)])
    return dense, band


@pytest.mark.parametrize("n, kd", [(9, 8), (30, 8), (147, 8), (20, 3)])
def test_banded_solves_match_dense(n, kd):
    rng = np.random.default_rng(n + kd)
    dense, band = random_band(n, kd, rng)
    rhs = rng.normal(size=n)
    np.testing.assert_allclose(band_matvec(band, rhs), dense @ rhs, rtol=1e-12)
    ok, factor = cholesky(band)
    assert ok
    np.testing.assert_allclose(solve(factor, rhs), np.linalg.solve(dense, rhs), rtol=1e-10)
    vectors = rng.normal(size=(2, n))
    weights = np.array([0.7, 2.5])
    full = dense + (weights[:, None, None] * vectors[:, :, None] * vectors[:, None, :]).sum(axis=0)
    np.testing.assert_allclose(solve_low_rank(factor, weights, vectors, rhs), np.linalg.solve(full, rhs), rtol=1e-9)


def test_not_positive_definite_is_reported_and_pinned_rows_are_identity():
    rng = np.random.default_rng(0)
    dense, band = random_band(12, 4, rng)
    band[0, 5] = -100.0
    assert not cholesky(band)[0]
    _, band = random_band(12, 4, rng)
    pin(band, np.array([0, 1, 11]))
    ok, factor = cholesky(band)
    rhs = rng.normal(size=12)
    y = solve(factor, rhs)
    assert ok and y[0] == pytest.approx(rhs[0]) and y[11] == pytest.approx(rhs[11])
