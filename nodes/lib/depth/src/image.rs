//! Depth images: the in-memory buffer, its `sensor_msgs/Image` encodings and a PNG preview.

use std::path::Path;

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::sensor_msgs::Image;

use crate::error::{Error, Result};

/// Wire encoding of a depth image in `sensor_msgs/Image`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Encoding {
    /// `32FC1`: 32-bit float metres; "no return" is written as NaN (the REP 118 convention).
    #[default]
    F32Metres,
    /// `16UC1`: 16-bit unsigned millimetres; "no return" is 0.
    U16Millimetres,
}

impl Encoding {
    /// The `sensor_msgs/Image.encoding` string.
    pub fn as_str(self) -> &'static str {
        match self {
            Encoding::F32Metres => "32FC1",
            Encoding::U16Millimetres => "16UC1",
        }
    }

    /// Parses an encoding string (`32FC1` or `16UC1`).
    pub fn parse(encoding: &str) -> Result<Self> {
        match encoding {
            "32FC1" => Ok(Encoding::F32Metres),
            "16UC1" => Ok(Encoding::U16Millimetres),
            other => Err(Error::UnknownEncoding { encoding: other.to_owned() }),
        }
    }

    /// Bytes per pixel.
    pub fn bytes_per_pixel(self) -> u32 {
        match self {
            Encoding::F32Metres => 4,
            Encoding::U16Millimetres => 2,
        }
    }
}

impl std::str::FromStr for Encoding {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Self::parse(s)
    }
}

impl std::fmt::Display for Encoding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A depth image: row-major `f32` depths in m along the optical axis (the optical-frame z of
/// the surface point, not the ray length); **`0.0` means no return** (nothing seen, out of
/// range, or dropped by the sensor). Pixel `(column u, row v)` is `data[v * width + u]`.
///
/// Values are never negative, NaN or infinite when produced by this crate or read by
/// [`from_image_msg`](Self::from_image_msg).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct DepthImage {
    /// Columns, px.
    pub width: u32,
    /// Rows, px.
    pub height: u32,
    /// `width * height` depths, m, row-major; 0 = no return.
    pub data: Vec<f32>,
}

