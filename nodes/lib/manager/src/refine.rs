//! Incremental kinesthetic refinement of HMM primitives in the primitive database (thesis
//! Sec. 4.1.3, App. A.3.3): an execution in which a person guided the robot is a new
//! demonstration; the HMM is refined with it after the first contact
//! ([`HmmPrimitive::refine_after`]: the states the execution left before the contact keep
//! their parameters), and the refined model replaces the old one together with a
//! [`Revision`] saying when, from which execution and which states changed.
//!
//! [`Database::refine_hmm_saved`] is all-or-nothing: the refined database is written
//! atomically ([`Database::save`]) before it replaces the one in memory, and any error — a
//! primitive that is not an HMM, a demonstration of the wrong dimension, not finite, too short,
//! a contact outside it, a refinement that produced a non-finite model, a failed write — leaves
//! both the file and the database as they were.
//!
//! Positions in the HMM are the tool point's (m, robot base frame), times in s from the start
//! of the execution.

use std::path::Path;

use cowork_motion::Demonstration;
use cowork_motion::hmm::HmmPrimitive;
use serde::{Deserialize, Serialize};

use crate::database::Database;
use crate::error::{ManagerError, Result};

/// Fewest samples of a refining demonstration.
pub const MIN_SAMPLES: usize = 10;

/// An HMM primitive with its version and refinement history.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HmmEntry {
    /// Database key.
    pub id: String,
    /// Label, e.g. `place(object)`.
    pub label: String,
    /// The model (3-D tool position, m, base frame).
    pub model: HmmPrimitive,
    /// 1 when learned; +1 per refinement.
    pub version: u32,
    /// Creation time, s since the Unix epoch (wall clock).
    pub created_unix_s: u64,
    /// One entry per refinement, oldest first (`history[i].version == i + 2`).
    pub history: Vec<Revision>,
}

/// One refinement of an [`HmmEntry`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Revision {
    /// Version the refinement produced.
    pub version: u32,
    /// When, s since the Unix epoch (wall clock).
    pub unix_s: u64,
    /// Where the demonstration came from (execution, bag or session name).
    pub demonstration: String,
    /// First contact of the person, s from the start of the execution: the motion before it
    /// is the segment left unchanged.
    pub t_contact_s: f64,
    /// Samples of the demonstration.
    pub samples: usize,
    /// States kept as they were (their Viterbi run ended before the contact).
    pub kept_states: Vec<usize>,
    /// States whose parameters changed.
    pub changed_states: Vec<usize>,
}

impl Database {
    /// Adds (or replaces) the HMM primitive `id` at version 1 with no history. Fails when `id`
    /// is empty or names a DMP / linear / gripper primitive, or the model is not 3-D or invalid.
    pub fn insert_hmm(&mut self, id: &str, label: &str, model: HmmPrimitive, created_unix_s: u64) -> Result<()> {
        let refuse = |reason: String| Err(ManagerError::Refine { id: id.to_owned(), reason });
        if id.is_empty() {
            return refuse("empty primitive name".into());
        }
        if let Some(p) = self.get(id) {
            return refuse(format!("the name is taken by the {:?} primitive {}", p.kind, p.label));
        }
        if let Err(reason) = check_model(&model) {
            return refuse(reason);
        }
        let entry = HmmEntry {
            id: id.to_owned(),
            label: label.to_owned(),
            model,
            version: 1,
            created_unix_s,
            history: Vec::new(),
        };
        self.hmm.insert(id.to_owned(), entry);
        Ok(())
    }

    /// The HMM primitive `id`.
    pub fn hmm(&self, id: &str) -> Option<&HmmEntry> {
        self.hmm.get(id)
    }

