//! Gaussian mixture models learned by expectation–maximisation, with BIC model selection
//! (thesis App. A.3.2, Sec. 3.1.4).
//!
//! Data are row-major flat slices: `n` samples of dimension `d` laid out as `[x₀₀ … x₀_d−1, x₁₀ …]`.
//! Covariances are full, regularised by `reg_covar · I` after every M-step (as scikit-learn does).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::error::{MotionError, Result, check_finite, invalid};
use crate::linalg::{LN_2PI, chol_logdet, cholesky, logsumexp, solve_lower};

/// A Gaussian mixture `p(z) = Σ_k π_k N(z | μ_k, Σ_k)` in `dim` dimensions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Gmm {
    /// Dimension of the modelled variable.
    pub dim: usize,
    /// Priors `π_k`, summing to one.
    pub priors: Vec<f64>,
    /// Means `μ_k`, each of length `dim`.
    pub means: Vec<Vec<f64>>,
    /// Covariances `Σ_k`, each row-major `dim × dim`.
    pub covariances: Vec<Vec<f64>>,
}

/// Settings of the EM algorithm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EmConfig {
    /// Maximum number of EM iterations.
    pub max_iter: usize,
    /// Stop when the mean per-sample log-likelihood improves by less than this.
    pub tol: f64,
    /// Added to the diagonal of every covariance (same role as scikit-learn's `reg_covar`).
    pub reg_covar: f64,
    /// Seed of the k-means++ initialisation.
    pub seed: u64,
    /// Number of Lloyd iterations after the k-means++ seeding.
    pub kmeans_iter: usize,
}

impl Default for EmConfig {
    fn default() -> Self {
        Self {
            max_iter: 200,
            tol: 1e-6,
            reg_covar: 1e-6,
            seed: 0,
            kmeans_iter: 10,
        }
    }
}

impl EmConfig {
    /// Rejects NaN and out-of-range settings.
    pub fn validate(&self) -> Result<()> {
        if self.max_iter == 0 {
            return Err(invalid("max_iter", "must be at least 1"));
        }
        if !(self.tol >= 0.0) || !self.tol.is_finite() {
            return Err(invalid(
                "tol",
                format!("must be finite and >= 0, got {}", self.tol),
            ));
        }
        if !(self.reg_covar >= 0.0) || !self.reg_covar.is_finite() {
            return Err(invalid(
                "reg_covar",
                format!("must be finite and >= 0, got {}", self.reg_covar),
            ));
        }
        Ok(())
    }
}

/// Result of one EM run.
#[derive(Debug, Clone)]
pub struct GmmFit {
    /// The learned mixture.
    pub gmm: Gmm,
    /// Total log-likelihood of the data under `gmm`.
    pub log_likelihood: f64,
    /// EM iterations run.
    pub iterations: usize,
    /// Whether the tolerance was reached before `max_iter`.
    pub converged: bool,
    /// Bayesian information criterion `−2 ln L + p ln n`.
    pub bic: f64,
}

/// Result of BIC model selection over `K = 1..=k_max`.
#[derive(Debug, Clone)]
pub struct BicSelection {
    /// The fit with the lowest BIC.
    pub best: GmmFit,
    /// `(K, BIC)` for every K tried.
    pub scores: Vec<(usize, f64)>,
}

/// Precomputed Cholesky factors and normalisers of a mixture, for fast density evaluation.
#[derive(Debug, Clone)]
pub(crate) struct Factors {
    pub(crate) chol: Vec<Vec<f64>>,
    /// `−½ ln|Σ_k| − d/2 ln 2π`.
    pub(crate) log_norm: Vec<f64>,
}

impl Gmm {
    /// Number of components.
    pub fn n_components(&self) -> usize {
        self.priors.len()
    }

    /// Number of free parameters (priors, means, full covariances).
    pub fn n_parameters(&self) -> usize {
        let k = self.n_components();
        let d = self.dim;
        (k - 1) + k * d + k * d * (d + 1) / 2
    }