impl DepthImage {
    /// An image of `width × height` pixels with no return anywhere.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, data: vec![0.0; width as usize * height as usize] }
    }

    /// Checks that `data` holds `width * height` values.
    pub fn validate(&self) -> Result<()> {
        if self.data.len() != self.width as usize * self.height as usize {
            return Err(Error::BufferSize { len: self.data.len(), width: self.width, height: self.height });
        }
        Ok(())
    }

    /// Depth at column `u`, row `v` (m, 0 = no return); `None` outside the image.
    pub fn get(&self, u: u32, v: u32) -> Option<f32> {
        if u >= self.width || v >= self.height {
            return None;
        }
        self.data.get(v as usize * self.width as usize + u as usize).copied()
    }

    /// Mutable depth at column `u`, row `v`; `None` outside the image.
    pub fn get_mut(&mut self, u: u32, v: u32) -> Option<&mut f32> {
        if u >= self.width || v >= self.height {
            return None;
        }
        self.data.get_mut(v as usize * self.width as usize + u as usize)
    }

    /// Resizes to `width × height` (reusing the buffer) and clears every pixel to no return.
    pub fn reset(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
        self.data.clear();
        self.data.resize(width as usize * height as usize, 0.0);
    }

    /// Number of pixels with a return (depth > 0).
    pub fn valid_count(&self) -> usize {
        self.data.iter().filter(|d| **d > 0.0).count()
    }

    /// Smallest and largest valid depth (m), `None` when no pixel has a return.
    pub fn depth_range(&self) -> Option<(f32, f32)> {
        self.data.iter().filter(|d| **d > 0.0).fold(None, |acc, &d| match acc {
            None => Some((d, d)),
            Some((lo, hi)) => Some((lo.min(d), hi.max(d))),
        })
    }

    /// Reads a depth `sensor_msgs/Image`.
    ///
    /// Accepts `32FC1` (m; NaN, ±inf and values ≤ 0 become 0 = no return) and `16UC1` (mm;
    /// 0 = no return), either byte order (`is_bigendian` 0 or 1), and row padding
    /// (`step` ≥ `width` × bytes per pixel). Errors name the field at fault: unknown
    /// `encoding`, zero `width`/`height`, `step` shorter than a row, `data` length ≠
    /// `step` × `height`, `is_bigendian` not 0/1.
    pub fn from_image_msg(msg: &Image) -> Result<Self> {
        let mut out = DepthImage::default();
        out.read_image_msg(msg)?;
        Ok(out)
    }

    /// Like [`from_image_msg`](Self::from_image_msg) but into `self`, reusing its buffer (no
    /// allocation once it is large enough). On error `self` is left unchanged. Returns the
    /// number of pixels with a return ([`valid_count`](Self::valid_count), counted while
    /// converting, so a caller checking for a blind camera makes no second pass).
    pub fn read_image_msg(&mut self, msg: &Image) -> Result<usize> {
        let encoding = Encoding::parse(&msg.encoding)?;
        if msg.width == 0 || msg.height == 0 {
            return Err(Error::ZeroSize { width: msg.width, height: msg.height });
        }
        let big = match msg.is_bigendian {
            0 => false,
            1 => true,
            value => return Err(Error::BadEndianFlag { value }),
        };
        let bpp = encoding.bytes_per_pixel();
        let min = u64::from(msg.width) * u64::from(bpp);
        if u64::from(msg.step) < min {
            return Err(Error::StepTooSmall { step: msg.step, width: msg.width, bytes_per_pixel: bpp, min });
        }
        let expected = u64::from(msg.step) * u64::from(msg.height);
        if msg.data.len() as u64 != expected {
            return Err(Error::DataLength { len: msg.data.len(), step: msg.step, height: msg.height, expected });
        }
        self.width = msg.width;
        self.height = msg.height;
        self.data.clear();
        self.data.reserve(msg.width as usize * msg.height as usize);
        let row_bytes = min as usize;
        let mut valid = 0usize;
        for row in msg.data.chunks_exact(msg.step as usize) {
            let row = &row[..row_bytes];
            match encoding {
                Encoding::F32Metres => self.data.extend(row.chunks_exact(4).map(|b| {
                    let b = [b[0], b[1], b[2], b[3]];
                    let d = if big { f32::from_be_bytes(b) } else { f32::from_le_bytes(b) };
                    if d.is_finite() && d > 0.0 {
                        valid += 1;
                        d
                    } else {
                        0.0
                    }
                })),
                Encoding::U16Millimetres => self.data.extend(row.chunks_exact(2).map(|b| {
                    let b = [b[0], b[1]];
                    let mm = if big { u16::from_be_bytes(b) } else { u16::from_le_bytes(b) };
                    valid += usize::from(mm > 0);
                    (f64::from(mm) / 1000.0) as f32
                })),
            }
        }
        Ok(valid)
    }

    /// The image as a `sensor_msgs/Image` in `encoding`, little-endian, no row padding.
    ///
    /// `32FC1` writes metres with NaN for no return; `16UC1` writes millimetres rounded to the
    /// nearest mm with 0 for no return (depths beyond 65.535 m are written as 0 too).
    pub fn to_image_msg(&self, stamp: Time, frame_id: &str, encoding: Encoding) -> Image {
        let mut msg = Image::default();
        self.write_image_msg(stamp, frame_id, encoding, &mut msg);
        msg
    }

    /// Like [`to_image_msg`](Self::to_image_msg) but into `msg`, reusing its buffers (no
    /// allocation once they are large enough).
    pub fn write_image_msg(&self, stamp: Time, frame_id: &str, encoding: Encoding, msg: &mut Image) {
        msg.header.stamp = stamp;
        if msg.header.frame_id != frame_id {
            msg.header.frame_id.clear();
            msg.header.frame_id.push_str(frame_id);
        }
        msg.height = self.height;
        msg.width = self.width;
        if msg.encoding != encoding.as_str() {
            msg.encoding.clear();
            msg.encoding.push_str(encoding.as_str());
        }
        msg.is_bigendian = 0;
        msg.step = self.width * encoding.bytes_per_pixel();
        msg.data.clear();
        match encoding {
            Encoding::F32Metres => msg.data.extend(
                self.data
                    .iter()
                    .flat_map(|&d| if d > 0.0 { d } else { f32::NAN }.to_le_bytes()),
            ),
            Encoding::U16Millimetres => msg.data.extend(self.data.iter().flat_map(|&d| {
                let mm = (f64::from(d) * 1e3).round();
                let mm = if d > 0.0 && mm <= f64::from(u16::MAX) { mm as u16 } else { 0 };
                mm.to_le_bytes()
            })),
        }
    }

    /// Writes a colour-mapped PNG for people to look at: near is red, far is blue (the "turbo"
    /// map over the image's own valid depth range), no return is black.
    pub fn write_png(&self, path: impl AsRef<Path>) -> Result<()> {
        let (near, far) = self.depth_range().unwrap_or((0.0, 1.0));
        self.write_png_range(path, near, far)
    }

    /// Like [`write_png`](Self::write_png) with a fixed colour range `[near, far]` (m), so a
    /// sequence of frames shares one scale. Depths outside the range are clamped to its ends.
    pub fn write_png_range(&self, path: impl AsRef<Path>, near: f32, far: f32) -> Result<()> {
        let path = path.as_ref();
        let png_err = |message: String| Error::Png { path: path.to_owned(), message };
        self.validate()?;
        if self.width == 0 || self.height == 0 {
            return Err(Error::ZeroSize { width: self.width, height: self.height });
        }
        let span = if far > near { far - near } else { 1.0 };
        let mut rgb = Vec::with_capacity(self.data.len() * 3);
        for &d in &self.data {
            if d > 0.0 {
                // Far end at 0.1: the map's darkest part stays distinct from black (no return).
                let t = 1.0 - 0.9 * ((d - near) / span).clamp(0.0, 1.0);
                rgb.extend_from_slice(&turbo(t));
            } else {
                rgb.extend_from_slice(&[0, 0, 0]);
            }
        }
        let file = std::fs::File::create(path).map_err(|e| png_err(e.to_string()))?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| png_err(e.to_string()))?;
        writer.write_image_data(&rgb).map_err(|e| png_err(e.to_string()))?;
        writer.finish().map_err(|e| png_err(e.to_string()))
    }
}

