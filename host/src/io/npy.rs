//! 2-D float64 `.npy` files (NumPy's format, NEP 1), the exchange format of
//! the fields: written as `<f8`, shape `(H, W)`, C order.

use std::fs;
use std::path::Path;

use npyz::WriterBuilder;

use crate::{HostError, io::atomic};

/// A 2-D float64 array, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Array2 {
    /// Rows (`H`, the first axis).
    pub height: usize,
    /// Columns (`W`, the second axis).
    pub width: usize,
    /// `height · width` values, row `y` at `y · width`.
    pub data: Vec<f64>,
}

/// The bytes of a `.npy` file holding `data` as a `(height, width)` `<f8`
/// array in C order.
///
/// # Panics
/// If `data.len() != height · width`.
pub fn encode(height: usize, width: usize, data: &[f64]) -> Vec<u8> {
    assert_eq!(
        data.len(),
        height * width,
        "data must hold height · width values"
    );
    let mut bytes = Vec::with_capacity(128 + 8 * data.len());
    // Writing into a Vec cannot fail, and the shape matches the data (asserted).
    let mut writer = npyz::WriteOptions::<f64>::new()
        .default_dtype()
        .shape(&[height as u64, width as u64])
        .writer(&mut bytes)
        .begin_nd()
        .expect("writing to memory");
    writer
        .extend(data.iter().copied())
        .expect("writing to memory");
    writer.finish().expect("writing to memory");
    bytes
}

/// Write a `(height, width)` float64 `.npy` atomically (see [`atomic`]).
pub fn write(path: &Path, height: usize, width: usize, data: &[f64]) -> Result<(), HostError> {
    atomic::write_file(path, &encode(height, width, data))
}

/// The header dictionary of a `.npy`, as text.
fn header_text(bytes: &[u8]) -> Option<&str> {
    let rest = bytes.strip_prefix(b"\x93NUMPY")?;
    let (&major, rest) = rest.split_first()?;
    let rest = rest.get(1..)?;
    let (len, rest) = match major {
        1 => (
            usize::from(u16::from_le_bytes(rest.get(..2)?.try_into().ok()?)),
            &rest[2..],
        ),
        2 | 3 => (
            u32::from_le_bytes(rest.get(..4)?.try_into().ok()?) as usize,
            &rest[4..],
        ),
        _ => return None,
    };
    std::str::from_utf8(rest.get(..len)?).ok()
}

/// Whether a header is the plain dictionary NumPy writes: quoted keys, and
/// values that are quoted strings, `True`/`False` or tuples of integers.
/// Checked in one linear pass before npyz parses it: npyz's Python-literal
/// grammar backtracks exponentially on some malformed float literals
/// (found by fuzz/npy: one 200-byte header ran for over ten minutes).
fn plain_header(header: &str) -> bool {
    let rest = &mut header.as_bytes();
    if !eat(rest, b"{") {
        return false;
    }
    loop {
        if eat(rest, b"}") {
            return rest.iter().all(u8::is_ascii_whitespace);
        }
        let value = |rest: &mut &[u8]| {
            quoted(rest) || eat(rest, b"True") || eat(rest, b"False") || int_tuple(rest)
        };
        if !(quoted(rest) && eat(rest, b":") && value(rest)) {
            return false;
        }
        if !eat(rest, b",") && !rest.trim_ascii_start().starts_with(b"}") {
            return false;
        }
    }
}

/// `token` after optional whitespace, consumed from `rest`.
fn eat(rest: &mut &[u8], token: &[u8]) -> bool {
    match rest.trim_ascii_start().strip_prefix(token) {
        Some(after) => {
            *rest = after;
            true
        }
        None => false,
    }
}

/// A quoted string without escapes, consumed from `rest`.
fn quoted(rest: &mut &[u8]) -> bool {
    let text = rest.trim_ascii_start();
    let Some((&quote, body)) = text.split_first() else {
        return false;
    };
    if quote != b'\'' && quote != b'"' {
        return false;
    }
    match body.iter().position(|&c| c == quote || c == b'\\') {
        Some(end) if body[end] == quote => {
            *rest = &body[end + 1..];
            true
        }
        _ => false,
    }
}

