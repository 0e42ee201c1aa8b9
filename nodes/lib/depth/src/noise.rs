//! Kinect-like depth noise: depth-dependent Gaussian error, disparity quantisation, range
//! limits, random and edge dropouts. Deterministic from a seed.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::StandardNormal;

use crate::error::{Error, Result};

/// Parameters of the Kinect (v1, structured light) noise model.
///
/// Per pixel with a return at ideal depth `z` (m), in this order:
/// 1. **axial noise**: `z + σ_g(z) n`, `n ~ N(0, 1)`, where `σ(z) = sigma_base_m +
///    sigma_quadratic_per_m (z − sigma_offset_m)²` is the total standard deviation measured by
///    Nguyen, Izadi and Lovell (3DIMPVT 2012, σ(z) = 1.2 mm + 1.9 mm/m² (z − 0.4 m)²; the thesis
///    gives no model of its own, Sec. 5.1.2 only notes "the typical accuracy of depth sensors"),
///    and `σ_g² = σ² − q²/12` removes the share the quantisation below adds, so the total
///    standard deviation stays `σ(z)` (when `q²/12 > σ²`, `σ_g = 0`);
/// 2. **disparity quantisation** (Khoshelham and Oude Elberink, Sensors 2012): the sensor
///    measures disparity `d = f b / z` in steps of `disparity_step_px`; depth is `f b / d_q`.
///    The depth step is `q(z) = z² Δd / (f b)` (2.9 mm at 1 m, 26 mm at 3 m with the defaults);
/// 3. **range**: depths outside `[min_range_m, max_range_m]` give no return;
/// 4. **edge dropouts**: a pixel next to a depth discontinuity (a 4-neighbour with no return or
///    more than `edge_jump_m` nearer or farther) has no return with `edge_dropout_probability`
///    (the Kinect loses the pattern at silhouettes);
/// 5. **random dropouts**: any pixel has no return with `dropout_probability`.
///
/// Noise is a pure function of `seed`, the frame number and the ideal image: the same seed
/// gives the same noisy sequence whatever the thread count.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KinectNoise {
    /// Seed of the random sequence.
    pub seed: u64,
    /// Constant part of σ(z), m.
    pub sigma_base_m: f64,
    /// Quadratic coefficient of σ(z), m per m² (i.e. 1/m).
    pub sigma_quadratic_per_m: f64,
    /// Depth where σ(z) is smallest, m.
    pub sigma_offset_m: f64,
    /// Projector–camera baseline `b`, m.
    pub baseline_m: f64,
    /// Focal length `f` of the IR camera that measures disparity, px.
    pub disparity_focal_px: f64,
    /// Disparity resolution `Δd`, px (the Kinect interpolates to 1/8 px); 0 disables quantisation.
    pub disparity_step_px: f64,
    /// Nearest depth with a return, m.
    pub min_range_m: f64,
    /// Farthest depth with a return, m.
    pub max_range_m: f64,
    /// Probability that any pixel has no return.
    pub dropout_probability: f64,
    /// Probability that a pixel at a depth discontinuity has no return.
    pub edge_dropout_probability: f64,
    /// Depth difference to a 4-neighbour that makes a discontinuity, m.
    pub edge_jump_m: f64,
}

impl Default for KinectNoise {
    fn default() -> Self {
        Self {
            seed: 0,
            sigma_base_m: 0.0012,
            sigma_quadratic_per_m: 0.0019,
            sigma_offset_m: 0.4,
            baseline_m: 0.075,
            disparity_focal_px: 580.0,
            disparity_step_px: 0.125,
            min_range_m: 0.4,
            max_range_m: 5.0,
            dropout_probability: 0.005,
            edge_dropout_probability: 0.5,
            edge_jump_m: 0.05,
        }
    }
}

impl KinectNoise {
    /// The default model with `seed`.
    pub fn with_seed(seed: u64) -> Self {
        Self { seed, ..Self::default() }
    }

    /// A model with only the axial Gaussian noise (no quantisation, dropouts or range limits),
    /// e.g. to check σ(z).
    pub fn gaussian_only(seed: u64) -> Self {
        Self {
            seed,
            disparity_step_px: 0.0,
            min_range_m: 0.0,
            max_range_m: f64::INFINITY,
            dropout_probability: 0.0,
            edge_dropout_probability: 0.0,
            ..Self::default()
        }
    }

