"""Gated nearest-neighbour association (:mod:`slam.mapping.association`)."""

from __future__ import annotations

import numpy as np

from slam.mapping.association import NEW, gated_choice


def test_gated_choice_accepts_best_normalised_distance_new_or_ambiguous():
    S = np.stack([np.eye(2), 4.0 * np.eye(2), np.eye(2)])
    # two candidates inside the gate: NIS 1.0 (det 1) vs NIS 0.5 (det 16): the normalised
    # distance nis + ln det picks the first, though its NIS is larger
    nu = np.array([[1.0, 0.0], [np.sqrt(2.0), 0.0], [10.0, 0.0]])
    assert gated_choice(nu, S, (4.0, 25.0)) == 0
    assert gated_choice(np.full((3, 2), 10.0), S, (4.0, 25.0)) == NEW  # all NIS > 25
    assert gated_choice(np.array([[2.5, 0.0], [6.0, 0.0], [9.0, 0.0]]), S,
                        (4.0, 25.0)) is None  # 6.25, 9, 81: none accepted, one below 25
    assert gated_choice(np.zeros((0, 2)), np.zeros((0, 2, 2)), (4.0, 25.0)) == NEW
