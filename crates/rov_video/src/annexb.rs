//! H.264 Annex B access units: the NAL units of one picture, each after a start code
//! (`00 00 01` or `00 00 00 01`). What recording stores (one AU per `/camera/video`
//! message) and what replay and export read back.
//!
//! [`check`] is a structural check (start code, forbidden bit, at least one picture slice)
//! that catches truncated or garbled messages before they reach a decoder.

/// NAL unit types of H.264 (ITU-T H.264 Table 7-1) that matter here.
pub mod nal {
    /// A slice of a non-IDR picture.
    pub const SLICE: u8 = 1;
    /// A slice of an IDR picture (a key frame).
    pub const IDR: u8 = 5;
    /// Supplemental enhancement information.
    pub const SEI: u8 = 6;
    /// Sequence parameter set.
    pub const SPS: u8 = 7;
    /// Picture parameter set.
    pub const PPS: u8 = 8;
    /// Access unit delimiter.
    pub const AUD: u8 = 9;
}

/// One encoded picture with its time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AccessUnit {
    /// Capture time of the picture, ns on the caller's clock.
    pub pts_ns: u64,
    /// An IDR picture (decoding can start here).
    pub key_frame: bool,
    /// Annex B bytes (start codes included).
    pub data: Vec<u8>,
}

impl AccessUnit {
    /// An access unit from recorded bytes; the key-frame flag is read from the NAL units.
    pub fn from_annex_b(pts_ns: u64, data: Vec<u8>) -> Self {
        let key_frame = nal_types(&data).any(|t| t == nal::IDR);
        Self {
            pts_ns,
            key_frame,
            data,
        }
    }

    /// Whether it carries SPS and PPS (every key frame of ours does).
    pub fn has_parameter_sets(&self) -> bool {
        let mut sps = false;
        let mut pps = false;
        for t in nal_types(&self.data) {
            sps |= t == nal::SPS;
            pps |= t == nal::PPS;
        }
        sps && pps
    }
}

/// The NAL units (without start codes) of an Annex B byte stream.
pub fn nal_units(data: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut rest = data;
    // Skip to the first start code.
    match find_start(rest) {
        Some((at, len)) => rest = rest.get(at + len..).unwrap_or(&[]),
        None => rest = &[],
    }
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let (unit, next) = match find_start(rest) {
            Some((at, len)) => (rest.get(..at)?, rest.get(at + len..)?),
            None => (rest, &[][..]),
        };
        rest = next;
        // Trailing zero bytes belong to the next start code (00 00 00 01).
        let mut end = unit.len();
        while end > 0 && unit.get(end - 1) == Some(&0) {
            end -= 1;
        }
        unit.get(..end)
    })
}

/// Position and length of the first start code.
fn find_start(data: &[u8]) -> Option<(usize, usize)> {
    let i = data.windows(3).position(|w| w == [0, 0, 1])?;
    Some((i, 3))
}

/// The NAL unit types, in order.
pub fn nal_types(data: &[u8]) -> impl Iterator<Item = u8> + '_ {
    nal_units(data).filter_map(|u| u.first().map(|b| b & 0x1F))
}

/// Why an access unit was rejected by [`check`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AuDefect {
    /// Empty.
    Empty,
    /// Does not start with a start code.
    NoStartCode,
    /// A NAL unit with the forbidden bit set or of a reserved type (0, 24..31).
    BadNalHeader,
    /// No slice of a picture.
    NoPicture,
}

impl std::fmt::Display for AuDefect {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Empty => "empty",
            Self::NoStartCode => "no Annex B start code",
            Self::BadNalHeader => "a NAL unit header is invalid",
            Self::NoPicture => "no picture slice",
        })
    }
}

/// Structural check of an access unit.
///
/// # Errors
/// The first [`AuDefect`] found.
pub fn check(data: &[u8]) -> Result<(), AuDefect> {
    if data.is_empty() {
        return Err(AuDefect::Empty);
    }
    let starts = data.starts_with(&[0, 0, 1]) || data.starts_with(&[0, 0, 0, 1]);
    if !starts {
        return Err(AuDefect::NoStartCode);
    }
    let mut picture = false;
    for unit in nal_units(data) {
        let Some(&h) = unit.first() else {
            return Err(AuDefect::BadNalHeader);
        };
        let t = h & 0x1F;
        if h & 0x80 != 0 || t == 0 || t >= 24 {
            return Err(AuDefect::BadNalHeader);
        }
        // A slice needs more than its header byte.
        if (nal::SLICE..=nal::IDR).contains(&t) {
            if unit.len() < 2 {
                return Err(AuDefect::BadNalHeader);
            }
            picture = true;
        }
    }
    if picture {
        Ok(())
    } else {
        Err(AuDefect::NoPicture)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEY: &[u8] = &[
        0, 0, 0, 1, 0x67, 0x42, 0x00, 0x1e, // SPS
        0, 0, 0, 1, 0x68, 0xce, 0x3c, 0x80, // PPS
        0, 0, 1, 0x65, 0x88, 0x84, 0x00, // IDR slice
    ];
    const DELTA: &[u8] = &[0, 0, 0, 1, 0x41, 0x9a, 0x02, 0x00];

    #[test]
    fn splits_and_classifies() {
        let types: Vec<u8> = nal_types(KEY).collect();
        assert_eq!(types, vec![nal::SPS, nal::PPS, nal::IDR]);
        let units: Vec<&[u8]> = nal_units(KEY).collect();
        assert_eq!(units[0], &[0x67, 0x42, 0x00, 0x1e]);
        assert_eq!(units[2], &[0x65, 0x88, 0x84]);
        let k = AccessUnit::from_annex_b(5, KEY.to_vec());
        assert!(k.key_frame && k.has_parameter_sets());
        let d = AccessUnit::from_annex_b(6, DELTA.to_vec());
        assert!(!d.key_frame && !d.has_parameter_sets());
    }

    #[test]
    fn check_finds_defects() {
        assert_eq!(check(KEY), Ok(()));
        assert_eq!(check(DELTA), Ok(()));
        assert_eq!(check(&[]), Err(AuDefect::Empty));
        assert_eq!(check(&[1, 2, 3, 4]), Err(AuDefect::NoStartCode));
        assert_eq!(check(&[0, 0, 1, 0xE5, 1, 2]), Err(AuDefect::BadNalHeader));
        assert_eq!(check(&[0, 0, 1, 0x67, 1, 2]), Err(AuDefect::NoPicture));
        assert_eq!(check(&[0, 0, 1, 0x65]), Err(AuDefect::BadNalHeader));
        // Truncated after the parameter sets.
        assert_eq!(check(&KEY[..16]), Err(AuDefect::NoPicture));
    }
}
