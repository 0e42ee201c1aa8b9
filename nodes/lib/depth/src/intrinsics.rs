//! Pin-hole camera intrinsics (thesis eq. 5.14) and their `sensor_msgs/CameraInfo` form.

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::sensor_msgs::{CameraInfo, RegionOfInterest};
use cowork_msgs::std_msgs::Header;
use nalgebra::Point3;

use crate::error::{Error, Result};

/// Intrinsics of a pin-hole depth camera (thesis eq. 5.14).
///
/// Frames and units: points are in the camera **optical frame** (z forward along the optical
/// axis, x to the image right, y to the image bottom), in m. Pixel coordinates `(u, v)` are in
/// px with the ROS convention that integer values are pixel **centres**: pixel `(i, j)` (column
/// `i`, row `j`) covers `[i − ½, i + ½) × [j − ½, j + ½)`, so the image spans
/// `u ∈ [−½, width − ½)`, `v ∈ [−½, height − ½)`. Depth is the optical-frame z of a point, m
/// (not the length of the ray).
///
/// ```
/// use cowork_depth::Intrinsics;
/// use nalgebra::Point3;
///
/// let k = Intrinsics::kinect();
/// let p = Point3::new(0.1, -0.05, 1.5);
/// let (u, v, d) = k.project(&p).unwrap();
/// assert!((k.unproject(u, v, d) - p).norm() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Image columns, px.
    pub width: u32,
    /// Image rows, px.
    pub height: u32,
    /// Focal length along u, px.
    pub fx: f64,
    /// Focal length along v, px.
    pub fy: f64,
    /// Principal point column, px.
    pub cx: f64,
    /// Principal point row, px.
    pub cy: f64,
}

impl Intrinsics {
    /// The nominal Kinect depth camera: 640×480 px, f = 525 px, principal point at the image
    /// centre (319.5, 239.5) px.
    pub fn kinect() -> Self {
        Self { width: 640, height: 480, fx: 525.0, fy: 525.0, cx: 319.5, cy: 239.5 }
    }

