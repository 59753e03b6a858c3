"""The turn / accelerating / steady split: each segment's RMS says how many epochs it is
over (a segment without epochs is null with ``epochs: 0``), and the GNSS-aided estimators
are scored between fixes that come less than once a second, so a turn between two fixes
is scored."""

from __future__ import annotations

import numpy as np

from slam.campaign import run_campaign
from slam.kinds.fixed_wing.report import REPORT
from slam.kinds.fixed_wing.run import run_once
from slam.kinds.fixed_wing.simulate import simulate
from slam.nulls import unexplained_nulls
from slam.render.tables import jsonable
from tests.slam.kinds.fixed_wing.worlds import LEVEL_FLIGHT, fw_world, turn_between_fixes

SEGMENTS = ("turns", "accelerating", "steady")


def test_a_flight_without_turns_or_accelerations_counts_its_empty_segments() -> None:
    w = fw_world(**LEVEL_FLIGHT, duration_s=20.0, runs=1,
                 **{"filters.names": ["ea-ckf", "ins-ekf"]})
    s = jsonable(run_campaign(w, workers=1).summary)
    epochs = {"ea-ckf": 101, "ins-ekf": 21, "gtsam": 21}  # EA 5 Hz, GNSS 1 Hz, from t = 0
    for name, e in [*s["filters"].items(), ("gtsam", s["reference"]["gtsam"])]:
        split = e["turn_split_rmse_deg"]
        for seg in ("turns", "accelerating"):
            assert split[seg] == {"roll": None, "pitch": None, "heading": None, "epochs": 0}
        assert split["steady"]["epochs"] == epochs[name]
        assert all(split["steady"][a] > 0.0 for a in ("roll", "pitch", "heading"))
    acc = s["accelerometer_angle_error_deg"]
    assert acc["turns"]["epochs"] == acc["accelerating"]["epochs"] == 0
    assert acc["steady"]["epochs"] == 100  # the EA epochs after t = 0
    assert unexplained_nulls(s) == []
    md = REPORT.markdown(s)
    assert "Epochs per run in turns / accelerating / steady: ea-ckf: 0 / 0 / 101;" in md
    assert "ins-ekf, gtsam: 0 / 0 / 21." in md and "A segment with no epoch has no RMS" in md
    assert "no epoch in a turn or accelerating (epochs 0), so there is nothing to split" in md


def test_gnss_fixes_far_apart_still_score_the_turn_between_them() -> None:
    """Fixes at 0, 10 and 20 s, a turn at 3-7 s: the INS filter predicts in 1 s epochs,
    updates at the fixes only, and is scored (as the smoother) in the turn."""
    w = turn_between_fixes(**{"filters.names": ["ins-ekf", "ins-srckf"]})
    log = simulate(w, np.random.default_rng(0))
    assert (log.n_gnss, log.n_ins, log.fix_every, log.ins_epochs) == (1000, 100, 10, 21)
    out = run_once(w, 0, np.random.SeedSequence(0), ["ins-ekf", "ins-srckf"])
    for name, sc in out.scores.items():
        assert not sc.diverged, (name, sc.failure)
        assert np.allclose(np.diff(sc.times), 1.0) and len(sc.times) == 21
        assert np.flatnonzero(sc.turn).tolist() == [4, 5, 6], name  # |rate| > 1 °/s, 3-7 s
    assert out.scores["ins-ekf"].nis.size == 3  # one update per fix
    s = jsonable(run_campaign(w, workers=1).summary)
    assert s["ins_epoch_s"] == 1.0
    for name, e in [*s["filters"].items(), ("gtsam", s["reference"]["gtsam"])]:
        turns = e["turn_split_rmse_deg"]["turns"]
        assert turns["epochs"] == 3 and all(turns[a] > 0.0 for a in ("roll", "pitch",
                                                                      "heading")), name
    assert unexplained_nulls(s) == []


def test_fixes_at_least_once_a_second_are_the_ins_epochs() -> None:
    """At 1 Hz and faster the GNSS-aided estimators run and are scored at the fixes, as
    before fixes far apart were cut."""
    for rate in (1.0, 2.0, 20.0):
        log = simulate(fw_world(**LEVEL_FLIGHT, duration_s=4.0, **{"gnss.rate_hz": rate}),
                       np.random.default_rng(0))
        assert log.n_ins == log.n_gnss and log.fix_every == 1
        assert log.ins_epochs == log.gnss_p.shape[0]


def test_smoother_marginals_that_fail_keep_its_estimate_and_say_why(monkeypatch) -> None:
    """Fixes 100 s apart with 1 s states made GTSAM's marginals fail ("Indeterminate linear
    system", bundled flight at 0.01 Hz) although the solve succeeds: the estimate is scored,
    the NEES is not, and the summary and the report count it."""
    import slam.kinds.fixed_wing.reference as ref

    def refuse(*_args):
        raise RuntimeError("Indeterminate linear system detected near x3.\n\nThrown when ...")

    monkeypatch.setattr(ref.gtsam, "Marginals", refuse)
    s = jsonable(run_campaign(turn_between_fixes(**{"filters.names": ["ins-ekf"]}),
                              workers=1).summary)
    g = s["reference"]["gtsam"]
    assert g["diverged_runs"] == 0 and g["no_covariance_runs"] == 1
    assert g["no_covariance_reasons"] == [
        "marginals: RuntimeError: Indeterminate linear system detected near x3."]
    assert g["att_rmse_deg"]["roll"] > 0.0 and "anees" not in g
    assert g["turn_split_rmse_deg"]["turns"]["epochs"] == 3
    assert "The smoother's marginal covariances failed on 1 run(s)" in REPORT.markdown(s)
    assert unexplained_nulls(s) == []