    /// Checks shapes, finiteness, priors and positive-definiteness.
    pub fn validate(&self) -> Result<()> {
        let k = self.priors.len();
        if k == 0 {
            return Err(invalid("gmm", "has no components"));
        }
        if self.dim == 0 {
            return Err(invalid("gmm.dim", "must be at least 1"));
        }
        if self.means.len() != k || self.covariances.len() != k {
            return Err(MotionError::DimensionMismatch {
                what: "gmm: number of means/covariances vs priors".into(),
                expected: k,
                got: self.means.len().min(self.covariances.len()),
            });
        }
        check_finite("gmm.priors", &self.priors)?;
        if self.priors.iter().any(|p| *p < 0.0)
            || (self.priors.iter().sum::<f64>() - 1.0).abs() > 1e-6
        {
            return Err(invalid("gmm.priors", "must be non-negative and sum to 1"));
        }
        for c in 0..k {
            crate::error::check_dim(&format!("gmm.means[{c}]"), self.dim, self.means[c].len())?;
            crate::error::check_dim(
                &format!("gmm.covariances[{c}]"),
                self.dim * self.dim,
                self.covariances[c].len(),
            )?;
            check_finite(&format!("gmm.means[{c}]"), &self.means[c])?;
            check_finite(&format!("gmm.covariances[{c}]"), &self.covariances[c])?;
        }
        self.factors("gmm validation").map(|_| ())
    }

    pub(crate) fn factors(&self, context: &str) -> Result<Factors> {
        let d = self.dim;
        let mut chol = Vec::with_capacity(self.n_components());
        let mut log_norm = Vec::with_capacity(self.n_components());
        for (c, cov) in self.covariances.iter().enumerate() {
            let mut l = vec![0.0; d * d];
            if !cholesky(cov, d, &mut l) {
                return Err(MotionError::SingularCovariance {
                    component: c,
                    context: context.to_string(),
                });
            }
            log_norm.push(-0.5 * chol_logdet(&l, d) - 0.5 * d as f64 * LN_2PI);
            chol.push(l);
        }
        Ok(Factors { chol, log_norm })
    }

    /// `ln N(z | μ_k, Σ_k)` for every sample and component, row-major `n × K`.
    pub fn component_log_pdfs(&self, data: &[f64]) -> Result<Vec<f64>> {
        let f = self.factors("density evaluation")?;
        let d = self.dim;
        let n = data.len() / d;
        let k = self.n_components();
        let mut out = vec![0.0; n * k];
        let mut z = vec![0.0; d];
        for i in 0..n {
            let x = &data[i * d..(i + 1) * d];
            for c in 0..k {
                out[i * k + c] = log_pdf_with(&f, c, &self.means[c], x, &mut z);
            }
        }
        Ok(out)
    }

    /// Total log-likelihood of `data` (row-major, `dim` columns).
    pub fn log_likelihood(&self, data: &[f64]) -> Result<f64> {
        let k = self.n_components();
        let lp = self.component_log_pdfs(data)?;
        let mut row = vec![0.0; k];
        let mut ll = 0.0;
        for chunk in lp.chunks(k) {
            for c in 0..k {
                row[c] = self.priors[c].ln() + chunk[c];
            }
            ll += logsumexp(&row);
        }
        Ok(ll)
    }

    /// Fits a `k`-component mixture by EM from a k-means++ initialisation.
    pub fn fit(data: &[f64], dim: usize, k: usize, cfg: &EmConfig) -> Result<GmmFit> {
        check_data(data, dim, k)?;
        cfg.validate()?;
        let init = kmeans_init(data, dim, k, cfg)?;
        em(data, dim, init, cfg)
    }

    /// Runs EM starting from `init` (warm start, e.g. for incremental re-training).
    pub fn fit_from(data: &[f64], init: &Gmm, cfg: &EmConfig) -> Result<GmmFit> {
        check_data(data, init.dim, init.n_components())?;
        cfg.validate()?;
        init.validate()?;
        em(data, init.dim, init.clone(), cfg)
    }

    /// Fits `K = 1..=k_max` and keeps the one with the lowest BIC.
    pub fn fit_bic(data: &[f64], dim: usize, k_max: usize, cfg: &EmConfig) -> Result<BicSelection> {
        if k_max == 0 {
            return Err(invalid("k_max", "must be at least 1"));
        }
        let mut best: Option<GmmFit> = None;
        let mut scores = Vec::with_capacity(k_max);
        let n = data.len() / dim.max(1);
        for k in 1..=k_max.min(n) {
            let fit = Self::fit(data, dim, k, cfg)?;
            scores.push((k, fit.bic));
            if best.as_ref().is_none_or(|b| fit.bic < b.bic) {
                best = Some(fit);
            }
        }
        let best = best.ok_or_else(|| invalid("k_max", "no model could be fitted"))?;
        Ok(BicSelection { best, scores })
    }
}

