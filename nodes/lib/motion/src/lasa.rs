//! The LASA handwriting benchmark of Sec. 3.1.4 on exported CSV demonstrations
//! (`DIR/<motion>/demo_<i>.csv`, see `tests/crosscheck/lasa_export.py`).
//!
//! Per motion: GMR (EM + BIC) and C-GMR trained on all demonstrations; each demonstration is
//! reproduced from its start at `dt`; the reported figures are the median DTW-aligned area between
//! demonstration and reproduction, the velocity RMSE `V_e` over all training samples, the training
//! time (fastest of [`LasaOptions::timing_repeats`] runs), and the fraction of random starts (uniform in the demonstrations' bounding box enlarged by
//! half its size on each side) that reach the target within `max_time_factor` × the longest
//! demonstration.

use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::cgmr::{Cgmr, CgmrConfig, Components, fit_gmr_ds};
use crate::csv_io::read_demonstration;
use crate::demo::Demonstration;
use crate::ds::{Autonomous, DsPolicy, FirstOrderDs, RolloutConfig, rollout};
use crate::dtw::area_between;
use crate::error::{MotionError, Result};
use crate::gmm::EmConfig;
use crate::model::Model;

/// Benchmark settings.
#[derive(Debug, Clone)]
pub struct LasaOptions {
    /// Keep every n-th sample for training (1000-sample LASA demos → 50 with 20; 350 points for 7
    /// demonstrations, near the thesis's T = 300).
    pub subsample: usize,
    /// BIC range `1..=k_max`.
    pub k_max: usize,
    /// Reproduction step (s); 2 ms in the thesis.
    pub dt: f64,
    /// Random starts per motion.
    pub random_starts: usize,
    /// Target tolerance (data unit: mm for LASA).
    pub tol: f64,
    /// Simulated time limit as a multiple of the longest demonstration.
    pub max_time_factor: f64,
    /// Seed of the random starts and EM.
    pub seed: u64,
    /// C-GMR settings.
    pub cgmr: CgmrConfig,
    /// EM settings (scikit-learn's defaults: tol 1e-3 on the mean log-likelihood, 100 iterations).
    pub em: EmConfig,
    /// Training is timed as the fastest of this many identical runs (robust to other load on
    /// the machine; the runs are deterministic, so the model is the same).
    pub timing_repeats: usize,
}

impl Default for LasaOptions {
    fn default() -> Self {
        Self {
            subsample: 20,
            k_max: 10,
            dt: 0.002,
            random_starts: 100,
            tol: 1.0,
            max_time_factor: 10.0,
            seed: 0,
            cgmr: CgmrConfig::default(),
            em: EmConfig {
                tol: 1e-3,
                max_iter: 100,
                ..EmConfig::default()
            },
            timing_repeats: 3,
        }
    }
}

/// Accuracy figures of one model on one motion.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Accuracy {
    /// Median over demonstrations of the DTW-aligned area (data unit²).
    pub area: f64,
    /// Velocity RMSE over all training samples (data unit/s).
    pub v_e: f64,
    /// Fraction of reproductions from the demonstration starts that reached the target.
    pub demo_reached: f64,
    /// Fraction of random starts that reached the target (NaN when not measured).
    pub random_reached: f64,
}

/// One row of the LASA table.
#[derive(Debug, Clone)]
pub struct MotionRow {
    /// Motion name.
    pub name: String,
    /// Components chosen by BIC.
    pub k: usize,
    /// EM + BIC time (ms).
    pub train_ms: f64,
    /// EM time at the chosen K only (ms), comparable with a fixed-K fit elsewhere.
    pub train_fixed_k_ms: f64,
    /// C-GMR extras: gains, δ_k, regions (ms).
    pub cgmr_extra_ms: f64,
    /// GMR figures.
    pub gmr: Accuracy,
    /// C-GMR figures.
    pub cgmr: Accuracy,
}

/// Motion folders under `root` (sorted by name), each with `demo_*.csv` files.
pub fn list_motions(root: &Path) -> Result<Vec<(String, PathBuf)>> {
    let rd = std::fs::read_dir(root).map_err(|source| MotionError::Io {
        file: root.to_path_buf(),
        source,
    })?;
    let mut out: Vec<(String, PathBuf)> = rd
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
        .collect();
    out.sort();
    Ok(out)
}

