//! Motion representation library of cowork (thesis Ch. 3, App. A.3, App. B), with no ROS
//! dependency: DMP, GMM/EM with BIC, GMR and the GMR dynamical system, contracting GMR,
//! invariant descriptors (unidirectional, DHB, EFS/DS), DTW and k-NN, HMM primitives, and the
//! demonstration CSV format used by `cowork learn`.
//!
//! ```
//! use cowork_motion::{Demonstration, Cgmr, CgmrConfig, Components, EmConfig, RolloutConfig, rollout};
//! let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.01).collect();
//! let pos: Vec<f64> = t.iter().flat_map(|t| [1.0 - t, (1.0 - t) * (1.0 - t)]).collect();
//! let demo = Demonstration::new(2, t, pos, None).unwrap();
//! let model = Cgmr::fit(&[demo], Components::Fixed(3), &EmConfig::default(), 1, &CgmrConfig::default()).unwrap();
//! let mut runner = model.runner(None).unwrap();
//! let tr = rollout(&mut runner, &[1.0, 1.0], &RolloutConfig { dt: 0.002, max_steps: 20_000, tol: 1e-3 }).unwrap();
//! assert!(tr.reached);
//! ```

// `!(x > 0.0)` is how NaN is rejected together with the range; index loops walk several
// parallel fixed-size buffers at once in the allocation-free paths.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod appendix_b;
pub mod cgmr;
pub mod csv_io;
pub mod demo;
pub mod dhb;
pub mod dmp;
pub mod ds;
pub mod dtw;
pub mod error;
pub mod gmm;
pub mod gmr;
pub mod hmm;
pub mod invariants;
pub mod lasa;
mod linalg;
pub mod model;
pub mod pose_invariants;
pub mod screw;

pub use cgmr::{Cgmr, CgmrConfig, CgmrRunner, Components, Region, mu1, stabilizing_gains};
pub use demo::Demonstration;
pub use ds::{Autonomous, DsPolicy, FirstOrderDs, LinearDs, RolloutConfig, Trajectory, rollout};
pub use error::{MotionError, Result};
pub use gmm::{BicSelection, EmConfig, Gmm, GmmFit};
pub use gmr::{Gmr, GmrDs};
