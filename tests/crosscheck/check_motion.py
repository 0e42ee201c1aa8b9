#!/usr/bin/env python3
"""Python side of check_motion.sh: cowork_motion against gmr, dtaidistance, movement_primitives
and scikit-learn + gmr on LASA. Each subcommand prints what it compared and exits non-zero on a
mismatch.

  check_motion.py gmr TOOL WORKDIR TOL
  check_motion.py dtw TOOL WORKDIR TOL
  check_motion.py dmp TOOL WORKDIR
  check_motion.py lasa-sklearn LASA_DIR KS_FILE OUT_DIR SUBSAMPLE
"""
import json
import os
import subprocess
import sys
import time

import numpy as np


def run_tool(tool, *args):
    return subprocess.run([tool, *map(str, args)], check=True, capture_output=True, text=True).stdout


def check_gmr(tool, work, tol):
    from gmr import GMM

    rng = np.random.default_rng(7)
    worst = 0.0
    cases = 0
    for trial in range(20):
        k = int(rng.integers(1, 8))
        d = int(rng.integers(2, 7))
        n_in = int(rng.integers(1, d))
        means = rng.normal(0, 3, (k, d))
        covs = []
        for _ in range(k):
            a = rng.normal(0, 1, (d, d))
            covs.append(a @ a.T + 0.1 * np.eye(d))
        pri = rng.random(k) + 0.1
        pri /= pri.sum()
        spec = {"dim": d, "priors": pri.tolist(), "means": means.tolist(), "covariances": [c.reshape(-1).tolist() for c in covs]}
        gpath = os.path.join(work, f"gmm{trial}.json")
        with open(gpath, "w") as f:
            json.dump(spec, f)
        x = rng.normal(0, 3, (50, n_in))
        ppath = os.path.join(work, f"pts{trial}.csv")
        np.savetxt(ppath, x, delimiter=",", header=",".join(f"x{i}" for i in range(n_in)), comments="", fmt="%.17g")
        ours = np.array([[float(v) for v in line.split(",")] for line in run_tool(tool, "gmr", gpath, n_in, ppath).strip().splitlines()])
        ref = GMM(n_components=k, priors=pri, means=means, covariances=np.array(covs)).predict(np.arange(n_in), x)
        err = np.max(np.abs(ours - ref) / np.maximum(1.0, np.abs(ref)))
        worst = max(worst, err)
        cases += len(x)
    print(f"GMR conditional mean vs gmr 2.0.3: {cases} queries on 20 random mixtures, max rel. error {worst:.2e} (tol {tol})")
    return 0 if worst <= tol else 1


def check_dtw(tool, work, tol):
    from dtaidistance import dtw

    rng = np.random.default_rng(11)
    pairs = []
    for _ in range(200):
        a = rng.normal(0, 1, int(rng.integers(5, 120)))
        b = rng.normal(0, 1, int(rng.integers(5, 120)))
        pairs.append((a, b))
    path = os.path.join(work, "pairs.txt")
    with open(path, "w") as f:
        for a, b in pairs:
            f.write(",".join(f"{v:.17g}" for v in a) + ";" + ",".join(f"{v:.17g}" for v in b) + "\n")
    ours = np.array([float(v) for v in run_tool(tool, "dtw", path).split()])
    ref = np.array([dtw.distance(a, b, use_c=False) for a, b in pairs])
    err = np.max(np.abs(ours - ref) / np.maximum(1.0, ref))
    print(f"DTW distance vs dtaidistance 2.5.1: 200 random pairs (length 5..120), max rel. error {err:.2e} (tol {tol})")
    return 0 if err <= tol else 1


def check_dmp(tool, work):
    from movement_primitives.dmp import DMP

    dt, T = 0.01, 2.0
    t = np.arange(0, T + dt / 2, dt)
    s = t / T
    mj = 10 * s**3 - 15 * s**4 + 6 * s**5
    y = np.column_stack([mj + 0.3 * np.sin(np.pi * mj) ** 2, 0.5 * np.sin(2 * np.pi * mj)])
    vel = np.gradient(y, dt, axis=0)
    demo = os.path.join(work, "dmp_demo.csv")
    np.savetxt(demo, np.column_stack([t, y, vel]), delimiter=",", header="t,x0,x1,v0,v1", comments="", fmt="%.17g")
    out = os.path.join(work, "dmp_ours.csv")
    line = run_tool(tool, "dmp", demo, 30, 50, out).strip()
    ours_s = float(line.split("=")[1])
    ours = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1:3]
    times = []
    for _ in range(50):
        t0 = time.perf_counter()
        d = DMP(n_dims=2, execution_time=T, dt=dt, n_weights_per_dim=30)
        d.imitate(t, y)
        d.configure(start_y=y[0], goal_y=y[-1])
        _, ref = d.open_loop()
        times.append(time.perf_counter() - t0)
    ref_s = float(np.median(times))
    n = min(len(ref), len(ours), len(y))
    e_ours = float(np.sqrt(np.mean(np.sum((ours[:n] - y[:n]) ** 2, axis=1))))
    e_ref = float(np.sqrt(np.mean(np.sum((ref[:n] - y[:n]) ** 2, axis=1))))
    print(f"DMP reproduction RMSE (30 basis functions, 2 s demo at 100 Hz): cowork {e_ours:.3e}, movement_primitives 0.9.1 {e_ref:.3e}")
    print(f"DMP fit + rollout median time: cowork {ours_s*1e3:.3f} ms, movement_primitives {ref_s*1e3:.3f} ms, ratio {ref_s/ours_s:.1f}x")
    # "Same reproduction error or better" (5 % slack for the different integrators).
    return 0 if e_ours <= 1.05 * e_ref else 1


