//! Contracting GMR (thesis Sec. 3.1.3): a GMR dynamical system stabilised at run time by the
//! control input of eq. 3.13, gains `U_k` from Algorithm 1, activation `ω` of eq. 3.14, and the
//! regions `D_r` (demonstration area, eq. 3.15), `C_r` (contraction) and `B_r` (ball at the target).
//!
//! All positions here are relative to the goal (`x − x*`), so eq. 3.13 reads
//! `ẋ = Σ h_k (A_k x + b_k) + ω Σ h_k (U_k x − b_k)`: with `ω = 1` it is `Σ h_k (A_k + U_k) x`, a
//! contracting system with equilibrium at the goal.
//!
//! **Deviation from Algorithm 1 as printed:** µ₁ is the column measure
//! `max_j (c_jj + Σ_{i≠j} |c_ij|)`, so the off-diagonal sum of column `d` is used (the printed
//! algorithm sums the row, which bounds µ_∞, not µ₁); and a strict margin `c_min > 0` is enforced
//! (`c_dd + s_d ≤ −c_min`), which also covers the printed algorithm's gaps `a_dd = 0` and
//! `|a_dd| = s` where it leaves µ₁ = 0. Both keep its four cases and the factor `p > 1`.

use serde::{Deserialize, Serialize};

use crate::demo::{Demonstration, common_dim, mean_end_point};
use crate::ds::DsPolicy;
use crate::error::{Result, check_dim, check_finite, invalid};
use crate::gmm::{BicSelection, EmConfig, Gmm};
use crate::gmr::{GmrDs, MAX_COMPONENTS, MAX_DIM};

/// µ₁ matrix measure (column form) of a row-major `n × n` matrix: `max_j (c_jj + Σ_{i≠j} |c_ij|)`.
pub fn mu1(c: &[f64], n: usize) -> f64 {
    (0..n)
        .map(|j| {
            c[j * n + j]
                + (0..n)
                    .filter(|&i| i != j)
                    .map(|i| c[i * n + j].abs())
                    .sum::<f64>()
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Algorithm 1: diagonal `U` (returned as its diagonal) such that `µ₁(A + U) ≤ −c_min < 0`.
/// `p > 1` is the algorithm's gain factor, `c_min > 0` the strict contraction margin (1/s).
pub fn stabilizing_gains(a: &[f64], n: usize, p: f64, c_min: f64) -> Vec<f64> {
    let mut u = vec![0.0; n];
    for d in 0..n {
        let add = a[d * n + d];
        let s: f64 = (0..n).filter(|&i| i != d).map(|i| a[i * n + d].abs()).sum();
        let mut udd = if add > 0.0 && add <= s {
            -s - p * add
        } else if add > 0.0 {
            -2.0 * add
        } else if add.abs() < s {
            -s
        } else {
            0.0
        };
        // Strict margin (see the module doc).
        if add + udd + s > -c_min {
            udd = -c_min - s - add;
        }
        u[d] = udd;
    }
    u
}

/// Settings of C-GMR (defaults from Sec. 3.1.3–3.1.4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CgmrConfig {
    /// `α` of eq. 3.15 (0 < α ≤ 1); bigger gives a tighter demonstration area.
    pub alpha: f64,
    /// Radius of `B_r` as a fraction of the mean start–target distance of the demonstrations.
    pub ball_fraction: f64,
    /// `γ` of eq. 3.14 (1/s): ω reaches c(x) after about 5/γ s.
    pub gamma: f64,
    /// `t_max` as a multiple of the longest demonstration duration.
    pub t_max_factor: f64,
    /// `p > 1` of Algorithm 1.
    pub p: f64,
    /// Strict contraction margin `c_min` (1/s) of the stabilised system.
    pub c_min: f64,
}

impl Default for CgmrConfig {
    fn default() -> Self {
        Self {
            alpha: 0.1,
            ball_fraction: 0.15,
            gamma: 20.0,
            t_max_factor: 1.5,
            p: 2.0,
            c_min: 1.0,
        }
    }
}

impl CgmrConfig {
    /// Rejects NaN and out-of-range values.
    pub fn validate(&self) -> Result<()> {
        let pos = |name: &str, v: f64| {
            if v > 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(invalid(name, format!("must be finite and > 0, got {v}")))
            }
        };
        pos("alpha", self.alpha)?;
        if self.alpha > 1.0 {
            return Err(invalid("alpha", "must be <= 1"));
        }
        if !(self.ball_fraction >= 0.0) || !self.ball_fraction.is_finite() {
            return Err(invalid("ball_fraction", "must be finite and >= 0"));
        }
        pos("gamma", self.gamma)?;
        pos("t_max_factor", self.t_max_factor)?;
        pos("c_min", self.c_min)?;
        if !(self.p > 1.0) || !self.p.is_finite() {
            return Err(invalid("p", "must be finite and > 1"));
        }
        Ok(())
    }
}

/// How many mixture components to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Components {
    /// Exactly this many.
    Fixed(usize),
    /// The best of `1..=k_max` by BIC.
    Bic(usize),
}

