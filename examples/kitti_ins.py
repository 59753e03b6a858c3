"""GTSAM's KITTI drive through the library: read, align, run an SRCKF INS/GNSS filter."""
from estimators import make_filter
from nav.gnss import gnss_measurement
from nav.ins import LAYOUT, SPACE, ins_transition
from slam.kinds.ins_log.readers import bundled_kitti, read_kitti
from slam.kinds.ins_log.run import alignment, fix_roles, model_of
from slam.kinds.ins_log.world import Scoring

log = read_kitti(bundled_kitti())  # the metadata read as slam.kinds.ins_log.settings says
a, x0, P0, how = alignment(log, fix_roles(log, Scoring()))  # levelling + GNSS track heading
srckf, model = make_filter("srckf"), model_of(log)  # WGS-84 gravity, the metadata's PSDs
gps = gnss_measurement(LAYOUT, position_sigma=log.settings.position_sigma_m)
belief = srckf.init(x0, SPACE, cov=P0)
for i in range(a + 1, log.n_fixes):  # one epoch per fix: the IMU pieces between, then GPS
    belief = srckf.predict(belief, ins_transition(belief.mean, *log.epochs.of(i), model))
    belief, innovation = srckf.update(belief, gps, log.fix_p[i])
print(how, "\nfinal position (m):", belief.mean[:3].round(2), "last NIS:", innovation.nis)
