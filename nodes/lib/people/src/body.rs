//! Body size and anthropometric segment lengths.
//!
//! Lengths are fractions of the standing height H after Drillis & Contini (1966) as tabulated by
//! Winter, *Biomechanics and Motor Control of Human Movement* (4th ed., Fig. 4.1): shoulder
//! height 0.818 H, chest 0.720 H, hip (greater trochanter) 0.530 H, knee 0.285 H, ankle 0.039 H,
//! chin 0.870 H, eyes 0.936 H, upper arm 0.186 H, forearm 0.146 H, hand 0.108 H, shoulder width
//! 0.259 H, hip width 0.191 H, foot length 0.152 H.

use serde::{Deserialize, Serialize};

use crate::error::{Result, check_range};

/// Standing height of a person (m); every segment length follows from it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BodySize {
    /// Standing height, floor to the top of the head (m).
    pub height: f64,
}

/// Segment lengths and offsets of a [`BodySize`] (all m).
///
/// Vertical offsets are above the floor for a person standing upright; lateral offsets are half
/// widths (joint centre to the body's mid-plane).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentLengths {
    /// Shoulder joint centre to elbow joint centre (0.186 H).
    pub upper_arm: f64,
    /// Elbow to wrist (0.146 H).
    pub forearm: f64,
    /// Wrist to finger tips (0.108 H); the `hand` segment point is half way.
    pub hand: f64,
    /// Hip joint centres above the floor when standing (0.530 H, knees very slightly bent).
    pub hip_height: f64,
    /// Thigh: hip to knee (0.245 H).
    pub thigh: f64,
    /// Shank: knee to ankle (0.246 H).
    pub shank: f64,
    /// Ankle above the sole (0.039 H).
    pub ankle_height: f64,
    /// Foot length, heel to toe (0.152 H).
    pub foot: f64,
    /// Hip joint centre half width (0.050 H).
    pub hip_half_width: f64,
    /// Shoulder joint centre half width (0.110 H: half the 0.259 H biacromial width less the
    /// acromion-to-joint-centre offset).
    pub shoulder_half_width: f64,
    /// Shoulder joint centres above the hip joints (0.818 H − 0.530 H).
    pub pelvis_to_shoulder: f64,
    /// Sternum point above the hip joints (0.720 H − 0.530 H).
    pub pelvis_to_sternum: f64,
    /// Sternum point in front of the trunk axis (0.050 H).
    pub sternum_forward: f64,
    /// Base of the neck above the hip joints (0.840 H − 0.530 H).
    pub pelvis_to_neck: f64,
    /// Head centre above the base of the neck (0.935 H − 0.840 H).
    pub neck_to_head: f64,
    /// Head centre in front of the neck axis (0.012 H).
    pub head_forward: f64,
}

impl BodySize {
    /// A small adult, 1.55 m.
    pub const SMALL: BodySize = BodySize { height: 1.55 };
    /// A medium adult, 1.72 m.
    pub const MEDIUM: BodySize = BodySize { height: 1.72 };
    /// A tall adult, 1.90 m.
    pub const TALL: BodySize = BodySize { height: 1.90 };
    /// Smallest accepted height (m).
    pub const MIN_HEIGHT: f64 = 1.0;
    /// Largest accepted height (m).
    pub const MAX_HEIGHT: f64 = 2.3;

    /// A body of `height` m, checked to be within [`Self::MIN_HEIGHT`, `Self::MAX_HEIGHT`].
    pub fn new(height: f64) -> Result<Self> {
        check_range("body height (m)", height, Self::MIN_HEIGHT, Self::MAX_HEIGHT, "1.0 to 2.3 m")?;
        Ok(Self { height })
    }

    /// The three presets: small, medium, tall.
    pub fn presets() -> [BodySize; 3] {
        [Self::SMALL, Self::MEDIUM, Self::TALL]
    }

    /// Segment lengths by the Drillis & Contini ratios (m).
    pub fn lengths(&self) -> SegmentLengths {
        let h = self.height;
        SegmentLengths {
            upper_arm: 0.186 * h,
            forearm: 0.146 * h,
            hand: 0.108 * h,
            hip_height: 0.528 * h,
            thigh: 0.245 * h,
            shank: 0.246 * h,
            ankle_height: 0.039 * h,
            foot: 0.152 * h,
            hip_half_width: 0.050 * h,
            shoulder_half_width: 0.110 * h,
            pelvis_to_shoulder: (0.818 - 0.530) * h,
            pelvis_to_sternum: (0.720 - 0.530) * h,
            sternum_forward: 0.050 * h,
            pelvis_to_neck: (0.840 - 0.530) * h,
            neck_to_head: (0.935 - 0.840) * h,
            head_forward: 0.012 * h,
        }
    }

    /// Capsule radii of the body parts (m), for the depth renderer.
    pub fn radii(&self) -> BodyRadii {
        let h = self.height;
        BodyRadii {
            torso: 0.062 * h,
            torso_half_width: 0.045 * h,
            neck: 0.030 * h,
            head: 0.048 * h,
            upper_arm: 0.024 * h,
            forearm: 0.019 * h,
            hand: 0.016 * h,
            thigh: 0.036 * h,
            shank: 0.026 * h,
            foot: 0.022 * h,
        }
    }

    /// Shoulder-to-hand-point distance with the arm straight (m): the reach of the `hand` point.
    pub fn arm_reach(&self) -> f64 {
        let l = self.lengths();
        l.upper_arm + l.forearm + 0.5 * l.hand
    }
}

impl Default for BodySize {
    fn default() -> Self {
        Self::MEDIUM
    }
}

/// Capsule radii of the body parts (m); `torso_half_width` is the lateral offset of the two
/// torso capsules' axes from the mid-plane.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[allow(missing_docs)]
pub struct BodyRadii {
    pub torso: f64,
    pub torso_half_width: f64,
    pub neck: f64,
    pub head: f64,
    pub upper_arm: f64,
    pub forearm: f64,
    pub hand: f64,
    pub thigh: f64,
    pub shank: f64,
    pub foot: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lengths_add_up_to_the_height() {
        for b in BodySize::presets() {
            let l = b.lengths();
            // Leg chain reaches the hip height (knees slightly bent).
            assert!(l.thigh + l.shank + l.ankle_height > l.hip_height);
            // Head top (centre + radius) near the height.
            let top = l.hip_height + l.pelvis_to_neck + l.neck_to_head + b.radii().head;
            assert!((top - b.height).abs() < 0.03 * b.height, "{top} vs {}", b.height);
        }
        assert!(BodySize::new(f64::NAN).is_err());
        assert!(BodySize::new(0.4).is_err());
        assert!(BodySize::new(1.8).is_ok());
    }
}