/// A tuple of decimal integers (`(2, 3)`, `(2, 3, )`, `()`), consumed from `rest`.
fn int_tuple(rest: &mut &[u8]) -> bool {
    let Some(body) = rest.trim_ascii_start().strip_prefix(b"(") else {
        return false;
    };
    let Some(end) = body.iter().position(|&c| c == b')') else {
        return false;
    };
    let items = &body[..end];
    let plain = items
        .split(|&c| c == b',')
        .map(<[u8]>::trim_ascii)
        .enumerate()
        .all(|(i, item)| {
            item.iter().all(u8::is_ascii_digit)
                && (!item.is_empty() || i > 0 || items.trim_ascii().is_empty())
        });
    *rest = &body[end + 1..];
    plain
}

/// The shape a `.npy` header states, read before npyz parses it.
fn header_shape(header: &str) -> Option<Vec<u64>> {
    let key = header
        .find("'shape'")
        .or_else(|| header.find("\"shape\""))?;
    let tuple = header[key + 7..].trim_start().strip_prefix(':')?;
    let tuple = tuple.trim_start().strip_prefix('(')?;
    let tuple = &tuple[..tuple.find(')')?];
    tuple
        .split(',')
        .map(str::trim)
        .filter(|axis| !axis.is_empty())
        .map(|axis| axis.parse().ok())
        .collect()
}

/// Open a `.npy` held in memory, refusing a shape whose values could not
/// be in the file before npyz sees it: npyz multiplies the axes unchecked
/// (an overflow panic, or a wrong count; found by fuzz/npy).
pub(crate) fn open(bytes: &[u8]) -> Result<npyz::NpyFile<&[u8]>, String> {
    let header = header_text(bytes).ok_or("not a .npy file: no readable NumPy header")?;
    if !plain_header(header) {
        return Err("not a .npy file: the header is not a plain NumPy dictionary".into());
    }
    let shape = header_shape(header).ok_or("not a .npy file: the header states no shape")?;
    // Zero axes count as one: npyz multiplies the other axes all the same
    // (a zero axis hid an overflowing shape from this check; fuzz/npy).
    let values = shape
        .iter()
        .try_fold(1u64, |n, &axis| n.checked_mul(axis.max(1)));
    if values.is_none_or(|n| n.saturating_mul(8) > bytes.len() as u64) {
        return Err(format!(
            "shape {shape:?} needs more data than the file's {} bytes",
            bytes.len()
        ));
    }
    npyz::NpyFile::new(bytes).map_err(|e| format!("not a .npy file: {e}"))
}

/// Parse a 2-D float64 `.npy` (either byte order; Fortran order is
/// transposed into row-major).
pub fn decode(bytes: &[u8]) -> Result<Array2, String> {
    let npy = open(bytes)?;
    let [height, width] = *npy.shape() else {
        return Err(format!(
            "array has shape {:?}; a 2-D (H, W) array is needed",
            npy.shape()
        ));
    };
    let (height, width) = (height as usize, width as usize);
    let order = npy.order();
    let dtype = npy.dtype().descr();
    let values = npy
        .into_vec::<f64>()
        .map_err(|e| format!("dtype {dtype} is not float64: {e}"))?;
    let data = match order {
        npyz::Order::C => values,
        npyz::Order::Fortran => (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| values[x * height + y])
            .collect(),
    };
    Ok(Array2 {
        height,
        width,
        data,
    })
}

