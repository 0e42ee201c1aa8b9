//! Benchmark-only baselines (thesis Sec. 5.1.2–5.1.3): they allocate, are slow by design, and
//! exist to measure fDED against.
//!
//! - [`brute_force`]: every robot point of the virtual depth × every obstacle pixel of the
//!   filtered depth, with the same metric (eq. 5.15–5.17) — the accuracy ground truth.
//! - [`Flacco`]: Flacco et al.'s CPU method as the thesis ran it: 10 spheres of r = 0.12 m on
//!   the robot, a surveillance cube of half-side ρ = 0.4 m around each, depths outside
//!   1.8–3.5 m skipped, 0.5 m when nothing is found.

mod brute;
mod flacco;

pub use brute::brute_force;
pub use flacco::{Flacco, FlaccoHit, FlaccoParams};