/// Region of the state space (Fig. 3.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Region {
    /// Demonstration area: controller off (`c = 0`).
    Demonstration,
    /// Contraction region: controller on.
    Contraction,
    /// Ball around the target: controller on.
    Ball,
}

/// A GMR dynamical system with its contracting controller.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Cgmr {
    /// The underlying GMR DS (eq. 3.6) over `[x − x*, ẋ]`.
    pub ds: GmrDs,
    /// Diagonals of the gains `U_k` (Algorithm 1).
    pub u: Vec<Vec<f64>>,
    /// `ln δ_k` of eq. 3.15 (`f64::MAX` for a component that owns no training point).
    pub ln_delta: Vec<f64>,
    /// Radius of `B_r` (state unit).
    pub ball_radius: f64,
    /// `t_max` (s) after which the controller is always on.
    pub t_max: f64,
    /// Settings used.
    pub config: CgmrConfig,
}

/// Builds the joint `[x − x*, ẋ]` training rows from demonstrations, keeping every `step`-th sample.
pub fn ds_training_data(demos: &[Demonstration], target: &[f64], step: usize) -> Result<Vec<f64>> {
    let n = common_dim(demos)?;
    check_dim("target", n, target.len())?;
    let mut data = Vec::new();
    for d in demos {
        let d = d.subsampled(step);
        for i in 0..d.len() {
            data.extend(d.position(i).iter().zip(target).map(|(x, g)| x - g));
            data.extend_from_slice(d.velocity(i));
        }
    }
    Ok(data)
}

/// Fits a GMR DS to demonstrations (target = mean end point).
pub fn fit_gmr_ds(
    demos: &[Demonstration],
    components: Components,
    em: &EmConfig,
    step: usize,
) -> Result<(GmrDs, Option<BicSelection>)> {
    let target = mean_end_point(demos)?;
    let n = target.len();
    let data = ds_training_data(demos, &target, step)?;
    let (gmm, sel) = match components {
        Components::Fixed(k) => (Gmm::fit(&data, 2 * n, k, em)?.gmm, None),
        Components::Bic(kmax) => {
            let sel = Gmm::fit_bic(&data, 2 * n, kmax.min(MAX_COMPONENTS), em)?;
            (sel.best.gmm.clone(), Some(sel))
        }
    };
    Ok((GmrDs::new(gmm, target)?, sel))
}

impl Cgmr {
    /// Learns GMR (EM, optionally BIC) and the C-GMR extras from the demonstrations.
    pub fn fit(
        demos: &[Demonstration],
        components: Components,
        em: &EmConfig,
        step: usize,
        cfg: &CgmrConfig,
    ) -> Result<Self> {
        let (ds, _) = fit_gmr_ds(demos, components, em, step)?;
        // δ_k from the same (subsampled) training positions EM saw, as in Sec. 3.1.3.
        let training: Vec<Demonstration> = demos.iter().map(|d| d.subsampled(step)).collect();
        Self::from_gmr_ds(ds, &training, cfg)
    }

