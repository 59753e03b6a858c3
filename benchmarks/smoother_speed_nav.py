"""Old vs new GTSAM reference paths of the drone and star-sensor kinds, in one process.

Each path runs ``--repeats`` times on run 0 of a world, the paths interleaved, and the
median CPU seconds (``time.process_time``, one BLAS thread) of each and their ratio are
printed as one JSON object, with the objective (½χ² of the final graph) of each path:

- drone (:func:`drone_paths`): ``today`` = ``smooth_drone`` as the campaign called it
  before the keyframes default (iSAM2 fed ``ISAM_BATCH`` epochs per update, each interval
  preintegrated about iSAM2's current bias; LM; marginals); ``epochs_prior`` = the same
  schedule on the graph
  preintegrated once about the prior bias; ``keyframes`` = that graph solved by one LM
  from iSAM2's keyframe estimate (LM's relative tolerance 1e-10, as ``today``'s);
  ``keyframes_chain`` = that with the marginals by the square-root chain instead of
  GTSAM's ``Marginals``; ``fast`` = ``smooth_drone``'s defaults (``keyframes_chain`` with
  the keyframes' LM tolerance 1e-9, ``reference.LM_REL_TOL``).  The last four share one
  graph and so one optimum; ``today``'s graph is another (the bias points differ).
- star-sensor (:func:`attitude_paths`): ``today`` = ``smooth_attitude``'s old default
  (per-sample preintegration, dead-reckoned start in vector mode, LM, GTSAM's joint
  marginals per epoch); ``chain`` = the same solve, marginals once by the sequential
  square-root chain; ``gauss_newton`` = batched preintegration, Wahba start, GTSAM's
  Gauss-Newton, marginals by square-root cyclic reduction at the result; ``fast`` = the
  default now (that with the steps after GTSAM's first solved by the reduction, whose
  last levels give the marginals), with the objective (½χ²) of each result on
  ``today``'s graph.

Usage: ``python -m benchmarks.smoother_speed_nav [--worlds drone,star-sensor]
[--repeats 3]``.  Timings under load are "loaded"; the ratios are side by side.
"""

from __future__ import annotations

import benchmarks.single_thread  # noqa: F401  (before numpy: one BLAS thread)

# isort: split
import argparse
import json
import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from slam.campaign import run_seeds
from slam.registry import load_world

DRONE_WORLDS = ("drone", "drone-hills")
ATTITUDE_WORLDS = ("star-sensor", "star-sensor-large-error", "star-sensor-hard")


def _cpu(fn: Callable[[], Any]) -> tuple[float, Any]:
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def _compare(paths: dict[str, Callable[[], Any]], repeats: int, base: str
             ) -> dict[str, dict[str, float]]:
    """Median CPU seconds of each path (interleaved repeats) and ``base`` over it."""
    times: dict[str, list[float]] = {k: [] for k in paths}
    for _ in range(repeats):
        for name, fn in paths.items():
            times[name].append(_cpu(fn)[0])
    med = {k: float(np.median(v)) for k, v in times.items()}
    return {k: {"cpu_s": med[k], "speedup_vs_" + base: med[base] / med[k]} for k in paths}


