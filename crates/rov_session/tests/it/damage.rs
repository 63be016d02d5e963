//! Truncated, corrupted and foreign files: clear errors or an exact prefix, never a panic;
//! recovery writes a complete file and leaves the input alone.

use std::path::Path;

use crate::common::{python_read, record};
use rov_session::{Damage, Session, SessionError, WriterOptions, open, recover, recovered_path};

type Msg = (String, u64, u32, Vec<u8>);

fn messages(s: &Session) -> Vec<Msg> {
    s.messages_in_file_order()
        .map(|m| (m.topic().to_string(), m.t_ns, m.sequence, m.data().to_vec()))
        .collect()
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

fn sample_file(dir: &Path, ticks: u64) -> (Vec<u8>, Vec<Msg>) {
    let path = dir.join("dive.mcap");
    record(&path, ticks, WriterOptions::default());
    let bytes = std::fs::read(&path).unwrap();
    let full = messages(&open(&path).unwrap());
    (bytes, full)
}

/// Offset of the summary section, from the footer.
fn summary_start(bytes: &[u8]) -> usize {
    let footer_body = bytes.len() - 8 - 20;
    u64::from_le_bytes(bytes[footer_body..footer_body + 8].try_into().unwrap()) as usize
}

fn load_prefix(bytes: &[u8], n: usize) -> Session {
    Session::from_bytes(bytes[..n].to_vec(), format!("prefix-{n}"))
        .unwrap_or_else(|e| panic!("prefix {n}: {e}"))
}

/// E3: truncation at every byte offset of the first 4 KiB and at 400 random offsets:
/// the reader returns exactly the messages of the complete records before the cut, reports
/// `Truncated` at the end of the last good record, and never panics.
#[test]
fn truncation_at_many_offsets_recovers_the_exact_prefix() {
    let dir = tempfile::tempdir().unwrap();
    let (bytes, full) = sample_file(dir.path(), 400);
    let len = bytes.len();
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut offsets: Vec<usize> = (1..4096.min(len)).collect();
    offsets.extend((0..400).map(|_| 1 + rng.below(len - 1)));
    offsets.extend(len - 64..len);
    offsets.sort_unstable();
    let mut last_count = 0;
    for &n in &offsets {
        let s = load_prefix(&bytes, n);
        let got = messages(&s);
        assert_eq!(
            got[..],
            full[..got.len()],
            "prefix {n}: recovered messages are not a prefix"
        );
        assert!(
            got.len() >= last_count,
            "prefix {n}: fewer messages than a shorter prefix"
        );
        last_count = got.len();
        let Some(Damage::Truncated {
            at_byte,
            messages_recovered,
        }) = s.damage()
        else {
            panic!("prefix {n}: expected Truncated, got {:?}", s.damage());
        };
        assert!(at_byte as usize <= n);
        assert_eq!(messages_recovered as usize, got.len());
        // Cutting at the reported offset loses nothing more: the prefix is exact.
        if at_byte == 0 {
            continue;
        }
        let again = load_prefix(&bytes, at_byte as usize);
        assert_eq!(again.len(), got.len(), "prefix {n} → at_byte {at_byte}");
        assert_eq!(again.damage().as_ref().map(Damage::at_byte), Some(at_byte));
    }
    // Once the data section is whole, every message is there.
    let data_whole = load_prefix(&bytes, summary_start(&bytes));
    assert_eq!(data_whole.len(), full.len());
    let complete = load_prefix(&bytes, len);
    assert!(complete.is_complete());
}

/// E3: 400 random single-byte flips, read both ways. Opened by a scan (as recovery
/// does): no panic; the messages returned are an exact prefix of the original; a flip in
/// a chunk's content is detected; a flip elsewhere in the data section is at least
/// reported by the data-section CRC. Opened through the summary (as the tools do): the
/// messages returned are still an exact prefix, and a flip in a chunk that a read reaches
/// is damage from then on.
#[test]
fn flipped_bytes_never_alter_returned_messages() {
    let dir = tempfile::tempdir().unwrap();
    let (bytes, full) = sample_file(dir.path(), 400);
    let data_end = summary_start(&bytes) - 13;
    let mut rng = Rng(12345);
    let mut detected = 0;
    let mut detected_fast = 0;
    for trial in 0..400 {
        let at = rng.below(bytes.len());
        let mut bad = bytes.clone();
        bad[at] ^= 1 << rng.below(8);
        let s = match Session::from_bytes_scanned(bad.clone(), "flipped") {
            Ok(s) => s,
            Err(e) => {
                assert!(at < 8, "trial {trial}: flip at {at}: unexpected error {e}");
                assert!(matches!(e, SessionError::NotMcap { .. }));
                continue;
            }
        };
        let got = messages(&s);
        assert_eq!(
            got[..],
            full[..got.len()],
            "trial {trial}: flip at {at} altered a returned message"
        );
        if s.damage().is_some() {
            detected += 1;
        } else if at < data_end {
            assert!(
                !s.warnings().is_empty(),
                "trial {trial}: flip at {at} in the data section went unreported"
            );
        }
        let fast = Session::from_bytes(bad, "flipped").unwrap();
        let got = messages(&fast);
        assert_eq!(
            got[..],
            full[..got.len()],
            "trial {trial}: flip at {at} altered a message read through the summary"
        );
        if got.len() < full.len() {
            assert!(
                fast.damage().is_some(),
                "trial {trial}: flip at {at}: messages lost silently"
            );
        }
        detected_fast += usize::from(fast.damage().is_some());
    }
    assert!(
        detected > 200,
        "only {detected} of 400 flips stopped the reader"
    );
    assert!(
        detected_fast > 150,
        "only {detected_fast} of 400 flips found through the summary"
    );
}

#[test]
fn foreign_files_are_clear_errors() {
    let mut png = vec![0x89, b'P', b'N', b'G', 0x0D, 0x0A, 0x1A, 0x0A];
    png.extend([0u8; 100]);
    let mut rng = Rng(7);
    let random: Vec<u8> = (0..5000).map(|_| rng.next() as u8).collect();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty", vec![], "empty"),
        ("png", png, "PNG"),
        ("random", random, "unknown content"),
        ("text", b"time_s,depth_m\n0,1\n".to_vec(), "text file"),
        ("zstd", vec![0x28, 0xb5, 0x2f, 0xfd, 0, 0, 0, 0, 0], "zstd"),
        ("mcap1", b"\x89MCAP1\r\nxxxxxxxx".to_vec(), "version"),
    ];
    for (name, bytes, needle) in cases {
        let e = Session::from_bytes(bytes, name).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, SessionError::NotMcap { .. }), "{name}: {text}");
        assert!(text.contains(needle), "{name}: {text}");
        assert!(text.contains("not an MCAP session file"), "{name}: {text}");
    }
    // The first bytes of the magic only: a recording cut at once.
    let s = Session::from_bytes(b"\x89MCA".to_vec(), "cut").unwrap();
    assert!(s.is_empty());
    assert_eq!(s.damage().as_ref().map(Damage::at_byte), Some(0));
    // A missing file is an I/O error naming the path.
    let e = open("/nonexistent/dive.mcap").unwrap_err();
    assert!(e.to_string().contains("/nonexistent/dive.mcap"), "{e}");
}