    /// Adds the C-GMR extras (gains, `δ_k`, `B_r`, `t_max`) to a learned GMR DS.
    pub fn from_gmr_ds(ds: GmrDs, demos: &[Demonstration], cfg: &CgmrConfig) -> Result<Self> {
        cfg.validate()?;
        let n = common_dim(demos)?;
        check_dim("C-GMR demonstrations vs model", ds.dim(), n)?;
        let mut me = Self {
            ds,
            u: Vec::new(),
            ln_delta: Vec::new(),
            ball_radius: 0.0,
            t_max: 0.0,
            config: cfg.clone(),
        };
        me.compute_extras(demos)?;
        Ok(me)
    }

    /// Incremental re-training: EM is warm-started from the current mixture on all
    /// demonstrations (old and new), then gains, regions and `t_max` are recomputed.
    pub fn retrain(&mut self, demos: &[Demonstration], em: &EmConfig, step: usize) -> Result<()> {
        let target = mean_end_point(demos)?;
        check_dim(
            "C-GMR re-training demonstrations",
            self.ds.dim(),
            target.len(),
        )?;
        let data = ds_training_data(demos, &target, step)?;
        let fit = Gmm::fit_from(&data, self.ds.gmr.gmm(), em)?;
        self.ds = GmrDs::new(fit.gmm, target)?;
        let training: Vec<Demonstration> = demos.iter().map(|d| d.subsampled(step)).collect();
        self.compute_extras(&training)
    }

    fn compute_extras(&mut self, demos: &[Demonstration]) -> Result<()> {
        let n = self.ds.dim();
        let k = self.ds.gmr.n_components();
        self.u = (0..k)
            .map(|c| stabilizing_gains(self.ds.gmr.gain(c), n, self.config.p, self.config.c_min))
            .collect();
        // δ_k: cluster training positions by the largest N(x | μ_k, Σ_k), keep α·min per cluster.
        let mut min_lp = vec![f64::INFINITY; k];
        let mut h = [0.0; MAX_COMPONENTS];
        let mut lp = [0.0; MAX_COMPONENTS];
        let mut rel = [0.0; MAX_DIM];
        let mut start_dist = 0.0;
        let mut longest: f64 = 0.0;
        for d in demos {
            for i in 0..d.len() {
                for j in 0..n {
                    rel[j] = d.position(i)[j] - self.ds.target[j];
                }
                self.ds
                    .gmr
                    .activations(&rel[..n], &mut h[..k], &mut lp[..k])?;
                let (best, v) = lp[..k]
                    .iter()
                    .enumerate()
                    .fold((0, f64::NEG_INFINITY), |acc, (c, v)| {
                        if *v > acc.1 { (c, *v) } else { acc }
                    });
                min_lp[best] = min_lp[best].min(v);
            }
            start_dist += d
                .position(0)
                .iter()
                .zip(&self.ds.target)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            longest = longest.max(d.duration());
        }
        self.ln_delta = min_lp
            .iter()
            .map(|m| {
                if m.is_finite() {
                    self.config.alpha.ln() + m
                } else {
                    f64::MAX
                }
            })
            .collect();
        self.ball_radius = self.config.ball_fraction * start_dist / demos.len() as f64;
        self.t_max = self.config.t_max_factor * longest;
        Ok(())
    }

    /// Checks a C-GMR read from a file or a message before it is run: the GMR-DS
    /// ([`GmrDs::validate`]), one gain diagonal of the state's dimension and one `ln δ_k` per
    /// component, finite gains, no NaN threshold, a finite non-negative ball radius, a
    /// non-negative `t_max` and valid settings.
    pub fn validate(&self) -> Result<()> {
        self.ds.validate()?;
        let (k, n) = (self.ds.gmr.n_components(), self.dim());
        check_dim("u (one gain diagonal per component)", k, self.u.len())?;
        for (c, u) in self.u.iter().enumerate() {
            check_dim(&format!("u[{c}]"), n, u.len())?;
            check_finite(&format!("u[{c}]"), u)?;
        }
        check_dim("ln_delta (one per component)", k, self.ln_delta.len())?;
        if let Some(c) = self.ln_delta.iter().position(|v| v.is_nan()) {
            return Err(invalid("ln_delta", format!("component {c} is NaN")));
        }
        if !(self.ball_radius.is_finite() && self.ball_radius >= 0.0) {
            return Err(invalid("ball_radius", format!("{} (must be non-negative and finite)", self.ball_radius)));
        }
        if !(self.t_max >= 0.0) {
            return Err(invalid("t_max", format!("{} s (must be non-negative)", self.t_max)));
        }
        self.config.validate()
    }

