//! `cowork say <words>`: publish a speech command, as a person would say it.

use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use clap::Args;
use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{NodeConfig, RosNode};

/// Speech vocabulary of the graph (thesis Sec. 5.2.3); `human <subtask>` takes any subtask;
/// `ARM: <words>` addresses one arm of a two-arm graph (`left: teach`).
pub const VOCABULARY: &[&str] =
    &["teach", "done", "stop", "repeat", "gripper open", "gripper close", "human <subtask>", "<arm>: <any of these>"];

/// Arguments of `cowork say`.
#[derive(Debug, Args)]
pub struct SayArgs {
    /// The words, e.g. `teach`, `gripper close`, `human add(water)`.
    #[arg(required = true, num_args = 1..)]
    words: Vec<String>,
    /// Wait this long for a listener before publishing anyway, s.
    #[arg(long, default_value_t = 2.0)]
    wait: f64,
    /// Publish even a phrase outside the vocabulary (listeners will log it as unknown).
    #[arg(long)]
    force: bool,
}

/// Whether `phrase` is in the speech vocabulary, addressed to one arm or not.
pub fn is_known(phrase: &str) -> bool {
    let p = phrase.trim();
    let p = match p.split_once(':') {
        Some((arm, words)) if cowork_ros::is_name_token(arm.trim()) => words.trim(),
        _ => p,
    };
    matches!(p, "teach" | "done" | "stop" | "repeat" | "gripper open" | "gripper close")
        || p.strip_prefix("human ").is_some_and(|s| !s.trim().is_empty())
}

/// Runs `cowork say`.
pub fn run(args: SayArgs) -> Result<()> {
    let phrase = args.words.join(" ");
    if !is_known(&phrase) && !args.force {
        bail!("{phrase:?} is not a speech command; known: {} (use --force to send it anyway)", VOCABULARY.join(", "));
    }
    if !(args.wait.is_finite() && args.wait >= 0.0) {
        bail!("--wait {}: must be a non-negative number of seconds", args.wait);
    }
    let mut node = RosNode::new(&format!("cowork_say_{}", std::process::id()), &NodeConfig::default())?;
    let publisher = node.advertise(&cowork_msgs::topics::SPEECH_COMMAND)?;
    let deadline = Instant::now() + cowork_ros::duration_s(args.wait);
    while publisher.subscription_count(&node) == 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let listeners = publisher.subscription_count(&node);
    publisher.publish(RosString { data: phrase.clone() })?;
    // Give reliable delivery a moment before the participant leaves.
    std::thread::sleep(Duration::from_millis(300));
    eprintln!("said {phrase:?} on /speech_command ({listeners} listener(s))");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vocabulary() {
        for p in ["teach", "done", "stop", "repeat", "gripper open", "gripper close", "human add(water)", "left: teach", "right:gripper close", "left: human add(water)"] {
            assert!(is_known(p), "{p}");
        }
        for p in ["", "human", "human  ", "go", "gripper", "left:", "left: go", "two arms: teach"] {
            assert!(!is_known(p), "{p}");
        }
    }
}
