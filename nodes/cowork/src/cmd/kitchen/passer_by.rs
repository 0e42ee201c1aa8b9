//! The person in every kitchen trial (issue #15, as in the HRI study of Sec. 5.1.3): drawn from
//! the trial's seed, they walk up to the table some seconds after the robot starts, reach once
//! into the robot's workspace near the cup, and leave. Their skeleton goes to `/human/skeleton`
//! (lwr_sim draws the body in the depth image, the human observer tracks it), so the robot
//! slows down by α_h and bends its path around the body by fDED. Judged from the simulated
//! world: the true robot–body distance and contacts (`cowork_experiment::judge`), and the
//! time the slow-down cost, from the observer's `/human/state`.

use anyhow::Result;
use cowork_experiment::judge::{Approach, Contact, Judge, Series, SpeedPeak};
use cowork_experiment::plan::{Variant, Visit, visitor};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{HumanState, LinkDistances, Skeleton, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_people::{MessageMeta, Timeline};
use cowork_robot::RobotModel;
use nalgebra::Point3;
use rand::Rng;
use serde::Serialize;

/// The kitchen's visit: walks in during `enter_s` (simulated s after the robot starts; each
/// kitchen task sets it so that the person arrives while the robot still works), one reach to a
/// point above the table between the person's side and the cup (where the robot carries the
/// bottle, the jar and the spoon), 15–30 cm above the table top.
fn kitchen_visit(enter_s: (f64, f64)) -> Visit {
    Visit {
        enter_s,
        reaches: (1, 1),
        target: |rng, sign, top| Point3::new(rng.random_range(0.45..0.65), sign * rng.random_range(0.05..0.30), top + rng.random_range(0.15..0.30)),
    }
}

/// Skeleton frames per simulated second.
const RATE_HZ: f64 = 120.0;

/// What the person did and cost in one trial.
#[derive(Debug, Clone, Serialize)]
pub struct PersonOutcome {
    /// Who came, when, and where they reached (`None`: `--no-person`).
    pub variant: Option<Variant>,
    /// Smallest true distance between a robot link and the body, m (`None`: nobody came
    /// while the joint states were known).
    pub min_distance_m: Option<f64>,
    /// Where and when that was (simulated s), which link and body part.
    pub closest: Option<Approach>,
    /// Robot–body contacts (clear → touching).
    pub collisions: u32,
    /// The first of them: where, and who was moving into whom.
    pub contacts: Vec<Contact>,
    /// Simulated time the slow-down cost: ∫ (1 − v / v_far) dt over the execution, with v the
    /// observer's speed scale and v_far its value with nobody near, s.
    pub slowed_cost_s: f64,
    /// Simulated time the observer had the robot stopped, s.
    pub stopped_s: f64,
    /// Skeleton frames not sent because the runner fell behind the simulated clock.
    pub frames_dropped: u64,
    /// Where the tool moved fastest above the speed α_h allowed (from `/lwr/world`).
    pub fastest_tool: Option<SpeedPeak>,
    /// The same while α_h was at the far speed (nobody close: the robot's own pace).
    pub fastest_tool_far: Option<SpeedPeak>,
}

/// The person of one trial, and the judge of what they did.
pub struct PasserBy {
    people: Option<(Timeline, Variant)>,
    judge: Judge,
    next_frame: u64,
    frames_dropped: u64,
    skeleton: Skeleton,
    /// Speed scale with nobody near (the largest seen), m/s.
    v_far: f64,
    /// Last `/human/state` (stamp s, speed scale m/s, stopped).
    last_state: Option<(f64, f64, bool)>,
    slowed_cost_s: f64,
    stopped_s: f64,
}

impl PasserBy {
    /// The person of `seed`, walking in during `enter_s` (simulated s after the robot starts;
    /// `None`: nobody comes, `--no-person`), judged against `model`.
    pub fn new(seed: u64, table_top_z: f64, enter_s: Option<(f64, f64)>, model: RobotModel) -> Result<Self> {
        let people = match enter_s {
            Some(enter_s) => Some(visitor(seed, table_top_z, &kitchen_visit(enter_s))?),
            None => None,
        };
        Ok(Self {
            people,
            judge: Judge::new(model, cowork_people::DEFAULT_FLOOR_Z)?,
            next_frame: 0,
            frames_dropped: 0,
            skeleton: Skeleton::default(),
            v_far: 0.0,
            last_state: None,
            slowed_cost_s: 0.0,
            stopped_s: 0.0,
        })
    }

    /// Sends, through `publish`, the skeleton frames due by simulated time `now` for a robot
    /// that started at `t0` (the timeline's zero). A runner that fell behind sends only the
    /// newest frame, as a tracker that drops frames.
    pub fn frames(&mut self, t0: f64, now: f64, mut publish: impl FnMut(&Skeleton) -> Result<()>) -> Result<()> {
        let Some((people, _)) = &self.people else { return Ok(()) };
        let t = (now - t0).min(people.duration());
        if t < 0.0 {
            return Ok(());
        }
        let due = (t * RATE_HZ).floor() as u64;
        if due > self.next_frame + 2 {
            self.frames_dropped += due - self.next_frame;
            self.next_frame = due;
        }
        while self.next_frame <= due {
            let tp = self.next_frame as f64 / RATE_HZ;
            for (id, pose) in people.poses_at(tp) {
                let meta = MessageMeta {
                    stamp: Time::from_secs_f64(t0 + tp),
                    frame_id: cowork_people::BASE_FRAME,
                    source: Skeleton::SOURCE_XSENS,
                    person_id: id,
                    with_velocities: true,
                };
                pose.write_message(&meta, &mut self.skeleton);
                self.judge.on_skeleton(&self.skeleton);
                publish(&self.skeleton)?;
            }
            self.next_frame += 1;
        }
        Ok(())
    }

    /// `/joint_states` (for the true distances).
    pub fn on_joint_state(&mut self, m: &JointState) {
        self.judge.on_joint_state(m);
    }

    /// `/lwr/world` (the tool's speed, for the report).
    pub fn on_world(&mut self, m: &WorldState) {
        self.judge.on_world(m);
    }

    /// `/fded/distances` (the measured distance, for the report).
    pub fn on_distances(&mut self, m: &LinkDistances) {
        self.judge.on_distances(m);
    }

    /// The trial's time series (true and measured distance, tool speed, α_h, mode).
    pub fn series(&self) -> &Series {
        &self.judge.series
    }

    /// `/human/state`: adds the slow-down's cost while the robot executes (`executing`).
    pub fn on_human_state(&mut self, m: &HumanState, executing: bool) {
        self.judge.on_human_state(m);
        let t = m.header.stamp.to_secs_f64();
        if !m.present && m.speed_scale.is_finite() {
            self.v_far = self.v_far.max(m.speed_scale);
        }
        if let Some((t_prev, v, stopped)) = self.last_state
            && executing
            && self.v_far > 0.0
        {
            // Gaps (a silent observer) count at most 0.2 s.
            let dt = (t - t_prev).clamp(0.0, 0.2);
            self.slowed_cost_s += dt * (1.0 - (v / self.v_far).clamp(0.0, 1.0));
            if stopped {
                self.stopped_s += dt;
            }
        }
        self.last_state = Some((t, m.speed_scale, m.stopped));
    }

    /// The outcome so far.
    pub fn outcome(&self) -> PersonOutcome {
        PersonOutcome {
            variant: self.people.as_ref().map(|(_, v)| v.clone()),
            min_distance_m: self.judge.min_distance(),
            closest: self.judge.closest.clone(),
            collisions: self.judge.collisions,
            contacts: self.judge.contacts.clone(),
            slowed_cost_s: self.slowed_cost_s,
            stopped_s: self.stopped_s,
            frames_dropped: self.frames_dropped,
            fastest_tool: self.judge.fastest_over_allowed(false),
            fastest_tool_far: self.judge.fastest_over_allowed(true),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> RobotModel {
        RobotModel::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/robot/lwr4plus.urdf")).expect("the LWR model")
    }

    fn state(t: f64, present: bool, v: f64, stopped: bool) -> HumanState {
        let mut m = HumanState { present, speed_scale: v, stopped, ..Default::default() };
        m.header.stamp = Time::from_secs_f64(t);
        m
    }

    #[test]
    fn the_slow_down_cost_integrates_one_minus_the_speed_ratio_while_executing() {
        let mut p = PasserBy::new(1, 0.0, None, model()).expect("passer-by");
        let mut t = 0.0;
        for _ in 0..10 {
            p.on_human_state(&state(t, false, 0.3, false), true); // nobody: no cost
            t += 0.1;
        }
        for _ in 0..20 {
            p.on_human_state(&state(t, true, 0.15, false), true); // half speed for 2 s: 1 s
            t += 0.1;
        }
        for _ in 0..10 {
            p.on_human_state(&state(t, true, 0.0, true), true); // stopped for 1 s: 1 s
            t += 0.1;
        }
        for _ in 0..10 {
            p.on_human_state(&state(t, true, 0.0, true), false); // not executing: nothing
            t += 0.1;
        }
        let o = p.outcome();
        assert!((o.slowed_cost_s - 2.0).abs() < 0.11, "{}", o.slowed_cost_s);
        assert!((o.stopped_s - 1.0).abs() < 0.11, "{}", o.stopped_s);
        assert!(o.variant.is_none() && o.min_distance_m.is_none());
    }

    #[test]
    fn the_person_is_sent_at_120_hz_of_simulated_time_and_a_late_runner_skips_frames() {
        let mut p = PasserBy::new(3, 0.0, Some((3.0, 40.0)), model()).expect("passer-by");
        let enter = p.outcome().variant.expect("a person").enter_s;
        assert!((3.0..40.0).contains(&enter));
        let mut stamps = Vec::new();
        p.frames(10.0, 10.0 + enter + 1.0, |m| Ok(stamps.push(m.header.stamp.to_secs_f64()))).expect("frames");
        // One frame, the newest: the runner started late.
        assert_eq!(stamps.len(), 1, "{stamps:?}");
        let mut t = 10.0 + enter + 1.0;
        for _ in 0..60 {
            t += 1.0 / 240.0;
            p.frames(10.0, t, |m| Ok(stamps.push(m.header.stamp.to_secs_f64()))).expect("frames");
        }
        assert!((29..=32).contains(&stamps.len()), "0.25 s at 120 Hz: {}", stamps.len());
        assert!(stamps.windows(2).all(|w| (w[1] - w[0] - 1.0 / 120.0).abs() < 1e-9));
        assert!(p.outcome().frames_dropped > 100);
    }
}
