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
    fn forward_backward(&self, logb: &[f64], t_len: usize) -> (f64, Vec<f64>, Vec<f64>) {
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
        let ll = logsumexp(&alpha[(t_len - 1) * l..]);
        let mut beta = vec![0.0; t_len * l];
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
            let (ll, g, xi) = self.forward_backward(&logb, t_len);
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
        let mut q = Vec::new();
        let mut i = self
            .prior
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map_or(0, |(i, _)| i);
        let mut visited = vec![false; l];
        loop {
            visited[i] = true;
            let aii = self.trans[i * l + i];
            let d = if aii < 1.0 - 1e-9 {
                1.0 / (1.0 - aii)
            } else {
                self.durations[i]
            };
            let d = d.round().max(1.0) as usize;
            q.extend(std::iter::repeat_n(i, d));
            let next = (0..l)
                .filter(|&j| j != i)
                .max_by(|a, b| self.trans[i * l + a].total_cmp(&self.trans[i * l + b]));
            match next {
                Some(j) if self.trans[i * l + j] > 0.0 && !visited[j] => i = j,
                _ => break,
            }
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
        let (_, gamma, _) = self.forward_backward(&logb, t_len);
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

    /// Incremental refinement (App. A.3.3): a weighted Baum–Welch on the new demonstration
    /// (weight `η`) and the trajectory generated by the current model (weight `1 − η`), starting
    /// from the current parameters; then the temporal terms are recomputed.
    pub fn refine(&mut self, demo: &Demonstration) -> Result<()> {
        check_dim("HMM refinement demonstration", self.dim, demo.dim)?;
        let generated = self.generate(None, self.dt)?;
        let seqs: Vec<&[f64]> = vec![demo.pos.as_slice(), generated.pos.as_slice()];
        let eta = self.config.forgetting;
        let weights = [eta, 1.0 - eta];
        let mut prev = f64::NEG_INFINITY;
        for _ in 0..self.config.max_iter {
            let (ll, _) = self.baum_welch_step(&seqs, &weights)?;
            if (ll - prev).abs() < self.config.tol * (demo.len() + generated.len()) as f64 {
                break;
            }
            prev = ll;
        }
        self.temporal_terms(&seqs, &weights)
    }

    /// [`refine`](Self::refine) for a correction that began `t_contact` s into `demo` (thesis
    /// Sec. 4.1.3: "the first seconds of the motion primitive, before the interaction, are left
    /// unchanged"): the states whose Viterbi run in `demo` (under the current model) ends before
    /// the contact keep their parameters (output, temporal terms, transitions, duration); the
    /// others are refined. Returns how many states were kept.
    pub fn refine_after(&mut self, demo: &Demonstration, t_contact: f64) -> Result<usize> {
        check_dim("HMM refinement demonstration", self.dim, demo.dim)?;
        if !t_contact.is_finite() {
            return Err(invalid("t_contact", "must be finite"));
        }
        let old = self.clone();
        let q = self.viterbi(&demo.pos)?;
        let t0 = demo.t.first().copied().unwrap_or(0.0);
        let mut last_index = vec![None; self.l()];
        for (k, &state) in q.iter().enumerate() {
            last_index[state] = Some(k);
        }
        let kept: Vec<usize> = (0..self.l())
            .filter(|&i| last_index[i].is_some_and(|k| demo.t[k] - t0 < t_contact))
            .collect();
        self.refine(demo)?;
        let l = self.l();
        for &i in &kept {
            self.states[i] = old.states[i].clone();
            self.trans[i * l..(i + 1) * l].copy_from_slice(&old.trans[i * l..(i + 1) * l]);
            self.durations[i] = old.durations[i];
            self.prior[i] = old.prior[i];
        }
        let ps: f64 = self.prior.iter().sum();
        if ps > 0.0 {
            self.prior.iter_mut().for_each(|p| *p /= ps);
        }
        Ok(kept.len())
    }
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