#[inline]
pub(crate) fn log_pdf_with(f: &Factors, c: usize, mean: &[f64], x: &[f64], z: &mut [f64]) -> f64 {
    let d = mean.len();
    for j in 0..d {
        z[j] = x[j] - mean[j];
    }
    solve_lower(&f.chol[c], d, &mut z[..d]);
    let m: f64 = z[..d].iter().map(|v| v * v).sum();
    f.log_norm[c] - 0.5 * m
}

fn check_data(data: &[f64], dim: usize, k: usize) -> Result<()> {
    if dim == 0 {
        return Err(invalid("dim", "must be at least 1"));
    }
    if !data.len().is_multiple_of(dim) {
        return Err(MotionError::DimensionMismatch {
            what: "training data length is not a multiple of the dimension".into(),
            expected: dim * (data.len() / dim + 1),
            got: data.len(),
        });
    }
    if k == 0 {
        return Err(invalid("components", "must be at least 1"));
    }
    let n = data.len() / dim;
    if n < k.max(2) {
        return Err(MotionError::TooFewSamples {
            what: format!("GMM with {k} components"),
            needed: k.max(2),
            got: n,
        });
    }
    check_finite("training data", data)
}

/// k-means++ seeding followed by a few Lloyd iterations; the initial mixture has the cluster
/// proportions, means and covariances.
fn kmeans_init(data: &[f64], d: usize, k: usize, cfg: &EmConfig) -> Result<Gmm> {
    let n = data.len() / d;
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let row = |i: usize| &data[i * d..(i + 1) * d];
    let dist2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
    // Centres flat (`k × d`), buffers allocated once.
    let mut centers: Vec<f64> = Vec::with_capacity(k * d);
    centers.extend_from_slice(row(rng.random_range(0..n)));
    let mut best_d2: Vec<f64> = data.chunks_exact(d).map(|x| dist2(x, &centers)).collect();
    while centers.len() < k * d {
        let total: f64 = best_d2.iter().sum();
        let next = if total > 0.0 {
            let mut r = rng.random::<f64>() * total;
            let mut chosen = n - 1;
            for (i, w) in best_d2.iter().enumerate() {
                if r < *w {
                    chosen = i;
                    break;
                }
                r -= w;
            }
            chosen
        } else {
            rng.random_range(0..n)
        };
        centers.extend_from_slice(row(next));
        let c = &centers[centers.len() - d..];
        for (b, x) in best_d2.iter_mut().zip(data.chunks_exact(d)) {
            *b = b.min(dist2(x, c));
        }
    }
    let mut assign = vec![0usize; n];
    let mut sums = vec![0.0; k * d];
    let mut counts = vec![0usize; k];
    for _ in 0..cfg.kmeans_iter.max(1) {
        let mut changed = false;
        for (a, x) in assign.iter_mut().zip(data.chunks_exact(d)) {
            let (mut bc, mut bd) = (0, f64::INFINITY);
            for (c, ctr) in centers.chunks_exact(d).enumerate() {
                let dd = dist2(x, ctr);
                if dd < bd {
                    bd = dd;
                    bc = c;
                }
            }
            if *a != bc {
                *a = bc;
                changed = true;
            }
        }
        sums.iter_mut().for_each(|v| *v = 0.0);
        counts.iter_mut().for_each(|v| *v = 0);
        for (&a, x) in assign.iter().zip(data.chunks_exact(d)) {
            counts[a] += 1;
            for (s, v) in sums[a * d..(a + 1) * d].iter_mut().zip(x) {
                *s += v;
            }
        }
        for c in 0..k {
            if counts[c] > 0 {
                for j in 0..d {
                    centers[c * d + j] = sums[c * d + j] / counts[c] as f64;
                }
            }
        }
        if !changed {
            break;
        }
    }
    // Hard responsibilities -> one M-step gives the starting mixture.
    Ok(hard_m_step(data, d, k, &assign, cfg.reg_covar))
}