    /// Refines the HMM primitive `id` in memory with `demo` (an executed trajectory: tool
    /// positions, m, base frame; times s from the execution's start) whose first contact was
    /// at `t_contact_s`, appending a [`Revision`] stamped `unix_s` naming `demonstration`.
    /// All-or-nothing: on any error the database is unchanged (see the module docs).
    pub fn refine_hmm(
        &mut self,
        id: &str,
        demo: &Demonstration,
        t_contact_s: f64,
        demonstration: &str,
        unix_s: u64,
    ) -> Result<Revision> {
        let refuse = |reason: String| ManagerError::Refine { id: id.to_owned(), reason };
        let Some(entry) = self.hmm.get(id) else {
            return Err(match self.get(id) {
                Some(p) => refuse(format!(
                    "{} is a {:?} primitive; only HMM primitives are refined by kinesthetic guidance",
                    p.label, p.kind
                )),
                None => ManagerError::NotFound { id: id.to_owned(), robot: self.robot.clone() },
            });
        };
        check_demo(entry.model.dim, demo, t_contact_s).map_err(refuse)?;
        let mut model = entry.model.clone();
        model.refine_after(demo, t_contact_s).map_err(|e| refuse(format!("refinement failed: {e}")))?;
        check_model(&model).map_err(|r| refuse(format!("the refined model is unusable: {r}")))?;
        let (mut kept_states, mut changed_states) = (Vec::new(), Vec::new());
        for (i, (old, new)) in entry.model.states.iter().zip(&model.states).enumerate() {
            let l = model.states.len();
            let same = old == new && entry.model.trans[i * l..(i + 1) * l] == model.trans[i * l..(i + 1) * l];
            if same { &mut kept_states } else { &mut changed_states }.push(i);
        }
        let version = entry.version.checked_add(1).ok_or_else(|| refuse("version counter exhausted".into()))?;
        let revision = Revision {
            version,
            unix_s,
            demonstration: demonstration.to_owned(),
            t_contact_s,
            samples: demo.len(),
            kept_states,
            changed_states,
        };
        let entry = self.hmm.get_mut(id).ok_or_else(|| refuse("vanished".into()))?;
        entry.model = model;
        entry.version = version;
        entry.history.push(revision.clone());
        Ok(revision)
    }

    /// [`refine_hmm`](Self::refine_hmm), then the database written atomically to `path`; only
    /// once the file is written does the refined database replace `self`. On any error `self`
    /// and the file are unchanged.
    pub fn refine_hmm_saved(
        &mut self,
        path: &Path,
        id: &str,
        demo: &Demonstration,
        t_contact_s: f64,
        demonstration: &str,
        unix_s: u64,
    ) -> Result<Revision> {
        let mut next = self.clone();
        let revision = next.refine_hmm(id, demo, t_contact_s, demonstration, unix_s)?;
        next.save(path)?;
        *self = next;
        Ok(revision)
    }
}

/// A model the controller can run: 3-D, every array consistent and finite.
fn check_model(m: &HmmPrimitive) -> std::result::Result<(), String> {
    if m.dim != 3 {
        return Err(format!("the HMM is {}-D; a tool-position primitive is 3-D", m.dim));
    }
    m.validate().map_err(|e| e.to_string())
}

fn check_demo(dim: usize, demo: &Demonstration, t_contact_s: f64) -> std::result::Result<(), String> {
    if demo.dim != dim {
        return Err(format!("demonstration is {}-D, the HMM {dim}-D", demo.dim));
    }
    let n = demo.t.len();
    if n < MIN_SAMPLES || demo.pos.len() != n * dim {
        return Err(format!(
            "demonstration has {n} times and {} position values (need at least {MIN_SAMPLES} samples of {dim})",
            demo.pos.len()
        ));
    }
    if let Some(i) = demo.pos.iter().position(|v| !v.is_finite()) {
        return Err(format!("demonstration position value {i} is not finite"));
    }
    if let Some(i) = demo.t.windows(2).position(|w| !(w[1] > w[0])) {
        return Err(format!("demonstration times do not increase at sample {}", i + 1));
    }
    let span = demo.t[n - 1] - demo.t[0];
    if !(t_contact_s.is_finite() && t_contact_s >= 0.0 && t_contact_s < span) {
        return Err(format!("first contact at {t_contact_s} s is not within the demonstration (0 to {span:.2} s)"));
    }
    Ok(())
}