/// The demonstrations `demo_*.csv` of one motion folder, in name order.
pub fn load_motion(dir: &Path) -> Result<Vec<Demonstration>> {
    let rd = std::fs::read_dir(dir).map_err(|source| MotionError::Io {
        file: dir.to_path_buf(),
        source,
    })?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("demo_"))
                && p.extension().is_some_and(|e| e == "csv")
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(MotionError::TooFewSamples {
            what: format!("demo_*.csv files in {}", dir.display()),
            needed: 1,
            got: 0,
        });
    }
    files.iter().map(|f| read_demonstration(f)).collect()
}

/// A velocity field as a closure: writes `f(x)` into the second argument.
pub type Field<'a> = dyn FnMut(&[f64], &mut [f64]) -> Result<()> + 'a;

/// Makes a fresh policy for each rollout.
type PolicyFactory<'a, 'm> = dyn FnMut() -> Result<Box<dyn DsPolicy + 'm>> + 'a;

/// Velocity RMSE `V_e` of a velocity field over all demonstration samples.
pub fn velocity_rmse(demos: &[Demonstration], f: &mut Field<'_>) -> Result<f64> {
    let mut se = 0.0;
    let mut count = 0usize;
    for d in demos {
        let mut v = vec![0.0; d.dim];
        for i in 0..d.len() {
            f(d.position(i), &mut v)?;
            se += v
                .iter()
                .zip(d.velocity(i))
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>();
            count += 1;
        }
    }
    Ok((se / count as f64).sqrt())
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Median of a column of values (NaN-free).
pub fn median_of(mut v: Vec<f64>) -> f64 {
    median(&mut v)
}

fn random_starts(demos: &[Demonstration], n: usize, seed: u64) -> Vec<Vec<f64>> {
    let dim = demos[0].dim;
    let mut lo = vec![f64::INFINITY; dim];
    let mut hi = vec![f64::NEG_INFINITY; dim];
    for d in demos {
        for i in 0..d.len() {
            for j in 0..dim {
                lo[j] = lo[j].min(d.position(i)[j]);
                hi[j] = hi[j].max(d.position(i)[j]);
            }
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            (0..dim)
                .map(|j| {
                    let w = hi[j] - lo[j];
                    lo[j] - 0.5 * w + rng.random::<f64>() * 2.0 * w
                })
                .collect()
        })
        .collect()
}

/// Accuracy of reproductions given as trajectories (one per demonstration).
pub fn reproduction_area(demos: &[Demonstration], repro: &[Vec<f64>]) -> Result<f64> {
    let mut areas = Vec::with_capacity(demos.len());
    for (d, r) in demos.iter().zip(repro) {
        areas.push(area_between(&d.pos, r, d.dim)?);
    }
    Ok(median(&mut areas))
}

fn evaluate_policy<'m>(
    demos: &[Demonstration],
    make: &mut PolicyFactory<'_, 'm>,
    field: &mut Field<'_>,
    opts: &LasaOptions,
    starts: &[Vec<f64>],
) -> Result<Accuracy> {
    let longest = demos
        .iter()
        .map(Demonstration::duration)
        .fold(0.0, f64::max);
    let cfg = RolloutConfig {
        dt: opts.dt,
        max_steps: (opts.max_time_factor * longest / opts.dt).ceil() as usize,
        tol: opts.tol,
    };
    let mut repro = Vec::new();
    let mut reached = 0usize;
    for d in demos {
        let tr = rollout(make()?.as_mut(), d.position(0), &cfg)?;
        reached += usize::from(tr.reached);
        repro.push(tr.pos);
    }
    let area = reproduction_area(demos, &repro)?;
    let v_e = velocity_rmse(demos, field)?;
    let mut ok = 0usize;
    for s in starts {
        let tr = rollout(make()?.as_mut(), s, &cfg)?;
        ok += usize::from(tr.reached);
    }
    let random_reached = if starts.is_empty() {
        f64::NAN
    } else {
        ok as f64 / starts.len() as f64
    };
    Ok(Accuracy {
        area,
        v_e,
        demo_reached: reached as f64 / demos.len() as f64,
        random_reached,
    })
}

