//! The JSON of a run: one [`TrialResult`] per trial and a [`Summary`].

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::cooperation::{GestureReaction, Release};
use crate::judge::{Approach, PlacementResult, Stats, Subtask, THESIS_MIN_DISTANCE_M};
use crate::plan::Variant;

/// One trial.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TrialResult {
    /// Seed of the trial.
    pub seed: u64,
    /// Every step done, every placement within tolerance, no collision, no node failure.
    pub success: bool,
    /// Why it failed (empty on success).
    pub reason: String,
    /// Simulated duration (s).
    pub duration_s: f64,
    /// Wall-clock duration (s).
    pub wall_s: f64,
    /// True minimum robot–person distance (m); absent when the person was never seen.
    pub min_distance_m: Option<f64>,
    /// Where and when that minimum was (link, body part).
    pub closest_approach: Option<Approach>,
    /// Clear → touching transitions between robot and person geometry.
    pub collisions: u32,
    /// Subtasks (one per placed block).
    pub subtasks: BTreeMap<String, Subtask>,
    /// Distance method (`fded`, `flacco`).
    pub distance: String,
    /// Backend the distance node reported.
    pub backend: String,
    /// Processing time of the distance node per frame (ms).
    pub processing_ms: Option<Stats>,
    /// Median tool speed while α_h was 0.3 / 0.1 m/s.
    pub speed_far_m_s: Option<f64>,
    /// Median tool speed while α_h was 0.1 m/s.
    pub speed_interaction_m_s: Option<f64>,
    /// α_h changes between far and interaction speeds.
    pub speed_switches: usize,
    /// Placement checks.
    pub placements: Vec<PlacementResult>,
    /// Skeleton frames of the scripted people not published because the runner fell behind
    /// the simulated clock (it then publishes only the newest).
    pub people_frames_dropped: u64,
    /// The last `/motion/status` of ds_controller, in words (`command 3 held: stale ...`).
    pub last_status: Option<String>,
    /// Steps finished / in the script.
    pub steps_done: usize,
    /// Steps in the script.
    pub steps_total: usize,
    /// Gestures recognised.
    pub gestures: Vec<String>,
    /// What the seed chose.
    pub variant: Option<Variant>,
    /// MCAP of the trial (`--record`).
    pub bag: Option<String>,
    /// Simulated time ds_controller's link-distance damper held a link back (s).
    #[serde(default)]
    pub approach_limited_s: f64,
    /// … per link (s).
    #[serde(default)]
    pub approach_limited_links: BTreeMap<String, f64>,
    /// `gestures-hri`: the robot's reaction to every gesture (recognised or performed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gesture_reactions: Vec<GestureReaction>,
    /// `gestures-hri`: where handed-over objects were released.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub releases: Vec<Release>,
    /// Latency in the graph seen by the runner on the simulated clock, ms
    /// ([`crate::cooperation::Latency`]): `depth_to_distances`, `distances_to_command`,
    /// `skeleton_to_state`, `state_to_command`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub latency_ms: BTreeMap<String, Stats>,
}

/// Over all trials.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Summary {
    /// Trials run.
    pub trials: usize,
    /// Trials that succeeded.
    pub successes: usize,
    /// Collisions in all trials.
    pub collisions: u32,
    /// Smallest minimum distance over the trials (m).
    pub min_distance_m: Option<f64>,
    /// Trials whose minimum distance is below the thesis's 6.7 cm.
    pub below_thesis_min_distance: usize,
    /// Median processing time over every frame of every trial (ms).
    pub processing_ms_median: Option<f64>,
}

/// The whole run as written by `--json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunResult {
    /// Experiment name.
    pub experiment: String,
    /// Trials.
    pub trials: Vec<TrialResult>,
    /// Summary.
    pub summary: Summary,
}

impl RunResult {
    /// The run of `trials`.
    pub fn new(experiment: &str, trials: Vec<TrialResult>) -> Self {
        let min = trials
            .iter()
            .filter_map(|t| t.min_distance_m)
            .reduce(f64::min);
        let medians: Vec<f64> = trials
            .iter()
            .filter_map(|t| t.processing_ms.map(|s| s.median))
            .collect();
        let summary = Summary {
            trials: trials.len(),
            successes: trials.iter().filter(|t| t.success).count(),
            collisions: trials.iter().map(|t| t.collisions).sum(),
            min_distance_m: min,
            below_thesis_min_distance: trials
                .iter()
                .filter(|t| t.min_distance_m.is_some_and(|d| d < THESIS_MIN_DISTANCE_M))
                .count(),
            processing_ms_median: Stats::of(medians.into_iter()).map(|s| s.median),
        };
        Self {
            experiment: experiment.to_owned(),
            trials,
            summary,
        }
    }
}