/// [`m_step`] for one-hot responsibilities given as the cluster of each sample: the same
/// mixture in O(n d²) instead of O(n k d²).
fn hard_m_step(data: &[f64], d: usize, k: usize, assign: &[usize], reg: f64) -> Gmm {
    let n = data.len() / d;
    let mut nk = vec![0.0; k];
    let mut means = vec![vec![0.0; d]; k];
    for (x, &c) in data.chunks_exact(d).zip(assign) {
        nk[c] += 1.0;
        for j in 0..d {
            means[c][j] += x[j];
        }
    }
    let mut gmean = vec![0.0; d];
    for x in data.chunks_exact(d) {
        for j in 0..d {
            gmean[j] += x[j] / n as f64;
        }
    }
    let tiny = 10.0 * f64::EPSILON;
    for c in 0..k {
        if nk[c] > tiny {
            for j in 0..d {
                means[c][j] /= nk[c];
            }
        } else {
            means[c].clone_from(&gmean);
        }
    }
    let mut covs = vec![vec![0.0; d * d]; k];
    let mut diff = vec![0.0; d];
    for (x, &c) in data.chunks_exact(d).zip(assign) {
        for j in 0..d {
            diff[j] = x[j] - means[c][j];
        }
        let cov = &mut covs[c];
        for a in 0..d {
            for b in 0..=a {
                cov[a * d + b] += diff[a] * diff[b];
            }
        }
    }
    let empty = nk.iter().any(|v| !(*v > tiny));
    let mut gcov = vec![0.0; d * d];
    if empty {
        for x in data.chunks_exact(d) {
            for a in 0..d {
                for b in 0..d {
                    gcov[a * d + b] += (x[a] - gmean[a]) * (x[b] - gmean[b]) / n as f64;
                }
            }
        }
    }
    for c in 0..k {
        let cov = &mut covs[c];
        if nk[c] > tiny {
            for a in 0..d {
                for b in 0..=a {
                    cov[a * d + b] /= nk[c];
                }
            }
        } else {
            cov.clone_from(&gcov);
        }
        for a in 0..d {
            for b in 0..a {
                cov[b * d + a] = cov[a * d + b];
            }
            cov[a * d + a] += reg;
        }
    }
    let total: f64 = nk.iter().sum();
    let priors = nk
        .iter()
        .map(|v| (v / total).max(f64::MIN_POSITIVE))
        .collect::<Vec<_>>();
    let s: f64 = priors.iter().sum();
    Gmm {
        dim: d,
        priors: priors.iter().map(|p| p / s).collect(),
        means,
        covariances: covs,
    }
}

/// M-step from responsibilities `resp` (row-major `n × k`). Components with (almost) no mass get
/// the data covariance so that they stay well defined.
fn m_step(data: &[f64], d: usize, k: usize, resp: &[f64], reg: f64) -> Gmm {
    let n = data.len() / d;
    let mut nk = vec![0.0; k];
    let mut means = vec![vec![0.0; d]; k];
    for i in 0..n {
        let x = &data[i * d..(i + 1) * d];
        for c in 0..k {
            let r = resp[i * k + c];
            nk[c] += r;
            for j in 0..d {
                means[c][j] += r * x[j];
            }
        }
    }
    // Global mean/covariance as a fallback for empty components.
    let mut gmean = vec![0.0; d];
    for i in 0..n {
        for j in 0..d {
            gmean[j] += data[i * d + j] / n as f64;
        }
    }
    let mut covs = vec![vec![0.0; d * d]; k];
    let tiny = 10.0 * f64::EPSILON;
    for c in 0..k {
        if nk[c] > tiny {
            for j in 0..d {
                means[c][j] /= nk[c];
            }
        } else {
            means[c].clone_from(&gmean);
        }
    }
    let mut diff = vec![0.0; d];
    for i in 0..n {
        let x = &data[i * d..(i + 1) * d];
        for c in 0..k {
            let r = resp[i * k + c];
            if r == 0.0 {
                continue;
            }
            for j in 0..d {
                diff[j] = x[j] - means[c][j];
            }
            let cov = &mut covs[c];
            for a in 0..d {
                let ra = r * diff[a];
                for b in 0..=a {
                    cov[a * d + b] += ra * diff[b];
                }
            }
        }
    }
    let mut gcov = vec![0.0; d * d];
    for i in 0..n {
        for a in 0..d {
            for b in 0..d {
                gcov[a * d + b] +=
                    (data[i * d + a] - gmean[a]) * (data[i * d + b] - gmean[b]) / n as f64;
            }
        }
    }
    for c in 0..k {
        let cov = &mut covs[c];
        if nk[c] > tiny {
            for a in 0..d {
                for b in 0..=a {
                    cov[a * d + b] /= nk[c];
                }
            }
        } else {
            cov.clone_from(&gcov);
        }
        for a in 0..d {
            for b in 0..a {
                cov[b * d + a] = cov[a * d + b];
            }
            cov[a * d + a] += reg;
        }
    }
    let total: f64 = nk.iter().sum();
    let priors = nk
        .iter()
        .map(|v| (v / total).max(f64::MIN_POSITIVE))
        .collect::<Vec<_>>();
    let s: f64 = priors.iter().sum();
    Gmm {
        dim: d,
        priors: priors.iter().map(|p| p / s).collect(),
        means,
        covariances: covs,
    }
}

