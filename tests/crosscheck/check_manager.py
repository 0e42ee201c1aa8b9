"""Python side of check_manager.sh: each NOA the robot manager learns from the pour bag
(position + orientation DMP, K = 70, D = 2 sqrt(K), gamma = 5 / duration, 30 basis functions)
against movement_primitives' CartesianDMP fitted on the same segment with the same gains.

Both rollouts run open loop from the demonstrated start to the demonstrated goal at 100 Hz and
are compared with the demonstration: position RMS / max (mm), orientation RMS / max (deg).
Ours must be as good as the reference within 1 mm (position) and 1 deg (orientation)."""

import glob
import json
import os
import sys

import numpy as np


def quat_angle(a, b):
    """Angle between unit quaternions (w, x, y, z) row-wise, rad."""
    d = np.abs(np.sum(a * b, axis=1)).clip(0.0, 1.0)
    return 2.0 * np.arccos(d)


def errors(ref, demo):
    n = min(len(ref), len(demo))
    e = np.linalg.norm(ref[:n, 1:4] - demo[:n, 1:4], axis=1)
    q = quat_angle(ref[:n, 4:8] / np.linalg.norm(ref[:n, 4:8], axis=1)[:, None], demo[:n, 4:8])
    return (1e3 * np.sqrt(np.mean(e**2)), 1e3 * e.max(), np.degrees(np.sqrt(np.mean(q**2))), np.degrees(q.max()))


def main():
    from movement_primitives.dmp import CartesianDMP

    work = sys.argv[1]
    status = 0
    rows = []
    for demo_file in sorted(glob.glob(os.path.join(work, "*.demo.csv"))):
        key = os.path.basename(demo_file)[: -len(".demo.csv")]
        meta = json.load(open(os.path.join(work, key + ".json")))
        demo = np.loadtxt(demo_file, delimiter=",", skiprows=1)
        ours = np.loadtxt(os.path.join(work, key + ".ours.csv"), delimiter=",", skiprows=1)
        t = demo[:, 0]
        dt = 0.01
        # Same transformation system: alpha_y = D, beta_y = K / D (alpha * beta = K), and the
        # -K (g - x0) s term of the thesis's variant (smooth_scaling).
        alpha = meta["damping"]
        dmp = CartesianDMP(
            execution_time=t[-1],
            dt=dt,
            n_weights_per_dim=meta["n_basis"],
            smooth_scaling=True,
            alpha_y=alpha,
            beta_y=meta["stiffness"] / alpha,
        )
        y = demo[:, 1:8].copy()
        # movement_primitives wants a continuous quaternion sign.
        for i in range(1, len(y)):
            if np.dot(y[i, 3:7], y[i - 1, 3:7]) < 0:
                y[i, 3:7] = -y[i, 3:7]
        dmp.imitate(t, y)
        dmp.configure(start_y=y[0], goal_y=y[-1])
        tr, yr = dmp.open_loop()
        ref = np.column_stack([tr, yr])
        e_ours = errors(ours, demo)
        e_ref = errors(ref, demo)
        ok = e_ours[0] <= e_ref[0] + 1.0 and e_ours[2] <= e_ref[2] + 1.0
        status |= 0 if ok else 1
        rows.append((meta["label"], len(demo), t[-1], e_ours, e_ref, ok))
    if not rows:
        print("no NOA exported")
        return 1
    print(f"{'NOA':<12} {'samples':>7} {'T_s':>5}   {'cowork pos rms/max mm':>22} {'rot rms/max deg':>16}   {'movement_primitives pos mm':>27} {'rot deg':>14}")
    for label, n, T, a, b, ok in rows:
        print(
            f"{label:<12} {n:>7} {T:>5.2f}   {a[0]:>10.2f} / {a[1]:>8.2f} {a[2]:>7.2f} / {a[3]:>6.2f}   {b[0]:>13.2f} / {b[1]:>10.2f} {b[2]:>6.2f} / {b[3]:>5.2f}  {'ok' if ok else 'WORSE'}"
        )
    return status


if __name__ == "__main__":
    sys.exit(main())