def lasa_sklearn(lasa_dir, ks_file, out_dir, subsample):
    from gmr import GMM
    from sklearn.mixture import GaussianMixture

    ks = dict(line.strip().split(",") for line in open(ks_file) if line.strip())
    # Warm-up so that import and thread-pool start-up are not charged to the first motion.
    GaussianMixture(n_components=2, random_state=0).fit(np.random.default_rng(0).normal(size=(200, 4)))
    for name, k in ks.items():
        k = int(k)
        folder = os.path.join(lasa_dir, name)
        files = sorted(f for f in os.listdir(folder) if f.startswith("demo_") and f.endswith(".csv"))
        demos = [np.loadtxt(os.path.join(folder, f), delimiter=",", skiprows=1) for f in files]
        target = np.mean([d[-1, 1:3] for d in demos], axis=0)
        rows = []
        for d in demos:
            idx = list(range(0, len(d), subsample))
            if idx[-1] != len(d) - 1:
                idx.append(len(d) - 1)
            rows.append(np.column_stack([d[idx, 1:3] - target, d[idx, 3:5]]))
        data = np.vstack(rows)
        # Fastest of 3 identical fits, as cowork times its own (LasaOptions::timing_repeats).
        fit_ms = float("inf")
        for _ in range(3):
            t0 = time.perf_counter()
            gm = GaussianMixture(n_components=k, covariance_type="full", tol=1e-3, max_iter=100, reg_covar=1e-6, random_state=0).fit(data)
            fit_ms = min(fit_ms, (time.perf_counter() - t0) * 1e3)
        g = GMM(n_components=k, priors=gm.weights_, means=gm.means_, covariances=gm.covariances_)
        od = os.path.join(out_dir, name)
        os.makedirs(od, exist_ok=True)
        with open(os.path.join(od, "fit.csv"), "w") as f:
            f.write(f"k,fit_ms\n{k},{fit_ms:.6f}\n")
        allx = np.vstack([d[:, 1:3] for d in demos]) - target
        np.savetxt(os.path.join(od, "vel_pred.csv"), g.predict(np.array([0, 1]), allx), delimiter=",", header="v0,v1", comments="", fmt="%.17g")
        longest = max(d[-1, 0] - d[0, 0] for d in demos)
        dt = 0.002
        # All demonstrations are integrated together (one gmr call per step for all of them).
        x = np.array([d[0, 1:3] for d in demos]) - target
        active = np.ones(len(demos), dtype=bool)
        trajs = [[] for _ in demos]
        for step in range(int(2 * longest / dt) + 1):
            idx = np.flatnonzero(active)
            if len(idx) == 0:
                break
            v = g.predict(np.array([0, 1]), x[idx])
            for row, i in enumerate(idx):
                trajs[i].append(np.concatenate([[step * dt], x[i] + target, v[row]]))
                if np.linalg.norm(x[i]) <= 1.0:
                    active[i] = False
            x[idx] = x[idx] + dt * v
        for i, traj in enumerate(trajs):
            np.savetxt(os.path.join(od, f"repro_{i}.csv"), np.array(traj), delimiter=",", header="t,x0,x1,v0,v1", comments="", fmt="%.17g")
        print(f"sklearn+gmr {name}: K={k} fit {fit_ms:.2f} ms", file=sys.stderr)
    return 0


def main():
    cmd = sys.argv[1]
    if cmd == "gmr":
        return check_gmr(sys.argv[2], sys.argv[3], float(sys.argv[4]))
    if cmd == "dtw":
        return check_dtw(sys.argv[2], sys.argv[3], float(sys.argv[4]))
    if cmd == "dmp":
        return check_dmp(sys.argv[2], sys.argv[3])
    if cmd == "lasa-sklearn":
        return lasa_sklearn(sys.argv[2], sys.argv[3], sys.argv[4], int(sys.argv[5]))
    print(__doc__, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
