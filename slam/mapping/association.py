r"""Gated nearest-neighbour data association (Bailey's rule), for any sensor.

Given, for every mapped landmark :math:`j`, the innovation :math:`\nu_j` of one
observation and its covariance :math:`S_j` (linearised at the current mean), the
observation is associated to the landmark with the smallest normalised distance

.. math::  d_j = \nu_j^\top S_j^{-1} \nu_j + \ln\det S_j

among those whose NIS :math:`\nu_j^\top S_j^{-1}\nu_j` is below the accept gate; it
starts a new landmark if every NIS exceeds the new-landmark gate, and is ignored
otherwise (ambiguous).
"""

from __future__ import annotations

import numpy as np

from estimators.linalg import Array

NEW = -1


def gated_choice(nu: Array, S: Array, gates: tuple[float, float]) -> int | None:
    """Decide one observation's association.

    Parameters
    ----------
    nu : (L, d) innovations against the L mapped landmarks (angles already wrapped).
    S : (L, d, d) innovation covariances.
    gates : (accept, new) squared-Mahalanobis gates.

    Returns
    -------
    The landmark index, :data:`NEW` (-1) for a new landmark, or ``None`` (ignore).
    """
    if len(nu) == 0:
        return NEW
    nis = np.einsum("li,li->l", nu, np.linalg.solve(S, nu[..., None])[..., 0])
    accepted = np.flatnonzero(nis < gates[0])
    if accepted.size:
        nd = nis[accepted] + np.linalg.slogdet(S[accepted])[1]
        return int(accepted[np.argmin(nd)])
    return NEW if nis.min() > gates[1] else None
