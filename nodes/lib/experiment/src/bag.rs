//! Judging a recorded run: every message of an MCAP bag into a [`Judge`], the same way the
//! runner feeds it live.

use std::path::Path;

use cowork_bag::BagReader;
use cowork_msgs::msg::{Gesture, HumanState, LinkDistances, MotionStatus, Skeleton, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Float64MultiArray;

use crate::error::Result;
use crate::judge::Judge;

/// What a bag gave the judge.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BagFeed {
    /// Messages handed to the judge.
    pub used: u64,
    /// Messages on the judged topics that did not decode (skipped).
    pub undecodable: u64,
    /// First decode problem, for the warning.
    pub first_problem: Option<String>,
    /// Whether the bag was damaged (e.g. a recorder stopped by a kill); what was readable is used.
    pub damaged: bool,
}

/// Feeds every judged topic of the bag at `path` to `judge`, in log-time order.
pub fn feed_bag(path: &Path, judge: &mut Judge) -> Result<BagFeed> {
    let reader = BagReader::open_recoverable(path)?;
    let mut feed = BagFeed {
        damaged: reader.damage().is_some(),
        ..BagFeed::default()
    };
    for m in reader.messages() {
        let Ok(m) = m else {
            feed.damaged = true;
            continue;
        };
        let r = match &*m.topic {
            "/joint_states" => m.decode::<JointState>().map(|x| judge.on_joint_state(&x)),
            "/human/skeleton" => m.decode::<Skeleton>().map(|x| judge.on_skeleton(&x)),
            "/fded/distances" => m.decode::<LinkDistances>().map(|x| judge.on_distances(&x)),
            "/human/state" => m.decode::<HumanState>().map(|x| judge.on_human_state(&x)),
            "/human/gesture" => m.decode::<Gesture>().map(|x| judge.on_gesture(&x)),
            "/motion/status" => m.decode::<MotionStatus>().map(|x| judge.on_status(&x)),
            "/lwr/joint_velocity_command" => m
                .decode::<Float64MultiArray>()
                .map(|x| judge.on_command(&x)),
            "/lwr/world" => m.decode::<WorldState>().map(|x| judge.on_world(&x)),
            _ => continue,
        };
        match r {
            Ok(()) => feed.used += 1,
            Err(e) => {
                feed.undecodable += 1;
                feed.first_problem.get_or_insert_with(|| e.to_string());
            }
        }
    }
    Ok(feed)
}
