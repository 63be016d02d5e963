//! Time stamps drawn into frames, so replay tests (and people) can read back when a frame
//! was captured, also after H.264 compression.
//!
//! The machine-readable stripe sits in the top-left corner: blocks of `b × 2b` pixels
//! (`b = width / 80`, at least 2: 8 × 16 px at 640 wide), white/black for 1/0:
//! a white then a black sync block, the 64 bits of the time in ns (most significant
//! first), then 8 check bits (XOR of the eight time bytes): 74 blocks, 592 px at 640 wide.
//! Below it, the time in seconds as text for people ([`draw_text`], a 5×7 pixel font).

use crate::frame::VideoFrame;

const SYNC_BLOCKS: u32 = 2;
const DATA_BITS: u32 = 64;
const CHECK_BITS: u32 = 8;
const BLOCKS: u32 = SYNC_BLOCKS + DATA_BITS + CHECK_BITS;
/// Luma levels of a 1 and a 0 (video range, survives compression well).
const HIGH: u8 = 235;
const LOW: u8 = 16;

fn block_px(width_px: u32) -> u32 {
    (width_px / 80).max(2)
}

/// Whether a frame is large enough to carry a stamp.
pub fn fits(width_px: u32, height_px: u32) -> bool {
    let b = block_px(width_px);
    BLOCKS * b <= width_px && 2 * b <= height_px
}

fn check_byte(t_ns: u64) -> u8 {
    t_ns.to_be_bytes().iter().fold(0, |a, b| a ^ b)
}

fn fill(frame: &mut VideoFrame, x0: u32, y0: u32, w: u32, h: u32, rgb: [u8; 3]) {
    let width = frame.width_px as usize;
    for y in y0..(y0 + h).min(frame.height_px) {
        let row = y as usize * width;
        let x1 = (x0 + w).min(frame.width_px) as usize;
        let start = (row + x0 as usize) * 4;
        let end = (row + x1) * 4;
        if let Some(span) = frame.rgba.get_mut(start..end) {
            for px in span.chunks_exact_mut(4) {
                px.copy_from_slice(&[rgb[0], rgb[1], rgb[2], 255]);
            }
        }
    }
}

/// Draws the stripe encoding `t_ns` and the time as text below it. Frames too small for
/// the stripe ([`fits`]) are left unchanged; returns whether the stamp was drawn.
pub fn stamp_time(frame: &mut VideoFrame, t_ns: u64) -> bool {
    if !fits(frame.width_px, frame.height_px) {
        return false;
    }
    let b = block_px(frame.width_px);
    let h = 2 * b;
    let check = check_byte(t_ns);
    for i in 0..BLOCKS {
        let one = match i {
            0 => true,
            1 => false,
            i if i < SYNC_BLOCKS + DATA_BITS => {
                (t_ns >> (DATA_BITS - 1 - (i - SYNC_BLOCKS))) & 1 == 1
            }
            i => (check >> (CHECK_BITS - 1 - (i - SYNC_BLOCKS - DATA_BITS))) & 1 == 1,
        };
        let v = if one { HIGH } else { LOW };
        fill(frame, i * b, 0, b, h, [v, v, v]);
    }
    let text = format!("t {:.3} s", t_ns as f64 * 1e-9);
    let scale = (b / 4).max(1);
    draw_text(frame, 2, h + 2, scale, &text, [255, 255, 0]);
    true
}

fn luma_mean(frame: &VideoFrame, x0: u32, y0: u32, w: u32, h: u32) -> Option<f64> {
    let mut sum = 0.0;
    let mut n = 0u32;
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let [r, g, bl, _] = frame.pixel(x, y)?;
            sum += 0.299 * f64::from(r) + 0.587 * f64::from(g) + 0.114 * f64::from(bl);
            n += 1;
        }
    }
    (n > 0).then(|| sum / f64::from(n))
}

