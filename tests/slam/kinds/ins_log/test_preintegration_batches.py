"""The log filters' epochs preintegrated in batches (``preintegration_fixes``): the same
filter as each epoch preintegrated alone, to second order in the bias estimate's moves
within a batch (on the error-free turn they stay near zero: positions to 1e-6 m), and the
setting is stated in the summary and the terminal's settings lines."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from click.testing import CliRunner

from slam import cli
from slam.kinds.ins_log.run import Ahead, alignment, fix_roles, run_filter
from slam.kinds.ins_log.settings import PREINTEGRATION_FIXES
from slam.kinds.ins_log.synthetic import write_log
from slam.kinds.ins_log.world import open_log


def _with(world, k):
    log = world.log
    return dataclasses.replace(world, log=dataclasses.replace(
        log, settings=dataclasses.replace(log.settings, preintegration_fixes=k)))


@pytest.mark.parametrize("name", ["ekf", "srckf", "srckf-inv"])
def test_batches_track_the_epoch_by_epoch_filter(tmp_path, name):
    world = open_log(write_log(tmp_path, duration=60.0), None, None, holdout=5)
    assert world.log.settings.preintegration_fixes == PREINTEGRATION_FIXES > 1
    roles = fix_roles(world.log, world.scoring)
    a, x0, P0, _ = alignment(world.log, roles)
    alone = run_filter(_with(world, 1), name, a, x0, P0, roles)
    batched = run_filter(world, name, a, x0, P0, roles)
    assert alone.failure is None and batched.failure is None
    assert 0.0 < np.abs(batched.p - alone.p).max() < 1e-6  # not the same path, same filter
    s = np.sqrt(np.einsum("eii->ei", alone.P))
    assert np.max(np.abs(batched.P - alone.P) / (s[:, :, None] * s[:, None, :])) < 1e-5


def test_one_fix_per_batch_preintegrates_nothing_ahead(tmp_path):
    world = open_log(write_log(tmp_path, duration=10.0), None, None)
    from slam.kinds.ins_log.run import model_of

    ahead = Ahead(world.log, model_of(world.log), 1)
    assert ahead.of(3, np.zeros(16)) is None
    batch = Ahead(world.log, model_of(world.log), 4)
    mean = np.concatenate([np.zeros(6), [1.0, 0, 0, 0], [1e-3] * 3, [0.01] * 3])
    pre = batch.of(2, mean)
    assert sorted(batch.done) == [2, 3, 4, 5]
    assert batch.of(5, mean + 1.0) is batch.done[5]  # inside the batch: no recompute
    np.testing.assert_array_equal(pre.b, mean[10:16])  # the reference: the first mean's


def test_the_setting_is_stated(tmp_path):
    log = write_log(tmp_path, duration=20.0)
    side = log.with_suffix(".toml")
    side.write_text(side.read_text().replace("[filters]\n", "[filters]\npreintegration_fixes "
                                             "= 7\n"))
    out = tmp_path / "out"
    r = CliRunner().invoke(cli.main, ["run", "--log", str(log), "--filters", "ekf",
                                      "--no-plots", "--out", str(out)])
    assert r.exit_code == 0, r.output
    s = json.loads((out / "summary.json").read_text())
    assert s["settings"]["preintegration_fixes"] == 7
    assert "increments of 7 epochs preintegrated together" in " ".join(r.output.split())
