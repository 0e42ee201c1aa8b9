//! Learned primitives of `cowork_motion` (DMP eq. 3.3–3.4, GMR-DS eq. 3.6–3.7, C-GMR
//! Algorithm 1, HMM Algorithm 3) as [`cowork_ds::LearnedField`]s, decoded from
//! `MotionCommand.parameters_json`.
//!
//! `parameters_json` holds either a model as `cowork_motion::Model::save` writes it (an object
//! with `"kind": "dmp" | "gmr" | "cgmr" | "hmm"`), or `{"model_file": "NAME"}` naming such a file inside
//! the configured primitive directory ([`ModelFiles`]). The model must be 3-D (TCP position, m,
//! base frame) and is checked completely when it is read (`cowork_motion::Model::validate`:
//! array lengths, finiteness, gains), so nothing a peer sends can make the real-time step index
//! out of bounds. An HMM's path is generated here, once, at [`HMM_SAMPLE_S`] (its length bounded
//! by [`HMM_MAX_DURATION_S`] before anything is generated) and tracked by
//! [`cowork_ds::PathTracker`] (Sec. 4.1.3). Decoding allocates (ROS side); the fields' `reset`
//! and `velocity` do not (real-time side).

use std::io::Read as _;
use std::path::{Component, Path, PathBuf};

use cowork_ds::{LearnedField, PathTracker};
use cowork_motion::dmp::Dmp;
use cowork_motion::model::Model;
use cowork_motion::{Cgmr, GmrDs};
use nalgebra::Vector3;

/// A decoded learned primitive.
#[derive(Debug)]
pub enum Learned {
    /// ẋ = f_GMR(x − g) (the learned field translated to the goal, eq. 5.2).
    Gmr(GmrDs),
    /// C-GMR with its activation ω and clock (eq. 3.13–3.14).
    Cgmr(CgmrField),
    /// DMP driven by the measured position (see [`DmpField`]).
    Dmp(DmpField),
    /// The path an HMM generated, translated to the start and tracked with position feedback,
    /// with its null-space (elbow) path if the command carried one.
    Hmm(HmmField),
}

/// An HMM end-effector path and, optionally, an HMM null-space path (thesis Sec. 4.1.1, Fig.
/// 4.1): the origin of `link` follows the second path on the first one's clock, in the
/// end-effector task's null space. The null-space path starts where that origin is and the
/// translation fades with [`NULL_SPACE_SETTLE_S`]: the elbow then runs where it was taught (an
/// obstacle it was taught to avoid stays where it is, wherever the previous motion left the
/// elbow), without a jump at the start.
#[derive(Debug)]
pub struct HmmField {
    /// The end-effector (tool) path.
    pub end_effector: PathTracker,
    /// The null-space path: the link (model index) and its path.
    pub null_space: Option<(usize, PathTracker)>,
    /// Translation of the null-space path at its start (m), once the first step set it.
    start_offset: Option<Vector3<f64>>,
}

/// Time constant (s of path time) with which the null-space path's start translation fades.
pub const NULL_SPACE_SETTLE_S: f64 = 0.5;

/// Sampling of an HMM's generated path (s).
pub const HMM_SAMPLE_S: f64 = 0.01;

/// Longest HMM path the controller generates (s): a model whose expected state durations add up
/// to more is refused before its path is generated (a peer cannot make the node allocate
/// without bound).
pub const HMM_MAX_DURATION_S: f64 = 600.0;

/// The HMM's generated path as a tracker (see the module docs).
fn hmm_path(m: &cowork_motion::hmm::HmmPrimitive) -> Result<PathTracker, String> {
    let l = m.states.len();
    // Upper bound of the generated length: every state's expected stay (samples), as
    // `HmmPrimitive::generate` computes it, whether or not the state sequence visits it.
    let samples: f64 = (0..l)
        .map(|i| {
            let aii = m.trans[i * l + i];
            let d = if aii < 1.0 - 1e-9 { 1.0 / (1.0 - aii) } else { m.durations[i] };
            d.round().max(1.0)
        })
        .sum();
    let duration = samples * m.dt;
    if !(duration <= HMM_MAX_DURATION_S) {
        return Err(format!(
            "the HMM's expected state durations add up to {duration:.1} s (at most {HMM_MAX_DURATION_S} s)"
        ));
    }
    let tr = m.generate(None, HMM_SAMPLE_S).map_err(|e| format!("the HMM generates no path: {e}"))?;
    PathTracker::from_flat(&tr.pos, &tr.vel, HMM_SAMPLE_S, cowork_ds::tracker::DEFAULT_GAIN)
        .map_err(|e| format!("the HMM's generated path: {e}"))
}

/// C-GMR state: activation ω and time since the start of the motion.
#[derive(Debug)]
pub struct CgmrField {
    model: Cgmr,
    omega: f64,
    t: f64,
    started: bool,
}