    /// Checks that the size is positive, the focal lengths finite and positive and the
    /// principal point finite.
    pub fn validate(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 {
            let field = if self.width == 0 { "width" } else { "height" };
            let value = if self.width == 0 { self.width } else { self.height };
            return Err(Error::BadIntrinsics {
                field,
                value: value.to_string(),
                reason: "the image must have pixels",
            });
        }
        for (field, v) in [("fx", self.fx), ("fy", self.fy)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::BadIntrinsics {
                    field,
                    value: v.to_string(),
                    reason: "focal length must be finite and > 0 px",
                });
            }
        }
        for (field, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !v.is_finite() {
                return Err(Error::BadIntrinsics {
                    field,
                    value: v.to_string(),
                    reason: "principal point must be finite",
                });
            }
        }
        Ok(())
    }

    /// Intrinsics from the `K` matrix and size of a `CameraInfo`.
    ///
    /// Checks: `width`, `height` > 0; `K` = `[fx 0 cx; 0 fy cy; 0 0 1]` with finite entries,
    /// `fx`, `fy` > 0 and zero skew; `binning_x`, `binning_y` ≤ 1. The distortion `D` is not
    /// used: depth images are taken to be rectified (as the Kinect's depth stream is). The
    /// error names the offending field.
    pub fn from_camera_info(info: &CameraInfo) -> Result<Self> {
        if info.width == 0 {
            return Err(Error::BadCameraInfo {
                field: "width",
                value: "0".into(),
                reason: "the image must have pixels",
            });
        }
        if info.height == 0 {
            return Err(Error::BadCameraInfo {
                field: "height",
                value: "0".into(),
                reason: "the image must have pixels",
            });
        }
        const NAMES: [&str; 9] = ["k[0]", "k[1]", "k[2]", "k[3]", "k[4]", "k[5]", "k[6]", "k[7]", "k[8]"];
        for (i, v) in info.k.iter().enumerate() {
            if !v.is_finite() {
                return Err(Error::BadCameraInfo {
                    field: NAMES[i],
                    value: v.to_string(),
                    reason: "K must be finite",
                });
            }
        }
        let k = &info.k;
        for (i, reason) in [(0, "fx must be > 0 px"), (4, "fy must be > 0 px")] {
            if k[i] <= 0.0 {
                return Err(Error::BadCameraInfo {
                    field: NAMES[i],
                    value: k[i].to_string(),
                    reason,
                });
            }
        }
        for (i, want, reason) in [
            (1, 0.0, "skew is not supported (must be 0)"),
            (3, 0.0, "K must be [fx 0 cx; 0 fy cy; 0 0 1]"),
            (6, 0.0, "K must be [fx 0 cx; 0 fy cy; 0 0 1]"),
            (7, 0.0, "K must be [fx 0 cx; 0 fy cy; 0 0 1]"),
            (8, 1.0, "K must be [fx 0 cx; 0 fy cy; 0 0 1]"),
        ] {
            if k[i] != want {
                return Err(Error::BadCameraInfo { field: NAMES[i], value: k[i].to_string(), reason });
            }
        }
        if info.binning_x > 1 {
            return Err(Error::BadCameraInfo {
                field: "binning_x",
                value: info.binning_x.to_string(),
                reason: "binned images are not supported (must be 0 or 1)",
            });
        }
        if info.binning_y > 1 {
            return Err(Error::BadCameraInfo {
                field: "binning_y",
                value: info.binning_y.to_string(),
                reason: "binned images are not supported (must be 0 or 1)",
            });
        }
        Ok(Self { width: info.width, height: info.height, fx: k[0], fy: k[4], cx: k[2], cy: k[5] })
    }

    /// The `CameraInfo` of these intrinsics: `plumb_bob` with zero distortion, `R` = identity,
    /// `P` = `[K | 0]`, no binning, full-image ROI.
    pub fn to_camera_info(&self, stamp: Time, frame_id: &str) -> CameraInfo {
        let (fx, fy, cx, cy) = (self.fx, self.fy, self.cx, self.cy);
        CameraInfo {
            header: Header::new(stamp, frame_id),
            height: self.height,
            width: self.width,
            distortion_model: "plumb_bob".into(),
            d: vec![0.0; 5],
            k: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
            r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            p: [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
            binning_x: 0,
            binning_y: 0,
            roi: RegionOfInterest::default(),
        }
    }

    /// Eq. 5.14: the pixel coordinates `(u, v)` (px) and depth `z` (m) of a point given in the
    /// optical frame (m). `None` when the point is not strictly in front of the camera
    /// (`z ≤ 0` or not finite) or projects outside the image (see [`Intrinsics`] for the pixel
    /// convention); use [`project_unclipped`](Self::project_unclipped) to keep those.
    pub fn project(&self, p: &Point3<f64>) -> Option<(f64, f64, f64)> {
        let (u, v, z) = self.project_unclipped(p)?;
        self.contains(u, v).then_some((u, v, z))
    }

    /// Like [`project`](Self::project) but without the image-bounds check.
    pub fn project_unclipped(&self, p: &Point3<f64>) -> Option<(f64, f64, f64)> {
        if !(p.z > 0.0 && p.z.is_finite() && p.x.is_finite() && p.y.is_finite()) {
            return None;
        }
        Some((self.fx * p.x / p.z + self.cx, self.fy * p.y / p.z + self.cy, p.z))
    }

    /// The point (optical frame, m) at pixel coordinates `(u, v)` (px) and depth `depth` (m):
    /// the inverse of eq. 5.14, `x = (u − cx) d / fx`, `y = (v − cy) d / fy`, `z = d`.
    pub fn unproject(&self, u: f64, v: f64, depth: f64) -> Point3<f64> {
        Point3::new((u - self.cx) * depth / self.fx, (v - self.cy) * depth / self.fy, depth)
    }

    /// `true` when `(u, v)` (px) lies inside the image.
    pub fn contains(&self, u: f64, v: f64) -> bool {
        u >= -0.5 && v >= -0.5 && u < f64::from(self.width) - 0.5 && v < f64::from(self.height) - 0.5
    }

    /// The pixel `(column, row)` that contains `(u, v)` (px), `None` outside the image.
    pub fn pixel(&self, u: f64, v: f64) -> Option<(u32, u32)> {
        self.contains(u, v).then(|| ((u + 0.5).floor() as u32, (v + 0.5).floor() as u32))
    }

    /// Number of pixels, `width * height`.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn camera_info_round_trip() {
        let k = Intrinsics { width: 320, height: 240, fx: 300.0, fy: 310.0, cx: 160.2, cy: 119.7 };
        let info = k.to_camera_info(Time { sec: 3, nanosec: 5 }, "cam");
        assert_eq!(info.header.frame_id, "cam");
        assert_eq!(info.header.stamp, Time { sec: 3, nanosec: 5 });
        assert_eq!(Intrinsics::from_camera_info(&info).unwrap(), k);
    }

    #[test]
    fn bad_camera_info_names_the_field() {
        let good = Intrinsics::kinect().to_camera_info(Time::default(), "cam");
        let cases: Vec<(Box<dyn Fn(&mut CameraInfo)>, &str)> = vec![
            (Box::new(|c| c.width = 0), "width"),
            (Box::new(|c| c.height = 0), "height"),
            (Box::new(|c| c.k[0] = 0.0), "k[0]"),
            (Box::new(|c| c.k[4] = -1.0), "k[4]"),
            (Box::new(|c| c.k[2] = f64::NAN), "k[2]"),
            (Box::new(|c| c.k[1] = 0.5), "k[1]"),
            (Box::new(|c| c.k[8] = 0.0), "k[8]"),
            (Box::new(|c| c.binning_x = 2), "binning_x"),
            (Box::new(|c| c.binning_y = 4), "binning_y"),
        ];
        for (break_it, field) in cases {
            let mut info = good.clone();
            break_it(&mut info);
            let err = Intrinsics::from_camera_info(&info).unwrap_err();
            match &err {
                Error::BadCameraInfo { field: f, .. } => assert_eq!(*f, field, "{err}"),
                other => panic!("unexpected error {other}"),
            }
            assert!(err.to_string().contains(field));
        }
    }

    #[test]
    fn validate_rejects_nan_and_zero() {
        let mut k = Intrinsics::kinect();
        k.fx = f64::NAN;
        assert!(k.validate().unwrap_err().to_string().contains("fx"));
        let mut k = Intrinsics::kinect();
        k.height = 0;
        assert!(k.validate().unwrap_err().to_string().contains("height"));
        assert!(Intrinsics::kinect().validate().is_ok());
    }

    #[test]
    fn principal_point_and_bounds() {
        let k = Intrinsics::kinect();
        let (u, v, d) = k.project(&Point3::new(0.0, 0.0, 2.0)).unwrap();
        assert_eq!((u, v, d), (319.5, 239.5, 2.0));
        // x right, y down.
        let (u, v, _) = k.project(&Point3::new(0.1, 0.1, 1.0)).unwrap();
        assert!(u > 319.5 && v > 239.5);
        assert!(k.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
        assert!(k.project(&Point3::new(0.0, 0.0, 0.0)).is_none());
        assert!(k.project(&Point3::new(10.0, 0.0, 1.0)).is_none());
        assert!(k.project_unclipped(&Point3::new(10.0, 0.0, 1.0)).is_some());
        assert_eq!(k.pixel(-0.5, -0.5), Some((0, 0)));
        assert_eq!(k.pixel(639.49, 479.49), Some((639, 479)));
        assert_eq!(k.pixel(639.5, 0.0), None);
    }

    proptest! {
        #[test]
        fn project_unproject_round_trip(
            x in -2.0..2.0f64, y in -2.0..2.0f64, z in 0.05..8.0f64,
            fx in 100.0..1000.0f64, fy in 100.0..1000.0f64, cx in 0.0..640.0f64, cy in 0.0..480.0f64,
        ) {
            let k = Intrinsics { width: 640, height: 480, fx, fy, cx, cy };
            let p = Point3::new(x, y, z);
            let (u, v, d) = k.project_unclipped(&p).unwrap();
            prop_assert!((k.unproject(u, v, d) - p).norm() < 1e-9);
            // And the other way round.
            let q = k.unproject(u, v, d);
            let (u2, v2, d2) = k.project_unclipped(&q).unwrap();
            prop_assert!((u2 - u).abs() < 1e-6 && (v2 - v).abs() < 1e-6 && (d2 - d).abs() < 1e-12);
        }
    }
}
