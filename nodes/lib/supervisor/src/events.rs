//! Stimuli the supervisor reacts to, and their JSON-lines file format (one timed event per
//! line, `t` in seconds), e.g.
//!
//! ```text
//! {"t":0.0,"type":"objects","objects":[{"name":"water","distance":0.4},{"name":"cup","distance":0.8}]}
//! {"t":0.5,"type":"speech","text":"teach"}
//! {"t":1.0,"type":"segment","label":"foa1(water)","kind":"foa","object":"water"}
//! {"t":1.2,"type":"gripper","state":"close","object":"water"}
//! {"t":3.0,"type":"action_done","label":"foa1(water)"}
//! {"t":3.1,"type":"state","var":"water.added","value":true}
//! ```
//!
//! They mirror `/object_stream`, `/robot_stream` (gripper, action events, segments) and
//! `/speech_command`; `arm` is omitted for a single-arm robot.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::schema::ActionKind;

/// One perceived object (ObjectStream).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectObs {
    /// Object name, as in the LTM.
    pub name: String,
    /// End-effector–object distance (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance: Option<f64>,
    /// Per-arm distances (m), dual-arm.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub arm_distances: BTreeMap<String, f64>,
    /// False when not seen.
    #[serde(default = "yes")]
    pub visible: bool,
    /// Workspace area: an arm name or the central area.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub area: Option<String>,
}

fn yes() -> bool {
    true
}

/// Gripper state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GripperState {
    /// Open: the hand is free.
    Open,
    /// Closed, on `object` if any.
    Close,
}

/// A stimulus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Event {
    /// Object distances, visibility, areas.
    Objects { objects: Vec<ObjectObs> },
    /// Gripper opened/closed.
    Gripper {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        arm: Option<String>,
        state: GripperState,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        object: Option<String>,
    },
    /// The robot manager accomplished an action (a.done).
    ActionDone {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        arm: Option<String>,
        label: String,
    },
    /// The robot manager could not accomplish an action.
    ActionFailed {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        arm: Option<String>,
        label: String,
        #[serde(default)]
        reason: String,
    },
    /// A segmented action from a demonstration (teaching).
    Segment {
        #[serde(default, skip_serializing_if = "Option::is_none")]
        arm: Option<String>,
        label: String,
        kind: ActionKind,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        object: Option<String>,
    },
    /// A speech command.
    Speech { text: String },
    /// A state variable observed directly (perception, a person reporting).
    State { var: String, value: bool },
}

/// An event at a time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimedEvent {
    /// Time (s) since the start of the script.
    pub t: f64,
    /// The event.
    #[serde(flatten)]
    pub event: Event,
}

/// Parses a JSON-lines script; blank lines and lines starting with `#` or `//` are skipped.
/// Times must be finite and non-decreasing.
pub fn parse_jsonl(text: &str) -> Result<Vec<TimedEvent>> {
    let mut out: Vec<TimedEvent> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') || l.starts_with("//") {
            continue;
        }
        let ev: TimedEvent = serde_json::from_str(l).map_err(|e| Error::Event { line: i + 1, message: e.to_string() })?;
        if !ev.t.is_finite() {
            return Err(Error::Event { line: i + 1, message: "time t is not finite".into() });
        }
        if let Some(prev) = out.last()
            && ev.t < prev.t
        {
            return Err(Error::Event { line: i + 1, message: format!("time {} goes back (previous {})", ev.t, prev.t) });
        }
        out.push(ev);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_json() {
        let text = r#"{"t":0.0,"type":"objects","objects":[{"name":"water","distance":0.4}]}
# comment
{"t":1.0,"type":"segment","label":"foa1(water)","kind":"foa","object":"water"}
{"t":1.5,"type":"speech","text":"human add(water)"}"#;
        let evs = parse_jsonl(text).expect("parse");
        assert_eq!(evs.len(), 3);
        let again = serde_json::to_string(&evs[1]).expect("ser");
        let back: TimedEvent = serde_json::from_str(&again).expect("de");
        assert_eq!(back, evs[1]);
        match &evs[0].event {
            Event::Objects { objects } => assert!(objects[0].visible),
            e => panic!("{e:?}"),
        }
    }

    #[test]
    fn bad_lines_name_the_line() {
        let e = parse_jsonl("{\"t\":0,\"type\":\"speech\",\"text\":\"x\"}\n{\"t\":1,\"type\":\"telepathy\"}").expect_err("bad");
        assert!(matches!(e, Error::Event { line: 2, .. }), "{e}");
        let e = parse_jsonl("{\"t\":2,\"type\":\"speech\",\"text\":\"x\"}\n{\"t\":1,\"type\":\"speech\",\"text\":\"y\"}").expect_err("back");
        assert!(matches!(e, Error::Event { line: 2, .. }), "{e}");
    }
}
