//! Gaussian mixture regression (thesis eq. A.23–A.24) and the GMR dynamical system
//! `ẋ = Σ_k h_k(x)(A_k x + b_k)` (eq. 3.6–3.7).
//!
//! Evaluation cost is O(K·(n_in² + n_out·n_in)) per query and allocation-free: the per-component
//! terms `A_k = Σ_yx Σ_xx⁻¹`, `b_k = μ_y − A_k μ_x`, the Cholesky factor of `Σ_xx` and the
//! conditional covariances are precomputed in [`Gmr::new`], and the query uses stack buffers of
//! [`MAX_COMPONENTS`] × [`MAX_DIM`] values.

use serde::{Deserialize, Serialize};

use crate::ds::FirstOrderDs;
use crate::error::{MotionError, Result, check_dim, check_finite, invalid};
use crate::gmm::{EmConfig, Gmm};
use crate::linalg::{LN_2PI, chol_inverse, chol_logdet, cholesky, solve_lower};

/// Largest number of mixture components a [`Gmr`] accepts (stack buffers of the query).
pub const MAX_COMPONENTS: usize = 64;
/// Largest input or output dimension a [`Gmr`] accepts.
pub const MAX_DIM: usize = 16;

#[derive(Debug, Clone)]
pub(crate) struct Component {
    pub(crate) ln_prior: f64,
    /// `−½ ln|Σ_xx| − n_in/2 ln 2π`.
    pub(crate) log_norm: f64,
    pub(crate) mu_x: Vec<f64>,
    pub(crate) chol_xx: Vec<f64>,
    /// `A_k`, row-major `n_out × n_in`.
    pub(crate) a: Vec<f64>,
    /// `b_k = μ_y − A_k μ_x`.
    pub(crate) b: Vec<f64>,
    /// `Σ_y − Σ_yx Σ_xx⁻¹ Σ_xy`, row-major `n_out × n_out`.
    pub(crate) cond_cov: Vec<f64>,
}

/// GMR over a joint mixture whose first `n_in` dimensions are the input and the rest the output.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(try_from = "GmrSpec", into = "GmrSpec")]
pub struct Gmr {
    gmm: Gmm,
    n_in: usize,
    n_out: usize,
    pub(crate) comps: Vec<Component>,
}

/// Serialised form of [`Gmr`]: the mixture and the input split; everything else is derived.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GmrSpec {
    /// Joint mixture over `[input, output]`.
    pub gmm: Gmm,
    /// Number of input dimensions (the first ones).
    pub n_in: usize,
}

impl TryFrom<GmrSpec> for Gmr {
    type Error = MotionError;
    fn try_from(s: GmrSpec) -> Result<Self> {
        Gmr::new(s.gmm, s.n_in)
    }
}

impl From<Gmr> for GmrSpec {
    fn from(g: Gmr) -> Self {
        GmrSpec {
            gmm: g.gmm,
            n_in: g.n_in,
        }
    }
}

impl Gmr {
    /// Precomputes the regression terms. Fails if a `Σ_xx` is singular or sizes are out of range.
    pub fn new(gmm: Gmm, n_in: usize) -> Result<Self> {
        gmm.validate()?;
        let d = gmm.dim;
        if n_in == 0 || n_in >= d {
            return Err(invalid("n_in", format!("must be in 1..{d}, got {n_in}")));
        }
        let n_out = d - n_in;
        if gmm.n_components() > MAX_COMPONENTS || n_in > MAX_DIM || n_out > MAX_DIM {
            return Err(invalid(
                "gmm",
                format!(
                    "at most {MAX_COMPONENTS} components and {MAX_DIM} input/output dimensions are supported"
                ),
            ));
        }
        let mut comps = Vec::with_capacity(gmm.n_components());
        for c in 0..gmm.n_components() {
            let s = &gmm.covariances[c];
            let mu = &gmm.means[c];
            let mut sxx = vec![0.0; n_in * n_in];
            for i in 0..n_in {
                for j in 0..n_in {
                    sxx[i * n_in + j] = s[i * d + j];
                }
            }
            let mut l = vec![0.0; n_in * n_in];
            if !cholesky(&sxx, n_in, &mut l) {
                return Err(MotionError::SingularCovariance {
                    component: c,
                    context: "GMR input block Σ_xx".into(),
                });
            }
            let mut inv = vec![0.0; n_in * n_in];
            chol_inverse(&l, n_in, &mut inv);
            // A = Σ_yx Σ_xx⁻¹
            let mut a = vec![0.0; n_out * n_in];
            for r in 0..n_out {
                for cc in 0..n_in {
                    let mut v = 0.0;
                    for k in 0..n_in {
                        v += s[(n_in + r) * d + k] * inv[k * n_in + cc];
                    }
                    a[r * n_in + cc] = v;
                }
            }
            let mut b = vec![0.0; n_out];
            for r in 0..n_out {
                b[r] = mu[n_in + r] - (0..n_in).map(|k| a[r * n_in + k] * mu[k]).sum::<f64>();
            }
            let mut cond_cov = vec![0.0; n_out * n_out];
            for r in 0..n_out {
                for q in 0..n_out {
                    let v: f64 = (0..n_in)
                        .map(|k| a[r * n_in + k] * s[k * d + n_in + q])
                        .sum();
                    cond_cov[r * n_out + q] = s[(n_in + r) * d + n_in + q] - v;
                }
            }
            comps.push(Component {
                ln_prior: gmm.priors[c].ln(),
                log_norm: -0.5 * chol_logdet(&l, n_in) - 0.5 * n_in as f64 * LN_2PI,
                mu_x: mu[..n_in].to_vec(),
                chol_xx: l,
                a,
                b,
                cond_cov,
            });
        }
        Ok(Self {
            gmm,
            n_in,
            n_out,
            comps,
        })
    }