/// Checks the HMM entries of a database file: key = id, a valid 3-D model, the version equal to
/// 1 + the number of revisions, which count up from 2. `Err((id, field, reason))`.
pub(crate) fn check_entries(db: &Database) -> std::result::Result<(), (String, String, String)> {
    for (key, e) in &db.hmm {
        let bad = |field: &str, reason: String| Err((key.clone(), field.to_owned(), reason));
        if *key != e.id {
            return bad("id", format!("{:?} differs from its key", e.id));
        }
        if db.primitives.contains_key(key) {
            return bad("id", "also the key of a DMP / linear / gripper primitive".into());
        }
        if let Err(r) = check_model(&e.model) {
            return bad("model", r);
        }
        if e.version as usize != e.history.len() + 1 {
            return bad("version", format!("{} with {} revision(s) (must be 1 + revisions)", e.version, e.history.len()));
        }
        if let Some(i) = e.history.iter().enumerate().position(|(i, r)| r.version as usize != i + 2) {
            return bad(&format!("history[{i}].version"), format!("{} (revisions count up from 2)", e.history[i].version));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use cowork_motion::hmm::HmmConfig;

    use super::*;

    /// A 4 s point-to-point path from the origin to (0.3, 0.1, 0) (m) with a vertical bow,
    /// 0.5 s at rest at the end, sampled at 0.01 s.
    fn demo(end: [f64; 3], bow: f64) -> Demonstration {
        let (n, rest) = (401, 50);
        let mut t = Vec::new();
        let mut pos = Vec::new();
        for k in 0..n + rest {
            let s = (k as f64 / (n - 1) as f64).min(1.0);
            let m = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
            t.push(k as f64 * 0.01);
            pos.extend([end[0] * m, end[1] * m, end[2] * m + bow * (std::f64::consts::PI * s).sin()]);
        }
        Demonstration::new(3, t, pos, None).expect("demo")
    }

    fn learned() -> Database {
        let demos: Vec<_> = [0.0, 0.01, -0.01].iter().map(|&b| demo([0.3, 0.1, 0.0], b)).collect();
        let hmm = HmmPrimitive::fit(&demos, &HmmConfig { states: 7, forgetting: 0.6, ..HmmConfig::default() }).expect("fit");
        let mut db = Database::new("lwr");
        db.insert_hmm("pick_place", "place(object)", hmm, 1).expect("insert");
        db
    }

    #[test]
    fn a_refinement_is_saved_with_its_history_and_reloads_identically() {
        let dir = tempfile::tempdir().expect("tmp");
        let path = Database::path(dir.path(), "lwr");
        let mut db = learned();
        db.save(&path).expect("save");
        // The person moved the end 10 cm along x from 2.5 s on.
        let taught = demo([0.4, 0.1, 0.0], 0.0);
        let r = db.refine_hmm_saved(&path, "pick_place", &taught, 2.5, "execution 1", 42).expect("refined");
        assert_eq!(r.version, 2);
        assert!(!r.kept_states.is_empty() && !r.changed_states.is_empty(), "{r:?}");
        assert_eq!(r.kept_states.len() + r.changed_states.len(), 7);
        let e = db.hmm("pick_place").expect("entry");
        assert_eq!((e.version, e.history.len()), (2, 1));
        let back = Database::load(&path).expect("reload");
        assert_eq!(back, db);
        assert_eq!(back.to_bytes(), std::fs::read(&path).expect("bytes"));
        // The end moved towards the taught one.
        let end = |m: &HmmPrimitive| {
            let tr = m.generate(None, 0.01).expect("gen");
            tr.pos[tr.pos.len() - 3]
        };
        let before = end(&learned().hmm("pick_place").expect("e").model);
        assert!(end(&e.model) > before + 0.03, "end x {} → {}", before, end(&e.model));
    }

    #[test]
    fn bad_refinements_leave_file_and_database_unchanged() {
        let dir = tempfile::tempdir().expect("tmp");
        let path = Database::path(dir.path(), "lwr");
        let mut db = learned();
        let pose = crate::primitive::StoredPose { position: [0.5, 0.0, 0.2], quaternion_xyzw: [0.0, 0.0, 0.0, 1.0] };
        db.insert(crate::primitive::Primitive {
            id: "foa1".into(),
            label: "foa1(cup)".into(),
            kind: crate::segment::ActionKind::Foa,
            object: "cup".into(),
            goal: pose,
            taught_object_pose: pose,
            dmp: None,
            orientation_dmp: None,
            linear_gain: Some(3.0),
            gripper: None,
            home: None,
            source: crate::primitive::Source { demonstration: String::new(), start_s: 0.0, end_s: 1.0 },
            samples: 100,
            created_unix_s: 0,
        });
        db.save(&path).expect("save");
        let bytes = std::fs::read(&path).expect("bytes");
        let good = demo([0.4, 0.1, 0.0], 0.0);
        let two_d = Demonstration::new(2, vec![0.0, 1.0], vec![0.0; 4], None).expect("2-D");
        let short = Demonstration::new(3, (0..5).map(f64::from).collect(), vec![0.0; 15], None).expect("short");
        let mut nan = good.clone();
        nan.pos[30] = f64::NAN;
        let cases: [(&str, &Demonstration, f64, &str); 7] = [
            ("foa1", &good, 2.5, "only HMM primitives"),
            ("nothing", &good, 2.5, "no primitive `nothing`"),
            ("pick_place", &two_d, 0.5, "2-D"),
            ("pick_place", &short, 1.0, "at least 10"),
            ("pick_place", &nan, 2.5, "value 30 is not finite"),
            ("pick_place", &good, f64::NAN, "first contact"),
            ("pick_place", &good, 9.0, "first contact"),
        ];
        for (id, d, tc, want) in cases {
            let before = db.clone();
            let e = db.refine_hmm_saved(&path, id, d, tc, "bad", 7).expect_err(want).to_string();
            assert!(e.contains(want), "{e:?} should say {want:?}");
            assert!(e.contains(id), "{e:?} should name {id}");
            assert_eq!(db, before);
            assert_eq!(std::fs::read(&path).expect("bytes"), bytes, "file changed by {id} / {want}");
        }
        // A directory where the file should be: the write fails, the database is unchanged.
        let before = db.clone();
        let blocked = dir.path().join("blocked");
        std::fs::create_dir_all(blocked.join("lwr.primitives.json")).expect("dir");
        assert!(db.refine_hmm_saved(&Database::path(&blocked, "lwr"), "pick_place", &good, 2.5, "x", 1).is_err());
        assert_eq!(db, before);
    }

    #[test]
    fn an_edited_history_is_refused_on_load() {
        let mut db = learned();
        db.refine_hmm("pick_place", &demo([0.4, 0.1, 0.0], 0.0), 2.5, "execution 1", 1).expect("refine");
        let p = Path::new("lwr.primitives.json");
        let mut v: serde_json::Value = serde_json::from_slice(&db.to_bytes()).expect("json");
        v["hmm"]["pick_place"]["version"] = serde_json::json!(5);
        let e = Database::from_bytes(&serde_json::to_vec(&v).expect("bytes"), p).expect_err("refused").to_string();
        assert!(e.contains("pick_place") && e.contains("version"), "{e}");
        let mut v: serde_json::Value = serde_json::from_slice(&db.to_bytes()).expect("json");
        v["hmm"]["pick_place"]["model"]["dt"] = serde_json::json!(-1.0);
        let e = Database::from_bytes(&serde_json::to_vec(&v).expect("bytes"), p).expect_err("refused").to_string();
        assert!(e.contains("model") && e.contains("dt"), "{e}");
        assert_eq!(Database::from_bytes(&db.to_bytes(), p).expect("valid"), db);
    }
}
