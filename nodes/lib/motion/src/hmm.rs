//! HMM motion primitives (thesis Algorithm 3, App. A.3.3): left-to-right HMM with Gaussian
//! outputs learned by Baum–Welch, Viterbi state sequences, a normalised time variable per state,
//! smooth generation by GMR on time within each state (eq. A.26–A.30), and incremental
//! refinement with a forgetting factor (A.3.3). Forward–backward runs in log space.
//!
//! One Gaussian per state (`M = 1` in eq. A.25). Positions are in the unit of the data; time
//! steps are the demonstrations' mean sampling period.

use serde::{Deserialize, Serialize};

use crate::demo::{Demonstration, common_dim};
use crate::ds::Trajectory;
use crate::error::{MotionError, Result, check_dim, check_finite, invalid};
use crate::linalg::{LN_2PI, chol_logdet, cholesky, logsumexp, solve_lower};

/// Most samples (at the learned period) a generated trajectory may have: a model whose state
/// durations add up to more is refused rather than allocated.
pub const MAX_GENERATED_SAMPLES: usize = 1_000_000;

/// Learning settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HmmConfig {
    /// Number of hidden states `L`.
    pub states: usize,
    /// Baum–Welch iterations (at most).
    pub max_iter: usize,
    /// Stop when the mean per-sample log-likelihood improves by less than this.
    pub tol: f64,
    /// Added to the covariance diagonals.
    pub reg_covar: f64,
    /// Forgetting factor `η` of the incremental update (weight of the new demonstration).
    pub forgetting: f64,
}

impl Default for HmmConfig {
    fn default() -> Self {
        Self {
            states: 10,
            max_iter: 50,
            tol: 1e-6,
            reg_covar: 1e-6,
            forgetting: 0.5,
        }
    }
}

/// One state's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HmmState {
    /// Spatial mean `ˢµ`.
    pub mean: Vec<f64>,
    /// Spatial covariance `ˢˢΣ`, row-major.
    pub cov: Vec<f64>,
    /// Temporal mean `ᵗµ` (≈ 0.5).
    pub t_mean: f64,
    /// Temporal variance `ᵗᵗΣ`.
    pub t_var: f64,
    /// Cross covariance `ᵗˢΣ` (one value per spatial dimension).
    pub ts_cov: Vec<f64>,
}

/// A learned HMM primitive `λ = {π, A, µ, Σ}` plus the temporal terms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HmmPrimitive {
    /// Spatial dimension.
    pub dim: usize,
    /// Initial state probabilities.
    pub prior: Vec<f64>,
    /// Transition matrix, row-major `L × L` (left-to-right).
    pub trans: Vec<f64>,
    /// States.
    pub states: Vec<HmmState>,
    /// Mean state durations from the Viterbi sequences (samples), used for the absorbing state.
    pub durations: Vec<f64>,
    /// Sampling period of the demonstrations (s).
    pub dt: f64,
    /// Settings used.
    pub config: HmmConfig,
}

struct Emissions {
    chol: Vec<Vec<f64>>,
    norm: Vec<f64>,
}