    /// State dimension.
    pub fn dim(&self) -> usize {
        self.ds.dim()
    }

    /// Region of the goal-relative state `x_rel`, from the densities `ln N(x|k)` of the GMR query.
    fn region_from(&self, x_rel: &[f64], log_pdf: &[f64]) -> Region {
        let r2: f64 = x_rel.iter().map(|v| v * v).sum();
        if r2.sqrt() <= self.ball_radius {
            Region::Ball
        } else if log_pdf.iter().zip(&self.ln_delta).any(|(lp, ld)| lp >= ld) {
            Region::Demonstration
        } else {
            Region::Contraction
        }
    }

    /// Region of `x_rel` (goal-relative).
    pub fn region(&self, x_rel: &[f64]) -> Result<Region> {
        let k = self.ds.gmr.n_components();
        let mut h = [0.0; MAX_COMPONENTS];
        let mut lp = [0.0; MAX_COMPONENTS];
        self.ds.gmr.activations(x_rel, &mut h[..k], &mut lp[..k])?;
        Ok(self.region_from(x_rel, &lp[..k]))
    }

    /// Eq. 3.13 at the goal-relative state `x_rel` for activation `omega`; returns `c(x)`.
    /// Allocation-free, O(K n²).
    pub fn velocity_with(&self, x_rel: &[f64], omega: f64, out: &mut [f64]) -> Result<f64> {
        let n = self.dim();
        check_dim("C-GMR output", n, out.len())?;
        let k = self.ds.gmr.n_components();
        let mut h = [0.0; MAX_COMPONENTS];
        let mut lp = [0.0; MAX_COMPONENTS];
        self.ds.gmr.activations(x_rel, &mut h[..k], &mut lp[..k])?;
        self.ds.gmr.mean_from_activations(x_rel, &h[..k], out);
        if omega != 0.0 {
            for c in 0..k {
                let hk = h[c];
                let b = self.ds.gmr.offset(c);
                for j in 0..n {
                    out[j] += omega * hk * (self.u[c][j] * x_rel[j] - b[j]);
                }
            }
        }
        Ok(match self.region_from(x_rel, &lp[..k]) {
            Region::Demonstration => 0.0,
            _ => 1.0,
        })
    }

    /// A stateful runner towards `goal` (the learned target if `None`).
    pub fn runner(&self, goal: Option<&[f64]>) -> Result<CgmrRunner<'_>> {
        let goal = goal.map_or_else(|| self.ds.target.clone(), <[f64]>::to_vec);
        check_dim("C-GMR goal", self.dim(), goal.len())?;
        check_finite("C-GMR goal", &goal)?;
        Ok(CgmrRunner {
            model: self,
            goal,
            omega: 0.0,
            t: 0.0,
            started: false,
        })
    }
}

/// C-GMR with its activation state `ω` and clock: the [`DsPolicy`] a controller steps.
#[derive(Debug, Clone)]
pub struct CgmrRunner<'a> {
    model: &'a Cgmr,
    goal: Vec<f64>,
    omega: f64,
    t: f64,
    started: bool,
}

impl CgmrRunner<'_> {
    /// Current activation `ω` (0 = pure GMR, 1 = contracting controller).
    pub fn omega(&self) -> f64 {
        self.omega
    }
}