/// Trains and evaluates GMR and C-GMR on one motion.
pub fn evaluate_motion(
    name: &str,
    demos: &[Demonstration],
    opts: &LasaOptions,
) -> Result<MotionRow> {
    let em = EmConfig {
        seed: opts.seed,
        ..opts.em.clone()
    };
    let mut train_ms = f64::INFINITY;
    let mut fitted = None;
    for _ in 0..opts.timing_repeats.max(1) {
        let t0 = Instant::now();
        let (ds, _) = fit_gmr_ds(demos, Components::Bic(opts.k_max), &em, opts.subsample)?;
        train_ms = train_ms.min(t0.elapsed().as_secs_f64() * 1e3);
        fitted = Some(ds);
    }
    let ds = fitted.ok_or_else(|| crate::error::invalid("timing_repeats", "no fit"))?;
    let k = ds.gmr.n_components();
    let mut train_fixed_k_ms = f64::INFINITY;
    for _ in 0..opts.timing_repeats.max(1) {
        let t0 = Instant::now();
        let _ = fit_gmr_ds(demos, Components::Fixed(k), &em, opts.subsample)?;
        train_fixed_k_ms = train_fixed_k_ms.min(t0.elapsed().as_secs_f64() * 1e3);
    }
    let training: Vec<Demonstration> = demos.iter().map(|d| d.subsampled(opts.subsample)).collect();
    let t0 = Instant::now();
    let cgmr = Cgmr::from_gmr_ds(ds.clone(), &training, &opts.cgmr)?;
    let cgmr_extra_ms = t0.elapsed().as_secs_f64() * 1e3;
    let starts = random_starts(demos, opts.random_starts, opts.seed ^ 0x5eed);
    let goal = ds.target.clone();
    let gmr = evaluate_policy(
        demos,
        &mut || {
            Ok(Box::new(Autonomous {
                ds: &ds,
                goal: goal.clone(),
            }) as Box<dyn DsPolicy + '_>)
        },
        &mut |x, v| ds.velocity(x, v),
        opts,
        &starts,
    )?;
    let model = Model::Cgmr(cgmr.clone());
    let c = evaluate_policy(
        demos,
        &mut || Ok(Box::new(cgmr.runner(None)?) as Box<dyn DsPolicy + '_>),
        &mut |x, v| {
            let out = model.eval(x)?;
            v.copy_from_slice(&out);
            Ok(())
        },
        opts,
        &starts,
    )?;
    Ok(MotionRow {
        name: name.to_string(),
        k,
        train_ms,
        train_fixed_k_ms,
        cgmr_extra_ms,
        gmr,
        cgmr: c,
    })
}

/// Figures of an external GMM/GMR implementation on one motion (e.g. scikit-learn + `gmr`),
/// computed here from its reproductions `repro_<i>.csv` and predicted training velocities
/// `vel_pred.csv` (`v0,…`, all demonstration samples in order).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ExternalRow {
    /// Components used.
    pub k: usize,
    /// Its training time (ms) as it reported it.
    pub fit_ms: f64,
    /// Median area.
    pub area: f64,
    /// Velocity RMSE.
    pub v_e: f64,
}

/// Reads an external result folder for one motion (`fit.csv` with header `k,fit_ms`).
pub fn evaluate_external(demos: &[Demonstration], dir: &Path) -> Result<ExternalRow> {
    let fit = crate::csv_io::read_table(&dir.join("fit.csv"))?;
    let row = fit.rows.first().ok_or_else(|| MotionError::Csv {
        file: dir.join("fit.csv"),
        row: 2,
        column: "k".into(),
        reason: "no data row".into(),
    })?;
    let mut repro = Vec::new();
    for i in 0..demos.len() {
        repro.push(read_demonstration(&dir.join(format!("repro_{i}.csv")))?.pos);
    }
    let area = reproduction_area(demos, &repro)?;
    let (n, v) = crate::csv_io::read_points_named(&dir.join("vel_pred.csv"), "v")?;
    let total: usize = demos.iter().map(Demonstration::len).sum();
    crate::error::check_dim("vel_pred.csv rows", total * demos[0].dim, v.len())?;
    crate::error::check_dim("vel_pred.csv columns", demos[0].dim, n)?;
    let mut idx = 0;
    let v_e = velocity_rmse(demos, &mut |_, out| {
        out.copy_from_slice(&v[idx..idx + out.len()]);
        idx += out.len();
        Ok(())
    })?;
    Ok(ExternalRow {
        k: row[0] as usize,
        fit_ms: row[1],
        area,
        v_e,
    })
}

fn pct(v: f64) -> String {
    if v.is_nan() {
        "-".into()
    } else {
        format!("{:.0}%", 100.0 * v)
    }
}

/// The LASA table: one line per motion plus the medians; `external` adds the scikit-learn + gmr
/// columns and the training-time ratio.
pub fn format_table(rows: &[MotionRow], external: Option<&[ExternalRow]>) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = write!(
        s,
        "{:<18} {:>2} {:>8} {:>8} {:>7} | {:>9} {:>7} {:>5} {:>5} | {:>9} {:>7} {:>5} {:>5}",
        "motion",
        "K",
        "EM+BIC",
        "EM@K",
        "C-GMR+",
        "GMR area",
        "GMR Ve",
        "demo",
        "rand",
        "CGMR area",
        "CGMR Ve",
        "demo",
        "rand"
    );
    if external.is_some() {
        let _ = write!(
            s,
            " | {:>8} {:>9} {:>7} {:>7}",
            "skl fit", "skl area", "skl Ve", "t ratio"
        );
    }
    s.push('\n');
    let _ = writeln!(
        s,
        "{:<18} {:>2} {:>8} {:>8} {:>7} |",
        "", "", "ms", "ms", "ms"
    );
    for (i, r) in rows.iter().enumerate() {
        let _ = write!(
            s,
            "{:<18} {:>2} {:>8.2} {:>8.2} {:>7.3} | {:>9.1} {:>7.2} {:>5} {:>5} | {:>9.1} {:>7.2} {:>5} {:>5}",
            r.name,
            r.k,
            r.train_ms,
            r.train_fixed_k_ms,
            r.cgmr_extra_ms,
            r.gmr.area,
            r.gmr.v_e,
            pct(r.gmr.demo_reached),
            pct(r.gmr.random_reached),
            r.cgmr.area,
            r.cgmr.v_e,
            pct(r.cgmr.demo_reached),
            pct(r.cgmr.random_reached)
        );
        if let Some(e) = external.and_then(|e| e.get(i)) {
            let _ = write!(
                s,
                " | {:>8.2} {:>9.1} {:>7.2} {:>7.1}",
                e.fit_ms,
                e.area,
                e.v_e,
                e.fit_ms / r.train_fixed_k_ms
            );
        }
        s.push('\n');
    }
    let med = |f: &dyn Fn(&MotionRow) -> f64| median_of(rows.iter().map(f).collect());
    let _ = write!(
        s,
        "{:<18} {:>2} {:>8.2} {:>8.2} {:>7.3} | {:>9.1} {:>7.2} {:>5} {:>5} | {:>9.1} {:>7.2} {:>5} {:>5}",
        "MEDIAN",
        "",
        med(&|r| r.train_ms),
        med(&|r| r.train_fixed_k_ms),
        med(&|r| r.cgmr_extra_ms),
        med(&|r| r.gmr.area),
        med(&|r| r.gmr.v_e),
        pct(med(&|r| r.gmr.demo_reached)),
        pct(med(&|r| r.gmr.random_reached)),
        med(&|r| r.cgmr.area),
        med(&|r| r.cgmr.v_e),
        pct(med(&|r| r.cgmr.demo_reached)),
        pct(med(&|r| r.cgmr.random_reached))
    );
    if let Some(e) = external {
        let m = |f: &dyn Fn(&ExternalRow) -> f64| median_of(e.iter().map(f).collect());
        let ratio = median_of(
            e.iter()
                .zip(rows)
                .map(|(e, r)| e.fit_ms / r.train_fixed_k_ms)
                .collect(),
        );
        let _ = write!(
            s,
            " | {:>8.2} {:>9.1} {:>7.2} {:>7.1}",
            m(&|e| e.fit_ms),
            m(&|e| e.area),
            m(&|e| e.v_e),
            ratio
        );
    }
    s.push('\n');
    let mean_rand =
        rows.iter().map(|r| r.cgmr.random_reached).sum::<f64>() / rows.len().max(1) as f64;
    let mean_rand_gmr =
        rows.iter().map(|r| r.gmr.random_reached).sum::<f64>() / rows.len().max(1) as f64;
    let _ = writeln!(
        s,
        "random starts reaching the target, mean over motions: GMR {}, C-GMR {}",
        pct(mean_rand_gmr),
        pct(mean_rand)
    );
    s
}