    /// Rejects NaN and out-of-range parameters, naming the field.
    pub fn validate(&self) -> Result<()> {
        let nonneg = [
            ("noise.sigma_base_m", self.sigma_base_m),
            ("noise.sigma_quadratic_per_m", self.sigma_quadratic_per_m),
            ("noise.sigma_offset_m", self.sigma_offset_m),
            ("noise.disparity_step_px", self.disparity_step_px),
            ("noise.min_range_m", self.min_range_m),
            ("noise.edge_jump_m", self.edge_jump_m),
        ];
        for (field, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::bad_value(field, v, "must be finite and ≥ 0"));
            }
        }
        for (field, v) in [("noise.baseline_m", self.baseline_m), ("noise.disparity_focal_px", self.disparity_focal_px)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::bad_value(field, v, "must be finite and > 0"));
            }
        }
        if !(self.max_range_m > self.min_range_m) {
            return Err(Error::bad_value(
                "noise.max_range_m",
                self.max_range_m,
                format!("must be greater than noise.min_range_m = {}", self.min_range_m),
            ));
        }
        for (field, v) in [
            ("noise.dropout_probability", self.dropout_probability),
            ("noise.edge_dropout_probability", self.edge_dropout_probability),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(Error::bad_value(field, v, "must be a probability in [0, 1]"));
            }
        }
        Ok(())
    }

    /// Total axial standard deviation σ(z) of the model at depth `z` (m), m.
    pub fn sigma(&self, z: f64) -> f64 {
        let dz = z - self.sigma_offset_m;
        self.sigma_base_m + self.sigma_quadratic_per_m * dz * dz
    }

    /// Depth quantisation step q(z) = z² Δd / (f b) at depth `z` (m), m; 0 without quantisation.
    pub fn quantisation_step(&self, z: f64) -> f64 {
        z * z * self.disparity_step_px / (self.disparity_focal_px * self.baseline_m)
    }

    /// Standard deviation of the Gaussian part, σ_g = √(σ² − q²/12), m.
    pub fn gaussian_sigma(&self, z: f64) -> f64 {
        let s = self.sigma(z);
        let q = self.quantisation_step(z);
        (s * s - q * q / 12.0).max(0.0).sqrt()
    }

    /// The random generator of rows band `band` of frame `frame`: one ChaCha stream each, so
    /// bands can be processed in any order or in parallel.
    pub(crate) fn rng(&self, frame: u64, band: u64) -> ChaCha8Rng {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(frame.wrapping_mul(1 << 16).wrapping_add(band));
        rng
    }

    /// Applies the noise to rows `y0..y0 + out.len() / width` of an image whose noise-free
    /// depths (m, 0 = no return) are `clean` (the whole image, `width` columns).
    pub(crate) fn apply_band(&self, clean: &[f32], width: usize, y0: usize, out: &mut [f32], rng: &mut ChaCha8Rng) {
        let height = clean.len() / width;
        let fb = self.disparity_focal_px * self.baseline_m;
        let step = self.disparity_step_px;
        let jump = self.edge_jump_m as f32;
        for (r, out_row) in out.chunks_exact_mut(width).enumerate() {
            let y = y0 + r;
            let row = &clean[y * width..(y + 1) * width];
            let up = (y > 0).then(|| &clean[(y - 1) * width..y * width]);
            let down = (y + 1 < height).then(|| &clean[(y + 1) * width..(y + 2) * width]);
            for (x, o) in out_row.iter_mut().enumerate() {
                let z = row[x];
                if z <= 0.0 {
                    *o = 0.0;
                    continue;
                }
                let far = |n: f32| n <= 0.0 || (n - z).abs() > jump;
                let edge = (x > 0 && far(row[x - 1]))
                    || (x + 1 < width && far(row[x + 1]))
                    || up.is_some_and(|u| far(u[x]))
                    || down.is_some_and(|d| far(d[x]));
                // Two draws per pixel with a return, whatever the outcome: the stream's use
                // depends only on the clean image.
                let n: f64 = rng.sample(StandardNormal);
                let drop_u: f64 = rng.random();
                if drop_u < self.dropout_probability
                    || (edge && drop_u < self.dropout_probability + self.edge_dropout_probability)
                {
                    *o = 0.0;
                    continue;
                }
                let z = f64::from(z);
                let mut zn = z + self.gaussian_sigma(z) * n;
                if step > 0.0 && zn > 0.0 {
                    let d = (fb / zn / step).round().max(1.0) * step;
                    zn = fb / d;
                }
                *o = if zn >= self.min_range_m && zn <= self.max_range_m { zn as f32 } else { 0.0 };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn model_figures() {
        let n = KinectNoise::default();
        assert!((n.sigma(0.4) - 0.0012).abs() < 1e-12);
        assert!((n.sigma(1.0) - (0.0012 + 0.0019 * 0.36)).abs() < 1e-12);
        assert!((n.sigma(3.0) - (0.0012 + 0.0019 * 6.76)).abs() < 1e-12);
        assert!((n.quantisation_step(1.0) - 0.125 / 43.5).abs() < 1e-12);
        assert!(n.gaussian_sigma(3.0) < n.sigma(3.0));
        assert!(n.validate().is_ok());
    }

    #[test]
    fn validate_names_fields() {
        let cases: [(fn(&mut KinectNoise), &str); 5] = [
            (|n| n.sigma_base_m = f64::NAN, "noise.sigma_base_m"),
            (|n| n.baseline_m = 0.0, "noise.baseline_m"),
            (|n| n.dropout_probability = 1.5, "noise.dropout_probability"),
            (|n| n.edge_dropout_probability = -0.1, "noise.edge_dropout_probability"),
            (|n| n.max_range_m = 0.1, "noise.max_range_m"),
        ];
        for (f, field) in cases {
            let mut n = KinectNoise::default();
            f(&mut n);
            assert!(n.validate().unwrap_err().to_string().contains(field), "{field}");
        }
    }
}
