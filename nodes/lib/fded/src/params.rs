//! Tunable parameters of fDED, with the thesis's values as defaults (Sec. 5.1.2, Table 5.1).

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// Which implementation runs the per-frame pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Backend {
    /// The CPU reference implementation in this crate (always available).
    #[default]
    Cpu,
    /// The wgpu compute path (`src/gpu/`); same stages and buffers as the CPU path.
    Gpu,
}

/// fDED parameters. Lengths in m, image quantities in px.
///
/// Defaults: T_s = 32 px, S_x = S_y = 16 px (Table 5.1), δ = 5 cm robot removal, L = 1 % of
/// the image's points for the normal fit. The table, depth range, removal margin, point
/// spacing and velocity settings are ours (the thesis removes the table without saying how).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FdedParams {
    /// Side T_s of the square tiles that build the robot lattice, px (≥ 1).
    pub tile_size: u32,
    /// Object lattice step S_x along image columns, px (≥ 1; 1 = every pixel).
    pub step_x: u32,
    /// Object lattice step S_y along image rows, px (≥ 1).
    pub step_y: u32,
    /// Robot removal threshold δ: a pixel covered by the virtual depth d_r whose real depth d
    /// has |d − d_r| ≤ δ is the robot itself, m.
    pub robot_delta: f64,
    /// Robot removal also takes pixels up to this far outside the projected link triangles
    /// (joint state and depth image a few ms apart, calibration), px.
    pub robot_margin: f64,
    /// Largest distance between neighbouring robot points: the mesh vertices (the thesis's
    /// robot points) plus points on longer triangle edges, m.
    pub robot_point_spacing: f64,
    /// Depth readings below this are ignored (sensor minimum range), m.
    pub min_depth: f64,
    /// Depth readings beyond this are background, m.
    pub max_depth: f64,
    /// Height of the table plane in the robot base frame (z), m; points below
    /// `table_z + table_margin` are not obstacles. `None` keeps every point.
    pub table_z: Option<f64>,
    /// Margin above the table plane that still counts as table (noise, thin objects), m. The
    /// default 3 cm covers a Kinect's depth quantisation on a table 2.5–3 m away (≈ 2.3 cm).
    pub table_margin: f64,
    /// After the thesis's robot-side refinement, also search the real depth at full resolution
    /// within ±S around the closest object lattice point (against the closest robot point,
    /// then the robot tile once more). Our addition; it lifts the accuracy bound set by S.
    pub refine_obstacle: bool,
    /// Fraction of the image's points used in the normal's plane fit (thesis: L = 1 %).
    pub normal_fraction: f64,
    /// Gaussian width of the normal fit's weights around the closest point, m.
    pub normal_sigma: f64,
    /// Closest obstacle points of one link that move faster than this between two frames are
    /// taken as a different obstacle: its velocity restarts at zero, m/s.
    pub max_obstacle_speed: f64,
    /// Weight of the newest finite difference in the smoothed obstacle velocity (0..=1; 1 = raw).
    pub velocity_smoothing: f64,
    /// Triangles with a vertex closer to the camera than this are not rendered, m.
    pub near_clip: f64,
    /// Worker threads of the CPU path (1 = the calling thread only).
    pub threads: usize,
    /// Which implementation runs the pipeline.
    pub backend: Backend,
}

impl Default for FdedParams {
    fn default() -> Self {
        Self {
            tile_size: 32,
            step_x: 16,
            step_y: 16,
            robot_delta: 0.05,
            robot_margin: 3.0,
            robot_point_spacing: 0.015,
            min_depth: 0.1,
            max_depth: 6.0,
            table_z: Some(0.0),
            table_margin: 0.03,
            refine_obstacle: true,
            normal_fraction: 0.01,
            normal_sigma: 0.05,
            max_obstacle_speed: 3.0,
            velocity_smoothing: 0.5,
            near_clip: 0.01,
            threads: 1,
            backend: Backend::Cpu,
        }
    }
}

impl FdedParams {
    /// Rejects NaN and out-of-range values, naming the field.
    pub fn validate(&self) -> Result<()> {
        fn bad(name: &'static str, value: impl ToString, reason: &'static str) -> Error {
            Error::BadParameter {
                name,
                value: value.to_string(),
                reason,
            }
        }
        for (name, v) in [
            ("tile_size", self.tile_size),
            ("step_x", self.step_x),
            ("step_y", self.step_y),
        ] {
            if !(1..=4096).contains(&v) {
                return Err(bad(name, v, "must be in 1..=4096 px"));
            }
        }
        for (name, v) in [
            ("robot_delta", self.robot_delta),
            ("robot_margin", self.robot_margin),
            ("min_depth", self.min_depth),
            ("table_margin", self.table_margin),
            ("near_clip", self.near_clip),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(name, v, "must be finite and ≥ 0"));
            }
        }
        if !(self.robot_point_spacing.is_finite() && self.robot_point_spacing >= 1e-3) {
            return Err(bad("robot_point_spacing", self.robot_point_spacing, "must be finite and ≥ 0.001 m"));
        }
        if !(self.max_depth.is_finite() && self.max_depth > self.min_depth) {
            return Err(bad("max_depth", self.max_depth, "must be finite and > min_depth"));
        }
        if let Some(z) = self.table_z
            && !z.is_finite()
        {
            return Err(bad("table_z", z, "must be finite"));
        }
        if !(self.normal_fraction.is_finite()
            && self.normal_fraction > 0.0
            && self.normal_fraction <= 1.0)
        {
            return Err(bad("normal_fraction", self.normal_fraction, "must be in (0, 1]"));
        }
        for (name, v) in [
            ("normal_sigma", self.normal_sigma),
            ("max_obstacle_speed", self.max_obstacle_speed),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, v, "must be finite and > 0"));
            }
        }
        if !(self.velocity_smoothing.is_finite()
            && self.velocity_smoothing > 0.0
            && self.velocity_smoothing <= 1.0)
        {
            return Err(bad("velocity_smoothing", self.velocity_smoothing, "must be in (0, 1]"));
        }
        if !(1..=64).contains(&self.threads) {
            return Err(bad("threads", self.threads, "must be in 1..=64"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_thesis_values_and_valid() {
        let p = FdedParams::default();
        assert_eq!((p.tile_size, p.step_x, p.step_y), (32, 16, 16));
        assert_eq!(p.robot_delta, 0.05);
        assert_eq!(p.normal_fraction, 0.01);
        p.validate().unwrap();
    }

    #[test]
    fn nan_and_zero_are_rejected() {
        let p = FdedParams {
            robot_delta: f64::NAN,
            ..FdedParams::default()
        };
        assert!(matches!(p.validate(), Err(Error::BadParameter { name: "robot_delta", .. })));
        let p = FdedParams {
            step_x: 0,
            ..FdedParams::default()
        };
        assert!(matches!(p.validate(), Err(Error::BadParameter { name: "step_x", .. })));
    }

    #[test]
    fn yaml_with_unknown_field_fails() {
        let y = "tile_size: 16\nstep: 4\n";
        assert!(serde_yaml_ng::from_str::<FdedParams>(y).is_err());
        let p: FdedParams = serde_yaml_ng::from_str("tile_size: 16\nbackend: gpu\n").unwrap();
        assert_eq!((p.tile_size, p.backend), (16, Backend::Gpu));
    }
}