/// A DMP whose transformation system is fed the measured TCP position x (so modulation and
/// saturation deviations are corrected) and integrates its own scaled velocity v and phase s:
/// v̇ = K(g − x) − D v − K(g − x₀)s + K f(s), ṡ = −γ s; ẋ_desired = v.
#[derive(Debug)]
pub struct DmpField {
    model: Dmp,
    x0: Vector3<f64>,
    v: Vector3<f64>,
    s: f64,
}

/// Where `{"model_file": NAME}` may read from: only regular files under `dir`, named by a
/// relative path without `..`, of at most `max_bytes`. A peer can therefore neither make the
/// node open a device, FIFO or file elsewhere, nor learn from the reason whether such a file
/// exists.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModelFiles {
    /// The primitive directory; `None` refuses every `model_file`.
    pub dir: Option<PathBuf>,
    /// Largest model file read (bytes).
    pub max_bytes: u64,
}

impl ModelFiles {
    /// Refuses every `model_file`.
    pub const NONE: Self = Self { dir: None, max_bytes: 0 };

    /// Reads `name` under the directory, or says why not without telling what is on disk
    /// outside it.
    fn read(&self, name: &str) -> Result<String, String> {
        let refused = || {
            format!(
                "model_file {name:?}: no readable model file of at most {} bytes by that name in the primitive directory",
                self.max_bytes
            )
        };
        let Some(dir) = &self.dir else {
            return Err(format!("model_file {name:?}: model files are disabled (no primitive_dir configured)"));
        };
        let rel = Path::new(name);
        if name.is_empty() || !rel.components().all(|c| matches!(c, Component::Normal(_))) {
            return Err(format!(
                "model_file {name:?}: must be a relative path inside the primitive directory (no `..`, no absolute path)"
            ));
        }
        let path = dir.join(rel);
        // A symbolic link could lead out of the directory: follow it and check where it lands.
        let (Ok(real), Ok(real_dir)) = (path.canonicalize(), dir.canonicalize()) else { return Err(refused()) };
        if !real.starts_with(&real_dir) {
            return Err(refused());
        }
        match std::fs::metadata(&real) {
            Ok(m) if m.is_file() && m.len() <= self.max_bytes => {}
            _ => return Err(refused()),
        }
        let mut text = String::new();
        let file = std::fs::File::open(&real).map_err(|_| refused())?;
        file.take(self.max_bytes + 1).read_to_string(&mut text).map_err(|_| refused())?;
        if text.len() as u64 > self.max_bytes {
            return Err(refused());
        }
        Ok(text)
    }
}

/// A model given inline or as `{"model_file": NAME}` (read only as `files` allows), of kind
/// `kind` and 3-D; `what` names it in errors.
fn model_of(value: serde_json::Value, kind: &str, files: &ModelFiles, what: &str) -> Result<Model, String> {
    let model = if let Some(name) = value.get("model_file") {
        let name = name.as_str().ok_or_else(|| format!("{what}: model_file must be a string"))?;
        let text = files.read(name)?;
        serde_json::from_str::<Model>(&text).map_err(|e| format!("model_file {name:?} is not a valid model: {e}"))?
    } else {
        serde_json::from_value::<Model>(value).map_err(|e| format!("{what} is not a {kind} model: {e}"))?
    };
    if model.kind() != kind {
        return Err(format!("{what}: command kind {kind} but the model is a {} model", model.kind()));
    }
    if model.dim() != 3 {
        return Err(format!("{what}: the {kind} model is {}-D; the controller needs a 3-D (position) model", model.dim()));
    }
    Ok(model)
}

