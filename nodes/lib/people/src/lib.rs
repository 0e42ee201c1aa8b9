//! Synthetic people (thesis Sec. 4.2, 5.1.3): 11-segment Xsens-like skeletons and their motions.
//!
//! A [`Performer`] is one person ([`BodySize`] → segment lengths by anthropometric ratios) with
//! a script of [`Action`]s — walking into and out of the workspace, standing with postural
//! sway, reaching towards a point, sweeping a hand along a line, and the command gestures
//! *come*, *stop* and *handover right* ([`GestureKind`]). The pose is a deterministic function
//! of time ([`Performer::pose`]): positions and orientations of the 11 segments in the robot
//! base frame (m, unit quaternions) with linear and angular velocities. A [`Timeline`] places
//! performers on one clock; a [`Sampler`] turns it into `cowork_msgs/Skeleton` messages as an
//! Xsens suit (120 Hz) or a depth tracker (30 Hz, lost frames, jitter) would, with Gaussian
//! noise per segment. [`GestureSet`] draws a labelled set of gesture performances across sizes,
//! speeds, positions and viewing angles; [`body_capsules`] gives the capsule body the depth
//! renderer draws. [`guide::Guide`] is a person who physically guides the robot's tool (Sec. 4.1.3).
//!
//! ```
//! use cowork_people::{Action, BodySize, GestureKind, GestureStyle, Performer, Room, SensorConfig, Stance, Timeline, Sampler};
//!
//! let room = Room::default();
//! let p = Performer::new(1, BodySize::MEDIUM, Stance::new(0.3, -1.1, 1.2), 7)?
//!     .then(Action::Stand { duration: 0.5 })?
//!     .then(Action::Gesture { kind: GestureKind::Stop, style: GestureStyle::default() })?;
//! let mut timeline = Timeline::new();
//! timeline.add(0.0, p)?;
//! let msgs: Vec<_> = Sampler::new(&timeline, SensorConfig::xsens(), 42)?.collect();
//! assert_eq!(msgs[0].segment_names.len(), 11);
//! assert_eq!(msgs[0].header.frame_id, "lwr_base_link");
//! assert!(msgs.len() as f64 >= timeline.duration() * 120.0);
//! # let _ = room;
//! # Ok::<(), cowork_people::PeopleError>(())
//! ```

mod body;
mod capsule;
mod error;
mod features;
mod gesture_set;
pub mod guide;
mod kinematics;
mod motion;
mod performer;
mod pose;
mod sampler;

pub use body::{BodyRadii, BodySize, SegmentLengths};
pub use capsule::{BODY_CAPSULE_COUNT, BODY_CAPSULE_NAMES, Capsule, body_capsules};
pub use error::{PeopleError, Result};
pub use features::{hand_relative_to_sternum, resample_flat};
pub use gesture_set::{GestureInstance, GestureSet, GestureSetConfig};
pub use motion::{Action, GestureKind, GestureStyle, Span, SpanKind, Stance};
pub use performer::{DEFAULT_FLOOR_Z, Performer, Room, Timeline, TimelineEntry, TimelineSpan};
pub use pose::{Foot, MessageMeta, SEGMENT_COUNT, Segment, SegmentState, Side, SkeletonPose};
pub use sampler::{BASE_FRAME, Sampler, SensorConfig, Source, add_noise, sample_timeline};
