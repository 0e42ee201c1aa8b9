//! `gestures`: a labelled gesture set (thesis Sec. 5.1.3: come, stop, handover right) performed
//! one after the other by people of different body sizes, speeds, amplitudes, positions and
//! viewing angles, tracked by a depth-camera skeleton tracker at 30 Hz (as in the thesis) and
//! drawn as capsule bodies in the depth frames. The robot stands still in its ready pose.
//!
//! Labels: one `std_msgs/String` on `/human/gesture_label` per gesture, written at the
//! gesture's end (log time = `end`), holding JSON:
//! `{"label":"come","start":3.512,"end":5.871,"person_id":2,"index":1,"height_m":1.73,
//! "view_angle_rad":0.41,"duration_scale":1.12,"position":[0.1,-1.3]}` (times in s of the bag's
//! clock, positions m in the base frame).

use cowork_depth::Capsule;
use cowork_msgs::std_msgs::String as RosString;
use cowork_people::{GestureSet, GestureSetConfig, Room, Sampler, SensorConfig};

use crate::depth::{DepthRig, people_capsules};
use crate::runner::Runner;
use crate::streams::topics;
use crate::{Result, SynthError};

/// Gestures in a bag of default length (three of each).
pub const DEFAULT_COUNT: usize = 9;
/// About how long one performance lasts, s (used to size the set for `--duration`).
const MEAN_PERFORMANCE_S: f64 = 4.0;

/// The gesture set of a bag: [`DEFAULT_COUNT`] gestures, or enough to fill `duration_s`.
pub(crate) fn gesture_set(seed: u64, duration_s: Option<f64>) -> Result<GestureSet> {
    let count = duration_s.map_or(DEFAULT_COUNT, |d| ((d / MEAN_PERFORMANCE_S).ceil() as usize + 1).max(3));
    let config = GestureSetConfig { count, ..GestureSetConfig::default() };
    Ok(GestureSet::generate(seed, &config, &Room::default())?)
}

/// Default length: the whole default set.
pub(crate) fn default_duration_s(seed: u64) -> Result<f64> {
    Ok((gesture_set(seed, None)?.timeline().duration() * 10.0).ceil() / 10.0)
}

/// Runs the scenario with the set drawn for this bag.
pub(crate) fn run_gestures(
    run: &mut Runner<'_>,
    depth: &mut Option<DepthRig>,
    set: &GestureSet,
    seed: u64,
    noise: bool,
) -> Result<()> {
    let timeline = set.timeline();
    let sensor = if noise { SensorConfig::depth_tracker() } else { SensorConfig::depth_tracker().noiseless() };
    let end_ns = (run.duration_s() * 1e9).round() as i64;
    let mut skeletons = Sampler::new(timeline, sensor, seed)?
        .take_while(|m| m.header.stamp.to_nanos() <= end_ns)
        .peekable();
    let mut labels = set
        .instances
        .iter()
        .map(|g| {
            let json = serde_json::json!({
                "label": g.label(),
                "start": round_ms(g.start),
                "end": round_ms(g.end),
                "person_id": g.person_id,
                "index": g.index,
                "height_m": round_ms(g.body.height),
                "view_angle_rad": round_ms(g.view_angle),
                "duration_scale": round_ms(g.style.duration_scale),
                "position": [round_ms(g.stance.position.x), round_ms(g.stance.position.y)],
            });
            ((round_ms(g.end) * 1e9).round() as i64, RosString { data: json.to_string() })
        })
        .filter(|(t, _)| *t <= end_ns)
        .peekable();
    if labels.peek().is_none() {
        return Err(SynthError::BadOption {
            option: "--duration",
            value: run.duration_s().to_string(),
            reason: "too short for a single complete gesture".into(),
        });
    }
    let mut capsules: Vec<Capsule> = Vec::new();
    while !run.done() {
        let now = run.now();
        while let Some(m) = skeletons.next_if(|m| m.header.stamp.to_nanos() <= now) {
            run.streams.write(topics::SKELETON, m.header.stamp.to_nanos(), &m)?;
        }
        while let Some((t, label)) = labels.next_if(|(t, _)| *t <= now) {
            run.streams.write(topics::GESTURE_LABEL, t, &label)?;
        }
        run.step()?;
        if let Some(rig) = depth.as_mut() {
            while let Some(t) = rig.due(run.now()) {
                people_capsules(timeline, t as f64 * 1e-9, &mut capsules);
                rig.write_frame(&mut run.streams, t, &run.sim, &capsules)?;
            }
        }
    }
    Ok(())
}

/// Rounds to 1 ms (labels are for people and tools, not for bit-exact replay).
fn round_ms(v: f64) -> f64 {
    (v * 1e3).round() * 1e-3
}
