//! Which `/human/state` the controller runs on when more than one writer speaks on the topic.
//!
//! Without DDS security any peer on the domain can publish `/human/state`. Taking the newest
//! message let a peer flooding `present: false` (or `far`) states override human_observer's
//! `interaction` about five times in six: the stranger test (`tests/crosscheck/check_stranger.sh`)
//! measured the tool at 0.3 m/s with a person standing at the table, where 0.1 m/s is allowed.
//! Now the most cautious state that is still live wins: stopped before interaction before
//! far / nobody, each kind kept with its newest stamp, a kind counting while its stamp is within
//! `window_s` (the watchdog's stale bound) of the node's clock. A peer can then only slow the
//! robot, never hurry it, as long as the real observer keeps reporting; the price is that a
//! legitimate change to a faster state (the person leaves, `repeat` after `stop`) takes effect
//! `window_s` later.

use cowork_ds::{HumanInput, HumanMode, HumanState};

/// How cautious a state is: 2 stopped, 1 interaction, 0 far or nobody present.
fn caution(h: &HumanState) -> usize {
    if h.stopped {
        2
    } else if h.present && h.mode == HumanMode::Interaction {
        1
    } else {
        0
    }
}

/// The newest state of each caution level (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CautiousHuman {
    window_s: f64,
    future_tolerance_s: f64,
    newest: [Option<HumanInput>; 3],
}

impl CautiousHuman {
    /// A state counts for `window_s` (s of the node clock) after its stamp; one stamped more
    /// than `future_tolerance_s` ahead of the clock is never kept.
    pub fn new(window_s: f64, future_tolerance_s: f64) -> Self {
        Self { window_s, future_tolerance_s, newest: [None; 3] }
    }

    /// Takes a state stamped `input.stamp` (s) and returns the one to run on at node time `now`
    /// (s): the most cautious live one. A state from the future (beyond the tolerance) is
    /// returned as it is — the watchdog holds the robot on it until the next message — but not
    /// kept, so it cannot pin the robot; with no live state, the one just received is used
    /// (the watchdog judges its age).
    pub fn on_state(&mut self, input: HumanInput, now: f64) -> HumanInput {
        if input.stamp > now + self.future_tolerance_s {
            return input;
        }
        let slot = &mut self.newest[caution(&input.state)];
        if slot.is_none_or(|s| s.stamp <= input.stamp) {
            *slot = Some(input);
        }
        let lo = now - self.window_s;
        let hi = now + self.future_tolerance_s;
        self.newest.iter().rev().flatten().find(|s| s.stamp >= lo && s.stamp <= hi).copied().unwrap_or(input)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state(stamp: f64, present: bool, mode: HumanMode, stopped: bool) -> HumanInput {
        HumanInput { stamp, state: HumanState { present, mode, stopped } }
    }

    #[test]
    fn a_flood_of_absent_states_does_not_override_a_live_interaction() {
        let mut h = CautiousHuman::new(0.3, 0.02);
        let close = state(10.0, true, HumanMode::Interaction, false);
        assert_eq!(h.on_state(close, 10.0), close);
        // A peer's `present: false`, far, newer than the observer's report, every 5 ms.
        for k in 1..20 {
            let t = 10.0 + 0.005 * f64::from(k);
            let got = h.on_state(state(t, false, HumanMode::Far, false), t);
            assert_eq!(got.state.mode, HumanMode::Interaction, "at {t}");
            assert!(got.state.present);
        }
        // The observer goes on reporting interaction: still interaction.
        let again = state(10.1, true, HumanMode::Interaction, false);
        assert_eq!(h.on_state(again, 10.1), again);
        // The observer reports far (the person left): far once interaction is no longer live.
        let far = state(10.2, true, HumanMode::Far, false);
        assert_eq!(h.on_state(far, 10.2).state.mode, HumanMode::Interaction);
        let far = state(10.45, true, HumanMode::Far, false);
        assert_eq!(h.on_state(far, 10.45), far);
    }

    #[test]
    fn stopped_wins_and_old_states_fall_back_to_the_newest() {
        let mut h = CautiousHuman::new(0.3, 0.02);
        let stop = state(1.0, true, HumanMode::Interaction, true);
        h.on_state(stop, 1.0);
        assert!(h.on_state(state(1.1, true, HumanMode::Interaction, false), 1.1).state.stopped);
        assert!(h.on_state(state(1.2, false, HumanMode::Far, false), 1.2).state.stopped);
        // Nothing live: the state just received, whose age the watchdog judges.
        let got = h.on_state(state(1.25, false, HumanMode::Far, false), 5.0);
        assert_eq!(got.stamp, 1.25);
        // A state from the future is used once (the watchdog holds on it) but never kept:
        // the next good state is used at once.
        let mut h = CautiousHuman::new(0.3, 0.02);
        let future = state(1010.0, true, HumanMode::Interaction, false);
        assert_eq!(h.on_state(future, 10.0), future);
        let far = state(10.01, true, HumanMode::Far, false);
        assert_eq!(h.on_state(far, 10.01), far);
        // An older state of a level does not replace a newer one.
        let mut h = CautiousHuman::new(0.3, 0.02);
        h.on_state(state(2.0, true, HumanMode::Interaction, false), 2.0);
        h.on_state(state(1.0, true, HumanMode::Interaction, false), 2.0);
        assert_eq!(h.newest[1].map(|s| s.stamp), Some(2.0));
    }
}
