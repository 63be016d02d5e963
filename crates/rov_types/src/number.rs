//! Numbers in text files (CSV): the shortest decimal that reads back to the same `f64`.
//!
//! Every CSV writer of the workspace formats its numbers here, so a value written and read
//! back (`str::parse::<f64>`, Python's `float`, pandas) is bit-for-bit the value written,
//! in as few characters as possible:
//!
//! * plain decimals for ordinary magnitudes (`0.25`, `-1013.25`, `42`; a whole number has
//!   no `.0`), scientific notation for very small or large ones (`1e-240`, `3.5e-7`,
//!   `1e+16`), where the plain form would be long (a value near 1e-240 as a plain decimal is
//!   about 240 zeros);
//! * `nan`, `inf`, `-inf` for the non-finite values; `-0` keeps its sign.
//!
//! The digits come from `zmij` (a Schubfach/yy shortest round-trip formatter, the one
//! `serde_json` uses); this module only chooses the layout.

use std::fmt::Write as _;

/// Appends `x` to `out`; see the module docs.
pub fn push_f64(out: &mut String, x: f64) {
    if x.is_nan() {
        out.push_str("nan");
        return;
    }
    if x.is_infinite() {
        out.push_str(if x > 0.0 { "inf" } else { "-inf" });
        return;
    }
    let mut buf = zmij::Buffer::new();
    let s = buf.format_finite(x);
    // zmij writes whole numbers as `1.0`; the `.0` adds nothing.
    match s.strip_suffix(".0") {
        Some(whole) => out.push_str(whole),
        None => out.push_str(s),
    }
}

/// `x` as text; see the module docs.
pub fn format_f64(x: f64) -> String {
    let mut s = String::new();
    push_f64(&mut s, x);
    s
}

/// Appends an integer.
pub fn push_u64(out: &mut String, x: u64) {
    let _ = write!(out, "{x}");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts() {
        for (x, s) in [
            (0.0, "0"),
            (-0.0, "-0"),
            (42.0, "42"),
            (0.25, "0.25"),
            (-1013.25, "-1013.25"),
            (0.1 + 0.2, "0.30000000000000004"),
            (1e-240, "1e-240"),
            (3.5e-7, "3.5e-7"),
            (1e16, "1e+16"),
            (123456.789, "123456.789"),
            (f64::NAN, "nan"),
            (f64::INFINITY, "inf"),
            (f64::NEG_INFINITY, "-inf"),
            (f64::MIN_POSITIVE, "2.2250738585072014e-308"),
        ] {
            assert_eq!(format_f64(x), s, "{x:e}");
        }
    }

    #[test]
    fn every_value_reads_back_bit_for_bit_and_stays_short() {
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..200_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let x = f64::from_bits(state);
            if !x.is_finite() {
                continue;
            }
            let s = format_f64(x);
            let back: f64 = s.parse().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{s}");
            assert!(s.len() <= 24, "{s}");
        }
    }
}