    /// Fits the joint mixture on `[input, output]` rows and builds the regressor.
    pub fn fit(data: &[f64], n_in: usize, n_out: usize, k: usize, cfg: &EmConfig) -> Result<Self> {
        let fit = Gmm::fit(data, n_in + n_out, k, cfg)?;
        Self::new(fit.gmm, n_in)
    }

    /// The joint mixture.
    pub fn gmm(&self) -> &Gmm {
        &self.gmm
    }
    /// Input dimension.
    pub fn n_in(&self) -> usize {
        self.n_in
    }
    /// Output dimension.
    pub fn n_out(&self) -> usize {
        self.n_out
    }
    /// Number of components.
    pub fn n_components(&self) -> usize {
        self.comps.len()
    }

    /// Writes `ln N(x | μ_x,k, Σ_xx,k)` to `log_pdf[k]` and the activations `h_k(x)` (eq. 3.7 /
    /// A.24) to `h[k]`. Both slices must have length K.
    pub fn activations(&self, x: &[f64], h: &mut [f64], log_pdf: &mut [f64]) -> Result<()> {
        check_dim("GMR query", self.n_in, x.len())?;
        let k = self.comps.len();
        check_dim("GMR activation buffer", k, h.len().min(log_pdf.len()))?;
        check_finite("GMR query", x)?;
        let mut z = [0.0; MAX_DIM];
        for (c, comp) in self.comps.iter().enumerate() {
            for j in 0..self.n_in {
                z[j] = x[j] - comp.mu_x[j];
            }
            solve_lower(&comp.chol_xx, self.n_in, &mut z[..self.n_in]);
            let m: f64 = z[..self.n_in].iter().map(|v| v * v).sum();
            log_pdf[c] = comp.log_norm - 0.5 * m;
            h[c] = comp.ln_prior + log_pdf[c];
        }
        // One exp per component: normalise exp(v − max).
        let m = h[..k].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut sum = 0.0;
        for v in h[..k].iter_mut() {
            *v = (*v - m).exp();
            sum += *v;
        }
        for v in h[..k].iter_mut() {
            *v /= sum;
        }
        Ok(())
    }

    /// Conditional mean `E[y | x]` (eq. A.23) into `mean` (length `n_out`).
    pub fn predict(&self, x: &[f64], mean: &mut [f64]) -> Result<()> {
        check_dim("GMR output", self.n_out, mean.len())?;
        let k = self.comps.len();
        let mut h = [0.0; MAX_COMPONENTS];
        let mut lp = [0.0; MAX_COMPONENTS];
        self.activations(x, &mut h[..k], &mut lp[..k])?;
        self.mean_from_activations(x, &h[..k], mean);
        Ok(())
    }

    /// `Σ_k h_k (A_k x + b_k)` for given activations.
    #[inline]
    pub(crate) fn mean_from_activations(&self, x: &[f64], h: &[f64], mean: &mut [f64]) {
        mean.iter_mut().for_each(|v| *v = 0.0);
        for (comp, hk) in self.comps.iter().zip(h) {
            if *hk == 0.0 {
                continue;
            }
            for r in 0..self.n_out {
                let row = &comp.a[r * self.n_in..(r + 1) * self.n_in];
                let v: f64 = comp.b[r] + row.iter().zip(x).map(|(a, x)| a * x).sum::<f64>();
                mean[r] += hk * v;
            }
        }
    }

    /// Conditional mean and the covariance `Σ_k h_k² (Σ_y − Σ_yx Σ_xx⁻¹ Σ_xy)` of eq. A.23.
    pub fn predict_with_covariance(
        &self,
        x: &[f64],
        mean: &mut [f64],
        cov: &mut [f64],
    ) -> Result<()> {
        check_dim("GMR covariance output", self.n_out * self.n_out, cov.len())?;
        check_dim("GMR output", self.n_out, mean.len())?;
        let k = self.comps.len();
        let mut h = [0.0; MAX_COMPONENTS];
        let mut lp = [0.0; MAX_COMPONENTS];
        self.activations(x, &mut h[..k], &mut lp[..k])?;
        self.mean_from_activations(x, &h[..k], mean);
        cov.iter_mut().for_each(|v| *v = 0.0);
        for (comp, hk) in self.comps.iter().zip(&h[..k]) {
            for (c, v) in cov.iter_mut().zip(&comp.cond_cov) {
                *c += hk * hk * v;
            }
        }
        Ok(())
    }

