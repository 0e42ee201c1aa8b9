//! Pin-hole camera geometry (eq. 5.14) in the form the stages use.

/// Intrinsics as `f32`, with the image size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cam {
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
    /// Focal lengths, px.
    pub fx: f32,
    /// Focal length along rows, px.
    pub fy: f32,
    /// Principal point, px.
    pub cx: f32,
    /// Principal point row, px.
    pub cy: f32,
}

impl Cam {
    /// Pixel coordinates `[p_x, p_y]` of a camera-frame point (eq. 5.14); `z > 0`.
    #[inline]
    pub fn project(&self, p: &[f32; 4]) -> [f32; 2] {
        let iz = 1.0 / p[2];
        [self.fx * p[0] * iz + self.cx, self.fy * p[1] * iz + self.cy]
    }
}
