//! Natural order of file names: runs of digits compare as numbers, so
//! `frame2` comes before `frame10`.

use std::cmp::Ordering;

/// The digit run of `s` starting at byte `i` (ASCII digits only).
fn digit_run(s: &[u8], i: usize) -> &[u8] {
    let len = s[i..].iter().take_while(|b| b.is_ascii_digit()).count();
    &s[i..i + len]
}

/// Compare two digit runs by value (any length), then fewer leading zeros first.
fn cmp_digits(a: &[u8], b: &[u8]) -> Ordering {
    fn strip(d: &[u8]) -> &[u8] {
        let zeros = d.iter().take_while(|&&c| c == b'0').count();
        &d[zeros..]
    }
    let (ta, tb) = (strip(a), strip(b));
    ta.len()
        .cmp(&tb.len())
        .then_with(|| ta.cmp(tb))
        .then_with(|| a.len().cmp(&b.len()))
}

/// Natural order: where both names have a run of digits they compare by
/// value, everything else character by character ignoring ASCII case;
/// exact byte order breaks ties, so the order is total.
pub fn compare(a: &str, b: &str) -> Ordering {
    let (x, y) = (a.as_bytes(), b.as_bytes());
    let (mut i, mut j) = (0, 0);
    while i < x.len() && j < y.len() {
        if x[i].is_ascii_digit() && y[j].is_ascii_digit() {
            let (dx, dy) = (digit_run(x, i), digit_run(y, j));
            let o = cmp_digits(dx, dy);
            if o != Ordering::Equal {
                return o;
            }
            i += dx.len();
            j += dy.len();
        } else {
            let o = x[i].to_ascii_lowercase().cmp(&y[j].to_ascii_lowercase());
            if o != Ordering::Equal {
                return o;
            }
            i += 1;
            j += 1;
        }
    }
    (x.len() - i).cmp(&(y.len() - j)).then_with(|| a.cmp(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_sort_by_value() {
        let mut names = vec![
            "frame10.png",
            "frame2.png",
            "frame1.png",
            "Frame3.png",
            "frame02.png",
            "frame.png",
            "a100b2",
            "a100b10",
            "a99",
            "123456789012345678901234567890.png",
            "9.png",
        ];
        names.sort_by(|a, b| compare(a, b));
        assert_eq!(
            names,
            [
                "9.png",
                "123456789012345678901234567890.png",
                "a99",
                "a100b2",
                "a100b10",
                "frame.png",
                "frame1.png",
                "frame2.png",
                "frame02.png",
                "Frame3.png",
                "frame10.png",
            ]
        );
    }
}