impl DsPolicy for CgmrRunner<'_> {
    fn dim(&self) -> usize {
        self.model.dim()
    }
    fn reset(&mut self, _x0: &[f64]) -> Result<()> {
        self.t = 0.0;
        self.started = false;
        Ok(())
    }
    fn step(&mut self, x: &[f64], dt: f64, out: &mut [f64]) -> Result<()> {
        let n = self.dim();
        check_dim("C-GMR state", n, x.len())?;
        let mut rel = [0.0; MAX_DIM];
        for j in 0..n {
            rel[j] = x[j] - self.goal[j];
        }
        let omega = self.omega;
        let c = self.model.velocity_with(&rel[..n], omega, out)?;
        if !self.started {
            // ω starts at c(x₀) so that a start outside the demonstrations is contracting at once.
            self.started = true;
            self.omega = c;
            if c != omega {
                self.model.velocity_with(&rel[..n], c, out)?;
            }
        }
        // Eq. 3.14, integrated exactly over dt (c is held constant over the step).
        self.t += dt;
        self.omega = if self.t >= self.model.t_max {
            1.0
        } else {
            c + (self.omega - c) * (-self.model.config.gamma * dt).exp()
        };
        Ok(())
    }
    fn goal(&self) -> &[f64] {
        &self.goal
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ds::{RolloutConfig, rollout};

    #[test]
    fn algorithm1_examples() {
        // Row-vs-column case: the printed row sums would leave µ₁ > 0 here.
        let a = [-1.0, 0.0, 5.0, -1.0];
        let u = stabilizing_gains(&a, 2, 2.0, 0.1);
        let c = [a[0] + u[0], a[1], a[2], a[3] + u[1]];
        assert!(mu1(&c, 2) <= -0.1 + 1e-12, "{c:?}");
        // Already contracting: untouched.
        let a = [-3.0, 1.0, 1.0, -3.0];
        assert_eq!(stabilizing_gains(&a, 2, 2.0, 0.1), vec![0.0, 0.0]);
    }

    /// A spiral demo set whose plain GMR has no guaranteed convergence.
    fn spiral_demos() -> Vec<Demonstration> {
        (0..3)
            .map(|k| {
                let t: Vec<f64> = (0..200).map(|i| i as f64 * 0.02).collect();
                let r0 = 1.0 + 0.1 * k as f64;
                let pos = t.iter().flat_map(|t| {
                    let r = r0 * (1.0 - t / 3.98);
                    [r * (2.0 * t).cos(), r * (2.0 * t).sin()]
                });
                Demonstration::new(2, t.clone(), pos.collect(), None).expect("demo")
            })
            .collect()
    }

    #[test]
    fn cgmr_reaches_target_from_far_starts_and_follows_demos() {
        let demos = spiral_demos();
        let m = Cgmr::fit(
            &demos,
            Components::Fixed(6),
            &EmConfig::default(),
            1,
            &CgmrConfig::default(),
        )
        .expect("fit");
        let cfg = RolloutConfig {
            dt: 0.01,
            max_steps: 20_000,
            tol: 0.01,
        };
        for start in [[5.0, 5.0], [-4.0, 0.5], [0.3, -3.0], [20.0, -20.0]] {
            let mut r = m.runner(None).expect("runner");
            let tr = rollout(&mut r, &start, &cfg).expect("rollout");
            assert!(
                tr.reached,
                "start {start:?} ended at {:?}",
                tr.position(tr.len() - 1)
            );
        }
        // From a demo start the reproduction stays close to the demonstration for a while.
        let mut r = m.runner(None).expect("runner");
        let tr = rollout(&mut r, demos[1].position(0), &cfg).expect("rollout");
        assert!(tr.reached);
        let p = tr.position(20);
        let q = demos[1].position(10);
        assert!(
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt() < 0.2,
            "{p:?} vs {q:?}"
        );
    }

    #[test]
    fn retraining_with_new_demo_recomputes_gains() {
        let demos = spiral_demos();
        let mut m = Cgmr::fit(
            &demos[..2],
            Components::Fixed(4),
            &EmConfig::default(),
            1,
            &CgmrConfig::default(),
        )
        .expect("fit");
        let before = m.u.clone();
        m.retrain(&demos, &EmConfig::default(), 1).expect("retrain");
        assert_ne!(before, m.u);
        for c in 0..m.ds.gmr.n_components() {
            let a = m.ds.gmr.gain(c);
            let mut s = a.to_vec();
            s[0] += m.u[c][0];
            s[3] += m.u[c][1];
            assert!(mu1(&s, 2) < 0.0);
        }
    }
}
