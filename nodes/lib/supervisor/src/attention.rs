//! Attentional regulation (thesis Sec. 4.3.2, Table 5.3): the activation period λ from the
//! distance stimulus (eq. 4.8), magnitudes μ inherited top-down and raised by k per
//! accomplished sub-behaviour, emphasis e = μ/λ.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::state::State;
use crate::wm::{NodeKind, Wm};

/// Parameters of the attentional system. Defaults are the thesis's (Table 5.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SupervisorConfig {
    /// λ_min: shortest activation period (s).
    pub lambda_min_s: f64,
    /// λ_max: longest activation period (s).
    pub lambda_max_s: f64,
    /// r_min: distance at or below which λ = λ_min (m).
    pub r_min_m: f64,
    /// r_max: distance at or above which λ = λ_max (m).
    pub r_max_m: f64,
    /// k: magnitude increment per accomplished sub-behaviour.
    pub k: f64,
    /// The running action keeps its arm unless a competitor's emphasis exceeds its own by
    /// this fraction (0 = pure winner-takes-all every tick).
    pub hysteresis: f64,
    /// Name of the shared, mutually exclusive workspace area (Sec. 5.2.4).
    pub central_area: String,
    /// Failures of one action before its subtask is given up (left to the person).
    pub max_retries: u32,
    /// Deepest task tree `alive` expands (guards against runaway schemas).
    pub max_depth: usize,
}

impl Default for SupervisorConfig {
    fn default() -> Self {
        Self {
            lambda_min_s: 0.1,
            lambda_max_s: 1.0,
            r_min_m: 0.0,
            r_max_m: 2.0,
            k: 1.0,
            hysteresis: 0.1,
            central_area: "central".into(),
            max_retries: 3,
            max_depth: 16,
        }
    }
}

impl SupervisorConfig {
    /// Rejects non-finite and inconsistent values.
    pub fn validate(&self) -> Result<()> {
        let check = |name: &'static str, value: f64, ok: bool, reason: &'static str| {
            if value.is_finite() && ok { Ok(()) } else { Err(Error::InvalidParameter { name, value, reason }) }
        };
        check("lambda_min_s", self.lambda_min_s, self.lambda_min_s > 0.0, "must be > 0")?;
        check("lambda_max_s", self.lambda_max_s, self.lambda_max_s >= self.lambda_min_s, "must be >= lambda_min_s")?;
        check("r_min_m", self.r_min_m, self.r_min_m >= 0.0, "must be >= 0")?;
        check("r_max_m", self.r_max_m, self.r_max_m > self.r_min_m, "must be > r_min_m")?;
        check("k", self.k, self.k >= 0.0, "must be >= 0")?;
        check("hysteresis", self.hysteresis, self.hysteresis >= 0.0, "must be >= 0")?;
        if self.max_depth == 0 {
            return Err(Error::InvalidParameter { name: "max_depth", value: 0.0, reason: "must be >= 1" });
        }
        Ok(())
    }

    /// Eq. 4.8: activation period λ (s) for a distance stimulus σ (m); λ_max when unknown.
    pub fn lambda(&self, sigma_m: Option<f64>) -> f64 {
        let Some(s) = sigma_m.filter(|s| s.is_finite()) else { return self.lambda_max_s };
        if s <= self.r_min_m {
            self.lambda_min_s
        } else if s >= self.r_max_m {
            self.lambda_max_s
        } else {
            let alpha = (self.lambda_max_s - self.lambda_min_s) / (self.r_max_m - self.r_min_m);
            let beta = self.lambda_min_s - alpha * self.r_min_m;
            alpha * s + beta
        }
    }
}

/// Recomputes μ, λ, e, releaser values and enabling for the whole tree (pre-order).
///
/// μ(root) = 1 + k·n(root), μ(b) = μ(parent) + k·n(b) with n the accomplished sub-behaviours;
/// concrete nodes take λ from the distance of their target object for their arm; abstract nodes
/// take the smallest λ of their children (for display); e = μ/λ. A node is enabled when its
/// parent is and its releaser holds (subtasks stay enabled once started); actions need their
/// own releaser every time.
pub fn update(wm: &mut Wm, state: &State, cfg: &SupervisorConfig) {
    let order = wm.preorder();
    for &id in &order {
        let (pmu, penabled) = match wm.get(id).and_then(|n| n.parent).and_then(|p| wm.get(p)) {
            Some(p) => (p.mu, p.enabled),
            None => (1.0, true),
        };
        let Some(n) = wm.get_mut(id) else { continue };
        n.mu = pmu + cfg.k * f64::from(n.n_done);
        n.releaser_value = state.eval(&n.releaser);
        let latched = n.started && !matches!(n.kind, NodeKind::Action(_));
        n.enabled = penabled && (n.releaser_value || latched) && !n.human && !n.blocked;
        let concrete = matches!(n.kind, NodeKind::Subtask | NodeKind::Action(_));
        if concrete {
            let sigma = n.object.as_deref().and_then(|o| state.distance(o, n.arm));
            n.lambda = cfg.lambda(sigma);
            n.accessible = n.object.as_deref().is_none_or(|o| state.accessible(o, n.arm));
        } else {
            n.lambda = cfg.lambda_max_s;
            n.accessible = true;
        }
    }
    for &id in order.iter().rev() {
        let Some(n) = wm.get(id) else { continue };
        if !matches!(n.kind, NodeKind::Subtask | NodeKind::Action(_)) && !n.children.is_empty() {
            let l = n.children.iter().filter_map(|c| wm.get(*c)).map(|c| c.lambda).fold(f64::INFINITY, f64::min);
            if let Some(n) = wm.get_mut(id) {
                n.lambda = l.min(cfg.lambda_max_s);
            }
        }
        if let Some(n) = wm.get_mut(id) {
            n.emphasis = n.mu / n.lambda;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambda_eq_4_8() {
        let c = SupervisorConfig::default();
        assert_eq!(c.lambda(Some(0.0)), 0.1);
        assert_eq!(c.lambda(Some(-1.0)), 0.1);
        assert_eq!(c.lambda(Some(2.0)), 1.0);
        assert_eq!(c.lambda(Some(5.0)), 1.0);
        assert!((c.lambda(Some(1.0)) - 0.55).abs() < 1e-12);
        assert_eq!(c.lambda(None), 1.0);
        assert_eq!(c.lambda(Some(f64::NAN)), 1.0);
    }

    #[test]
    fn validate_rejects_bad() {
        let c = SupervisorConfig { lambda_min_s: f64::NAN, ..Default::default() };
        assert!(c.validate().is_err());
        let c = SupervisorConfig { r_max_m: 0.0, ..Default::default() };
        assert!(c.validate().is_err());
        assert!(SupervisorConfig::default().validate().is_ok());
    }
}
