//! Middlebury `.flo` files: the magic float `202021.25` (bytes `PIEH`),
//! width and height as little-endian `i32`, then `u, v` as little-endian
//! `f32` per pixel, row-major (x to the right, y down, in pixels).

use crate::{Flow, HostError};

/// The tag float at the start of every `.flo` file.
pub const TAG: f32 = 202_021.25;

/// The bytes of a `.flo` file of the planes `u`, `v` (rounded to `f32`).
///
/// # Panics
/// If the planes do not hold `width · height` values.
pub fn encode(width: usize, height: usize, u: &[f64], v: &[f64]) -> Result<Vec<u8>, HostError> {
    assert!(
        u.len() == width * height && v.len() == width * height,
        "plane size"
    );
    let side = |n: usize| {
        i32::try_from(n).map_err(|_| {
            HostError::invalid(".flo", format!("{width}x{height} is too large for .flo"))
        })
    };
    let mut out = Vec::with_capacity(12 + 8 * width * height);
    out.extend_from_slice(&TAG.to_le_bytes());
    out.extend_from_slice(&side(width)?.to_le_bytes());
    out.extend_from_slice(&side(height)?.to_le_bytes());
    for (a, b) in u.iter().zip(v) {
        out.extend_from_slice(&(*a as f32).to_le_bytes());
        out.extend_from_slice(&(*b as f32).to_le_bytes());
    }
    Ok(out)
}

/// Parse a `.flo` file; its `f32` values are exact in the field's `f64`.
pub fn decode(bytes: &[u8]) -> Result<Flow, String> {
    let word = |i: usize| -> Option<[u8; 4]> { bytes.get(4 * i..4 * i + 4)?.try_into().ok() };
    let (Some(tag), Some(w), Some(h)) = (word(0), word(1), word(2)) else {
        return Err("too short for a .flo header".to_owned());
    };
    if f32::from_le_bytes(tag) != TAG {
        return Err("not a .flo file (no PIEH tag)".to_owned());
    }
    let (w, h) = (i32::from_le_bytes(w), i32::from_le_bytes(h));
    let (Ok(width), Ok(height)) = (usize::try_from(w), usize::try_from(h)) else {
        return Err(format!("negative size {w}x{h}"));
    };
    // Checked: two i32 sides make 8·W·H overflow (found by fuzz/flo).
    let n = width.checked_mul(height);
    let expected = n.and_then(|n| n.checked_mul(8)?.checked_add(12));
    let (Some(n), Some(expected)) = (n, expected) else {
        return Err(format!(
            "size {width}x{height} is too large for a .flo file"
        ));
    };
    if bytes.len() != expected {
        return Err(format!(
            "{} bytes for a {width}x{height} field (expected {expected})",
            bytes.len(),
        ));
    }
    let value = |i: usize| f64::from(f32::from_le_bytes(word(3 + i).expect("length checked")));
    Ok(Flow::from_parts(
        width,
        height,
        (0..n).map(|i| value(2 * i)).collect(),
        (0..n).map(|i| value(2 * i + 1)).collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_header() {
        let bytes = encode(3, 2, &[0.5, -1.0, 2.0, 0.0, 1e-3, 7.25], &[1.0; 6]).unwrap();
        assert_eq!(&bytes[..4], b"PIEH");
        assert_eq!(bytes.len(), 12 + 48);
        let flo = decode(&bytes).unwrap();
        assert_eq!((flo.width, flo.height), (3, 2));
        // Each value as the file's f32 holds it.
        assert_eq!(flo.u, [0.5, -1.0, 2.0, 0.0, f64::from(1e-3f32), 7.25]);
        assert_eq!(flo.v, [1.0; 6]);
        assert!(decode(&bytes[..20]).is_err());
        assert!(decode(b"garbage-garbage-").is_err());
    }

    /// fuzz/flo: sides of 2³¹ − 1 overflowed the expected length.
    #[test]
    fn huge_sides_are_an_error_not_an_overflow() {
        let mut bytes = encode(1, 1, &[0.0], &[0.0]).unwrap();
        bytes[4..12].copy_from_slice(&[0xff, 0xff, 0xff, 0x7f, 0xff, 0xff, 0xff, 0x7f]);
        let err = decode(&bytes).unwrap_err();
        assert!(err.contains("2147483647x2147483647 is too large"), "{err}");
    }
}
