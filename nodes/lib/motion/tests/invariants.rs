//! DHB (Sec. 3.2.2) against EFS and DS (App. B): reconstruction error on the synthetic twist of
//! Fig. B.1, invariance to roto-translation and scale, and the noise sensitivity of Fig. B.3.
//! Run with `--nocapture` to see the figures.

use cowork_motion::appendix_b::{noise_sensitivity, reconstruction_errors};
use cowork_motion::dhb::{Dhb, Poses, scale_normalised};
use cowork_motion::invariants::{efs_reconstruct, efs_signal, residual_snr_db};
use cowork_motion::screw::{
    DsInvariants, ds_from_hybrid, ds_invariants, ds_reconstruct, ds_scale_normalised,
};
use nalgebra::{Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn twist(dt: f64) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    let n = (4.0 / dt).round() as usize + 1;
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            (
                Vector3::new(0.01 * t.exp(), 5.0 + 1.5 * t.sin(), t.cos()),
                Vector3::new(0.5 * t.sin(), t.cos(), 0.1 * t),
            )
        })
        .unzip()
}

fn rmse(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    (a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm_squared())
        .sum::<f64>()
        / a.len().min(b.len()) as f64)
        .sqrt()
}

#[test]
fn reconstruction_error_dhb_vs_efs_fig_b2() {
    println!("Δt      DHB lin    DHB ang    EFS lin    EFS ang");
    for dt in [0.1, 0.01, 0.001] {
        let (v, w) = twist(dt);
        let dhb = Dhb::from_twists(&v, &w).expect("dhb");
        let (rv, rw) = dhb.reconstruct_vectors();
        let (dl, da) = (rmse(&rv, &v), rmse(&rw, &w));
        let ev = efs_reconstruct(&efs_signal(&v, dt).expect("efs"), dt);
        let ew = efs_reconstruct(&efs_signal(&w, dt).expect("efs"), dt);
        let (el, ea) = (rmse(&ev, &v), rmse(&ew, &w));
        println!("{dt:<7} {dl:.2e}   {da:.2e}   {el:.2e}   {ea:.2e}");
        assert!(dl <= 1e-9 && da <= 1e-9, "DHB at {dt}: {dl} {da}");
        assert!(el > dl && ea > da, "EFS should be less accurate than DHB");
    }
}

#[test]
fn dhb_invariant_to_roto_translation_and_scale() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let n = 60;
    let p: Vec<_> = (0..n)
        .map(|i| {
            let t = i as f64 * 0.05;
            Vector3::new(t.cos(), (1.5 * t).sin(), 0.2 * t * t)
        })
        .collect();
    let r: Vec<_> = (0..n)
        .map(|i| {
            let t = i as f64 * 0.05;
            Rotation3::from_euler_angles(0.3 * t, (t).sin() * 0.5, 0.1 * t * t)
        })
        .collect();
    let base = Dhb::from_poses(&Poses {
        p: p.clone(),
        r: r.clone(),
    })
    .expect("dhb");
    for _ in 0..20 {
        let ra = Rotation3::from_euler_angles(
            rng.random_range(-3.0..3.0),
            rng.random_range(-1.5..1.5),
            rng.random_range(-3.0..3.0),
        );
        let ta = Vector3::new(
            rng.random_range(-5.0..5.0),
            rng.random_range(-5.0..5.0),
            rng.random_range(-5.0..5.0),
        );
        let s = rng.random_range(0.2..5.0);
        let p2: Vec<_> = p.iter().map(|x| ra * x * s + ta).collect();
        let r2: Vec<_> = r.iter().map(|x| ra * x).collect();
        let moved = Dhb::from_poses(&Poses {
            p: p2.clone(),
            r: r2,
        })
        .expect("dhb");
        let (a, b) = (
            scale_normalised(&base.rows()),
            scale_normalised(&moved.rows()),
        );
        for (x, y) in a.iter().zip(&b) {
            for k in 0..6 {
                assert!((x[k] - y[k]).abs() < 1e-9, "{x:?} vs {y:?}");
            }
        }
        // The scaled, roto-translated reconstruction of the original invariants gives the moved
        // poses (the start point is placed by the translation, the shape is scaled).
        let rec = base.reconstruct_poses(s, &ra, &(ta + ra * base.p0 * (s - 1.0)));
        for (x, y) in rec.p.iter().zip(&p2) {
            assert!((x - y).norm() < 1e-9, "{x:?} vs {y:?}");
        }
    }
}

