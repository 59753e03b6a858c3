"""Square-root cyclic reduction (:mod:`slam.chain_reduction`) against a dense QR of the
whole problem, on random chains of every small length (odd and even levels)."""

from __future__ import annotations

import numpy as np
import pytest

from slam.chain_marginals import chain_marginals
from slam.chain_reduction import chain_covariances, chain_solve, epoch_factors, reduce_chain

N = 3


def _random_chain(M: int, rng: np.random.Generator):
    """Rows on (x_j, x_{j+1}) (none past the last epoch), 4-7 per epoch, scales spread
    over six decades."""
    local, base = [], []
    for j in range(M):
        k = int(rng.integers(4, 8))
        rows = rng.normal(size=(k, 2 * N)) * 10.0 ** rng.uniform(-3, 3, size=(k, 1))
        if j == M - 1:
            rows[:, N:] = 0.0
        local.append(rows)
        base += [j] * k
    local = np.vstack(local)
    return local, rng.normal(size=len(local)), np.array(base)


def _dense(local, rhs, base, M):
    J = np.zeros((len(local), N * M + N))
    for i, (row, b) in enumerate(zip(local, base)):
        J[i, N * b:N * b + 2 * N] = row
    J = J[:, :N * M]
    R_inv = np.linalg.inv(np.linalg.qr(J, mode="r"))
    covs = np.stack([R_inv[N * j:N * j + N] @ R_inv[N * j:N * j + N].T for j in range(M)])
    return np.linalg.lstsq(J, rhs, rcond=None)[0].reshape(M, N), covs


def _scaled(a: np.ndarray, b: np.ndarray) -> float:
    d = np.sqrt(np.einsum("...ii->...i", a))
    return float(np.max(np.abs(a - b) / (d[..., :, None] * d[..., None, :])))


@pytest.mark.parametrize("M", list(range(1, 12)) + [37, 64])
def test_reduction_equals_a_dense_qr(M: int) -> None:
    rng = np.random.default_rng(M)
    local, rhs, base = _random_chain(M, rng)
    x_dense, cov_dense = _dense(local, rhs, base, M)
    levels, R_inv, d = reduce_chain(epoch_factors(local, rhs, base, M))
    x = chain_solve(levels, R_inv, d)
    covs = chain_covariances(levels, R_inv)
    sd = np.sqrt(np.einsum("...ii->...i", cov_dense))
    # Measured worst over these M: 3.5e-11, 1.1e-11 (the sequential sweep: 1.0e-11 against
    # the dense QR, 2.3e-12 against the reduction): the problems' conditioning.
    assert np.max(np.abs(x - x_dense) / sd) < 1e-9
    assert _scaled(cov_dense, covs) < 1e-10
    seq = chain_marginals(local, np.zeros((len(local), 0)), base, M)[0]
    assert _scaled(seq, covs) < 1e-10


def test_an_indeterminate_epoch_is_reported() -> None:
    local, rhs, base = _random_chain(5, np.random.default_rng(0))
    local[:, :N][base == 2] = 0.0  # epoch 2 only seen from epoch 1's rows
    local[:, N:][base == 1] = 0.0
    with pytest.raises(np.linalg.LinAlgError, match="indeterminate"):
        reduce_chain(epoch_factors(local, rhs, base, 5))