def drone_paths(world_name: str, repeats: int) -> dict[str, Any]:
    """The drone reference's paths on run 0 of ``world_name``."""
    import slam.kinds.drone.reference as ref
    from slam.kinds.drone.simulate import simulate_drone

    w = load_world(world_name)
    log = simulate_drone(w, np.random.default_rng(run_seeds(w.seed, 1)[0]))
    fs = w.filters
    kw = {"imu_noise_scale": fs.imu_noise_scale, "sensor_noise_scale": fs.sensor_noise_scale}
    joint = {"marginal_method": "joint"}
    kf = {"schedule": "keyframes", "bias_point": "prior"}
    variants = {"today": {"schedule": "epochs", "bias_point": "estimate", **joint},  # old default
                "epochs_prior": {"schedule": "epochs", "bias_point": "prior", **joint},
                "keyframes": {**kf, **joint, "lm_rel_tol": 1e-10},
                "keyframes_chain": {**kf, "marginal_method": "chain", "lm_rel_tol": 1e-10},
                "fast": {}}
    out: dict[str, Any] = {"world": world_name, "epochs": log.n_epochs,
                           "paths": _compare({k: (lambda v=v: ref.smooth_drone(log, **kw, **v))
                                              for k, v in variants.items()}, repeats, "today")}
    obj = {}
    for k, v in variants.items():
        g, vals, _ = ref.solve_graph(log, **kw, **{k: x for k, x in v.items()
                                                    if k != "marginal_method"})
        obj[k] = g.error(vals)
        out["paths"][k]["objective"] = obj[k]
    for k in ("keyframes", "fast"):
        out[k + "_vs_epochs_prior_rel"] = abs(obj[k] - obj["epochs_prior"]) / obj["epochs_prior"]
    out["prior_vs_today_graph_rel"] = abs(obj["epochs_prior"] - obj["today"]) / obj["today"]
    return out


def attitude_paths(world_name: str, repeats: int) -> dict[str, Any]:
    """The star-sensor reference's paths on run 0 of ``world_name``."""
    import gtsam

    import slam.kinds.attitude.run as att
    from slam.kinds.attitude import smoother as sm
    from slam.kinds.attitude.simulate import simulate_attitude

    w = load_world(world_name)
    log = simulate_attitude(att.sim_config(w), np.random.default_rng(run_seeds(w.seed, 1)[0]))
    x0, P0 = att.initial_belief(w, log)
    fs = w.filters
    args = (log, x0, P0, fs.arw_rad_sqrt_s, fs.bias_rw_rad_s_sqrt_s, fs.star_sigma_rad)
    old = {"preintegration": "samples", "solver": "lm", "vector_start": "dead-reckoning"}
    variants: dict[str, dict[str, str]] = {"today": {**old, "marginal_method": "joint"},
                                           "chain": {**old, "marginal_method": "chain"},
                                           "gauss_newton": {"solver": "gauss-newton"},
                                           "fast": {}}
    paths = {k: (lambda v=v: att.smooth_attitude(*args, **v)) for k, v in variants.items()}
    out: dict[str, Any] = {"world": world_name, "star_epochs": log.n_star,
                           "paths": _compare(paths, repeats, "today")}
    out["solve_only_cpu_s_median"] = {k: float(np.median([_cpu(
        lambda v=variants[k]: att.smooth_attitude(*args, marginals=False, **v))[0]
        for _ in range(repeats)])) for k in ("today", "fast")}
    graph, _, X, B = sm.attitude_graph(*args, preintegration="samples",
                                       vector_start="dead-reckoning")
    got = {k: f() for k, f in paths.items()}
    for k, s in got.items():  # ½χ² of each result on the old path's graph
        values = gtsam.Values()
        for j, (x, b) in enumerate(zip(X, B)):
            values.insert(x, gtsam.Rot3.Quaternion(*s.means[j, :4]))
            values.insert(b, s.means[j, 4:])
        out["paths"][k]["objective"] = graph.error(values)
    e0 = out["paths"]["today"]["objective"]
    for k in ("gauss_newton", "fast"):
        out[k + "_vs_today_objective_rel"] = abs(out["paths"][k]["objective"] - e0) / e0
    d = np.sqrt(np.einsum("...ii->...i", got["today"].covs))
    for k in ("chain", "gauss_newton", "fast"):
        out[k + "_vs_joint_marginals_scaled"] = float(np.max(
            np.abs(got["today"].covs - got[k].covs) / (d[..., :, None] * d[..., None, :])))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--worlds", default=",".join(DRONE_WORLDS + ATTITUDE_WORLDS))
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    rows = []
    for name in [n.strip() for n in args.worlds.split(",") if n.strip()]:
        kind = load_world(name).kind
        fn = drone_paths if kind.startswith("drone") else attitude_paths
        rows.append(fn(name, args.repeats))
    print(json.dumps({"python": platform.python_version(), "machine": platform.machine(),
                      "repeats": args.repeats, "worlds": rows}, indent=1))


if __name__ == "__main__":
    main()
