//! Robot manager (thesis Sec. 4.3.1, 5.2.1, Fig. 4.10), without ROS: the node `robot_manager`
//! and the CLI drive it.
//!
//! * [`Manager`] — modes execute / teach switched by speech (`teach`, `done`, `stop`,
//!   `repeat`, `gripper open|close`, `human <subtask>`); typed [`Input`]s (the simulator's
//!   world report, speech, supervisor actions, controller statuses, ticks) in, typed
//!   [`Output`]s (motion orders, gripper commands, action events, segments, log lines) out,
//!   time given by the caller;
//! * [`segment`] — online segmentation by proximity spheres (r = 0.12 m) and gripper commands
//!   into NOA / FOA / gripper actions, with the thesis's failure cases logged;
//! * [`primitive`] — NOA as position + orientation DMPs (`cowork_motion`, γ = 5 / duration,
//!   K = 70, D = 2√K), FOA as a linear DS to the end pose, goals and demonstrations in the
//!   object's frame (goal adaptation, eq. 5.2); reproduction error against the demonstration;
//! * [`turn`] — a round object's frame turned about its axis when the taught yaw would bring
//!   the arm onto another object, chosen by previewing the motion with ds_controller's own
//!   controller (ours, beyond the thesis);
//! * [`database`] — one JSON file per robot, written atomically, reloaded byte for byte;
//! * [`refine`] — HMM primitives refined by kinesthetic guidance (Sec. 4.1.3), saved atomically
//!   with their history (version, time, which states changed).
//!
//! State for the supervisor (held object, `hand.free`) comes from the world report, i.e. from
//! what the simulator did, never from what was commanded.
//!
//! ```
//! use cowork_manager::{Database, Input, Manager, ManagerConfig, Output, Stamp};
//! let mut m = Manager::new(ManagerConfig::default(), Database::new("lwr"));
//! let mut out = Vec::new();
//! m.handle(&Input::Speech("make coffee".into()), Stamp { t: 0.0, unix_s: 0 }, &mut out);
//! assert!(matches!(&out[0], Output::Warn(w) if w.contains("not in the vocabulary")));
//! ```

pub mod config;
pub mod database;
pub mod error;
pub mod label;
pub mod manager;
pub mod primitive;
pub mod refine;
pub mod segment;
pub mod turn;
pub mod world;

pub use config::{ManagerConfig, NoaExecution, WORLD, Workspace};
pub use database::Database;
pub use error::{ManagerError, Result};
pub use label::Label;
pub use manager::{
    ActionReport, ActionRequest, Input, Manager, MotionOrder, MotionReport, MotionState, Mode, Output, SegmentReport,
    Stamp, VOCABULARY,
};
pub use refine::{HmmEntry, Revision};
pub use primitive::{MotionPlan, Primitive, ReproductionError, Source, StoredPose, reproduction_error};
pub use segment::{ActionKind, GripperCommand, Note, Segment, Segmenter};
pub use turn::{PreviewPath, PreviewRun, Previewer, TurnConfig};
pub use world::{ObjectReport, World, WorldReport};
