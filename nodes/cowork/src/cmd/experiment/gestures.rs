//! The `gestures-hri` side of the runner (Sec. 5.1.3, cooperative stacking): which trials run
//! the observer's gesture recognition, where a handed-over object was released against the
//! person's true hand, and the reaction table.

use cowork_experiment::cooperation::{self, GestureReaction, Release};
use cowork_experiment::{Experiment, Judge, Sequencer};
use cowork_sim::Shape;
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

/// Whether human_observer recognises gestures in this experiment (its bundled model); the
/// others run it with no model, so that a reach that looks like a `stop` cannot hold the task.
pub fn recognises_gestures(exp: &Experiment) -> bool {
    exp.steps.iter().any(|s| {
        matches!(
            s,
            cowork_experiment::Step::AwaitGesture { .. } | cowork_experiment::Step::Handover { .. }
        )
    })
}

/// Called when the gripper is about to open at `now` (s): if a handover of the held object is
/// running, record where it is released against the person's true right hand (the judge's
/// newest skeleton, not the observer's estimate).
pub fn note_release(
    seq: &Sequencer,
    judge: &Judge,
    exp: &Experiment,
    now: f64,
    releases: &mut Vec<Release>,
) {
    let Some(h) = seq.handovers().last() else {
        return;
    };
    if releases.iter().any(|r| r.object == h.object && r.t >= h.commanded_t) {
        return;
    }
    let (Some(world), Some((_, hand))) = (judge.world(), judge.right_hand) else {
        return;
    };
    if world.held_object != h.object {
        return;
    }
    let Some(o) = world.objects.iter().find(|o| o.name == h.object) else {
        return;
    };
    let half = exp
        .scene
        .objects
        .iter()
        .find(|s| s.name == h.object)
        .map_or(Vector3::zeros(), |s| match s.shape {
            Shape::Box { size } => 0.5 * Vector3::from(size),
            Shape::Cylinder { radius, height } => Vector3::new(radius, radius, 0.5 * height),
            Shape::Sphere { radius } => Vector3::repeat(radius),
        });
    let p = &o.pose.position;
    let q = &o.pose.orientation;
    let rotation = UnitQuaternion::try_new(Quaternion::new(q.w, q.x, q.y, q.z), 1e-9)
        .unwrap_or_else(UnitQuaternion::identity);
    let pose = Isometry3::from_parts(Translation3::new(p.x, p.y, p.z), rotation);
    releases.push(Release {
        object: h.object.clone(),
        t: now,
        distance_to_hand_m: cooperation::point_box_distance(&hand, &pose, &half),
        hand: [hand.x, hand.y, hand.z],
        object_centre: [p.x, p.y, p.z],
    });
}

/// The reaction to every gesture of the trial (empty for experiments without gestures).
pub fn reactions(
    exp: &Experiment,
    judge: &Judge,
    seq: &Sequencer,
    t0: Option<f64>,
    end: f64,
    releases: &[Release],
) -> Vec<GestureReaction> {
    if !recognises_gestures(exp) {
        return Vec::new();
    }
    let Some(t0) = t0 else {
        return Vec::new();
    };
    cooperation::reactions(
        &judge.series,
        t0,
        end,
        &cooperation::performed(&exp.people),
        seq.handovers(),
        releases,
    )
}

/// Header of [`table`].
pub const TABLE_HEADER: &str = "| seed | gesture | performed (end) | recognised | reaction | max speed while stopped | release to hand | acted on |\n|---|---|---|---|---|---|---|---|\n";

/// The per-gesture table of a trial (Markdown rows, for the console and the README).
pub fn table(seed: u64, reactions: &[GestureReaction]) -> String {
    let f = |v: Option<f64>, unit: &str| v.map_or("-".to_owned(), |x| format!("{x:.2}{unit}"));
    let mut s = String::new();
    for r in reactions {
        s.push_str(&format!(
            "| {seed} | {} | {} | {} | {} | {} | {} | {}{} |\n",
            r.label,
            f(r.performed_end_s, " s"),
            f(r.recognised_s, " s"),
            f(r.reaction_s, " s"),
            r.held_max_speed_m_s
                .map_or("-".into(), |v| format!("{v:.3} m/s")),
            f(r.release_distance_m, " m"),
            if r.acted { "yes" } else { "no" },
            if r.note.is_empty() {
                String::new()
            } else {
                format!(" ({})", r.note)
            }
        ));
    }
    s
}