/// Recovery of a truncated file: a complete file with exactly the readable messages,
/// which the official reader opens; the input is untouched.
#[test]
fn recover_writes_a_complete_file_beside_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let (bytes, _) = sample_file(dir.path(), 300);
    let cut = bytes.len() * 2 / 3 + 17;
    let input = dir.path().join("cut.mcap");
    std::fs::write(&input, &bytes[..cut]).unwrap();
    let before = open(&input).unwrap();
    let report = recover(&input).unwrap();
    assert_eq!(
        std::fs::read(&input).unwrap(),
        &bytes[..cut],
        "the input must not change"
    );
    assert_eq!(report.output, dir.path().join("cut.recovered.mcap"));
    assert_eq!(report.output, recovered_path(&input));
    assert_eq!(report.messages_recovered, before.len() as u64);
    assert_eq!(report.input_bytes, cut as u64);
    assert_eq!(report.good_bytes + report.lost_bytes, cut as u64);
    assert!(report.lost_bytes > 0);
    assert_eq!(report.last_good_t_ns, before.end_ns());
    assert!(matches!(report.damage, Some(Damage::Truncated { .. })));
    assert!(report.to_string().contains("truncated"), "{report}");
    let after = open(&report.output).unwrap();
    assert!(after.is_complete());
    assert!(after.warnings().is_empty(), "{:?}", after.warnings());
    assert_eq!(messages(&after), messages(&before));
    assert_eq!(after.config_toml(), before.config_toml());
    assert_eq!(after.metadata(), before.metadata());
    let py = python_read(&report.output);
    assert_eq!(py["summary_messages"], before.len() as u64);
    // Recovering an intact file copies it and reports nothing lost.
    let whole = dir.path().join("dive.mcap");
    let r = recover(&whole).unwrap();
    assert_eq!(r.lost_bytes, 0);
    assert!(r.damage.is_none());
    assert_eq!(open(&r.output).unwrap().len(), open(&whole).unwrap().len());
}
