"""Outside anchor for issue "Consistent SLAM": ukfm's UKFs on our ``webmap`` logs.

ukfm (Brossard, Barrau & Bonnabel, https://github.com/CAOR-MINES-ParisTech/ukfm; not on
PyPI) is not a dependency: export its repository and put its ``python/`` folder on
``PYTHONPATH`` (``git clone`` it, or ``git --git-dir=<bare repo> archive HEAD python/ukfm |
tar -x -C /tmp/ukfm``, then ``PYTHONPATH=/tmp/ukfm/python``).  It needs only numpy, scipy
and matplotlib.  ukfm is imported lazily; without it the script exits with one line.

What it does, per run ``r`` of ``--runs N`` (``--seed S``, default 0): simulates the log
exactly as ``slam run webmap`` does (``run_seeds(S, N)[r]`` ->
``numpy.random.default_rng`` -> :func:`slam.kinds.planar.simulate.simulate_planar`), then
runs ukfm's ``JUKF`` on it with our model written in ukfm's interface (:class:`CarModel`):
the car model with noisy ``[V, G]`` controls (noise ``log.control_cov`` added to the
controls), propagated at every control step; range-bearing observations
(``log.obs_cov``) of known landmark ids, the re-observed ones in one batch update, then
each new landmark augmented through the inverse observation; prior ``log.x0``,
``log.P0``.  Filters (``--filters``):

``ukf-lg``  right-invariant UKF on :math:`SE_{1+n}(2)` (ukfm's "right" retraction; the
            propagation Jacobian is the identity, the noise Jacobian is inferred on the
            whole state, as in ukfm's ``benchmarks/slam2d.py``);
``ukf``     standard UKF on :math:`SO(2) \\times R^{2+2n}` (Jacobians on the pose only).

Sigma-point parameters are ukfm's SLAM ones (``alpha = 1e-3`` everywhere).  The filters
are scored at our filters' epochs (:func:`slam.kinds.planar.slam.epochs_of`) with our
planar scoring (:func:`slam.kinds.planar.scoring.reduce_run` and ``summarize``): 3-dof
pose NEES, ANEES with its per-epoch 95 % band, the share of epochs in band, landmark RMSE
at the end, pose RMSE.  The right-invariant pose covariance is carried to the world
``(x, y, φ)`` error to first order (:meth:`estimators.slam_group.SlamGroup.to_world`).
A run whose position error exceeds 50 m at an epoch, or whose maths fails, is diverged.
Prints one JSON object: runs, seed, band, per filter the summary (``--also M``: and of the
first M runs).  ``PYTHONPATH=/tmp/ukfm/python python -m benchmarks.ukfm_anchor --runs 100``
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from estimators.slam_group import SlamGroup
from slam.campaign import run_seeds
from slam.kinds.planar.scoring import reduce_run, summarize
from slam.kinds.planar.simulate import simulate_planar
from slam.kinds.planar.slam import epochs_of
from slam.registry import load_world
from slam.scoring import anees_band

FILTERS = ("ukf-lg", "ukf")
DIVERGE_M = 50.0
POSE = SlamGroup(0, "right")  # pose-only right-invariant error, for to_world / from_world
UKFM_ORDER = np.array([2, 0, 1])  # ukfm's pose error [θ, x, y] from ours [x, y, φ]
WORLD_ORDER = np.array([1, 2, 0])  # ours from ukfm's


def import_ukfm():
    """ukfm, or exit with one line."""
    try:
        import ukfm
    except ImportError as exc:
        sys.exit(f"ukfm is not importable ({exc}); put ukfm's python/ folder on PYTHONPATH")
    return ukfm


class State:
    """ukfm-style state: rotation matrix, position (2,), landmarks (n, 2) - or one (2,)
    while ukfm updates or augments with a single landmark."""

    def __init__(self, Rot, p, p_l=None):
        self.Rot, self.p = Rot, p
        self.p_l = np.zeros((0, 2)) if p_l is None else p_l


def rot(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


class CarModel:
    """Our car model and range-bearing sensor in ukfm's model interface: ``f``, ``h``,
    ``aug_z`` and the retractions of the right-invariant (``r_*``) and standard (``s_*``)
    errors, tangent order ``[θ, x, y, l_1x, l_1y, ...]``."""

    def __init__(self, ukfm, wheelbase: float):
        self.SO2, self.SE2, self.SEK2 = ukfm.SO2, ukfm.SE2, ukfm.SEK2
        self.wb = wheelbase

    def f(self, s, u, w, dt):
        """Car step: controls ``[V, G]`` plus noise ``w``; landmarks stay."""
        v, g = u[0] + w[0], u[1] + w[1]
        move = v * dt * np.array([np.cos(g), np.sin(g)])
        return State(s.Rot @ rot(v * dt * np.sin(g) / self.wb), s.p + s.Rot @ move, s.p_l)

    def h(self, s):
        """Range and bearing of the one landmark in ``s.p_l`` (2,); bearings of our front
        half-plane sensor stay within ±π/2, so no wrapping is needed."""
        d = s.Rot.T @ (s.p_l - s.p)
        return np.array([np.hypot(d[0], d[1]), np.arctan2(d[1], d[0])])

    def aug_z(self, s, y):
        """Inverse observation: the state with its new landmark as ``p_l``."""
        return State(s.Rot, s.p, s.p + s.Rot @ (y[0] * np.array([np.cos(y[1]), np.sin(y[1])])))

    # --- right-invariant error: X <- exp(ξ) X on SE_{1+n}(2) ------------------------------
    def _right(self, s, xi, with_lm: bool):
        T = self.SEK2.exp(xi)
        C = T[:2, :2]
        if not with_lm:
            return State(C @ s.Rot, C @ s.p + T[:2, 2])
        lm = s.p_l @ C.T + T[:2, 3:].T.reshape(np.shape(s.p_l))
        return State(C @ s.Rot, C @ s.p + T[:2, 2], lm)

    def _right_log(self, Rot, pts, Rot_hat, pts_hat):
        """log(X̂ X⁻¹) of two states' rotations and points (k, 2)."""
        C = Rot_hat @ Rot.T
        theta = self.SO2.log(C)
        t = pts_hat - pts @ C.T
        return np.hstack([theta, (t @ self.SO2.inv_left_jacobian(theta).T).ravel()])

    def r_phi(self, s, xi):  # also ukfm's red_phi (whole state) and up_phi (one landmark)
        return self._right(s, xi, True)

    def r_red_phi_inv(self, s, s_hat):
        return self._right_log(s.Rot, np.vstack([s.p, s.p_l]), s_hat.Rot,
                               np.vstack([s_hat.p, s_hat.p_l]))

    def r_aug_phi(self, s, xi):
        return self._right(s, xi, False)

    def r_aug_phi_inv(self, s, s_aug):
        return self._right_log(s.Rot, s.p_l[None], s_aug.Rot, s_aug.p_l[None])[1:]

    # --- standard error: heading on SO(2), positions additive ----------------------------
    def s_phi(self, s, xi):
        lm = s.p_l + xi[3:].reshape(np.shape(s.p_l)) if xi.size > 3 else s.p_l
        return State(s.Rot @ rot(xi[0]), s.p + xi[1:3], lm)

    def s_red_phi_inv(self, s, s_hat):
        return np.hstack([self.SO2.log(s_hat.Rot @ s.Rot.T), s_hat.p - s.p])

    def s_aug_phi(self, s, xi):
        return State(s.Rot @ rot(xi[0]), s.p + xi[1:3])

    def s_aug_phi_inv(self, s, s_aug):
        return s_aug.p_l - s.p_l


