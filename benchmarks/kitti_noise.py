"""How the KITTI scores depend on the reading of the metadata's bias sigmas: the held-out
RMSE, normalised error and NIS of the filters and GTSAM (online, smoothed) with both bias
random-walk densities scaled by ``--scales`` (1: the documented per-sample reading of
:data:`slam.kinds.ins_log.settings.KITTI_READING`; 0.1: the sigmas read as densities per
sqrt(s); 10: about what GTSAM's example's growing between-factor amounts to mid-drive).
A measurement, not a tuning: the kind always uses the documented reading.

    python -m benchmarks.kitti_noise --scales 0.1,1,3,10
"""

from __future__ import annotations

import argparse
import dataclasses as dc
import json
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scales", default="0.1,1,3,10")
    ap.add_argument("--holdout", type=int, default=5)
    ap.add_argument("--filters", default="ekf,srckf")
    args = ap.parse_args(argv)
    from estimators.threads import single_thread_blas
    from nav.imu_noise import BiasProcess
    from slam.kinds.ins_log.run import run_once
    from slam.kinds.ins_log.world import open_log

    names = args.filters.split(",")
    w = open_log(Path("kitti"), names, None, holdout=args.holdout)
    s = w.log.settings
    out = {}
    with single_thread_blas():
        for k in (float(x) for x in args.scales.split(",")):
            g, a = s.psd.gyro_bias.walk_psd * k * k, s.psd.accel_bias.walk_psd * k * k
            psd = dc.replace(s.psd, gyro_bias=BiasProcess(walk_psd=g),
                             accel_bias=BiasProcess(walk_psd=a))
            ww = dc.replace(w, log=dc.replace(w.log, settings=dc.replace(s, psd=psd)))
            o = run_once(ww, 0, None, names)
            out[f"bias sigma x{k:g}"] = {
                n: {"heldout_rmse_m": v.values["heldout"]["rmse_m"],
                    "heldout_err2_over_sigma2": v.values["heldout"]["mean_normalised_error"],
                    "nis_per_dof": v.values.get("nis", {}).get("mean_nis_per_dof")}
                for n, v in o.scores.items()}
    json.dump(out, sys.stdout, indent=1)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