impl HmmPrimitive {
    /// Checks an HMM primitive read from a file: at least one state, `prior` and `durations`
    /// of one value per state, `trans` of `L × L`, each state's mean, covariance and cross
    /// covariance of the dimension's sizes, every value finite, a positive sampling period.
    pub fn validate(&self) -> Result<()> {
        let (l, n) = (self.states.len(), self.dim);
        if l == 0 || n == 0 {
            return Err(invalid("states", format!("{l} states of dimension {n} (need at least one of each)")));
        }
        check_dim("prior (one per state)", l, self.prior.len())?;
        check_dim("trans (states × states)", l * l, self.trans.len())?;
        check_dim("durations (one per state)", l, self.durations.len())?;
        check_finite("prior", &self.prior)?;
        check_finite("trans", &self.trans)?;
        check_finite("durations", &self.durations)?;
        for (i, st) in self.states.iter().enumerate() {
            check_dim(&format!("states[{i}].mean"), n, st.mean.len())?;
            check_dim(&format!("states[{i}].cov"), n * n, st.cov.len())?;
            check_dim(&format!("states[{i}].ts_cov"), n, st.ts_cov.len())?;
            for (what, v) in [("mean", &st.mean), ("cov", &st.cov), ("ts_cov", &st.ts_cov)] {
                check_finite(&format!("states[{i}].{what}"), v)?;
            }
            if !(st.t_mean.is_finite() && st.t_var.is_finite() && st.t_var > 0.0) {
                return Err(invalid(&format!("states[{i}]"), "temporal mean / variance not finite or variance not positive"));
            }
        }
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(invalid("dt", format!("{} s (must be positive and finite)", self.dt)));
        }
        Ok(())
    }

    /// State dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }
    fn l(&self) -> usize {
        self.states.len()
    }

    /// Algorithm 3, learning part (steps 1–5).
    pub fn fit(demos: &[Demonstration], cfg: &HmmConfig) -> Result<Self> {
        let n = common_dim(demos)?;
        let l = cfg.states;
        if l == 0 {
            return Err(invalid("states", "must be at least 1"));
        }
        if !(cfg.forgetting > 0.0 && cfg.forgetting < 1.0) {
            return Err(invalid("forgetting", "must be in (0, 1)"));
        }
        for (i, d) in demos.iter().enumerate() {
            if d.len() < 2 * l {
                return Err(MotionError::TooFewSamples {
                    what: format!("HMM demonstration {i} ({l} states)"),
                    needed: 2 * l,
                    got: d.len(),
                });
            }
        }
        let seqs: Vec<&[f64]> = demos.iter().map(|d| d.pos.as_slice()).collect();
        let dt = demos
            .iter()
            .map(|d| d.duration() / (d.len() - 1) as f64)
            .sum::<f64>()
            / demos.len() as f64;
        // Step 1 initialisation: equal segments.
        let mut resp: Vec<Vec<f64>> = seqs
            .iter()
            .map(|s| {
                let t = s.len() / n;
                let mut g = vec![0.0; t * l];
                for k in 0..t {
                    g[k * l + (k * l / t).min(l - 1)] = 1.0;
                }
                g
            })
            .collect();
        let mut me = Self {
            dim: n,
            prior: (0..l).map(|i| if i == 0 { 1.0 } else { 0.0 }).collect(),
            trans: vec![0.0; l * l],
            states: vec![
                HmmState {
                    mean: vec![0.0; n],
                    cov: vec![0.0; n * n],
                    t_mean: 0.5,
                    t_var: 1.0 / 12.0,
                    ts_cov: vec![0.0; n]
                };
                l
            ],
            durations: vec![1.0; l],
            dt,
            config: cfg.clone(),
        };
        let mean_len = seqs.iter().map(|s| s.len() / n).sum::<usize>() as f64 / seqs.len() as f64;
        let stay = 1.0 - l as f64 / mean_len;
        for i in 0..l {
            if i + 1 < l {
                me.trans[i * l + i] = stay;
                me.trans[i * l + i + 1] = 1.0 - stay;
            } else {
                me.trans[i * l + i] = 1.0;
            }
        }
        me.m_step_emissions(&seqs, &[1.0; 64][..seqs.len().min(64)], &resp)?;
        // Step 2: Baum–Welch.
        let weights = vec![1.0; seqs.len()];
        let mut prev = f64::NEG_INFINITY;
        for _ in 0..cfg.max_iter {
            let (ll, r) = me.baum_welch_step(&seqs, &weights)?;
            resp = r;
            let mean_ll = ll / seqs.iter().map(|s| s.len() / n).sum::<usize>() as f64;
            if (mean_ll - prev).abs() < cfg.tol {
                break;
            }
            prev = mean_ll;
        }
        drop(resp);
        me.temporal_terms(&seqs, &weights)?;
        Ok(me)
    }

    fn emissions(&self) -> Result<Emissions> {
        let n = self.dim;
        let mut chol = Vec::new();
        let mut norm = Vec::new();
        for (i, s) in self.states.iter().enumerate() {
            let mut lc = vec![0.0; n * n];
            if !cholesky(&s.cov, n, &mut lc) {
                return Err(MotionError::SingularCovariance {
                    component: i,
                    context: format!("HMM state output {:?}", s.cov),
                });
            }
            norm.push(-0.5 * chol_logdet(&lc, n) - 0.5 * n as f64 * LN_2PI);
            chol.push(lc);
        }
        Ok(Emissions { chol, norm })
    }

    fn log_b(&self, e: &Emissions, x: &[f64], out: &mut [f64]) {
        let n = self.dim;
        let mut z = vec![0.0; n];
        for (i, s) in self.states.iter().enumerate() {
            for j in 0..n {
                z[j] = x[j] - s.mean[j];
            }
            solve_lower(&e.chol[i], n, &mut z);
            out[i] = e.norm[i] - 0.5 * z.iter().map(|v| v * v).sum::<f64>();
        }
    }

    /// Forward–backward in log space on emission log-likelihoods `logb` (`T × L`): returns the
    /// log-likelihood, `γ` (`T × L`) and the expected transition counts (`L × L`). Log space keeps
    /// it exact when every reachable state is far from a sample (no underflow floor needed).
    /// With `end`, only state sequences that end in that state count.
    fn forward_backward(&self, logb: &[f64], t_len: usize, end: Option<usize>) -> (f64, Vec<f64>, Vec<f64>) {
        let l = self.l();
        let ln = |p: f64| if p > 0.0 { p.ln() } else { f64::NEG_INFINITY };
        let la: Vec<f64> = self.trans.iter().map(|&p| ln(p)).collect();
        let lp: Vec<f64> = self.prior.iter().map(|&p| ln(p)).collect();
        let mut alpha = vec![f64::NEG_INFINITY; t_len * l];
        let mut tmp = vec![0.0; l];
        for j in 0..l {
            alpha[j] = lp[j] + logb[j];
        }
        for t in 1..t_len {
            for j in 0..l {
                for i in 0..l {
                    tmp[i] = alpha[(t - 1) * l + i] + la[i * l + j];
                }
                alpha[t * l + j] = logsumexp(&tmp) + logb[t * l + j];
            }
        }
        let mut beta = vec![0.0; t_len * l];
        if let Some(e) = end {
            for j in 0..l {
                if j != e {
                    alpha[(t_len - 1) * l + j] = f64::NEG_INFINITY;
                    beta[(t_len - 1) * l + j] = f64::NEG_INFINITY;
                }
            }
        }
        let ll = logsumexp(&alpha[(t_len - 1) * l..]);
        for t in (0..t_len - 1).rev() {
            for i in 0..l {
                for j in 0..l {
                    tmp[j] = la[i * l + j] + logb[(t + 1) * l + j] + beta[(t + 1) * l + j];
                }
                beta[t * l + i] = logsumexp(&tmp);
            }
        }
        let mut gamma = vec![0.0; t_len * l];
        for t in 0..t_len {
            for i in 0..l {
                tmp[i] = alpha[t * l + i] + beta[t * l + i];
            }
            let z = logsumexp(&tmp);
            for i in 0..l {
                gamma[t * l + i] = if z.is_finite() {
                    (tmp[i] - z).exp()
                } else {
                    0.0
                };
            }
        }
        let mut xi = vec![0.0; l * l];
        if ll.is_finite() {
            for t in 0..t_len.saturating_sub(1) {
                for i in 0..l {
                    if alpha[t * l + i] == f64::NEG_INFINITY {
                        continue;
                    }
                    for j in 0..l {
                        let v = alpha[t * l + i]
                            + la[i * l + j]
                            + logb[(t + 1) * l + j]
                            + beta[(t + 1) * l + j]
                            - ll;
                        if v > -745.0 {
                            xi[i * l + j] += v.exp();
                        }
                    }
                }
            }
        }
        (ll, gamma, xi)
    }

    /// One weighted Baum–Welch iteration; returns the log-likelihood before the update and `γ`.
    fn baum_welch_step(
        &mut self,
        seqs: &[&[f64]],
        weights: &[f64],
    ) -> Result<(f64, Vec<Vec<f64>>)> {
        let (n, l) = (self.dim, self.l());
        let e = self.emissions()?;
        let mut total_ll = 0.0;
        let mut gammas = Vec::new();
        let mut prior = vec![0.0; l];
        let mut num = vec![0.0; l * l];
        let mut den = vec![0.0; l];
        for (s, w) in seqs.iter().zip(weights) {
            let t_len = s.len() / n;
            let mut logb = vec![0.0; t_len * l];
            for t in 0..t_len {
                self.log_b(&e, &s[t * n..(t + 1) * n], &mut logb[t * l..(t + 1) * l]);
            }
            let (ll, g, xi) = self.forward_backward(&logb, t_len, None);
            total_ll += w * ll;
            for i in 0..l {
                prior[i] += w * g[i];
                for t in 0..t_len - 1 {
                    den[i] += w * g[t * l + i];
                }
                for j in 0..l {
                    num[i * l + j] += w * xi[i * l + j];
                }
            }
            gammas.push(g);
        }
        let ps: f64 = prior.iter().sum();
        if ps > 0.0 && ps.is_finite() {
            self.prior = prior.iter().map(|p| p / ps).collect();
        }
        for i in 0..l {
            let rs: f64 = (0..l).map(|j| num[i * l + j]).sum();
            if den[i] > 0.0 && rs > 0.0 && rs.is_finite() {
                for j in 0..l {
                    self.trans[i * l + j] = num[i * l + j] / rs;
                }
            }
        }
        self.m_step_emissions(seqs, weights, &gammas)?;
        Ok((total_ll, gammas))
    }

    fn m_step_emissions(
        &mut self,
        seqs: &[&[f64]],
        weights: &[f64],
        gammas: &[Vec<f64>],
    ) -> Result<()> {
        let (n, l) = (self.dim, self.l());
        for i in 0..l {
            let mut w_sum = 0.0;
            let mut mean = vec![0.0; n];
            for ((s, w), g) in seqs.iter().zip(weights).zip(gammas) {
                for t in 0..s.len() / n {
                    let r = w * g[t * l + i];
                    w_sum += r;
                    for j in 0..n {
                        mean[j] += r * s[t * n + j];
                    }
                }
            }
            if !(w_sum > 1e-12) || !w_sum.is_finite() {
                continue; // keep the previous parameters of an unvisited state
            }
            mean.iter_mut().for_each(|m| *m /= w_sum);
            let mut cov = vec![0.0; n * n];
            for ((s, w), g) in seqs.iter().zip(weights).zip(gammas) {
                for t in 0..s.len() / n {
                    let r = w * g[t * l + i];
                    for a in 0..n {
                        for b in 0..n {
                            cov[a * n + b] +=
                                r * (s[t * n + a] - mean[a]) * (s[t * n + b] - mean[b]);
                        }
                    }
                }
            }
            for a in 0..n {
                for b in 0..n {
                    cov[a * n + b] /= w_sum;
                }
                cov[a * n + a] += self.config.reg_covar;
            }
            self.states[i].mean = mean;
            self.states[i].cov = cov;
        }
        Ok(())
    }

    /// Most likely state sequence (log-space Viterbi).
    pub fn viterbi(&self, seq: &[f64]) -> Result<Vec<usize>> {
        let (n, l) = (self.dim, self.l());
        if !seq.len().is_multiple_of(n) || seq.is_empty() {
            return Err(MotionError::DimensionMismatch {
                what: "HMM sequence length vs dimension".into(),
                expected: n,
                got: seq.len() % n,
            });
        }
        check_finite("HMM sequence", seq)?;
        let e = self.emissions()?;
        let t_len = seq.len() / n;
        let ln = |p: f64| if p > 0.0 { p.ln() } else { f64::NEG_INFINITY };
        let mut delta = vec![0.0; l];
        let mut back = vec![0usize; t_len * l];
        let mut lb = vec![0.0; l];
        self.log_b(&e, &seq[..n], &mut lb);
        for i in 0..l {
            delta[i] = ln(self.prior[i]) + lb[i];
        }
        for t in 1..t_len {
            self.log_b(&e, &seq[t * n..(t + 1) * n], &mut lb);
            let mut nd = vec![f64::NEG_INFINITY; l];
            for j in 0..l {
                for i in 0..l {
                    let v = delta[i] + ln(self.trans[i * l + j]);
                    if v > nd[j] {
                        nd[j] = v;
                        back[t * l + j] = i;
                    }
                }
                nd[j] += lb[j];
            }
            delta = nd;
        }
        let mut q = vec![0usize; t_len];
        q[t_len - 1] = (0..l)
            .max_by(|a, b| delta[*a].total_cmp(&delta[*b]))
            .unwrap_or(0);
        for t in (1..t_len).rev() {
            q[t - 1] = back[t * l + q[t]];
        }
        Ok(q)
    }

    /// Relative time in each run of equal states: `(k + ½)/d` for the k-th of d samples.
    fn relative_time(q: &[usize]) -> Vec<f64> {
        let mut out = vec![0.0; q.len()];
        let mut start = 0;
        for t in 1..=q.len() {
            if t == q.len() || q[t] != q[start] {
                let d = (t - start) as f64;
                for k in start..t {
                    out[k] = ((k - start) as f64 + 0.5) / d;
                }
                start = t;
            }
        }
        out
    }

    /// Steps 3–5: Viterbi sequences, relative time, and the temporal/cross covariances.
    fn temporal_terms(&mut self, seqs: &[&[f64]], weights: &[f64]) -> Result<()> {
        let (n, l) = (self.dim, self.l());
        let mut acc = vec![(0.0, 0.0, 0.0, vec![0.0; n], vec![0.0; n]); l]; // w, Σw·t, Σw·t², Σw·s, Σw·t·s
        let mut runs = vec![(0.0, 0.0); l];
        for (s, w) in seqs.iter().zip(weights) {
            let q = self.viterbi(s)?;
            let to = Self::relative_time(&q);
            for t in 0..q.len() {
                let a = &mut acc[q[t]];
                a.0 += w;
                a.1 += w * to[t];
                a.2 += w * to[t] * to[t];
                for j in 0..n {
                    a.3[j] += w * s[t * n + j];
                    a.4[j] += w * to[t] * s[t * n + j];
                }
                if t == 0 || q[t] != q[t - 1] {
                    runs[q[t]].1 += w;
                }
                runs[q[t]].0 += w;
            }
        }
        for i in 0..l {
            let (w, st, stt, ss, sts) = &acc[i];
            if *w <= 0.0 {
                continue;
            }
            let tm = st / w;
            let st_state = &mut self.states[i];
            st_state.t_mean = tm;
            st_state.t_var = (stt / w - tm * tm).max(1e-6);
            for j in 0..n {
                st_state.ts_cov[j] = sts[j] / w - tm * ss[j] / w;
            }
            if runs[i].1 > 0.0 {
                self.durations[i] = runs[i].0 / runs[i].1;
            }
        }
        Ok(())
    }

    /// Algorithm 3, generation part (steps 6–10), at the learned sampling period, resampled to
    /// `dt`; translated so that it starts at `start` when given.
    pub fn generate(&self, start: Option<&[f64]>, dt: f64) -> Result<Trajectory> {
        if !(dt > 0.0) || !dt.is_finite() {
            return Err(invalid("dt", "must be finite and > 0"));
        }
        let (n, l) = (self.dim, self.l());
        // Step 6: deterministic state sequence.
        let order = self.visiting_order();
        let runs: Vec<f64> = order.iter().map(|&i| self.expected_duration(i).round().max(1.0)).collect();
        let samples: f64 = runs.iter().sum();
        if !(samples <= MAX_GENERATED_SAMPLES as f64) {
            return Err(invalid(
                "durations / trans",
                format!("the state durations add up to {samples:.3e} samples (at most {MAX_GENERATED_SAMPLES})"),
            ));
        }
        let mut q = Vec::with_capacity(samples as usize);
        for (&i, &d) in order.iter().zip(&runs) {
            q.extend(std::iter::repeat_n(i, d as usize));
        }
        // Step 7–8: relative time and responsibilities from the temporal model.
        let to = Self::relative_time(&q);
        let t_len = q.len();
        let mut logb = vec![0.0; t_len * l];
        for t in 0..t_len {
            for (k, s) in self.states.iter().enumerate() {
                let z = to[t] - s.t_mean;
                logb[t * l + k] = -0.5 * (LN_2PI + s.t_var.ln()) - 0.5 * z * z / s.t_var;
            }
        }
        // Q ends in its last state: so do the responsibilities (a free end smears the last states'
        // outputs into the end point).
        let (ll, gamma, _) = self.forward_backward(&logb, t_len, q.last().copied());
        if !ll.is_finite() {
            return Err(invalid("prior / trans", "no state sequence of the generated length ends in its last state"));
        }
        // Step 9–10. Each state's time variable is extended linearly beyond its own run in Q
        // (`(t − start_k + ½)/d_k`), so that `ˢo_k(t)` is continuous in t; with the literal
        // per-run `ᵗo(t)`, which jumps from ≈1 to ≈0 at every state change, the mixture A.30 jumps
        // wherever the responsibilities overlap.
        let mut run = vec![(0usize, 0usize); l];
        for (t, &k) in q.iter().enumerate() {
            if run[k].1 == 0 {
                run[k].0 = t;
            }
            run[k].1 += 1;
        }
        let mut pos = vec![0.0; t_len * n];
        for t in 0..t_len {
            for (k, s) in self.states.iter().enumerate() {
                let g = gamma[t * l + k];
                if g == 0.0 {
                    continue;
                }
                let tk = if run[k].1 > 0 {
                    (t as f64 - run[k].0 as f64 + 0.5) / run[k].1 as f64
                } else {
                    s.t_mean
                };
                for j in 0..n {
                    pos[t * n + j] += g * (s.mean[j] + s.ts_cov[j] / s.t_var * (tk - s.t_mean));
                }
            }
        }
        if let Some(x0) = start {
            check_dim("HMM start", n, x0.len())?;
            let off: Vec<f64> = (0..n).map(|j| x0[j] - pos[j]).collect();
            for t in 0..t_len {
                for j in 0..n {
                    pos[t * n + j] += off[j];
                }
            }
        }
        // Resample to dt by linear interpolation.
        let duration = (t_len - 1) as f64 * self.dt;
        let m = (duration / dt).floor() as usize + 1;
        let mut tr = Trajectory {
            dim: n,
            ..Default::default()
        };
        for k in 0..m {
            let tt = k as f64 * dt;
            let f = (tt / self.dt).min((t_len - 1) as f64);
            let a = f.floor() as usize;
            let b = (a + 1).min(t_len - 1);
            let w = f - a as f64;
            tr.t.push(tt);
            for j in 0..n {
                tr.pos.push((1.0 - w) * pos[a * n + j] + w * pos[b * n + j]);
            }
        }
        tr.vel = crate::demo::finite_differences(n, &tr.t, &tr.pos);
        tr.reached = true;
        Ok(tr)
    }

    /// Expected number of samples the model stays in state `i` (unrounded): `1/(1 − aᵢᵢ)`, or
    /// the learned duration of an absorbing state. Generation (step 6) rounds it.
    fn expected_duration(&self, i: usize) -> f64 {
        let aii = self.trans[i * self.l() + i];
        if aii < 1.0 - 1e-9 { 1.0 / (1.0 - aii) } else { self.durations[i] }
    }

    /// The states in the order generation (step 6) visits them.
    fn visiting_order(&self) -> Vec<usize> {
        let l = self.l();
        let mut order = Vec::with_capacity(l);
        let mut i = self.prior.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map_or(0, |(i, _)| i);
        loop {
            order.push(i);
            let next = (0..l).filter(|&j| j != i).max_by(|a, b| self.trans[i * l + a].total_cmp(&self.trans[i * l + b]));
            match next {
                Some(j) if self.trans[i * l + j] > 0.0 && !order.contains(&j) => i = j,
                _ => return order,
            }
        }
    }

    /// Incremental refinement (App. A.3.3) with a whole new demonstration: see
    /// [`refine_after`](Self::refine_after); here no state is kept.
    pub fn refine(&mut self, demo: &Demonstration) -> Result<()> {
        check_dim("HMM refinement demonstration", self.dim, demo.dim)?;
        self.refine_from(demo, 0).map(|_| ())
    }

    /// Incremental refinement (App. A.3.3) with a correction that began `t_contact` s into
    /// `demo` (thesis Sec. 4.1.3: "the first seconds of the motion primitive, before the
    /// interaction, are left unchanged"). Returns how many states were kept.
    ///
    /// The thesis blends the new demonstration (weight `η`) with the trajectory generated by the
    /// current model (weight `1 − η`) in one weighted re-estimation. Here:
    /// - **Alignment.** The demonstration is an execution of this model (or a motion of the same
    ///   structure): its samples are laid on the model's state timeline by time, scaled to the
    ///   model's length (states in generation order, each as long as its expected duration) —
    ///   a linear time warp. Forward–backward (or Viterbi) under the current model cannot align
    ///   a correction that leaves the states by many standard deviations: the corrected end
    ///   never reaches the last state, the states after the contact become absorbing or
    ///   unvisited, and the goal does not move (seen in the graph with a 17 cm correction); and
    ///   on the part before the contact it follows the corners the smooth reproduction cuts, so
    ///   the refined states' durations drift.
    /// - **Kept states.** States whose samples all lie before the contact keep every parameter
    ///   (output, temporal terms, transition row, duration), and so does the state active at
    ///   the contact when at least half of its samples lie before it: refining it would bend the
    ///   motion before the contact too (the generated path mixes neighbouring states).
    /// - **Blend.** Each other state's joint (time, position) moments become the mixture of the
    ///   demonstration samples aligned to it (weight `η`) and its current moments — which are
    ///   what the generated trajectory has in that state — (weight `1 − η`): so its mean moves
    ///   exactly `η` of the way to the demonstration's, whatever the two sample counts. Its
    ///   expected duration is blended the same way and sets the self-transition (the successor
    ///   keeps the rest; the last state stays absorbing).
    pub fn refine_after(&mut self, demo: &Demonstration, t_contact: f64) -> Result<usize> {
        check_dim("HMM refinement demonstration", self.dim, demo.dim)?;
        if !t_contact.is_finite() {
            return Err(invalid("t_contact", "must be finite"));
        }
        let t0 = demo.t.first().copied().unwrap_or(0.0);
        let before = demo.t.iter().take_while(|&&t| t - t0 < t_contact).count();
        self.refine_from(demo, before)
    }

    /// The refinement of [`refine_after`](Self::refine_after) with the first `before` samples of
    /// `demo` before the contact.
    fn refine_from(&mut self, demo: &Demonstration, before: usize) -> Result<usize> {
        let n = self.dim;
        let t_len = demo.len();
        if t_len < 2 {
            return Err(MotionError::TooFewSamples { what: "HMM refinement demonstration".into(), needed: 2, got: t_len });
        }
        check_finite("HMM refinement demonstration", &demo.pos)?;
        let eta = self.config.forgetting;
        // Model samples per demonstration sample.
        let ratio = demo.duration() / (t_len - 1) as f64 / self.dt;
        if !(ratio.is_finite() && ratio > 0.0) {
            return Err(invalid("HMM refinement demonstration", "times must increase"));
        }
        // Alignment: the demonstration's time, scaled to the model's length, on the model's
        // state timeline (expected durations in generation order).
        let order = self.visiting_order();
        let budget: Vec<f64> = order.iter().map(|&i| self.expected_duration(i)).collect();
        let total: f64 = budget.iter().sum();
        let mut q = Vec::with_capacity(t_len);
        let (mut k, mut edge) = (0, budget[0]);
        for j in 0..t_len {
            let u = (j as f64 + 0.5) / t_len as f64 * total;
            while u > edge && k + 1 < budget.len() {
                k += 1;
                edge += budget[k];
            }
            q.push(k);
        }
        // States before the contact are kept, and so is the one active at it when at least half
        // of its samples lie before it (the motion before the contact stays as it was); the
        // others are refined.
        let first = match q.get(before) {
            Some(&k) => {
                let run = q.iter().filter(|&&s| s == k).count();
                let done = q[..before].iter().filter(|&&s| s == k).count();
                if 2 * done >= run { k + 1 } else { k }
            }
            None => order.len(),
        };
        let q: Vec<usize> = q.into_iter().map(|k| order[k]).collect();
        // Blend of each refined state: joint moments of z = (relative time, position).
        let l = self.l();
        let m = n + 1;
        for &i in &order[first..] {
            let Some(start) = q.iter().position(|&s| s == i) else {
                continue; // no demonstration sample: the state stays as it is
            };
            let len = q[start..].iter().take_while(|&&s| s == i).count();
            let (d_mean, d_cov) = run_moments(demo, start, len);
            let (o_mean, o_cov) = state_moments(&self.states[i]);
            let mean: Vec<f64> = (0..m).map(|a| eta * d_mean[a] + (1.0 - eta) * o_mean[a]).collect();
            let mut cov = vec![0.0; m * m];
            for a in 0..m {
                for b in 0..m {
                    cov[a * m + b] = eta * (d_cov[a * m + b] + (d_mean[a] - mean[a]) * (d_mean[b] - mean[b]))
                        + (1.0 - eta) * (o_cov[a * m + b] + (o_mean[a] - mean[a]) * (o_mean[b] - mean[b]));
                }
            }
            let duration = (eta * len as f64 * ratio + (1.0 - eta) * self.expected_duration(i)).max(1.0);
            let st = &mut self.states[i];
            st.t_mean = mean[0];
            st.t_var = cov[0].max(1e-6);
            st.mean.copy_from_slice(&mean[1..]);
            for a in 0..n {
                st.ts_cov[a] = cov[1 + a];
                for b in 0..n {
                    st.cov[a * n + b] = cov[(1 + a) * m + 1 + b];
                }
                st.cov[a * n + a] += self.config.reg_covar;
            }
            self.durations[i] = duration;
            let row = &mut self.trans[i * l..(i + 1) * l];
            let leave: f64 = row.iter().enumerate().filter(|&(j, _)| j != i).map(|(_, p)| p).sum();
            if leave > 0.0 {
                let stay = 1.0 - 1.0 / duration;
                for (j, p) in row.iter_mut().enumerate() {
                    *p = if j == i { stay } else { *p / leave * (1.0 - stay) };
                }
            }
        }
        Ok(first)
    }
}