def make_filter(ukfm, car: CarModel, name: str, log):
    """ukfm's JUKF for ``name`` on ``log``'s prior and noise."""
    x0 = np.asarray(log.x0, dtype=float)
    P0 = np.asarray(log.P0, dtype=float)
    if name == "ukf-lg":  # the prior in the right-invariant error
        P0 = POSE.from_world(x0, POSE.from_world(x0, P0).T)
    P0 = P0[np.ix_(UKFM_ORDER, UKFM_ORDER)]
    pre = "r_" if name == "ukf-lg" else "s_"

    def fn(key):
        return getattr(car, pre + key)

    return ukfm.JUKF(f=car.f, h=car.h, phi=fn("phi"), Q=np.asarray(log.control_cov),
                     alpha=np.full(5, 1e-3), state0=State(rot(x0[2]), x0[:2].copy()),
                     P0=P0, red_phi=fn("phi"),
                     red_phi_inv=fn("red_phi_inv"), red_idxs=np.arange(3),
                     up_phi=fn("phi"), up_idxs=np.arange(5), aug_z=car.aug_z,
                     aug_phi=fn("aug_phi"), aug_phi_inv=fn("aug_phi_inv"),
                     aug_idxs=np.arange(3), aug_q=2)


def propagate(ukf, name: str, u, dt: float) -> None:
    """One control step: ukfm's propagation (right-invariant: F = I, G on the whole
    state, as ukfm's ``benchmarks/slam2d.py`` does)."""
    if name == "ukf":
        ukf.propagation(u, dt)
        return
    d = ukf.P.shape[0]
    ukf.state_propagation(u, dt)
    if ukf.F.shape[0] != d:
        ukf.F = np.eye(d)
    ukf.red_idxs, ukf.red_d = np.arange(d), d
    ukf.G_num(u, dt)
    ukf.cov_propagation()


