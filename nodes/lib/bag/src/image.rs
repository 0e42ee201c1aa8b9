//! Sanity checks of `sensor_msgs/Image` messages before anyone indexes their data.

use cowork_msgs::sensor_msgs::Image;

use crate::{BagError, Result};

/// Encodings we know, with their bytes per pixel.
const ENCODINGS: &[(&str, usize)] = &[
    ("32FC1", 4),
    ("16UC1", 2),
    ("16SC1", 2),
    ("32SC1", 4),
    ("64FC1", 8),
    ("8UC1", 1),
    ("8UC3", 3),
    ("8UC4", 4),
    ("mono8", 1),
    ("mono16", 2),
    ("rgb8", 3),
    ("bgr8", 3),
    ("rgba8", 4),
    ("bgra8", 4),
];

/// Bytes per pixel of an image encoding, or `None` when the encoding is not known.
pub fn bytes_per_pixel(encoding: &str) -> Option<usize> {
    ENCODINGS
        .iter()
        .find(|(name, _)| *name == encoding)
        .map(|&(_, bpp)| bpp)
}

/// Checks that `image` (received on `topic`) has a known encoding, a row length `step` that
/// holds `width` pixels, and exactly `step × height` bytes of data.
///
/// Errors name the topic and the offending numbers; the depth pipeline relies on this check to
/// index the data without bounds surprises. Costs O(1).
pub fn check_image(topic: &str, image: &Image) -> Result<()> {
    let Some(bpp) = bytes_per_pixel(&image.encoding) else {
        return Err(BagError::ImageEncoding {
            topic: topic.to_owned(),
            encoding: image.encoding.clone(),
            known: ENCODINGS
                .iter()
                .map(|(n, _)| *n)
                .collect::<Vec<_>>()
                .join(", "),
        });
    };
    if u64::from(image.step) < u64::from(image.width) * bpp as u64 {
        return Err(BagError::ImageStep {
            topic: topic.to_owned(),
            step: image.step,
            width: image.width,
            bytes_per_pixel: bpp,
            encoding: image.encoding.clone(),
        });
    }
    let expected = u64::from(image.step) * u64::from(image.height);
    if expected != image.data.len() as u64 {
        return Err(BagError::ImageSize {
            topic: topic.to_owned(),
            step: image.step,
            height: image.height,
            expected,
            len: image.data.len(),
        });
    }
    Ok(())
}