/// EM from `gmm`: the fixed-size fused pass for the common dimensions (2-D and 3-D motions give
/// `d` = 4 and 6), the generic one otherwise. Both compute the same iterates (to rounding).
fn em(data: &[f64], d: usize, gmm: Gmm, cfg: &EmConfig) -> Result<GmmFit> {
    match d {
        1 => em_fixed::<1, 1>(data, gmm, cfg),
        2 => em_fixed::<2, 3>(data, gmm, cfg),
        3 => em_fixed::<3, 6>(data, gmm, cfg),
        4 => em_fixed::<4, 10>(data, gmm, cfg),
        6 => em_fixed::<6, 21>(data, gmm, cfg),
        _ => em_generic(data, d, gmm, cfg),
    }
}

/// Index of `(a, b)`, `b ≤ a`, in the packed lower triangle (row-major).
#[inline(always)]
const fn tri(a: usize, b: usize) -> usize {
    a * (a + 1) / 2 + b
}

/// EM for dimension `D` (`T = D(D+1)/2`) with one fused pass over the data per iteration: the
/// E-step of iteration `t` accumulates the sufficient statistics `Σr`, `Σr x`, `Σr x xᵀ` of the
/// M-step, on data centred at their mean (so that `Σ = Σr x xᵀ/N_k − μμᵀ` loses no precision).
/// Densities use the inverse Cholesky factor (a triangular matrix–vector product, no division).
/// Buffers are allocated once per call, not per iteration.
fn em_fixed<const D: usize, const T: usize>(
    data: &[f64],
    mut gmm: Gmm,
    cfg: &EmConfig,
) -> Result<GmmFit> {
    debug_assert_eq!(T, D * (D + 1) / 2);
    let n = data.len() / D;
    let k = gmm.n_components();
    let mut center = [0.0; D];
    for x in data.chunks_exact(D) {
        for j in 0..D {
            center[j] += x[j];
        }
    }
    for c in center.iter_mut() {
        *c /= n as f64;
    }
    let mut xs: Vec<[f64; D]> = Vec::with_capacity(n);
    let mut phi: Vec<[f64; T]> = Vec::with_capacity(n);
    let mut gcov = [0.0; T];
    for x in data.chunks_exact(D) {
        let mut y = [0.0; D];
        for j in 0..D {
            y[j] = x[j] - center[j];
        }
        let mut p = [0.0; T];
        for a in 0..D {
            for b in 0..=a {
                p[tri(a, b)] = y[a] * y[b];
            }
        }
        for t in 0..T {
            gcov[t] += p[t] / n as f64;
        }
        xs.push(y);
        phi.push(p);
    }
    // Current parameters, centred.
    let mut mu: Vec<[f64; D]> = gmm
        .means
        .iter()
        .map(|m| std::array::from_fn(|j| m[j] - center[j]))
        .collect();
    let mut cov: Vec<[f64; T]> = gmm
        .covariances
        .iter()
        .map(|c| std::array::from_fn(|t| c[tri_row(t) * D + tri_col(t)]))
        .collect();
    let mut priors = gmm.priors.clone();
    let mut linv: Vec<[f64; T]> = vec![[0.0; T]; k];
    let mut lconst = vec![0.0; k];
    let mut s0 = vec![0.0; k];
    let mut s1: Vec<[f64; D]> = vec![[0.0; D]; k];
    let mut s2: Vec<[f64; T]> = vec![[0.0; T]; k];
    let mut row = vec![0.0; k];
    let mut full = vec![0.0; D * D];
    let mut l = vec![0.0; D * D];
    let mut prev = f64::NEG_INFINITY;
    let mut converged = false;
    let mut iterations = 0;
    let mut ll = f64::NEG_INFINITY;
    let tiny = 10.0 * f64::EPSILON;
    let half_d_ln2pi = 0.5 * D as f64 * LN_2PI;
    for it in 0..cfg.max_iter {
        iterations = it + 1;
        // Factors of the current parameters.
        for c in 0..k {
            for a in 0..D {
                for b in 0..=a {
                    full[a * D + b] = cov[c][tri(a, b)];
                    full[b * D + a] = cov[c][tri(a, b)];
                }
            }
            if !cholesky(&full, D, &mut l) {
                return Err(MotionError::SingularCovariance {
                    component: c,
                    context: "EM".into(),
                });
            }
            // Inverse of the lower-triangular L by forward substitution, column by column.
            let li = &mut linv[c];
            for j in 0..D {
                for a in j..D {
                    let mut s = if a == j { 1.0 } else { 0.0 };
                    for b in j..a {
                        s -= l[a * D + b] * li[tri(b, j)];
                    }
                    li[tri(a, j)] = s / l[a * D + a];
                }
            }
            lconst[c] = priors[c].ln() - 0.5 * chol_logdet(&l, D) - half_d_ln2pi;
        }
        s0.iter_mut().for_each(|v| *v = 0.0);
        s1.iter_mut().for_each(|v| *v = [0.0; D]);
        s2.iter_mut().for_each(|v| *v = [0.0; T]);
        ll = 0.0;
        for (x, p) in xs.iter().zip(&phi) {
            let mut m = f64::NEG_INFINITY;
            for c in 0..k {
                let mut diff = [0.0; D];
                for j in 0..D {
                    diff[j] = x[j] - mu[c][j];
                }
                let li = &linv[c];
                let mut q = 0.0;
                for a in 0..D {
                    let mut z = 0.0;
                    for b in 0..=a {
                        z += li[tri(a, b)] * diff[b];
                    }
                    q += z * z;
                }
                let v = lconst[c] - 0.5 * q;
                row[c] = v;
                m = m.max(v);
            }
            // exp(−40) ≈ 4e-18 is below the rounding of the sum (≥ 1): such responsibilities
            // are exactly zero to double precision and need no `exp`.
            let mut sum = 0.0;
            for v in row.iter_mut() {
                let e = *v - m;
                *v = if e < -40.0 { 0.0 } else { e.exp() };
                sum += *v;
            }
            ll += m + sum.ln();
            let inv = 1.0 / sum;
            for c in 0..k {
                let r = row[c] * inv;
                if r == 0.0 {
                    continue;
                }
                s0[c] += r;
                for j in 0..D {
                    s1[c][j] += r * x[j];
                }
                for t in 0..T {
                    s2[c][t] += r * p[t];
                }
            }
        }
        let mean_ll = ll / n as f64;
        if !mean_ll.is_finite() {
            return Err(invalid(
                "training data",
                "log-likelihood is not finite (degenerate data?)",
            ));
        }
        if (mean_ll - prev).abs() < cfg.tol {
            converged = true;
            break;
        }
        prev = mean_ll;
        // M-step from the statistics.
        let total: f64 = s0.iter().sum();
        for c in 0..k {
            let nk = s0[c];
            if nk > tiny {
                for j in 0..D {
                    mu[c][j] = s1[c][j] / nk;
                }
                for a in 0..D {
                    for b in 0..=a {
                        cov[c][tri(a, b)] = s2[c][tri(a, b)] / nk - mu[c][a] * mu[c][b];
                    }
                }
            } else {
                mu[c] = [0.0; D];
                cov[c] = gcov;
            }
            for a in 0..D {
                cov[c][tri(a, a)] += cfg.reg_covar;
            }
            priors[c] = (nk / total).max(f64::MIN_POSITIVE);
        }
        let ps: f64 = priors.iter().sum();
        priors.iter_mut().for_each(|p| *p /= ps);
    }
    gmm.priors = priors;
    for c in 0..k {
        for j in 0..D {
            gmm.means[c][j] = mu[c][j] + center[j];
        }
        for a in 0..D {
            for b in 0..=a {
                gmm.covariances[c][a * D + b] = cov[c][tri(a, b)];
                gmm.covariances[c][b * D + a] = cov[c][tri(a, b)];
            }
        }
    }
    if !converged {
        // `ll` belongs to the parameters before the last M-step; report the final ones.
        ll = gmm.log_likelihood(data)?;
    }
    let bic = -2.0 * ll + gmm.n_parameters() as f64 * (n as f64).ln();
    Ok(GmmFit {
        gmm,
        log_likelihood: ll,
        iterations,
        converged,
        bic,
    })
}

