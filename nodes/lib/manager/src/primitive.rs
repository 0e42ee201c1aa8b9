//! Motion primitives learned from segments (thesis Sec. 4.3.1 "Learning motion primitives"):
//! a NOA is a DMP on position and orientation (γ = 5 / duration, K = 70, D = 2√K), a FOA a
//! linear DS to the segment's end pose, a gripper action its command. Every goal — and a NOA's
//! whole demonstration — is stored in the frame of the segment's object, so at execution the
//! primitive is carried to where the object is now (goal adaptation, eq. 5.2).

use cowork_motion::Demonstration;
use cowork_motion::dmp::{Dmp, DmpConfig, OrientationDmp};
use cowork_motion::model::Model;
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::config::WORLD;
use crate::error::{ManagerError, Result};
use crate::segment::{ActionKind, GripperCommand, Segment};

/// A pose as stored: position (m) and quaternion `[x, y, z, w]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StoredPose {
    /// m.
    pub position: [f64; 3],
    /// Unit quaternion, x y z w.
    pub quaternion_xyzw: [f64; 4],
}

impl StoredPose {
    /// From an isometry.
    pub fn from_isometry(p: &Isometry3<f64>) -> Self {
        let t = p.translation.vector;
        let q = p.rotation.coords;
        Self { position: [t.x, t.y, t.z], quaternion_xyzw: [q.x, q.y, q.z, q.w] }
    }

    /// To an isometry; `None` when not finite or not a unit quaternion (within 1e-6).
    pub fn to_isometry(&self) -> Option<Isometry3<f64>> {
        let [x, y, z, w] = self.quaternion_xyzw;
        let q = Quaternion::new(w, x, y, z);
        let finite = self.position.iter().chain(self.quaternion_xyzw.iter()).all(|v| v.is_finite());
        if !finite || (q.norm() - 1.0).abs() > 1e-6 {
            return None;
        }
        let [px, py, pz] = self.position;
        Some(Isometry3::from_parts(Translation3::new(px, py, pz), UnitQuaternion::new_normalize(q)))
    }
}

/// Where a primitive's demonstration came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Source {
    /// Bag or session the demonstration was taught in (empty when live).
    pub demonstration: String,
    /// Segment start, s (bag / simulated time).
    pub start_s: f64,
    /// Segment end, s.
    pub end_s: f64,
}

/// A learned primitive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Primitive {
    /// Database key: the label's functor, e.g. `noa2`.
    pub id: String,
    /// Label as segmented, e.g. `noa2(water)`.
    pub label: String,
    /// Kind.
    pub kind: ActionKind,
    /// Object whose frame holds the goal (`world`: base frame).
    pub object: String,
    /// Goal (end pose of the segment) in the object's frame.
    pub goal: StoredPose,
    /// Pose of the object when it was taught, base frame.
    pub taught_object_pose: StoredPose,
    /// NOA: position DMP of the tool point in the object's frame (3-D, m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dmp: Option<Dmp>,
    /// NOA: orientation DMP of the tool in the object's frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation_dmp: Option<OrientationDmp>,
    /// FOA: gain k of ẋ = k (g − x), 1/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linear_gain: Option<f64>,
    /// Gripper action: the command.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gripper: Option<GripperCommand>,
    /// A FOA that puts this object back ([`Segment::home`]): `goal` is relative to where the
    /// object stood when it was grasped (`taught_object_pose` at teaching), and executed
    /// relative to where it stood when the execution grasped it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub home: Option<String>,
    /// Where it was taught.
    pub source: Source,
    /// Samples in the segment.
    pub samples: usize,
    /// Creation time, s since the Unix epoch (wall clock).
    pub created_unix_s: u64,
}

/// A pose trajectory: (time s, pose) pairs.
pub type PoseTrajectory = Vec<(f64, Isometry3<f64>)>;

