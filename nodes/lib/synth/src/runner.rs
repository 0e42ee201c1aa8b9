//! The simulation loop shared by the scenarios: 1 kHz steps of the kinematic simulator, the
//! common streams written when due, progress reports.

use std::path::Path;

use cowork_sim::Simulator;

use crate::streams::{Streams, Ticker, rates};
use crate::{Result, SynthError};

/// Simulator + bag + the tickers of the common streams.
pub(crate) struct Runner<'p> {
    pub sim: Simulator,
    pub streams: Streams,
    clock: Ticker,
    joint_states: Ticker,
    tf: Ticker,
    end_ns: i64,
    progress: &'p mut dyn FnMut(f64),
    next_report_ns: i64,
}

impl std::fmt::Debug for Runner<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Runner")
            .field("sim", &self.sim)
            .field("end_ns", &self.end_ns)
            .finish_non_exhaustive()
    }
}

const REPORT_EVERY_NS: i64 = 100_000_000;

impl<'p> Runner<'p> {
    /// Opens the bag, writes `/tf_static` and the state at t = 0.
    pub fn new(
        sim: Simulator,
        path: &Path,
        duration_s: f64,
        progress: &'p mut dyn FnMut(f64),
    ) -> Result<Self> {
        // The plans and the streams are timed from 0: a simulator that already ran would play
        // its plan from the middle (use `continue_from`).
        if sim.time_ns() != 0 {
            return Err(SynthError::Plan {
                scenario: "synth",
                reason: format!("the simulator is at t = {:.3} s, a bag starts at t = 0 (continue_from)", sim.time_ns() as f64 * 1e-9),
            });
        }
        let mut streams = Streams::create(path, &sim)?;
        streams.tf_static(0, &sim)?;
        let mut run = Self {
            sim,
            streams,
            clock: Ticker::new(rates::CLOCK_HZ),
            joint_states: Ticker::new(rates::JOINT_STATES_HZ),
            tf: Ticker::new(rates::TF_HZ),
            end_ns: (duration_s * 1e9).round() as i64,
            progress,
            next_report_ns: 0,
        };
        run.emit_state()?;
        Ok(run)
    }

    /// Simulated time, ns.
    pub fn now(&self) -> i64 {
        self.sim.time_ns()
    }

    /// Whether the scenario's duration is reached.
    pub fn done(&self) -> bool {
        self.sim.time_ns() >= self.end_ns
    }

    /// Duration of the bag, s.
    pub fn duration_s(&self) -> f64 {
        self.end_ns as f64 * 1e-9
    }

    /// One simulator step, then the common streams that became due.
    pub fn step(&mut self) -> Result<()> {
        self.sim.step();
        self.emit_state()
    }

    fn emit_state(&mut self) -> Result<()> {
        let now = self.sim.time_ns();
        while let Some(t) = self.clock.due(now) {
            self.streams.clock(t)?;
        }
        while let Some(t) = self.joint_states.due(now) {
            self.streams.joint_states(t, &self.sim)?;
        }
        while let Some(t) = self.tf.due(now) {
            self.streams.tf(t, &self.sim)?;
        }
        if now >= self.next_report_ns {
            self.next_report_ns = now + REPORT_EVERY_NS;
            (self.progress)((now as f64 / self.end_ns.max(1) as f64).min(1.0));
        }
        Ok(())
    }
}