/// Read a 2-D float64 `.npy` file.
pub fn read(path: &Path) -> Result<Array2, HostError> {
    let bytes = fs::read(path).map_err(|e| HostError::io(path, e))?;
    decode(&bytes).map_err(|problem| HostError::Npy {
        path: path.to_owned(),
        problem,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_exactly_with_a_numpy_header() {
        let data: Vec<f64> = (0..6).map(|i| f64::from(i) * 0.1 - 1e-300).collect();
        let bytes = encode(2, 3, &data);
        // NEP 1: magic, version 1.0, header padded so the data starts 64-aligned.
        assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + header_len) % 64, 0);
        let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
        assert!(header.contains("'descr': '<f8'"), "{header}");
        assert!(header.contains("'fortran_order': False"), "{header}");
        // npyz writes the tuple as `(2, 3, )`, which Python (and NumPy) reads as (2, 3).
        assert!(header.contains("'shape': (2, 3"), "{header}");
        assert_eq!(bytes.len(), 10 + header_len + 48);
        let back = decode(&bytes).unwrap();
        assert_eq!(
            back,
            Array2 {
                height: 2,
                width: 3,
                data
            }
        );
    }

    #[test]
    fn refuses_other_shapes_and_types() {
        let mut bytes = Vec::new();
        let mut w = npyz::WriteOptions::<i32>::new()
            .default_dtype()
            .shape(&[2, 2])
            .writer(&mut bytes)
            .begin_nd()
            .unwrap();
        w.extend([1, 2, 3, 4]).unwrap();
        w.finish().unwrap();
        assert!(decode(&bytes).unwrap_err().contains("not float64"));
        let mut bytes = Vec::new();
        let mut w = npyz::WriteOptions::<f64>::new()
            .default_dtype()
            .shape(&[4])
            .writer(&mut bytes)
            .begin_nd()
            .unwrap();
        w.extend([1.0, 2.0, 3.0, 4.0]).unwrap();
        w.finish().unwrap();
        assert!(decode(&bytes).unwrap_err().contains("2-D"));
        assert!(decode(b"garbage").unwrap_err().contains("not a .npy"));
    }

    /// fuzz/npy (a 300 s campaign): after a plain `shape`, 40 nested `[`
    /// kept npyz's literal parser backtracking for over ten minutes. Refused
    /// before npyz parses it, as is anything beyond NumPy's plain dictionary.
    #[test]
    fn a_header_beyond_numpys_dictionary_is_refused_before_npyz() {
        let slow = include_bytes!("npy_regressions/nested-brackets.npy");
        let err = decode(slow).unwrap_err();
        assert!(err.contains("not a plain NumPy dictionary"), "{err}");
        let plain = encode(2, 3, &[0.0; 6]);
        assert!(plain_header(header_text(&plain).unwrap()));
        for header in [
            "{'shape': (2, 3), 'x': 1.5e3}",
            "{'shape': (2, 3), 'descr': ['<f8']}",
            "{'shape': (2, 3)} trailing",
            "{'shape' (2, 3)}",
            "{'shape': (2, 3.0)}",
            "{'unterminated: (2, 3)}",
        ] {
            assert!(!plain_header(header), "{header}");
        }
        for header in [
            "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }   \n",
            "{\"shape\": (), \"fortran_order\": True}",
        ] {
            assert!(plain_header(header), "{header}");
        }
    }

    /// fuzz/npy (a 300 s campaign): `(0, 42949672294967296, 4294967296)`
    /// has no values, yet the product of its other axes overflows.
    #[test]
    fn a_zero_axis_does_not_hide_an_overflowing_shape() {
        let bytes = include_bytes!("npy_regressions/zero-axis-overflow.npy");
        let err = decode(bytes).unwrap_err();
        assert!(err.contains("shape"), "{err}");
    }

    /// fuzz/npy: a shape of 2³² × 2³² overflowed npyz's element count.
    #[test]
    fn a_shape_larger_than_the_file_is_refused_before_npyz() {
        let header =
            "{'descr': '<f8', 'fortran_order': False, 'shape': (4294967296, 4294967296), }";
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend((header.len() as u16 + 1).to_le_bytes());
        bytes.extend(header.bytes());
        bytes.push(b'\n');
        bytes.extend([0; 48]);
        let err = decode(&bytes).unwrap_err();
        assert!(
            err.contains("shape [4294967296, 4294967296] needs more data"),
            "{err}"
        );
        assert!(crate::outputs::decode_npy_xy(&bytes).is_err());
        // A plain shape that the data cannot fill is refused the same way.
        let short = encode(2, 3, &[0.0; 6]);
        assert!(decode(&short[..short.len() - 8]).is_err());
    }
}
