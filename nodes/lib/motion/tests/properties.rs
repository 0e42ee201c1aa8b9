//! Property tests of the issue: Algorithm 1 makes µ₁(A + U) < 0 for random A; C-GMR converges
//! from random starts for random (stable and unstable) mixtures.

use cowork_motion::{
    Cgmr, CgmrConfig, DsPolicy, Gmm, GmrDs, RolloutConfig, mu1, rollout, stabilizing_gains,
};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn algorithm1_gives_negative_mu1(n in 1usize..7, vals in prop::collection::vec(-10.0f64..10.0, 49), p in 1.01f64..5.0) {
        let a: Vec<f64> = vals[..n * n].to_vec();
        let u = stabilizing_gains(&a, n, p, 1e-3);
        let mut c = a.clone();
        for d in 0..n {
            c[d * n + d] += u[d];
        }
        prop_assert!(mu1(&c, n) < 0.0, "A = {a:?}, U = {u:?}, µ1 = {}", mu1(&c, n));
    }
}

/// A random 2-D GMR DS over `[x, ẋ]` with arbitrary (possibly destabilising) joint covariances.
fn random_gmm(k: usize, params: &[f64]) -> Gmm {
    let mut means = Vec::new();
    let mut covs = Vec::new();
    for c in 0..k {
        let q = &params[c * 24..(c + 1) * 24];
        means.push(vec![q[0] * 5.0, q[1] * 5.0, q[2] * 3.0, q[3] * 3.0]);
        // Σ = L Lᵀ + 0.1 I with a random lower-triangular L.
        let l = [
            [q[4], 0.0, 0.0, 0.0],
            [q[5], q[6], 0.0, 0.0],
            [q[7], q[8], q[9], 0.0],
            [q[10], q[11], q[12], q[13]],
        ];
        let mut s = vec![0.0; 16];
        for i in 0..4 {
            for j in 0..4 {
                s[i * 4 + j] =
                    (0..4).map(|m| l[i][m] * l[j][m]).sum::<f64>() + if i == j { 0.1 } else { 0.0 };
            }
        }
        covs.push(s);
    }
    Gmm {
        dim: 4,
        priors: vec![1.0 / k as f64; k],
        means,
        covariances: covs,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    #[test]
    fn cgmr_converges_from_random_starts(k in 1usize..5, params in prop::collection::vec(-2.0f64..2.0, 96),
                                          sx in -20.0f64..20.0, sy in -20.0f64..20.0) {
        let gmm = random_gmm(k, &params);
        let ds = GmrDs::new(gmm, vec![0.0, 0.0]).expect("gmr");
        // The demonstration area comes from a short synthetic path; t_max = 1.5 × 2 s.
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 0.04).collect();
        let pos = t.iter().flat_map(|t| [4.0 * (1.0 - t / 1.96), 2.0 * (1.0 - t / 1.96)]).collect();
        let demo = cowork_motion::Demonstration::new(2, t, pos, None).expect("demo");
        let m = Cgmr::from_gmr_ds(ds, &[demo], &CgmrConfig::default()).expect("cgmr");
        let mut r = m.runner(None).expect("runner");
        let cfg = RolloutConfig { dt: 0.002, max_steps: 20_000, tol: 1e-2 };
        let tr = rollout(&mut r, &[sx, sy], &cfg).expect("rollout");
        prop_assert!(tr.reached, "ended at {:?} (ω = {})", tr.position(tr.len() - 1), r.omega());
        prop_assert_eq!(r.goal(), &[0.0, 0.0][..]);
    }
}