/// Reads the time back from a stamped frame; `None` if there is no valid stamp (sync
/// blocks or check bits wrong).
pub fn read_time(frame: &VideoFrame) -> Option<u64> {
    if !fits(frame.width_px, frame.height_px) {
        return None;
    }
    let b = block_px(frame.width_px);
    let h = 2 * b;
    // Sample the inside of each block: compression blurs the edges.
    let m = if b >= 4 { b / 4 } else { 0 };
    let bit = |i: u32| -> Option<bool> {
        Some(luma_mean(frame, i * b + m, m, b - 2 * m, h - 2 * m)? > f64::from(HIGH + LOW) / 2.0)
    };
    if !bit(0)? || bit(1)? {
        return None;
    }
    let mut t = 0u64;
    for i in 0..DATA_BITS {
        t = (t << 1) | u64::from(bit(SYNC_BLOCKS + i)?);
    }
    let mut check = 0u8;
    for i in 0..CHECK_BITS {
        check = (check << 1) | u8::from(bit(SYNC_BLOCKS + DATA_BITS + i)?);
    }
    (check == check_byte(t)).then_some(t)
}

/// 5×7 glyphs, one byte per row, bit 4 = leftmost column.
fn glyph(c: char) -> [u8; 7] {
    match c {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
        '/' => [0x01, 0x01, 0x02, 0x04, 0x08, 0x10, 0x10],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        'm' => [0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11],
        's' => [0x00, 0x00, 0x0E, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'd' => [0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F],
        'h' => [0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11],
        'g' => [0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E],
        _ => [0; 7],
    }
}

/// Draws text (digits, `. : - + = / %` and `m s t d h g`; other characters are blank)
/// with a dark outline so it reads on any background. `scale` multiplies the 5×7 font.
pub fn draw_text(
    frame: &mut VideoFrame,
    x_px: u32,
    y_px: u32,
    scale: u32,
    text: &str,
    rgb: [u8; 3],
) {
    let s = scale.max(1);
    // Outline first, then the glyphs.
    for (pass, color) in [(0, [0, 0, 0]), (1, rgb)] {
        let mut x = x_px;
        for c in text.chars() {
            let g = glyph(c);
            for (row, bits) in (0u32..).zip(g) {
                for col in 0..5u32 {
                    if bits & (0x10 >> col) != 0 {
                        let (px, py) = (x + col * s, y_px + row * s);
                        if pass == 0 {
                            fill(
                                frame,
                                px.saturating_sub(1),
                                py.saturating_sub(1),
                                s + 2,
                                s + 2,
                                color,
                            );
                        } else {
                            fill(frame, px, py, s, s, color);
                        }
                    }
                }
            }
            x += 6 * s;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamp_round_trip() {
        for t in [0u64, 1, 12_345_678_901, u64::MAX, 1_700_000_000_123_456_789] {
            let mut f = VideoFrame::black(640, 480, 0);
            assert!(stamp_time(&mut f, t));
            assert_eq!(read_time(&f), Some(t));
        }
    }

    #[test]
    fn small_frames_and_unstamped_frames() {
        let mut f = VideoFrame::black(100, 3, 0);
        assert!(!stamp_time(&mut f, 5));
        assert_eq!(read_time(&f), None);
        assert_eq!(read_time(&VideoFrame::black(640, 480, 0)), None);
        // 160 wide: 2-px blocks still fit.
        let mut g = VideoFrame::black(160, 120, 0);
        assert!(stamp_time(&mut g, 42));
        assert_eq!(read_time(&g), Some(42));
    }

    #[test]
    fn a_flipped_bit_is_detected() {
        let mut f = VideoFrame::black(640, 480, 0);
        stamp_time(&mut f, 1000);
        // Flip data bit 63 (the last data block).
        fill(&mut f, (SYNC_BLOCKS + 63) * 8, 0, 8, 16, [235, 235, 235]);
        assert_eq!(read_time(&f), None);
    }
}