#[test]
fn noise_sensitivity_fig_b3() {
    let dt = 0.01;
    let (v, w) = twist(dt);
    let flat = |rows: &[[f64; 3]]| {
        rows.iter()
            .flat_map(|r| r.iter().copied())
            .collect::<Vec<f64>>()
    };
    let dhb_clean = Dhb::from_twists(&v, &w).expect("dhb");
    let dhb_clean: Vec<f64> = dhb_clean
        .rows()
        .iter()
        .flat_map(|r| r.iter().copied())
        .collect();
    let efs_clean = [
        flat(&efs_signal(&v, dt).expect("e").rows),
        flat(&efs_signal(&w, dt).expect("e").rows),
    ]
    .concat();
    let power =
        |s: &[Vector3<f64>], k: usize| s.iter().map(|x| x[k] * x[k]).sum::<f64>() / s.len() as f64;
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    println!("snr dB   DHB residual snr (mean ± sd)   EFS residual snr (mean ± sd)");
    for snr in [100.0, 90.0, 80.0, 70.0, 60.0, 50.0] {
        let mut d = Vec::new();
        let mut e = Vec::new();
        for _ in 0..100 {
            let noisy = |s: &[Vector3<f64>], rng: &mut ChaCha8Rng| -> Vec<Vector3<f64>> {
                let sd: Vec<f64> = (0..3)
                    .map(|k| (power(s, k) / 10f64.powf(snr / 10.0)).sqrt())
                    .collect();
                s.iter()
                    .map(|x| {
                        let g = |rng: &mut ChaCha8Rng| {
                            // Box–Muller.
                            let (u1, u2): (f64, f64) =
                                (rng.random::<f64>().max(1e-300), rng.random());
                            (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
                        };
                        Vector3::new(
                            x[0] + sd[0] * g(rng),
                            x[1] + sd[1] * g(rng),
                            x[2] + sd[2] * g(rng),
                        )
                    })
                    .collect()
            };
            let (nv, nw) = (noisy(&v, &mut rng), noisy(&w, &mut rng));
            let dn: Vec<f64> = Dhb::from_twists(&nv, &nw)
                .expect("dhb")
                .rows()
                .iter()
                .flat_map(|r| r.iter().copied())
                .collect();
            let en = [
                flat(&efs_signal(&nv, dt).expect("e").rows),
                flat(&efs_signal(&nw, dt).expect("e").rows),
            ]
            .concat();
            d.push(residual_snr_db(&dhb_clean, &dn));
            e.push(residual_snr_db(&efs_clean, &en));
        }
        let ms = |x: &[f64]| {
            let m = x.iter().sum::<f64>() / x.len() as f64;
            (
                m,
                (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len() as f64).sqrt(),
            )
        };
        let ((dm, ds), (em, es)) = (ms(&d), ms(&e));
        println!("{snr:<8} {dm:>8.1} ± {ds:<8.1}               {em:>8.1} ± {es:<8.1}");
        assert!(
            dm > em,
            "DHB should be less sensitive to noise than EFS at {snr} dB"
        );
    }
}

#[test]
fn ds_reconstruction_error_fig_b2() {
    // Same figures as `cowork bench invariants`; DS is exact only in the limit Δt → 0 (second-order
    // finite differences: the error falls ~100× per decade of Δt), DHB is exact at every Δt.
    let rows: Vec<_> = [0.1, 0.01, 0.001]
        .iter()
        .map(|dt| reconstruction_errors(*dt).expect("recon"))
        .collect();
    for r in &rows {
        println!(
            "Δt {:<6} DHB {:.2e}/{:.2e}  EFS {:.2e}/{:.2e}  DS {:.2e}/{:.2e}",
            r.dt, r.dhb[0], r.dhb[1], r.efs[0], r.efs[1], r.ds[0], r.ds[1]
        );
        assert!(r.dhb[0] <= 1e-9 && r.dhb[1] <= 1e-9);
        assert!(r.ds[0] > r.dhb[0] && r.ds[1] > r.dhb[1]);
        // d_ω = e_ω (App. B.1.2): same angular reconstruction as EFS.
        assert!(
            (r.ds[1] - r.efs[1]).abs() <= 1e-6 * r.efs[1].max(1e-12),
            "{r:?}"
        );
    }
    for w in rows.windows(2) {
        assert!(w[1].ds[0] < 0.05 * w[0].ds[0], "{w:?}");
        assert!(w[1].ds[1] < 0.05 * w[0].ds[1], "{w:?}");
    }
    assert!(rows[2].ds[0] < 1e-5, "{:?}", rows[2]);
}

/// A smooth spatial twist with a moving ISA.
fn screw_twist(dt: f64, n: usize) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            (
                Vector3::new(0.3 + t.sin(), 0.5 * (2.0 * t).cos(), 0.2 * t),
                Vector3::new(1.0 + 0.3 * t, 0.4 * t.sin(), 0.5 * (1.5 * t).cos()),
            )
        })
        .unzip()
}

fn assert_rows_close(a: &[[f64; 6]], b: &[[f64; 6]], tol: f64) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(b) {
        for k in 0..6 {
            assert!(
                (x[k] - y[k]).abs() <= tol * (1.0 + x[k].abs()),
                "col {k}: {x:?} vs {y:?}"
            );
        }
    }
}

