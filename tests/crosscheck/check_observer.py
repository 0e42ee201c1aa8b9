"""Re-filters a hand track written by the `kalman_track` example with filterpy and compares.

usage: check_observer.py TRACK.csv PROCESS_NOISE MEASUREMENT_NOISE INITIAL_VELOCITY_STD TOL
"""
import sys

import numpy as np
from filterpy.common import Q_continuous_white_noise
from filterpy.kalman import KalmanFilter


def main():
    path, q, r, v0, tol = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
    d = np.loadtxt(path, delimiter=",", skiprows=1)
    t, z, truth, vtruth, ours_p, ours_v = d[:, 0], d[:, 1:4], d[:, 4:7], d[:, 7:10], d[:, 10:13], d[:, 13:16]
    kf = KalmanFilter(dim_x=6, dim_z=3)
    kf.H = np.hstack([np.eye(3), np.zeros((3, 3))])
    kf.R = np.eye(3) * r * r
    kf.x = np.concatenate([z[0], np.zeros(3)]).reshape(6, 1)
    kf.P = np.diag([r * r] * 3 + [v0 * v0] * 3)
    est = [kf.x.ravel().copy()]
    for k in range(1, len(t)):
        dt = t[k] - t[k - 1]
        f = np.eye(6)
        f[0:3, 3:6] = np.eye(3) * dt
        kf.F = f
        # State order [x y z vx vy vz]: position block then velocity block.
        kf.Q = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=q, block_size=3, order_by_dim=False)
        kf.predict()
        kf.update(z[k].reshape(3, 1))
        est.append(kf.x.ravel().copy())
    est = np.array(est)
    dp = np.abs(est[:, 0:3] - ours_p).max()
    dv = np.abs(est[:, 3:6] - ours_v).max()

    def rmse(a, b, skip=10):
        return float(np.sqrt(np.mean(np.sum((a[skip:] - b[skip:]) ** 2, axis=1))))

    raw_v = np.gradient(z, t, axis=0)
    print(
        f"{path.split('/')[-1]}: {len(t)} frames, max |filterpy - ours| position {dp:.2e} m, velocity {dv:.2e} m/s; "
        f"RMSE position raw {rmse(z, truth):.4f} m filtered {rmse(ours_p, truth):.4f} m, "
        f"velocity raw (differences) {rmse(raw_v, vtruth):.4f} m/s filtered {rmse(ours_v, vtruth):.4f} m/s"
    )
    ok = dp <= tol and dv <= tol
    if not ok:
        print(f"FAIL: differs from filterpy by more than {tol}")
    if rmse(ours_p, truth) >= rmse(z, truth):
        print("FAIL: the filtered position is not closer to the truth than the measurement")
        ok = False
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