/// The "turbo" colour map (Google, polynomial fit by its author) at `t` ∈ [0, 1]:
/// dark at 0, blue, green in the middle, yellow, dark red at 1.
fn turbo(t: f32) -> [u8; 3] {
    let t = f64::from(t.clamp(0.0, 1.0));
    let poly = |c: [f64; 6]| {
        let v = c[0] + t * (c[1] + t * (c[2] + t * (c[3] + t * (c[4] + t * c[5]))));
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    };
    [
        poly([0.135_721_38, 4.615_392_6, -42.660_322_58, 132.131_082_34, -152.942_393_59, 59.286_379_93]),
        poly([0.091_402_61, 2.194_188_39, 4.842_966_58, -14.185_033_33, 4.277_298_55, 2.829_566_04]),
        poly([0.106_673_3, 12.641_946_08, -60.582_048_36, 110.362_767_71, -89.903_109_13, 27.348_249_81]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_msgs::std_msgs::Header;

    fn sample() -> DepthImage {
        DepthImage { width: 3, height: 2, data: vec![0.0, 1.0, 2.5, 0.3336, 0.0, 4.0] }
    }

    #[test]
    fn f32_round_trip_is_exact_and_no_return_is_nan_on_the_wire() {
        let img = sample();
        let msg = img.to_image_msg(Time { sec: 1, nanosec: 2 }, "cam", Encoding::F32Metres);
        assert_eq!(msg.encoding, "32FC1");
        assert_eq!(msg.step, 12);
        assert_eq!(msg.data.len(), 24);
        assert!(f32::from_le_bytes(msg.data[0..4].try_into().unwrap()).is_nan());
        assert_eq!(DepthImage::from_image_msg(&msg).unwrap(), img);
    }

    #[test]
    fn u16_round_trip_rounds_to_millimetres() {
        let img = sample();
        let msg = img.to_image_msg(Time::default(), "cam", Encoding::U16Millimetres);
        assert_eq!(msg.encoding, "16UC1");
        assert_eq!(msg.step, 6);
        let mm: Vec<u16> = msg.data.chunks_exact(2).map(|b| u16::from_le_bytes([b[0], b[1]])).collect();
        assert_eq!(mm, vec![0, 1000, 2500, 334, 0, 4000]);
        let back = DepthImage::from_image_msg(&msg).unwrap();
        for (a, b) in back.data.iter().zip(&img.data) {
            assert!((a - b).abs() <= 0.0005 + 1e-6, "{a} vs {b}");
        }
    }

    #[test]
    fn far_depth_does_not_wrap_in_u16() {
        let img = DepthImage { width: 2, height: 1, data: vec![70.0, 65.0] };
        let msg = img.to_image_msg(Time::default(), "cam", Encoding::U16Millimetres);
        assert_eq!(&msg.data, &[0, 0, 0xE8, 0xFD]);
    }

    #[test]
    fn reads_big_endian_padded_rows_and_cleans_invalid_floats() {
        let values = [1.5f32, f32::NAN, f32::INFINITY, -2.0, 0.0, 3.25];
        let mut data = Vec::new();
        for row in values.chunks(3) {
            for v in row {
                data.extend_from_slice(&v.to_be_bytes());
            }
            data.extend_from_slice(&[0xAA; 4]); // padding
        }
        let msg = Image {
            header: Header::default(),
            height: 2,
            width: 3,
            encoding: "32FC1".into(),
            is_bigendian: 1,
            step: 16,
            data,
        };
        let img = DepthImage::from_image_msg(&msg).unwrap();
        assert_eq!(img.data, vec![1.5, 0.0, 0.0, 0.0, 0.0, 3.25]);

        let mut data = Vec::new();
        for mm in [1234u16, 0, 65535, 7] {
            data.extend_from_slice(&mm.to_be_bytes());
        }
        let msg = Image { height: 2, width: 2, encoding: "16UC1".into(), is_bigendian: 1, step: 4, data, ..Default::default() };
        let img = DepthImage::from_image_msg(&msg).unwrap();
        assert_eq!(img.data, vec![1.234, 0.0, 65.535, 0.007]);
    }

    #[test]
    fn bad_images_give_errors_naming_the_field() {
        let good = sample().to_image_msg(Time::default(), "cam", Encoding::F32Metres);
        let check = |msg: Image, field: &str| {
            let err = DepthImage::from_image_msg(&msg).unwrap_err();
            assert!(err.to_string().contains(field), "{field}: {err}");
            err
        };
        let mut m = good.clone();
        m.encoding = "rgb8".into();
        assert!(matches!(check(m, "encoding"), Error::UnknownEncoding { .. }));
        let mut m = good.clone();
        m.width = 0;
        assert!(matches!(check(m, "width"), Error::ZeroSize { .. }));
        let mut m = good.clone();
        m.height = 0;
        assert!(matches!(check(m, "height"), Error::ZeroSize { .. }));
        let mut m = good.clone();
        m.step = 8;
        m.data.truncate(16);
        assert!(matches!(check(m, "step"), Error::StepTooSmall { min: 12, .. }));
        let mut m = good.clone();
        m.data.pop();
        assert!(matches!(check(m, "data"), Error::DataLength { len: 23, expected: 24, .. }));
        let mut m = good.clone();
        m.data.extend_from_slice(&[0; 12]);
        assert!(matches!(check(m, "data"), Error::DataLength { len: 36, .. }));
        let mut m = good.clone();
        m.is_bigendian = 7;
        assert!(matches!(check(m, "is_bigendian"), Error::BadEndianFlag { value: 7 }));
        // 16UC1 with the step of a 32FC1 image is fine (padding); with a shorter one it is not.
        let mut m = good.clone();
        m.encoding = "16UC1".into();
        assert!(DepthImage::from_image_msg(&m).is_ok());
        // Huge sizes do not overflow.
        let mut m = good;
        m.width = u32::MAX;
        m.height = u32::MAX;
        m.step = u32::MAX;
        assert!(matches!(check(m, "step"), Error::StepTooSmall { .. }));
    }

    #[test]
    fn failed_read_leaves_image_unchanged() {
        let mut img = sample();
        let mut msg = img.to_image_msg(Time::default(), "cam", Encoding::F32Metres);
        msg.data.pop();
        assert!(img.read_image_msg(&msg).is_err());
        assert_eq!(img, sample());
    }

    #[test]
    fn write_reuses_buffers() {
        let img = DepthImage::new(64, 48);
        let mut msg = Image::default();
        img.write_image_msg(Time::default(), "cam", Encoding::F32Metres, &mut msg);
        let ptr = msg.data.as_ptr();
        img.write_image_msg(Time { sec: 1, nanosec: 0 }, "cam", Encoding::U16Millimetres, &mut msg);
        assert_eq!(msg.data.as_ptr(), ptr);
        assert_eq!(msg.data.len(), 64 * 48 * 2);
    }

    #[test]
    fn png_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("d.png");
        sample().write_png(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let err = sample().write_png(dir.path().join("no/such/dir.png")).unwrap_err();
        assert!(err.to_string().contains("dir.png"));
        let bad = DepthImage { width: 5, height: 5, data: vec![] };
        assert!(matches!(bad.write_png(&path), Err(Error::BufferSize { .. })));
    }

    #[test]
    fn turbo_ends() {
        let lo = turbo(0.1);
        let hi = turbo(0.95);
        assert!(lo[2] > lo[0], "0 is blue: {lo:?}");
        assert!(hi[0] > hi[2], "1 is red: {hi:?}");
    }
}

#[cfg(test)]
mod count_tests {
    use super::*;

    /// The count returned while decoding is the one `valid_count` finds afterwards, for both
    /// encodings, with NaN, zero and negative depths as no return.
    #[test]
    fn read_image_msg_counts_the_returns_it_decodes() {
        let mut img = DepthImage::new(4, 3);
        for (i, d) in img.data.iter_mut().enumerate() {
            *d = [0.0, 1.5, 0.0, 2.25][i % 4];
        }
        for encoding in [Encoding::F32Metres, Encoding::U16Millimetres] {
            let msg = img.to_image_msg(Time::default(), "cam", encoding);
            let mut back = DepthImage::default();
            let n = back.read_image_msg(&msg).expect("decodes");
            assert_eq!(n, back.valid_count());
            assert_eq!(n, 6);
        }
        let mut nan = img.to_image_msg(Time::default(), "cam", Encoding::F32Metres);
        nan.data = [f32::NAN, -1.0, 0.5, f32::INFINITY].iter().cycle().take(12).flat_map(|v| v.to_le_bytes()).collect();
        let mut back = DepthImage::default();
        assert_eq!(back.read_image_msg(&nan).expect("decodes"), 3);
    }
}