def correct(ukf, log, sl: slice, slots: dict[int, int], ids: list[int]) -> None:
    """Batch update with the re-observed landmarks, then augment the new ones."""
    R = np.asarray(log.obs_cov)
    Z, lids = log.obs[sl], log.obs_id[sl]
    lms = ukf.state.p_l
    for z, lid in zip(Z, lids):
        j = slots.get(int(lid))
        if j is None:
            continue
        ukf.state.p_l = lms[j]
        ukf.H_num(z, np.r_[0, 1, 2, 3 + 2 * j, 4 + 2 * j], R)
    ukf.state.p_l = lms
    if ukf.H.shape[0]:
        ukf.state_update()
    for z, lid in zip(Z, lids):
        if int(lid) in slots:
            continue
        lms = ukf.state.p_l
        new = ukf.state.p + ukf.state.Rot @ (z[0] * np.array([np.cos(z[1]), np.sin(z[1])]))
        ukf.state.p_l = new
        ukf.aug(z, np.arange(3), R)
        ukf.state.p_l = np.vstack([lms, new[None]])
        slots[int(lid)] = len(ids)
        ids.append(int(lid))


def world_pose(ukf, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Pose ``[x, y, φ]`` and its world-frame covariance (first order)."""
    s = ukf.state
    x = np.array([s.p[0], s.p[1], np.arctan2(s.Rot[1, 0], s.Rot[0, 0])])
    P = ukf.P[np.ix_(WORLD_ORDER, WORLD_ORDER)]
    if name == "ukf-lg":
        P = POSE.to_world(x, POSE.to_world(x, P).T)
    return x, P


def run_filter(ukfm, name: str, log, steps: np.ndarray):
    """One filter on one log: poses, covariances at ``steps``, landmark ids and positions,
    seconds, diverged, failure."""
    E = len(steps)
    poses, covs = np.full((E, 3), np.nan), np.full((E, 3, 3), np.nan)
    at_epoch = {int(k): e for e, k in enumerate(steps)}
    obs = log.observations_at()
    slots: dict[int, int] = {}
    ids: list[int] = []
    t0 = time.perf_counter()
    ukf = make_filter(ukfm, CarModel(ukfm, log.wheelbase), name, log)
    poses[0], covs[0] = world_pose(ukf, name)
    failure = None
    try:
        for k in range(1, log.n_steps + 1):
            propagate(ukf, name, log.controls[k - 1], log.dt)
            if k in obs:
                correct(ukf, log, obs[k], slots, ids)
            e = at_epoch.get(k)
            if e is not None:
                poses[e], covs[e] = world_pose(ukf, name)
                err = float(np.linalg.norm(poses[e, :2] - log.truth[k, :2]))
                if not err <= DIVERGE_M:
                    failure = f"position error {err:.3g} m at step {k}"
                    break
    except (np.linalg.LinAlgError, FloatingPointError, ValueError) as exc:
        failure = f"{type(exc).__name__}: {exc}"
    seconds = time.perf_counter() - t0
    lm = np.asarray(ukf.state.p_l, dtype=float).reshape(-1, 2)[:len(ids)]
    return poses, covs, np.array(ids, dtype=int), lm, seconds, failure is not None, failure


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--world", default="webmap")
    ap.add_argument("--filters", default=",".join(FILTERS))
    ap.add_argument("--also", type=int, default=0,
                    help="also summarise the first ALSO runs (e.g. 20: the issue's anchor)")
    args = ap.parse_args(argv)
    ukfm = import_ukfm()
    names = [n for n in args.filters.split(",") if n]
    if set(names) - set(FILTERS):
        ap.error(f"unknown filter in {args.filters!r}; choose from {', '.join(FILTERS)}")
    world = load_world(args.world)
    period = world.sensor.period_steps
    scores: dict[str, list] = {n: [] for n in names}
    for r, seq in enumerate(run_seeds(args.seed, args.runs)):
        log = simulate_planar(world, np.random.default_rng(seq))
        steps = epochs_of(log, period)
        truth = log.truth[steps]
        for n in names:
            poses, covs, ids, lm, sec, div, why = run_filter(ukfm, n, log, steps)
            scores[n].append(reduce_run(n, poses, covs, truth, ids, lm, log.landmarks,
                                        np.zeros(0), np.zeros(0, int), sec, div, why))
            s = scores[n][-1]
            print(f"run {r} {n}: {sec:.1f} s, final pos err "
                  f"{np.linalg.norm(s.err[-1, :2]):.2f} m{' DIVERGED ' + why if div else ''}",
                  file=sys.stderr, flush=True)
    out = {"world": args.world, "runs": args.runs, "seed": args.seed,
           "band": list(anees_band(args.runs, 3)), "epochs": int(len(steps))}
    keys = ("anees", "anees_bounds_95", "anees_steps_inside_95", "anees_steps_above_95",
            "landmark_rmse_m", "pos_rmse_m", "heading_rmse_deg", "runs_scored",
            "diverged_runs", "time_per_run_s")
    subsets = [("filters", args.runs)]
    if 0 < args.also < args.runs:
        subsets.append((f"first_{args.also}_runs", args.also))
    for section, m in subsets:
        out[section] = {}
        for n in names:
            summ = summarize(scores[n][:m])
            out[section][n] = {k: summ[k] for k in keys if k in summ}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