/// Row of the packed lower-triangle index `t`.
fn tri_row(t: usize) -> usize {
    let mut a = 0;
    while tri(a + 1, 0) <= t {
        a += 1;
    }
    a
}

/// Column of the packed lower-triangle index `t`.
fn tri_col(t: usize) -> usize {
    t - tri(tri_row(t), 0)
}

/// The reference EM: separate E- and M-steps over flat slices, any dimension.
fn em_generic(data: &[f64], d: usize, mut gmm: Gmm, cfg: &EmConfig) -> Result<GmmFit> {
    let n = data.len() / d;
    let k = gmm.n_components();
    let mut resp = vec![0.0; n * k];
    let mut z = vec![0.0; d];
    let mut prev = f64::NEG_INFINITY;
    let mut converged = false;
    let mut iterations = 0;
    let mut ll = f64::NEG_INFINITY;
    for it in 0..cfg.max_iter {
        iterations = it + 1;
        let f = gmm.factors("EM")?;
        let log_priors: Vec<f64> = gmm.priors.iter().map(|p| p.ln()).collect();
        ll = 0.0;
        for i in 0..n {
            let x = &data[i * d..(i + 1) * d];
            let row = &mut resp[i * k..(i + 1) * k];
            for c in 0..k {
                row[c] = log_priors[c] + log_pdf_with(&f, c, &gmm.means[c], x, &mut z);
            }
            // One exp per component: normalise exp(v − max) instead of exp(v − logsumexp).
            let m = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let mut sum = 0.0;
            for v in row.iter_mut() {
                *v = (*v - m).exp();
                sum += *v;
            }
            ll += m + sum.ln();
            for v in row.iter_mut() {
                *v /= sum;
            }
        }
        let mean_ll = ll / n as f64;
        if !mean_ll.is_finite() {
            return Err(invalid(
                "training data",
                "log-likelihood is not finite (degenerate data?)",
            ));
        }
        if (mean_ll - prev).abs() < cfg.tol {
            converged = true;
            break;
        }
        prev = mean_ll;
        gmm = m_step(data, d, k, &resp, cfg.reg_covar);
    }
    if !converged {
        // `ll` belongs to the parameters before the last M-step; report the final ones.
        ll = gmm.log_likelihood(data)?;
    }
    let bic = -2.0 * ll + gmm.n_parameters() as f64 * (n as f64).ln();
    Ok(GmmFit {
        gmm,
        log_likelihood: ll,
        iterations,
        converged,
        bic,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_blobs() -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let normal = rand_distr::Normal::new(0.0, 0.3).expect("normal");
        let mut v = Vec::new();
        for i in 0..400 {
            let (cx, cy) = if i % 2 == 0 { (-5.0, 0.0) } else { (5.0, 2.0) };
            v.push(cx + rng.sample(normal));
            v.push(cy + 0.5 * rng.sample(normal));
        }
        v
    }

    #[test]
    fn em_finds_two_blobs_and_bic_prefers_two() {
        let data = two_blobs();
        let sel = Gmm::fit_bic(&data, 2, 5, &EmConfig::default()).expect("fit");
        assert_eq!(sel.best.gmm.n_components(), 2, "scores {:?}", sel.scores);
        let mut xs: Vec<f64> = sel.best.gmm.means.iter().map(|m| m[0]).collect();
        xs.sort_by(f64::total_cmp);
        assert!(
            (xs[0] + 5.0).abs() < 0.1 && (xs[1] - 5.0).abs() < 0.1,
            "{xs:?}"
        );
        for p in &sel.best.gmm.priors {
            assert!((p - 0.5).abs() < 0.02, "{p}");
        }
        let c = &sel.best.gmm.covariances[0];
        assert!((c[0] - 0.09).abs() < 0.02, "{c:?}");
    }

    #[test]
    fn em_log_likelihood_never_decreases() {
        let data = two_blobs();
        let mut prev = f64::NEG_INFINITY;
        let init = kmeans_init(&data, 2, 3, &EmConfig::default()).expect("init");
        let mut g = init;
        for _ in 0..10 {
            let cfg = EmConfig {
                max_iter: 1,
                ..EmConfig::default()
            };
            let fit = Gmm::fit_from(&data, &g, &cfg).expect("em");
            let ll = fit.gmm.log_likelihood(&data).expect("ll");
            assert!(ll >= prev - 1e-9, "{ll} < {prev}");
            prev = ll;
            g = fit.gmm;
        }
    }

    #[test]
    fn fixed_size_em_matches_the_generic_one() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let normal = rand_distr::Normal::new(0.0, 1.0).expect("normal");
        for d in [1usize, 2, 3, 4, 6] {
            // Three clusters far from the origin (tests the centring).
            let data: Vec<f64> = (0..300)
                .flat_map(|i| {
                    let c = (i % 3) as f64;
                    (0..d)
                        .map(|j| 100.0 + 4.0 * c * (j as f64 + 1.0) + rng.sample(normal))
                        .collect::<Vec<_>>()
                })
                .collect();
            for k in [1, 3, 5] {
                let cfg = EmConfig {
                    tol: 1e-8,
                    ..EmConfig::default()
                };
                let init = kmeans_init(&data, d, k, &cfg).expect("init");
                let a = em(&data, d, init.clone(), &cfg).expect("fixed");
                let b = em_generic(&data, d, init, &cfg).expect("generic");
                assert_eq!(a.iterations, b.iterations, "d {d} k {k}");
                assert!(
                    (a.log_likelihood - b.log_likelihood).abs() < 1e-8 * b.log_likelihood.abs(),
                    "d {d} k {k}: {} vs {}",
                    a.log_likelihood,
                    b.log_likelihood
                );
                for c in 0..k {
                    assert!((a.gmm.priors[c] - b.gmm.priors[c]).abs() < 1e-9);
                    for (x, y) in a.gmm.means[c].iter().zip(&b.gmm.means[c]) {
                        assert!((x - y).abs() < 1e-8, "d {d} k {k}: {x} vs {y}");
                    }
                    for (x, y) in a.gmm.covariances[c].iter().zip(&b.gmm.covariances[c]) {
                        assert!((x - y).abs() < 1e-8, "d {d} k {k}: {x} vs {y}");
                    }
                }
            }
        }
    }

    #[test]
    fn hard_m_step_equals_m_step_with_one_hot_responsibilities() {
        let data = two_blobs();
        let n = data.len() / 2;
        let k = 4;
        // Cluster 3 stays empty (takes the data covariance).
        let assign: Vec<usize> = (0..n).map(|i| (i * 7 + i / 5) % 3).collect();
        let mut resp = vec![0.0; n * k];
        for i in 0..n {
            resp[i * k + assign[i]] = 1.0;
        }
        let a = hard_m_step(&data, 2, k, &assign, 1e-6);
        let b = m_step(&data, 2, k, &resp, 1e-6);
        assert_eq!(a.priors, b.priors);
        for c in 0..k {
            for (x, y) in a.means[c].iter().zip(&b.means[c]) {
                assert!((x - y).abs() < 1e-12);
            }
            for (x, y) in a.covariances[c].iter().zip(&b.covariances[c]) {
                assert!((x - y).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn bad_inputs_are_rejected() {
        assert!(matches!(
            Gmm::fit(&[1.0, f64::NAN, 2.0, 3.0], 2, 1, &EmConfig::default()),
            Err(MotionError::NotFinite { .. })
        ));
        assert!(matches!(
            Gmm::fit(&[1.0, 2.0, 3.0], 2, 1, &EmConfig::default()),
            Err(MotionError::DimensionMismatch { .. })
        ));
        assert!(matches!(
            Gmm::fit(&[1.0, 2.0], 2, 1, &EmConfig::default()),
            Err(MotionError::TooFewSamples { .. })
        ));
        // Identical points and no regularisation: covariance is singular.
        let cfg = EmConfig {
            reg_covar: 0.0,
            ..EmConfig::default()
        };
        let r = Gmm::fit(&[1.0, 1.0, 1.0, 1.0, 1.0, 1.0], 2, 1, &cfg);
        assert!(
            matches!(r, Err(MotionError::SingularCovariance { .. })),
            "{r:?}"
        );
        let g = Gmm {
            dim: 2,
            priors: vec![1.0],
            means: vec![vec![0.0, 0.0]],
            covariances: vec![vec![1.0, 1.0, 1.0, 1.0]],
        };
        assert!(matches!(
            g.validate(),
            Err(MotionError::SingularCovariance { component: 0, .. })
        ));
    }
}