/// Decodes `parameters_json` for a command of kind `kind` ("dmp", "gmr", "cgmr" or "hmm"); a
/// `model_file` is read only as `files` allows.
///
/// An HMM command may carry a null-space (elbow) primitive beside its model:
/// `{"null_space": {"link": NAME, "model": HMM or {"model_file": NAME}}, ...the model...}`,
/// `NAME` one of `links` (the robot model's link names, base first); its origin then follows
/// that HMM's path in the null space of the end-effector task (Sec. 4.1.1).
pub fn decode(kind: &str, parameters_json: &str, files: &ModelFiles, links: &[String]) -> Result<Learned, String> {
    if parameters_json.trim().is_empty() {
        return Err(format!(
            "{kind} command without a model: parameters_json must hold a cowork_motion model or {{\"model_file\": PATH}}"
        ));
    }
    let mut value: serde_json::Value =
        serde_json::from_str(parameters_json).map_err(|e| format!("parameters_json is not JSON: {e}"))?;
    let null_space = value.as_object_mut().and_then(|o| o.remove("null_space"));
    let model = model_of(value, kind, files, "parameters_json")?;
    let null_space = match null_space {
        None => None,
        Some(_) if kind != "hmm" => {
            return Err(format!("null_space: a null-space primitive runs on an HMM's clock; a {kind} command cannot carry one"));
        }
        Some(ns) => {
            let link = ns.get("link").and_then(|l| l.as_str()).ok_or("null_space.link must be a link name")?;
            // The base does not move: a primitive for it would ask for nothing possible.
            let index = links
                .iter()
                .skip(1)
                .position(|n| n == link)
                .map(|i| i + 1)
                .ok_or_else(|| format!("null_space.link {link:?} is not a moving link of the robot model ({})", links.join(", ")))?;
            let m = ns.get("model").cloned().ok_or("null_space.model is missing")?;
            let Model::Hmm(m) = model_of(m, "hmm", files, "null_space.model")? else { unreachable!("kind checked") };
            Some((index, hmm_path(&m).map_err(|e| format!("null_space.model: {e}"))?))
        }
    };
    Ok(match model {
        Model::Gmr(m) => Learned::Gmr(m),
        Model::Cgmr(m) => Learned::Cgmr(CgmrField { model: m, omega: 0.0, t: 0.0, started: false }),
        Model::Dmp(m) => {
            if !(m.stiffness > 0.0 && m.damping >= 0.0 && m.basis.gamma > 0.0) {
                return Err("DMP with non-positive stiffness, damping or phase decay".into());
            }
            Learned::Dmp(DmpField { model: m, x0: Vector3::zeros(), v: Vector3::zeros(), s: 1.0 })
        }
        Model::Hmm(m) => Learned::Hmm(HmmField { end_effector: hmm_path(&m)?, null_space, start_offset: None }),
    })
}

fn nan3() -> Vector3<f64> {
    Vector3::repeat(f64::NAN)
}

impl LearnedField for Learned {
    fn reset(&mut self, x0: &Vector3<f64>, goal: &Vector3<f64>) {
        match self {
            Learned::Gmr(_) => {}
            Learned::Hmm(h) => {
                h.end_effector.reset(x0, goal);
                h.start_offset = None;
            }
            Learned::Cgmr(c) => {
                c.omega = 0.0;
                c.t = 0.0;
                c.started = false;
            }
            Learned::Dmp(d) => {
                d.x0 = *x0;
                d.v = Vector3::zeros();
                d.s = 1.0;
            }
        }
    }

    fn velocity(&mut self, x: &Vector3<f64>, goal: &Vector3<f64>, dt: f64) -> Vector3<f64> {
        let mut out = [0.0; 3];
        match self {
            Learned::Hmm(h) => return h.end_effector.velocity(x, goal, dt),
            Learned::Gmr(m) => {
                if m.velocity_towards(x.as_slice(), goal.as_slice(), &mut out).is_err() {
                    return nan3();
                }
            }
            Learned::Cgmr(c) => {
                let rel = x - goal;
                let omega = c.omega;
                let Ok(mut act) = c.model.velocity_with(rel.as_slice(), omega, &mut out) else { return nan3() };
                if !c.started {
                    // ω starts at c(x₀), as `cowork_motion::CgmrRunner` does.
                    c.started = true;
                    c.omega = act;
                    if act != omega && c.model.velocity_with(rel.as_slice(), act, &mut out).is_err() {
                        return nan3();
                    }
                } else if !act.is_finite() {
                    act = 1.0;
                }
                c.t += dt;
                c.omega = if c.t >= c.model.t_max {
                    1.0
                } else {
                    act + (c.omega - act) * (-c.model.config.gamma * dt).exp()
                };
            }
            Learned::Dmp(d) => {
                let m = &d.model;
                let mut f = [0.0; 3];
                m.forcing(d.s, &mut f);
                let f = Vector3::from(f);
                let a = (goal - x) * m.stiffness - d.v * m.damping - (goal - d.x0) * (m.stiffness * d.s)
                    + f * m.stiffness;
                d.v += a * dt;
                d.s *= (-m.basis.gamma * dt).exp();
                return d.v;
            }
        }
        Vector3::from(out)
    }

    fn null_space_link(&self) -> Option<usize> {
        match self {
            Learned::Hmm(HmmField { null_space: Some((link, _)), .. }) => Some(*link),
            _ => None,
        }
    }

    fn null_space_velocity(&mut self, x: &Vector3<f64>) -> Vector3<f64> {
        let Learned::Hmm(h) = self else { return Vector3::zeros() };
        let tau = h.end_effector.tau();
        let Some((_, path)) = &h.null_space else { return Vector3::zeros() };
        let start = *h.start_offset.get_or_insert_with(|| x - path.positions()[0]);
        // offset(τ) = offset₀ e^{−τ/T}: its rate −offset/T is part of the reference velocity.
        let offset = start * (-tau / NULL_SPACE_SETTLE_S).exp();
        path.velocity_with_offset(tau, x, &offset) - offset / NULL_SPACE_SETTLE_S
    }
}