/// What executing a primitive asks of the controller.
#[derive(Debug, Clone, PartialEq)]
pub enum MotionPlan {
    /// Linear DS to `goal` (base frame) with gain k.
    Linear {
        /// Goal, base frame.
        goal: Isometry3<f64>,
        /// 1/s.
        gain: f64,
    },
    /// The DMP carried into the base frame (3-D model JSON for ds_controller) to `goal`.
    Dmp {
        /// Goal, base frame.
        goal: Isometry3<f64>,
        /// `cowork_motion::Model` JSON of the position DMP in the base frame.
        model_json: String,
    },
    /// Gripper command.
    Gripper(GripperCommand),
    /// A move in joint space to `joints` (rad): gain (1/s), no joint faster than `max_speed`
    /// (rad/s); `tool` is the tool's pose there (base frame). Sent to unwind the arm
    /// ([`crate::turn`], *The way round*).
    Joints {
        /// Goal joint positions, rad.
        joints: cowork_robot::JointVector,
        /// 1/s.
        gain: f64,
        /// rad/s.
        max_speed: f64,
        /// Tool pose at `joints`, base frame.
        tool: Isometry3<f64>,
    },
}

fn to_frame(frame: &Isometry3<f64>, p: &Isometry3<f64>) -> Isometry3<f64> {
    frame.inverse() * p
}

impl Primitive {
    /// Learns the primitive of `seg` (see the module docs). `demonstration` names the bag or
    /// session, `created_unix_s` is stamped into it.
    pub fn learn(seg: &Segment, cfg: &DmpConfig, linear_gain: f64, demonstration: &str, created_unix_s: u64) -> Result<Self> {
        let fail = |reason: String| ManagerError::Learn { label: seg.label.clone(), reason };
        let goal = to_frame(&seg.frame, &seg.end_pose());
        let mut p = Self {
            id: seg.id.clone(),
            label: seg.label.clone(),
            kind: seg.kind,
            object: seg.object.clone(),
            goal: StoredPose::from_isometry(&goal),
            taught_object_pose: StoredPose::from_isometry(&seg.frame),
            dmp: None,
            orientation_dmp: None,
            linear_gain: None,
            gripper: seg.gripper,
            home: seg.home.clone(),
            source: Source { demonstration: demonstration.to_owned(), start_s: seg.t_start, end_s: seg.t_end },
            samples: seg.samples.len(),
            created_unix_s,
        };
        match seg.kind {
            ActionKind::Gripper => {
                if seg.gripper.is_none() {
                    return Err(fail("a gripper segment without its command".into()));
                }
            }
            ActionKind::Foa => p.linear_gain = Some(linear_gain),
            ActionKind::Noa => {
                let t0 = seg.samples.first().map_or(0.0, |s| s.0);
                let t: Vec<f64> = seg.samples.iter().map(|s| s.0 - t0).collect();
                let local: Vec<Isometry3<f64>> = seg.samples.iter().map(|s| to_frame(&seg.frame, &s.1)).collect();
                let pos: Vec<f64> = local.iter().flat_map(|l| l.translation.vector.iter().copied().collect::<Vec<_>>()).collect();
                let demo = Demonstration::new(3, t.clone(), pos, None)
                    .map_err(|source| ManagerError::Motion { label: seg.label.clone(), source })?;
                let dmp = Dmp::fit(&demo, cfg).map_err(|source| ManagerError::Motion { label: seg.label.clone(), source })?;
                let q: Vec<UnitQuaternion<f64>> = local.iter().map(|l| l.rotation).collect();
                let odmp = OrientationDmp::fit(&t, &q, cfg).map_err(|source| ManagerError::Motion { label: seg.label.clone(), source })?;
                p.dmp = Some(dmp);
                p.orientation_dmp = Some(odmp);
            }
        }
        Ok(p)
    }

