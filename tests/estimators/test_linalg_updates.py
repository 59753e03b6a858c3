"""Cholesky factor updates (:mod:`estimators.linalg`), the square-root kernels of local mode.

``chol_update_mixed(S, Vp, Vn)`` must return the lower factor of
:math:`SS^\\top + V_pV_p^\\top - V_nV_n^\\top` - lower triangular with a positive diagonal, so
the unique Cholesky factor - for any block size, raise
:class:`~estimators.linalg.NotPositiveDefiniteError` when that matrix is not positive
definite, and agree with ``chol_update_sweep`` / ``chol_update`` when one of the two sets is
empty.  The random cases are well conditioned by construction:
:math:`S = \\mathrm{chol}(AA^\\top + nI)` and :math:`V_n = S G c` with
:math:`c\\,\\lVert G\\rVert_2 = 0.7`, so the downdated matrix keeps eigenvalues of
:math:`S(I - c^2GG^\\top)S^\\top` at least half of those of :math:`SS^\\top`.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators.linalg import (
    SWEEP_BLOCK,
    NotPositiveDefiniteError,
    chol,
    chol_update,
    chol_update_mixed,
    chol_update_sweep,
    solve_lower,
    svd_factor,
    tria,
)


def factor(n: int, rng: np.random.Generator) -> np.ndarray:
    A = rng.standard_normal((n, n))
    return np.linalg.cholesky(A @ A.T + n * np.eye(n))


def downdate_columns(S: np.ndarray, k: int, rng: np.random.Generator,
                     norm: float = 0.7) -> np.ndarray:
    """``S G c`` with ``c ||G||_2 = norm``: ``SS' - VV'`` is positive definite iff norm < 1."""
    G = rng.standard_normal((S.shape[0], k))
    return S @ G * (norm / np.linalg.norm(G, 2))


def assert_lower_factor_of(S_new: np.ndarray, target: np.ndarray, rtol: float = 1e-11) -> None:
    assert np.array_equal(S_new, np.tril(S_new)), "not lower triangular"
    assert np.all(np.diagonal(S_new) > 0.0), "diagonal not positive"
    scale = np.abs(target).max()
    np.testing.assert_allclose(S_new @ S_new.T, target, rtol=0, atol=rtol * scale)
    # a lower factor with a positive diagonal is unique: it is the Cholesky factor
    np.testing.assert_allclose(S_new, np.linalg.cholesky(target), rtol=0,
                               atol=1e3 * rtol * np.sqrt(scale))


CASES = [  # (n, p, k, block): one block, several, a partial last block, one row per block
    (1, 1, 1, SWEEP_BLOCK), (5, 2, 1, SWEEP_BLOCK), (5, 1, 3, 1), (12, 3, 2, 4),
    (17, 0, 2, 5), (17, 2, 0, 5), (70, 3, 2, SWEEP_BLOCK), (70, 1, 4, 16), (9, 6, 6, 2),
]


@pytest.mark.parametrize(("n", "p", "k", "block"), CASES)
def test_mixed_update_is_the_factor_of_the_updated_matrix(n, p, k, block):
    rng = np.random.default_rng(1000 * n + 10 * p + k)
    S = factor(n, rng)
    Vp = rng.standard_normal((n, p))
    Vn = downdate_columns(S, k, rng) if k else np.zeros((n, 0))
    copies = S.copy(), Vp.copy(), Vn.copy()
    out = chol_update_mixed(S, Vp, Vn, block)
    assert_lower_factor_of(out, S @ S.T + Vp @ Vp.T - Vn @ Vn.T)
    for before, after in zip(copies, (S, Vp, Vn)):  # inputs untouched
        assert np.array_equal(before, after)


@pytest.mark.parametrize("block", [1, 3, SWEEP_BLOCK])
def test_mixed_update_with_one_sign_equals_the_one_sided_updates(block):
    rng = np.random.default_rng(7)
    n = 11
    S = factor(n, rng)
    V = rng.standard_normal((n, 3))
    D = downdate_columns(S, 2, rng)
    none = np.zeros((n, 0))
    np.testing.assert_allclose(chol_update_mixed(S, V, none, block), chol_update(S, V, 1.0),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(chol_update_mixed(S, none, D, block),
                               chol_update_sweep(S, D, -1.0, block), rtol=0, atol=1e-13)
    np.testing.assert_allclose(chol_update_mixed(S, none, D, block), chol_update(S, D, -1.0),
                               rtol=0, atol=1e-12)
    # nothing to do: a copy of S
    same = chol_update_mixed(S, none, none, block)
    assert np.array_equal(same, S) and same is not S
    # vectors are single columns
    v, d = V[:, 0], D[:, 0]
    np.testing.assert_allclose(chol_update_mixed(S, v, d, block),
                               chol_update_mixed(S, v[:, None], d[:, None], block), atol=0)


def test_mixed_update_succeeds_where_the_downdate_alone_would_fail():
    """The point of doing both signs in one sweep: ``I - 1.44 e1 e1'`` is indefinite, but
    ``I + e1 e1' - 1.44 e1 e1' = diag(0.56, 1, 1)`` is not."""
    S = np.eye(3)
    e1 = np.array([1.0, 0.0, 0.0])
    with pytest.raises(NotPositiveDefiniteError):
        chol_update_sweep(S, 1.2 * e1, -1.0)
    out = chol_update_mixed(S, e1, 1.2 * e1)
    np.testing.assert_allclose(out, np.diag([np.sqrt(0.56), 1.0, 1.0]), atol=1e-15)
    # a large downdate cancelled exactly by the same update leaves S
    rng = np.random.default_rng(3)
    S = factor(8, rng)
    V = downdate_columns(S, 3, rng, norm=3.0)
    np.testing.assert_allclose(chol_update_mixed(S, V, V, 3), S, rtol=0, atol=1e-10)


@pytest.mark.parametrize("block", [1, 4, SWEEP_BLOCK])
def test_mixed_update_raises_when_the_result_is_not_positive_definite(block):
    rng = np.random.default_rng(11)
    S = factor(10, rng)
    Vn = downdate_columns(S, 2, rng, norm=1.2)  # S(I - c^2 GG')S' has a negative eigenvalue
    Vp = 1e-3 * rng.standard_normal((10, 1))  # too small to rescue it
    with pytest.raises(NotPositiveDefiniteError, match="positive definiteness"):
        chol_update_mixed(S, Vp, Vn, block)
    with pytest.raises(NotPositiveDefiniteError):
        chol_update_sweep(S, Vn, -1.0, block)
    with pytest.raises(NotPositiveDefiniteError):
        chol_update(S, Vn, -1.0)
    # exactly singular is not positive definite either
    with pytest.raises(NotPositiveDefiniteError):
        chol_update_mixed(np.eye(4), np.zeros((4, 0)), np.eye(4)[:, [2]], block)


def test_the_error_names_the_block_where_definiteness_is_lost():
    S = np.eye(10)
    Vn = 1.5 * np.eye(10)[:, [8]]  # only row 8 fails: the block starting at row 8
    with pytest.raises(NotPositiveDefiniteError, match="block at row 8"):
        chol_update_mixed(S, np.zeros((10, 0)), Vn, 4)
    with pytest.raises(NotPositiveDefiniteError, match="block at row 0"):
        chol_update_mixed(S, np.zeros((10, 0)), Vn, 16)


def test_a_singular_diagonal_block_is_refused():
    S = np.diag([1.0, 0.0, 1.0])
    with pytest.raises(NotPositiveDefiniteError, match="singular"):
        chol_update_mixed(S, np.ones((3, 1)), np.zeros((3, 0)), 1)
    assert issubclass(NotPositiveDefiniteError, np.linalg.LinAlgError)


# --------------------------------------------------------------------------- friends


@pytest.mark.parametrize(("n", "k", "block"), [(6, 1, 2), (30, 4, 8), (70, 2, SWEEP_BLOCK)])
def test_sweep_update_and_downdate_are_the_updated_factors(n, k, block):
    rng = np.random.default_rng(n + k)
    S = factor(n, rng)
    V = rng.standard_normal((n, k))
    assert_lower_factor_of(chol_update_sweep(S, V, 1.0, block), S @ S.T + V @ V.T)
    D = downdate_columns(S, k, rng)
    assert_lower_factor_of(chol_update_sweep(S, D, -1.0, block), S @ S.T - D @ D.T)
    assert_lower_factor_of(chol_update(S, D, -1.0, method="sweep"), S @ S.T - D @ D.T)
    assert_lower_factor_of(chol_update(S, V, 1.0, method="qr"), S @ S.T + V @ V.T)
    with pytest.raises(ValueError, match="unknown chol_update method"):
        chol_update(S, V, 1.0, method="givens")  # type: ignore[arg-type]


def test_tria_is_a_lower_square_root_with_non_negative_diagonal():
    rng = np.random.default_rng(5)
    for n, k in ((4, 9), (4, 4), (5, 2)):  # wide, square, and k < n (zero-padded)
        A = rng.standard_normal((n, k))
        T = tria(A)
        assert T.shape == (n, n) and np.array_equal(T, np.tril(T))
        assert np.all(np.diagonal(T) >= 0.0)
        np.testing.assert_allclose(T @ T.T, A @ A.T, atol=1e-12)
    assert np.all(tria(rng.standard_normal((5, 2)))[:, 2:] == 0.0)


def test_chol_solve_lower_and_svd_factor():
    rng = np.random.default_rng(6)
    S = factor(6, rng)
    P = S @ S.T
    np.testing.assert_allclose(chol(P), S, atol=1e-12)
    with pytest.raises(NotPositiveDefiniteError):
        chol(-P)
    B = rng.standard_normal((6, 2))
    np.testing.assert_allclose(S @ solve_lower(S, B), B, atol=1e-12)
    np.testing.assert_allclose(S.T @ solve_lower(S, B, transpose=True), B, atol=1e-12)
    with pytest.raises(NotPositiveDefiniteError, match="singular"):
        solve_lower(np.diag([1.0, 0.0]), np.ones((2, 1)))
    A = rng.standard_normal((6, 3))
    F = svd_factor(A)
    assert F.shape == (6, 6)
    np.testing.assert_allclose(F @ F.T, A @ A.T, atol=1e-12)
