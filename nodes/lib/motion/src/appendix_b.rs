//! The experimental comparison of App. B.2 between DHB (velocity-based, Sec. 3.2.2), EFS and DS
//! (Table B.1): reconstruction error of the synthetic twist of Fig. B.1 (Fig. B.2) and the
//! residual signal-to-noise ratio of the invariants of noisy twists (Fig. B.3).
//! `cowork bench invariants` prints both tables.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::dhb::Dhb;
use crate::error::Result;
use crate::invariants::{efs_reconstruct, efs_signal, residual_snr_db};
use crate::screw::{ds_invariants, ds_reconstruct};

/// The synthetic twist of Fig. B.1 sampled every `dt` s over `t ∈ [0, 4]` s:
/// `v = (0.01 eᵗ, 5 + 1.5 sin t, cos t)` m/s, `ω = (0.5 sin t, cos t, 0.1 t)` rad/s.
pub fn fig_b1_twist(dt: f64) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
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

/// RMSE of the vector difference over the common length (`a` may be shorter: DHB reconstructs
/// `N − 2` of `N` samples).
pub fn rmse(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    let n = a.len().min(b.len());
    (a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm_squared())
        .sum::<f64>()
        / n.max(1) as f64)
        .sqrt()
}

/// Reconstruction RMSE `[linear (m/s), angular (rad/s)]` of each representation at one `Δt`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReconstructionRow {
    /// Sampling time (s).
    pub dt: f64,
    /// DHB (velocity-based).
    pub dhb: [f64; 2],
    /// EFS.
    pub efs: [f64; 2],
    /// DS.
    pub ds: [f64; 2],
}

/// Fig. B.2: twists of Fig. B.1 at `dt` → invariants → twists, for DHB, EFS and DS.
pub fn reconstruction_errors(dt: f64) -> Result<ReconstructionRow> {
    let (v, w) = fig_b1_twist(dt);
    let dhb = Dhb::from_twists(&v, &w)?;
    let (rv, rw) = dhb.reconstruct_vectors();
    let ev = efs_reconstruct(&efs_signal(&v, dt)?, dt);
    let ew = efs_reconstruct(&efs_signal(&w, dt)?, dt);
    let (dv, dw) = ds_reconstruct(&ds_invariants(&v, &w, dt)?, dt);
    Ok(ReconstructionRow {
        dt,
        dhb: [rmse(&rv, &v), rmse(&rw, &w)],
        efs: [rmse(&ev, &v), rmse(&ew, &w)],
        ds: [rmse(&dv, &v), rmse(&dw, &w)],
    })
}

/// Residual SNR (dB) of each representation at one input SNR: mean and standard deviation over
/// the trials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseRow {
    /// SNR of the noisy twists (dB).
    pub snr_db: f64,
    /// DHB `(mean, sd)`.
    pub dhb: (f64, f64),
    /// EFS `(mean, sd)`.
    pub efs: (f64, f64),
    /// DS `(mean, sd)`.
    pub ds: (f64, f64),
}

/// All invariant values of the three representations of one twist, flattened.
fn invariant_values(v: &[Vector3<f64>], w: &[Vector3<f64>], dt: f64) -> Result<[Vec<f64>; 3]> {
    let dhb: Vec<f64> = Dhb::from_twists(v, w)?
        .rows()
        .iter()
        .flatten()
        .copied()
        .collect();
    let mut efs: Vec<f64> = efs_signal(v, dt)?.rows.iter().flatten().copied().collect();
    efs.extend(efs_signal(w, dt)?.rows.iter().flatten().copied());
    let ds: Vec<f64> = ds_invariants(v, w, dt)?
        .rows
        .iter()
        .flatten()
        .copied()
        .collect();
    Ok([dhb, efs, ds])
}

fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    // Box–Muller.
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Adds white Gaussian noise to each component of `s` at `snr_db` (component power over noise
/// power).
pub fn add_noise(s: &[Vector3<f64>], snr_db: f64, rng: &mut ChaCha8Rng) -> Vec<Vector3<f64>> {
    let sd: Vec<f64> = (0..3)
        .map(|k| {
            let p = s.iter().map(|x| x[k] * x[k]).sum::<f64>() / s.len().max(1) as f64;
            (p / 10f64.powf(snr_db / 10.0)).sqrt()
        })
        .collect();
    s.iter()
        .map(|x| {
            Vector3::new(
                x[0] + sd[0] * gaussian(rng),
                x[1] + sd[1] * gaussian(rng),
                x[2] + sd[2] * gaussian(rng),
            )
        })
        .collect()
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    (
        m,
        (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt(),
    )
}

/// Fig. B.3: Gaussian noise at each SNR (dB) on the twist of Fig. B.1 sampled at `dt`, `trials`
/// times; the residual SNR of the invariants against the noiseless ones.
pub fn noise_sensitivity(
    dt: f64,
    snrs_db: &[f64],
    trials: usize,
    seed: u64,
) -> Result<Vec<NoiseRow>> {
    let (v, w) = fig_b1_twist(dt);
    let clean = invariant_values(&v, &w, dt)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::with_capacity(snrs_db.len());
    for &snr in snrs_db {
        let mut res: [Vec<f64>; 3] = Default::default();
        for _ in 0..trials {
            let nv = add_noise(&v, snr, &mut rng);
            let nw = add_noise(&w, snr, &mut rng);
            let noisy = invariant_values(&nv, &nw, dt)?;
            for k in 0..3 {
                res[k].push(residual_snr_db(&clean[k], &noisy[k]));
            }
        }
        out.push(NoiseRow {
            snr_db: snr,
            dhb: mean_sd(&res[0]),
            efs: mean_sd(&res[1]),
            ds: mean_sd(&res[2]),
        });
    }
    Ok(out)
}

/// Both tables as text.
pub fn format_tables(recon: &[ReconstructionRow], noise: &[NoiseRow]) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Reconstruction RMSE of the twist of Fig. B.1 (Fig. B.2): linear m/s | angular rad/s"
    );
    let _ = writeln!(
        s,
        "{:>7} | {:>9} {:>9} | {:>9} {:>9} | {:>9} {:>9}",
        "dt s", "DHB lin", "DHB ang", "EFS lin", "EFS ang", "DS lin", "DS ang"
    );
    for r in recon {
        let _ = writeln!(
            s,
            "{:>7} | {:>9.2e} {:>9.2e} | {:>9.2e} {:>9.2e} | {:>9.2e} {:>9.2e}",
            r.dt, r.dhb[0], r.dhb[1], r.efs[0], r.efs[1], r.ds[0], r.ds[1]
        );
    }
    if !noise.is_empty() {
        let _ = writeln!(
            s,
            "\nResidual SNR of the invariants of noisy twists (Fig. B.3), dB, mean ± sd"
        );
        let _ = writeln!(
            s,
            "{:>8} | {:>15} | {:>15} | {:>15}",
            "snr dB", "DHB", "EFS", "DS"
        );
        for r in noise {
            let f = |(m, sd): (f64, f64)| format!("{m:>6.1} ± {sd:<6.1}");
            let _ = writeln!(
                s,
                "{:>8} | {:>15} | {:>15} | {:>15}",
                r.snr_db,
                f(r.dhb),
                f(r.efs),
                f(r.ds)
            );
        }
    }
    s
}