/// Mean and covariance (population) of z = (relative time, position) over samples
/// `start..start + len` of `demo`, one run of a state: relative time `(k + ½)/len`.
fn run_moments(demo: &Demonstration, start: usize, len: usize) -> (Vec<f64>, Vec<f64>) {
    let n = demo.dim;
    let m = n + 1;
    let z_at = |k: usize, z: &mut [f64]| {
        z[0] = (k as f64 + 0.5) / len as f64;
        z[1..].copy_from_slice(demo.position(start + k));
    };
    let mut z = vec![0.0; m];
    let mut mean = vec![0.0; m];
    for k in 0..len {
        z_at(k, &mut z);
        mean.iter_mut().zip(&z).for_each(|(a, v)| *a += v / len as f64);
    }
    let mut cov = vec![0.0; m * m];
    for k in 0..len {
        z_at(k, &mut z);
        for a in 0..m {
            for b in 0..m {
                cov[a * m + b] += (z[a] - mean[a]) * (z[b] - mean[b]) / len as f64;
            }
        }
    }
    (mean, cov)
}

/// A state's parameters as the mean and covariance of z = (relative time, position).
fn state_moments(st: &HmmState) -> (Vec<f64>, Vec<f64>) {
    let n = st.mean.len();
    let m = n + 1;
    let mut mean = vec![st.t_mean];
    mean.extend_from_slice(&st.mean);
    let mut cov = vec![0.0; m * m];
    cov[0] = st.t_var;
    for a in 0..n {
        cov[1 + a] = st.ts_cov[a];
        cov[(1 + a) * m] = st.ts_cov[a];
        for b in 0..n {
            cov[(1 + a) * m + 1 + b] = st.cov[a * n + b];
        }
    }
    (mean, cov)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn demo(scale: f64) -> Demonstration {
        let t: Vec<f64> = (0..150).map(|i| i as f64 * 0.01).collect();
        let pos = t
            .iter()
            .flat_map(|t| [scale * (2.0 * t).sin(), t * t])
            .collect();
        Demonstration::new(2, t, pos, None).expect("demo")
    }

    #[test]
    fn learns_and_generates_a_smooth_copy() {
        let demos = [demo(1.0), demo(1.05), demo(0.95)];
        let hmm = HmmPrimitive::fit(
            &demos,
            &HmmConfig {
                states: 8,
                ..Default::default()
            },
        )
        .expect("fit");
        // Left-to-right structure is kept.
        let l = hmm.states.len();
        for i in 0..l {
            for j in 0..i {
                assert_eq!(hmm.trans[i * l + j], 0.0);
            }
        }
        let tr = hmm.generate(Some(demos[0].position(0)), 0.01).expect("gen");
        // Similar duration and the generated path stays near the demonstration (DTW-aligned).
        assert!(
            (tr.t[tr.len() - 1] - demos[0].duration()).abs() < 0.3,
            "{}",
            tr.t[tr.len() - 1]
        );
        let d = crate::dtw::dtw_distance(&tr.pos, &demos[0].pos, 2, None).expect("dtw")
            / (tr.len() as f64).sqrt();
        // A.28 responsibilities smear neighbouring states (weak; see the crate notes).
        assert!(d < 0.2, "per-sample distance {d}");
        // Smooth: no step larger than a few demo steps.
        let max_step = (1..tr.len())
            .map(|i| {
                (0..2)
                    .map(|j| (tr.position(i)[j] - tr.position(i - 1)[j]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max);
        assert!(max_step < 0.1, "{max_step}");
    }

    #[test]
    fn refinement_after_a_contact_keeps_the_states_before_it() {
        let cfg = HmmConfig { states: 6, forgetting: 0.6, ..Default::default() };
        let mut hmm = HmmPrimitive::fit(&[demo(1.0)], &cfg).expect("fit");
        let old = hmm.clone();
        // The same motion until 0.75 s, then bent away.
        let base = demo(1.0);
        let pos: Vec<f64> = base
            .t
            .iter()
            .zip(base.pos.chunks(2))
            .flat_map(|(t, p)| [p[0] + 0.5 * (t - 0.75).max(0.0), p[1]])
            .collect();
        let bent = Demonstration::new(2, base.t.clone(), pos, None).expect("demo");
        let kept = hmm.refine_after(&bent, 0.75).expect("refine");
        assert!((2..6).contains(&kept), "{kept} states kept");
        for i in 0..kept {
            assert_eq!(hmm.states[i], old.states[i], "state {i} before the contact");
        }
        assert!((kept..6).any(|i| hmm.states[i].mean != old.states[i].mean), "the states after it follow the correction");
        assert!(hmm.refine_after(&bent, f64::NAN).is_err());
    }

    /// A correction far outside the states' spread (the graph's 17 cm push to g′): each
    /// refinement moves the generated end `η` of the way to the corrected end, the motion keeps
    /// its duration and no state but the last becomes absorbing.
    #[test]
    fn a_far_correction_moves_the_goal_by_the_forgetting_factor_each_round() {
        let eta = 0.6;
        let cfg = HmmConfig { states: 7, forgetting: eta, ..Default::default() };
        let base = demo(1.0);
        let mut hmm = HmmPrimitive::fit(&[base.clone(), demo(1.02), demo(0.98)], &cfg).expect("fit");
        let shift = [0.8, -0.5];
        let pos: Vec<f64> = base
            .t
            .iter()
            .zip(base.pos.chunks(2))
            .flat_map(|(t, p)| {
                let s = ((t - 0.6) / 0.8).clamp(0.0, 1.0);
                let m = s * s * (3.0 - 2.0 * s);
                [p[0] + shift[0] * m, p[1] + shift[1] * m]
            })
            .collect();
        let bent = Demonstration::new(2, base.t.clone(), pos, None).expect("demo");
        let new_end = bent.position(bent.len() - 1).to_vec();
        let end = |h: &HmmPrimitive| {
            let tr = h.generate(None, 0.01).expect("gen");
            (tr.position(tr.len() - 1).to_vec(), tr.t[tr.len() - 1])
        };
        let dist = |a: &[f64], b: &[f64]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
        let (end0, duration0) = end(&hmm);
        let mut previous = dist(&end0, &new_end);
        assert!(previous > 0.5, "{previous}");
        for round in 1..=3 {
            let kept = hmm.refine_after(&bent, 0.6).expect("refine");
            assert!((1..7).contains(&kept), "round {round}: {kept} kept");
            let (e, duration) = end(&hmm);
            let d = dist(&e, &new_end);
            eprintln!("round {round}: {kept} kept, generated end {previous:.3} -> {d:.3} from the corrected end, {duration:.2} s");
            // At least η of the remaining distance (less 0.1 for the GMR smear of the last states).
            assert!(d < (1.1 - eta) * previous + 0.02, "round {round}: {previous} -> {d}");
            assert!((duration - duration0).abs() < 0.1 * duration0, "round {round}: {duration0} s -> {duration} s");
            let l = hmm.states.len();
            for i in 0..l - 1 {
                assert!(hmm.trans[i * l + i] < 0.99, "round {round}: state {i} stays {}", hmm.trans[i * l + i]);
            }
            hmm.validate().expect("valid");
            previous = d;
        }
        assert!(previous < 0.1, "{previous}");
    }

    #[test]
    fn a_model_no_state_sequence_can_run_is_refused_not_generated_as_zeros() {
        let mut hmm = HmmPrimitive::fit(&[demo(1.0)], &HmmConfig { states: 4, ..Default::default() }).expect("fit");
        hmm.prior = vec![0.0; 4];
        hmm.validate().expect("finite, so it passes the structural check");
        assert!(hmm.generate(None, 0.01).is_err());
    }

    #[test]
    fn refinement_blends_the_new_demo_with_the_forgetting_factor() {
        let eta = 0.7;
        let mut hmm = HmmPrimitive::fit(
            &[demo(1.0)],
            &HmmConfig {
                states: 6,
                forgetting: eta,
                ..Default::default()
            },
        )
        .expect("fit");
        let peak = |h: &HmmPrimitive| {
            h.states
                .iter()
                .map(|s| s.mean[0])
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let before = peak(&hmm);
        hmm.refine(&demo(1.5)).expect("refine");
        let after = peak(&hmm);
        // The x amplitude of the states moves from ≈1.0 to ≈ η·1.5 + (1 − η)·1.0.
        let want = eta * 1.5 + (1.0 - eta) * before;
        assert!(
            (after - want).abs() < 0.1,
            "peak {before} -> {after}, expected ≈ {want}"
        );
        assert!(hmm.generate(None, 0.01).expect("gen").len() > 100);
    }
}