    /// `A_k` of component `c` (row-major `n_out × n_in`).
    pub fn gain(&self, c: usize) -> &[f64] {
        &self.comps[c].a
    }
    /// `b_k` of component `c`.
    pub fn offset(&self, c: usize) -> &[f64] {
        &self.comps[c].b
    }
}

/// The GMR dynamical system of eq. 3.6–3.7: `ẋ = f(x − x*)`, learned on positions relative to
/// the target `x*` (the mean end point of the demonstrations). Units follow the data (e.g. m and
/// m/s); the frame is the frame of the demonstrations.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GmrDs {
    /// Regressor from relative position to velocity.
    pub gmr: Gmr,
    /// Target `x*` in the demonstration frame.
    pub target: Vec<f64>,
}

impl GmrDs {
    /// Builds the DS from a mixture over `[x − x*, ẋ]` (dimension `2n`).
    pub fn new(gmm: Gmm, target: Vec<f64>) -> Result<Self> {
        let n = target.len();
        check_dim("GMR-DS mixture dimension (2 × state)", 2 * n, gmm.dim)?;
        check_finite("GMR-DS target", &target)?;
        Ok(Self {
            gmr: Gmr::new(gmm, n)?,
            target,
        })
    }

    /// Checks a GMR-DS read from a file or a message (the mixture itself is checked when it is
    /// read): the target is finite and as long as the regressor's input and output.
    pub fn validate(&self) -> Result<()> {
        check_dim("GMR-DS target (regressor input)", self.gmr.n_in(), self.target.len())?;
        check_dim("GMR-DS output (regressor input)", self.gmr.n_in(), self.gmr.n_out())?;
        check_finite("GMR-DS target", &self.target)
    }

    /// State dimension `n`.
    pub fn dim(&self) -> usize {
        self.target.len()
    }

    /// `ẋ` at `x` for the goal `goal` (the learned field is translated to the new goal).
    pub fn velocity_towards(&self, x: &[f64], goal: &[f64], out: &mut [f64]) -> Result<()> {
        let n = self.dim();
        check_dim("GMR-DS state", n, x.len())?;
        check_dim("GMR-DS goal", n, goal.len())?;
        let mut rel = [0.0; MAX_DIM];
        for i in 0..n {
            rel[i] = x[i] - goal[i];
        }
        self.gmr.predict(&rel[..n], out)
    }
}

impl FirstOrderDs for GmrDs {
    fn dim(&self) -> usize {
        self.target.len()
    }
    fn velocity(&self, x: &[f64], out: &mut [f64]) -> Result<()> {
        self.velocity_towards(x, &self.target, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toy_gmm() -> Gmm {
        Gmm {
            dim: 2,
            priors: vec![0.3, 0.7],
            means: vec![vec![-1.0, 2.0], vec![1.0, -1.0]],
            covariances: vec![vec![1.0, 0.5, 0.5, 2.0], vec![0.5, -0.2, -0.2, 1.0]],
        }
    }

    #[test]
    fn single_component_is_the_gaussian_conditional() {
        let g = Gmm {
            dim: 2,
            priors: vec![1.0],
            means: vec![vec![1.0, 2.0]],
            covariances: vec![vec![2.0, 1.0, 1.0, 3.0]],
        };
        let gmr = Gmr::new(g, 1).expect("gmr");
        let mut m = [0.0];
        let mut c = [0.0];
        gmr.predict_with_covariance(&[3.0], &mut m, &mut c)
            .expect("predict");
        assert!((m[0] - (2.0 + 0.5 * 2.0)).abs() < 1e-12);
        assert!((c[0] - (3.0 - 0.5)).abs() < 1e-12);
    }

    #[test]
    fn far_queries_stay_finite_and_pick_the_closest_component() {
        let gmr = Gmr::new(toy_gmm(), 1).expect("gmr");
        let mut m = [0.0];
        gmr.predict(&[1e4], &mut m).expect("predict");
        assert!(m[0].is_finite());
    }

    #[test]
    fn rejects_bad_queries_and_singular_input_block() {
        let gmr = Gmr::new(toy_gmm(), 1).expect("gmr");
        let mut m = [0.0];
        assert!(gmr.predict(&[f64::NAN], &mut m).is_err());
        assert!(gmr.predict(&[0.0, 1.0], &mut m).is_err());
        let mut g = toy_gmm();
        g.covariances[1] = vec![0.0, 0.0, 0.0, 1.0];
        assert!(matches!(
            Gmr::new(g, 1),
            Err(MotionError::SingularCovariance { .. })
        ));
    }

    #[test]
    fn serde_round_trip_rebuilds_the_derived_terms() {
        let gmr = Gmr::new(toy_gmm(), 1).expect("gmr");
        let s = serde_json::to_string(&gmr).expect("ser");
        let back: Gmr = serde_json::from_str(&s).expect("de");
        let (mut a, mut b) = ([0.0], [0.0]);
        gmr.predict(&[0.3], &mut a).expect("p");
        back.predict(&[0.3], &mut b).expect("p");
        assert_eq!(a, b);
    }
}