    /// Checks a primitive read from a file: returns the field at fault and why.
    pub fn check(&self) -> std::result::Result<(), (String, String)> {
        let bad = |f: &str, r: String| Err((f.to_owned(), r));
        if self.id.is_empty() || !self.label.starts_with(&format!("{}(", self.id)) {
            return bad("label", format!("{:?} does not start with the key {:?} and `(`", self.label, self.id));
        }
        if self.goal.to_isometry().is_none() {
            return bad("goal", "not a finite position and unit quaternion".into());
        }
        if self.taught_object_pose.to_isometry().is_none() {
            return bad("taught_object_pose", "not a finite position and unit quaternion".into());
        }
        match self.kind {
            ActionKind::Noa => {
                let Some(d) = &self.dmp else { return bad("dmp", "a NOA needs its position DMP".into()) };
                if d.dim != 3 {
                    return bad("dmp.dim", format!("{} (must be 3)", d.dim));
                }
                if let Err(e) = d.validate() {
                    return bad("dmp", e.to_string());
                }
                let Some(o) = &self.orientation_dmp else {
                    return bad("orientation_dmp", "a NOA needs its orientation DMP".into());
                };
                if let Err(e) = o.validate() {
                    return bad("orientation_dmp", e.to_string());
                }
            }
            ActionKind::Foa => match self.linear_gain {
                Some(k) if k.is_finite() && k > 0.0 => {}
                other => return bad("linear_gain", format!("{other:?} (a FOA needs a positive finite gain)")),
            },
            ActionKind::Gripper => {
                if self.gripper.is_none() {
                    return bad("gripper", "a gripper action needs `close` or `open`".into());
                }
            }
        }
        if !(self.source.start_s.is_finite() && self.source.end_s.is_finite() && self.source.end_s >= self.source.start_s) {
            return bad("source", format!("times {} .. {} s", self.source.start_s, self.source.end_s));
        }
        Ok(())
    }

    /// Goal in the base frame for the object at `object_pose` (identity for the world).
    pub fn goal_at(&self, object_pose: &Isometry3<f64>) -> Option<Isometry3<f64>> {
        Some(object_pose * self.goal.to_isometry()?)
    }

    /// Whether the goal lives in an object's frame (not the world's).
    pub fn relative_to_object(&self) -> bool {
        self.object != WORLD
    }

    /// The controller plan with the object at `object_pose` (base frame): the goal carried
    /// with the object; a NOA's DMP rotated and translated with it (the DMP equations are
    /// invariant under a rigid motion of x, x₀, g and the forcing term together).
    pub fn plan(&self, object_pose: &Isometry3<f64>) -> Result<MotionPlan> {
        let fail = |reason: &str| ManagerError::Learn { label: self.label.clone(), reason: reason.to_owned() };
        let goal = self.goal_at(object_pose).ok_or_else(|| fail("stored goal is not a valid pose"))?;
        Ok(match self.kind {
            ActionKind::Gripper => MotionPlan::Gripper(self.gripper.ok_or_else(|| fail("no gripper command"))?),
            ActionKind::Foa => MotionPlan::Linear { goal, gain: self.linear_gain.ok_or_else(|| fail("no FOA gain"))? },
            ActionKind::Noa => {
                let d = self.dmp.as_ref().ok_or_else(|| fail("no DMP"))?;
                let mut base = d.clone();
                let r = object_pose.rotation;
                let move_point = |v: &[f64]| -> Vec<f64> {
                    let p = object_pose * Point3::new(v[0], v[1], v[2]);
                    vec![p.x, p.y, p.z]
                };
                if d.start.len() != 3 || d.goal.len() != 3 || d.weights.len() % 3 != 0 {
                    return Err(fail("DMP is not 3-D"));
                }
                base.start = move_point(&d.start);
                base.goal = move_point(&d.goal);
                for w in base.weights.chunks_mut(3) {
                    let v = r * Vector3::new(w[0], w[1], w[2]);
                    w.copy_from_slice(v.as_slice());
                }
                let model_json = serde_json::to_string(&Model::Dmp(base)).map_err(|e| fail(&e.to_string()))?;
                MotionPlan::Dmp { goal, model_json }
            }
        })
    }
}

