//! Kinesthetic demonstrations of the other kitchen subtasks the thesis teaches (Sec. 4.3.3,
//! Fig. 4.14, 5.23), generated like `kinesthetic-pour` ([`crate::pour`]): a scripted teacher
//! pushes the gravity-compensated arm along a planned path with wrenches (eq. 4.6 inverted) and
//! speaks `teach`, `gripper close`, `gripper open`, `done`.
//!
//! | scenario | subtask | take | use at the cup | place (x, y) m |
//! |---|---|---|---|---|
//! | `kinesthetic-coffee` | add(coffee) | the coffee jar | pour (tilt 2.0 rad) | (0.42, −0.20) |
//! | `kinesthetic-spoon` | use(spoon) | the spoon | stir: bowl down 3 cm into the cup, 2 circles of 1.5 cm | (0.55, −0.18) |
//! | `kinesthetic-tea` | add(tea) | the tea box | tilt 1.6 rad, 2 shakes of ±0.25 rad | (0.25, 0.25) |
//!
//! Each is segmented by the robot manager into the nine actions of the pour (Fig. 5.18): FOA
//! and NOA to the object, gripper close, FOA and NOA at the cup, FOA to the place, gripper open,
//! NOA and FOA of the retreat. The tea demonstration passes two waypoints that keep the tool out
//! of the bottle's proximity sphere (a path through it would add a NOA on the bottle).

use crate::pour::{Demonstration, Usage};

/// `kinesthetic-coffee`: add(coffee).
pub const COFFEE: Demonstration = Demonstration {
    scenario: "kinesthetic-coffee",
    object: "coffee",
    target: "cup",
    place_xy: [0.42, -0.20],
    usage: Usage::Pour { tilt_rad: 2.0 },
    approach_via: None,
    carry_via: None,
};

/// `kinesthetic-spoon`: use(spoon).
pub const SPOON: Demonstration = Demonstration {
    scenario: "kinesthetic-spoon",
    object: "spoon",
    target: "cup",
    place_xy: [0.55, -0.18],
    usage: Usage::Stir { depth_m: 0.03, radius_m: 0.015, turns: 2 },
    approach_via: None,
    carry_via: None,
};

/// `kinesthetic-tea`: add(tea).
pub const TEA: Demonstration = Demonstration {
    scenario: "kinesthetic-tea",
    object: "tea",
    target: "cup",
    place_xy: [0.25, 0.25],
    usage: Usage::Shake { tilt_rad: 1.6, amplitude_rad: 0.25, shakes: 2 },
    approach_via: Some([0.25, 0.20, 0.35]),
    carry_via: Some([0.30, 0.15, 0.35]),
};

/// Natural length of `kinesthetic-coffee` (the pour's path), s.
pub const COFFEE_DURATION_S: f64 = 28.5;
/// Natural length of `kinesthetic-spoon` (16 stirring moves of 0.5 s instead of the 2 s hold), s.
pub const SPOON_DURATION_S: f64 = 34.5;
/// Natural length of `kinesthetic-tea` (two waypoints of 2.5 s, 2 shakes of 1.2 s and 0.6 s back), s.
pub const TEA_DURATION_S: f64 = 36.5;