#[test]
fn ds_invariant_to_roto_translation_and_scale() {
    let dt = 0.01;
    let (v, w) = screw_twist(dt, 300);
    let base = ds_invariants(&v, &w, dt).expect("ds");
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..20 {
        let ra = Rotation3::from_euler_angles(
            rng.random_range(-3.0..3.0),
            rng.random_range(-1.5..1.5),
            rng.random_range(-3.0..3.0),
        );
        let ta = Vector3::new(
            rng.random_range(-5.0..5.0),
            rng.random_range(-5.0..5.0),
            rng.random_range(-5.0..5.0),
        );
        let s = rng.random_range(0.2..5.0);
        // World change x ↦ s R x + t: ω' = R ω, v' (velocity of the body point at the new
        // origin) = s R v + t × R ω.
        let w2: Vec<_> = w.iter().map(|x| ra * x).collect();
        let v2: Vec<_> = v
            .iter()
            .zip(&w2)
            .map(|(x, om)| ra * x * s + ta.cross(om))
            .collect();
        let moved = ds_invariants(&v2, &w2, dt).expect("ds");
        assert_rows_close(
            &ds_scale_normalised(&base.rows),
            &ds_scale_normalised(&moved.rows),
            1e-9,
        );
        // Linear invariants scale with s, angular ones do not.
        let expect: DsInvariants = base.transformed(&ra, &ta, s);
        assert_rows_close(&expect.rows, &moved.rows, 1e-9);
        assert!((expect.frame0 - moved.frame0).norm() < 1e-9);
        assert!((expect.origin0 - moved.origin0).norm() < 1e-9 * (1.0 + ta.norm()));
        // Reconstructing the original invariants at the moved frame gives the moved twists as
        // well as reconstructing the moved invariants does (same integration error).
        let (rv, rw) = ds_reconstruct(&expect, dt);
        let (mv, mw) = ds_reconstruct(&moved, dt);
        for i in 0..v.len() {
            assert!((rv[i] - mv[i]).norm() < 1e-8 * (1.0 + mv[i].norm()));
            assert!((rw[i] - mw[i]).norm() < 1e-9);
        }
    }
}

#[test]
fn ds_invariant_to_the_reference_point_dhb_is_not() {
    // The same rigid motion described by two body points (Table B.2, "reference point").
    let dt = 0.01;
    let n = 200;
    let (p, r): (Vec<Vector3<f64>>, Vec<Rotation3<f64>>) = (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            (
                Vector3::new(t.cos(), (1.5 * t).sin(), 0.2 * t * t),
                Rotation3::from_euler_angles(0.3 * t, t.sin() * 0.5, 0.1 * t * t),
            )
        })
        .unzip();
    // Analytic velocities of the first point by central differences of the path (only the
    // consistency of the two descriptions matters here).
    let (w, vp): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = (1..n - 1)
        .map(|i| {
            let w = (r[i + 1] * r[i - 1].inverse()).scaled_axis() / (2.0 * dt);
            (w, (p[i + 1] - p[i - 1]) / (2.0 * dt))
        })
        .unzip();
    let c = Vector3::new(0.1, -0.3, 0.25); // body-frame offset of the second point (m)
    let p1: Vec<_> = p[1..n - 1].to_vec();
    let p2: Vec<_> = (1..n - 1).map(|i| p[i] + r[i] * c).collect();
    let v2: Vec<_> = (0..n - 2)
        .map(|i| vp[i] + w[i].cross(&(p2[i] - p1[i])))
        .collect();
    let a = ds_from_hybrid(&vp, &w, &p1, dt).expect("ds");
    let b = ds_from_hybrid(&v2, &w, &p2, dt).expect("ds");
    assert_rows_close(&a.rows, &b.rows, 1e-9);
    let da = Dhb::from_twists(&vp, &w).expect("dhb").rows();
    let db = Dhb::from_twists(&v2, &w).expect("dhb").rows();
    let diff = da
        .iter()
        .zip(&db)
        .map(|(x, y)| (x[0] - y[0]).abs())
        .fold(0.0, f64::max);
    assert!(
        diff > 1e-3,
        "DHB should depend on the reference point ({diff})"
    );
}

#[test]
fn noise_sensitivity_with_ds_fig_b3() {
    let rows = noise_sensitivity(0.01, &[100.0, 80.0, 60.0], 30, 3).expect("noise");
    for r in &rows {
        println!(
            "{} dB: DHB {:.1}±{:.1}  EFS {:.1}±{:.1}  DS {:.1}±{:.1}",
            r.snr_db, r.dhb.0, r.dhb.1, r.efs.0, r.efs.1, r.ds.0, r.ds.1
        );
        assert!(r.dhb.0 > r.efs.0 && r.dhb.0 > r.ds.0, "{r:?}");
    }
    // The residual SNR falls with the input SNR for all three.
    for w in rows.windows(2) {
        assert!(w[1].dhb.0 < w[0].dhb.0 && w[1].ds.0 < w[0].ds.0 && w[1].efs.0 < w[0].efs.0);
    }
}
