//! CDR (de)serialisation with the 4-byte RTPS encapsulation header, as ROS 2 puts on the wire
//! and in MCAP bags (message encoding `cdr`).

use byteorder::{BigEndian, LittleEndian};

use crate::RosMessage;

/// Encapsulation header written by [`to_cdr`]: `CDR_LE` (0x0001) and two zero option bytes.
pub const CDR_LE_HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Why a CDR payload could not be decoded (or a JSON value encoded).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CdrError {
    /// The payload is shorter than the 4-byte encapsulation header.
    #[error(
        "{type_name}: CDR payload of {len} bytes is shorter than the 4-byte encapsulation header"
    )]
    TooShort {
        /// ROS type the payload was decoded as.
        type_name: String,
        /// Payload length (bytes).
        len: usize,
    },
    /// The encapsulation is neither plain little- nor big-endian CDR.
    #[error(
        "{type_name}: unsupported CDR encapsulation {:#04x} {:#04x} (expected 00 01 = CDR_LE or 00 00 = CDR_BE)",
        header[0], header[1]
    )]
    UnsupportedEncapsulation {
        /// ROS type the payload was decoded as.
        type_name: String,
        /// The first two header bytes.
        header: [u8; 2],
    },
    /// The body does not decode as this type (truncated, bad bool, bad UTF-8 ...).
    #[error("{type_name}: cannot decode CDR body of {len} bytes: {source}")]
    Decode {
        /// ROS type the payload was decoded as.
        type_name: String,
        /// Body length after the header (bytes).
        len: usize,
        /// The decoder's error.
        source: cdr_encoding::Error,
    },
    /// A JSON value could not be converted to or from the message type.
    #[error("{type_name}: JSON conversion failed: {source}")]
    Json {
        /// ROS type involved.
        type_name: String,
        /// serde_json's error.
        source: serde_json::Error,
    },
}

/// Serialises `msg` as little-endian CDR with the encapsulation header `00 01 00 00`.
///
/// Allocates the returned buffer; see [`to_cdr_into`] to reuse one.
pub fn to_cdr<T: RosMessage>(msg: &T) -> Vec<u8> {
    let mut out = Vec::new();
    to_cdr_into(msg, &mut out);
    out
}

/// Like [`to_cdr`] but clears and fills `out`, so a long-lived buffer stops allocating once
/// it is large enough.
pub fn to_cdr_into<T: RosMessage>(msg: &T, out: &mut Vec<u8>) {
    out.clear();
    out.extend_from_slice(&CDR_LE_HEADER);
    // cdr-encoding only fails on sequences of unknown length or on writer I/O errors; every
    // message type here has fixed-size or length-known fields and a Vec never fails to grow.
    #[allow(clippy::expect_used)]
    cdr_encoding::to_writer::<T, LittleEndian, _>(&mut *out, msg)
        .expect("CDR serialisation of a RosMessage into a Vec cannot fail");
}

/// Decodes a CDR payload (with its 4-byte encapsulation header, little- or big-endian).
///
/// Trailing bytes after the message (alignment padding) are ignored.
pub fn from_cdr<T: RosMessage>(bytes: &[u8]) -> Result<T, CdrError> {
    let Some((header, body)) = bytes.split_first_chunk::<4>() else {
        return Err(CdrError::TooShort {
            type_name: T::type_name(),
            len: bytes.len(),
        });
    };
    let decoded = match [header[0], header[1]] {
        [0x00, 0x01] => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        [0x00, 0x00] => cdr_encoding::from_bytes::<T, BigEndian>(body),
        other => {
            return Err(CdrError::UnsupportedEncapsulation {
                type_name: T::type_name(),
                header: other,
            });
        }
    };
    decoded
        .map(|(msg, _consumed)| msg)
        .map_err(|source| CdrError::Decode {
            type_name: T::type_name(),
            len: body.len(),
            source,
        })
}

/// Decodes a CDR payload of type `T` into a JSON value (field names as in the `.msg`).
pub(crate) fn cdr_to_json<T: RosMessage>(bytes: &[u8]) -> Result<serde_json::Value, CdrError> {
    let msg: T = from_cdr(bytes)?;
    serde_json::to_value(&msg).map_err(|source| CdrError::Json {
        type_name: T::type_name(),
        source,
    })
}

/// Encodes a JSON value (as produced by [`cdr_to_json`]) of type `T` as CDR.
pub(crate) fn json_to_cdr<T: RosMessage>(value: &serde_json::Value) -> Result<Vec<u8>, CdrError> {
    let msg: T = serde_json::from_value(value.clone()).map_err(|source| CdrError::Json {
        type_name: T::type_name(),
        source,
    })?;
    Ok(to_cdr(&msg))
}