impl Primitive {
    /// A NOA's pose trajectory in the base frame (time s from the start, pose), rolled out
    /// open loop (step `dt` s) by both DMPs from `start` (the tool now) to the goal carried with
    /// the object at `object_pose` — the Cartesian poses the thesis's robot manager sends to
    /// the low-level controller (Sec. 5.2.1). `None` for primitives that are not NOAs.
    pub fn rollout_poses(&self, object_pose: &Isometry3<f64>, start: &Isometry3<f64>, dt: f64) -> Result<Option<PoseTrajectory>> {
        let (Some(d), Some(o)) = (&self.dmp, &self.orientation_dmp) else { return Ok(None) };
        let motion = |source| ManagerError::Motion { label: self.label.clone(), source };
        let fail = |reason: &str| ManagerError::Learn { label: self.label.clone(), reason: reason.to_owned() };
        let goal = self.goal.to_isometry().ok_or_else(|| fail("stored goal is not a valid pose"))?;
        let local = object_pose.inverse() * start;
        let x0 = local.translation.vector;
        let g = goal.translation.vector;
        let steps = (d.duration / dt).ceil() as usize;
        let tr = d.rollout(Some(x0.as_slice()), Some(g.as_slice()), 1.0, dt, steps, 0.0).map_err(motion)?;
        let qs = o.rollout(Some(local.rotation), Some(goal.rotation), 1.0, dt).map_err(motion)?;
        let n = tr.len().min(qs.len());
        let mut out = Vec::with_capacity(n + 1);
        for (k, q) in qs.iter().enumerate().take(n) {
            let p = Translation3::new(tr.pos[3 * k], tr.pos[3 * k + 1], tr.pos[3 * k + 2]);
            out.push((k as f64 * dt, object_pose * Isometry3::from_parts(p, *q)));
        }
        // The rollout ends near the goal; the last reference is the goal itself.
        out.push((n as f64 * dt, object_pose * goal));
        Ok(Some(out))
    }
}

/// Reproduction error of a NOA against its demonstration: the DMP rolled out from the
/// demonstrated start to the demonstrated goal, on the demonstration's time grid.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReproductionError {
    /// RMS position error, m.
    pub position_rms_m: f64,
    /// Largest position error, m.
    pub position_max_m: f64,
    /// RMS orientation error, rad.
    pub orientation_rms_rad: f64,
    /// Largest orientation error, rad.
    pub orientation_max_rad: f64,
}

/// Rolls out `p`'s DMPs (time step `dt` s) and compares them with `seg`'s samples (both in the
/// object's frame). `None` for primitives that are not NOAs.
pub fn reproduction_error(p: &Primitive, seg: &Segment, dt: f64) -> Result<Option<ReproductionError>> {
    let (Some(d), Some(o)) = (&p.dmp, &p.orientation_dmp) else { return Ok(None) };
    let motion = |source| ManagerError::Motion { label: p.label.clone(), source };
    let tr = d.rollout(None, None, 1.0, dt, (d.duration / dt).ceil() as usize, 0.0).map_err(motion)?;
    let qs = o.rollout(None, None, 1.0, dt).map_err(motion)?;
    let t0 = seg.samples.first().map_or(0.0, |s| s.0);
    let (mut se, mut me, mut sq, mut mq, mut n) = (0.0, 0.0f64, 0.0, 0.0f64, 0usize);
    for (t, pose) in &seg.samples {
        let local = to_frame(&seg.frame, pose);
        let k = (((t - t0) / dt).round() as usize).min(tr.len().saturating_sub(1)).min(qs.len().saturating_sub(1));
        let x = Vector3::new(tr.pos[3 * k], tr.pos[3 * k + 1], tr.pos[3 * k + 2]);
        let e = (x - local.translation.vector).norm();
        let a = qs[k].angle_to(&local.rotation);
        se += e * e;
        sq += a * a;
        me = me.max(e);
        mq = mq.max(a);
        n += 1;
    }
    let n = n.max(1) as f64;
    Ok(Some(ReproductionError {
        position_rms_m: (se / n).sqrt(),
        position_max_m: me,
        orientation_rms_rad: (sq / n).sqrt(),
        orientation_max_rad: mq,
    }))
}
