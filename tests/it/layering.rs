//! The layer rules of ARCHITECTURE.md, checked.
//!
//! 1. Every dependency edge between workspace crates (normal, build and dev) is one that
//!    ARCHITECTURE.md's crate table allows: a normal edge must be in the row's "may depend
//!    on" column and point to a lower layer; a dev edge may also name a crate in the row's
//!    "its tests may also use" column (still a lower layer). Every workspace member has a
//!    row.
//! 2. The pure crates (the ARCHITECTURE.md rule "do no I/O and never read the wall
//!    clock") contain, outside their tests, no clock read, no file system, no socket and
//!    no environment access.
//!
//! Both read the real files, so the table cannot drift from the code unnoticed.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the scenarios crate sits in the workspace root")
        .to_path_buf()
}

/// One row of the crate table.
#[derive(Debug)]
struct Row {
    /// `None` for the scenarios crate (no layer: it may use anything).
    layer: Option<u32>,
    allowed: Allowed,
    dev_allowed: Allowed,
}

#[derive(Debug)]
enum Allowed {
    Names(BTreeSet<String>),
    /// "any lower layer"
    AnyLower,
    /// "any crate"
    Any,
}

impl Allowed {
    fn parse(cell: &str) -> Allowed {
        let cell = cell.trim();
        match cell {
            "any lower layer" => Allowed::AnyLower,
            "any crate" => Allowed::Any,
            "—" | "-" | "" => Allowed::Names(BTreeSet::new()),
            _ => Allowed::Names(
                cell.split(',')
                    .map(|s| s.trim().trim_matches('`').to_string())
                    .filter(|s| !s.is_empty())
                    .collect(),
            ),
        }
    }

    fn names(&self, dep: &str) -> Option<bool> {
        match self {
            Allowed::Names(n) => Some(n.contains(dep)),
            Allowed::AnyLower | Allowed::Any => None,
        }
    }
}

/// The crate table of ARCHITECTURE.md: package name → row.
fn table() -> BTreeMap<String, Row> {
    let text = std::fs::read_to_string(root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md");
    let mut rows = BTreeMap::new();
    let mut in_table = false;
    for line in text.lines() {
        if line.starts_with("| layer | crate") {
            in_table = true;
            continue;
        }
        if !in_table {
            continue;
        }
        if !line.starts_with('|') {
            if !rows.is_empty() {
                break;
            }
            continue;
        }
        if line.starts_with("|---") {
            continue;
        }
        let cells: Vec<&str> = line.trim().trim_matches('|').split(" | ").collect();
        assert!(
            cells.len() >= 5,
            "ARCHITECTURE.md crate table row without its five columns: {line}"
        );
        let layer = cells[0].trim().parse::<u32>().ok();
        let name = cells[1]
            .split('`')
            .nth(1)
            .unwrap_or_else(|| panic!("no `crate` name in row: {line}"))
            .to_string();
        let n = cells.len();
        rows.insert(
            name,
            Row {
                layer,
                allowed: Allowed::parse(cells[n - 2]),
                dev_allowed: Allowed::parse(cells[n - 1]),
            },
        );
    }
    assert!(
        rows.len() > 5,
        "the crate table was not found in ARCHITECTURE.md"
    );
    rows
}

/// Every workspace member: package name → (manifest, which workspace crates it uses as
/// normal/build and as dev dependencies).
struct Member {
    dir: PathBuf,
    normal: BTreeSet<String>,
    dev: BTreeSet<String>,
}

fn members() -> BTreeMap<String, Member> {
    let ws: toml::Table = std::fs::read_to_string(root().join("Cargo.toml"))
        .expect("Cargo.toml")
        .parse()
        .expect("the workspace manifest parses");
    let paths: Vec<String> = ws["workspace"]["members"]
        .as_array()
        .expect("workspace.members")
        .iter()
        .filter_map(|v| v.as_str().map(str::to_string))
        .collect();
    let mut manifests = BTreeMap::new();
    for p in &paths {
        let dir = root().join(p);
        let m: toml::Table = std::fs::read_to_string(dir.join("Cargo.toml"))
            .unwrap_or_else(|e| panic!("{p}/Cargo.toml: {e}"))
            .parse()
            .unwrap_or_else(|e| panic!("{p}/Cargo.toml: {e}"));
        let name = m["package"]["name"]
            .as_str()
            .expect("package.name")
            .to_string();
        manifests.insert(name, (dir, m));
    }
    let names: BTreeSet<String> = manifests.keys().cloned().collect();
    let deps_of = |m: &toml::Table, key: &str| -> BTreeSet<String> {
        let mut out = BTreeSet::new();
        let mut tables = vec![m.get(key)];
        if let Some(t) = m.get("target").and_then(|t| t.as_table()) {
            for cfg in t.values() {
                tables.push(cfg.get(key));
            }
        }
        for t in tables.into_iter().flatten().filter_map(|t| t.as_table()) {
            for (k, v) in t {
                // `package = "…"` renames a dependency.
                let real = v
                    .get("package")
                    .and_then(|p| p.as_str())
                    .unwrap_or(k)
                    .to_string();
                if names.contains(&real) {
                    out.insert(real);
                }
            }
        }
        out
    };
    manifests
        .into_iter()
        .map(|(name, (dir, m))| {
            let mut normal = deps_of(&m, "dependencies");
            normal.extend(deps_of(&m, "build-dependencies"));
            let mut dev = deps_of(&m, "dev-dependencies");
            // A dev-dependency on the crate itself only turns on its features.
            dev.remove(&name);
            (name, Member { dir, normal, dev })
        })
        .collect()
}

#[test]
fn every_dependency_edge_is_one_the_architecture_table_allows() {
    let table = table();
    let members = members();
    let mut wrong = Vec::new();
    for name in members.keys() {
        if !table.contains_key(name) {
            wrong.push(format!(
                "{name}: a workspace member without a row in ARCHITECTURE.md's crate table"
            ));
        }
    }
    for name in table.keys() {
        if !members.contains_key(name) {
            wrong.push(format!(
                "{name}: a row of ARCHITECTURE.md's crate table that is no workspace member"
            ));
        }
    }
    for (name, m) in &members {
        let Some(row) = table.get(name) else { continue };
        let check = |dep: &String, dev: bool, wrong: &mut Vec<String>| {
            let kind = if dev { "dev-dependency" } else { "dependency" };
            let Some(dep_row) = table.get(dep) else {
                return;
            };
            if matches!(row.allowed, Allowed::Any) || matches!(row.dev_allowed, Allowed::Any) && dev
            {
                return;
            }
            if let (Some(l), Some(dl)) = (row.layer, dep_row.layer)
                && dl >= l
            {
                wrong.push(format!(
                    "{name} (layer {l}) → {dep} (layer {dl}): a {kind} that does not point to a lower layer"
                ));
                return;
            }
            let listed = row.allowed.names(dep).unwrap_or(true)
                || (dev && row.dev_allowed.names(dep).unwrap_or(true));
            if !listed {
                wrong.push(format!(
                    "{name} → {dep}: a {kind} that ARCHITECTURE.md's row for {name} does not list"
                ));
            }
        };
        for dep in &m.normal {
            check(dep, false, &mut wrong);
        }
        for dep in &m.dev {
            check(dep, true, &mut wrong);
        }
        // The table lists only edges that exist, so that it stays a true map.
        if let Allowed::Names(listed) = &row.allowed {
            for dep in listed {
                if !m.normal.contains(dep) {
                    wrong.push(format!(
                        "{name}: ARCHITECTURE.md lists {dep} as a dependency but {}/Cargo.toml has no such edge",
                        m.dir.display()
                    ));
                }
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "layer rules broken:\n  {}",
        wrong.join("\n  ")
    );
}

/// The crates ARCHITECTURE.md calls pure: no I/O, no wall clock.
const PURE: [&str; 8] = [
    "firmware_proto",
    "rov_logs",
    "rov_types",
    "rov_plot",
    "rov_dynamics",
    "rov_sim",
    "rov_control",
    "rov_lab",
];

/// What a pure crate must not contain outside its tests.
const FORBIDDEN: [&str; 15] = [
    "Instant::now",
    "SystemTime::now",
    "std::fs",
    "File::open",
    "File::create",
    "OpenOptions",
    "std::net",
    "env::var",
    "std::process",
    "std::io::stdin",
    "stdout()",
    "stderr()",
    "println!",
    "eprintln!",
    "tempfile",
];

/// Crates that exist to do I/O (files, scratch files, devices, sockets, dialogs, video,
/// the OS's folders): a pure crate may not depend on them, whatever its sources look like
/// (a grep of the sources cannot see what a dependency does for them).
const IO_CRATES: [&str; 17] = [
    "tempfile",
    "memmap2",
    "serialport",
    "tokio",
    "mio",
    "socket2",
    "nix",
    "rfd",
    "directories",
    "dirs",
    "notify",
    "reqwest",
    "ureq",
    "gstreamer",
    "gstreamer-app",
    "gstreamer-video",
    "foxglove",
];

/// The lines of `text` outside `#[cfg(test)]` items (brace counting; good enough for
/// rustfmt-formatted code, whose test modules open a brace on the item's line).
fn non_test_lines(text: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut skip_next_item = false;
    let mut depth: i64 = 0;
    let mut skipping = false;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if skipping {
            depth += t.matches('{').count() as i64 - t.matches('}').count() as i64;
            if depth <= 0 {
                skipping = false;
            }
            continue;
        }
        if t.starts_with("#[cfg(test)]") {
            skip_next_item = true;
            continue;
        }
        if skip_next_item {
            if t.starts_with("#[") || t.is_empty() || t.starts_with("//") {
                continue;
            }
            skip_next_item = false;
            depth = t.matches('{').count() as i64 - t.matches('}').count() as i64;
            skipping = depth > 0;
            continue;
        }
        if t.starts_with("//") {
            continue;
        }
        out.push((i + 1, line));
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn the_pure_crates_read_no_clock_and_do_no_io() {
    let members = members();
    let mut wrong = Vec::new();
    for name in PURE {
        let m = members
            .get(name)
            .unwrap_or_else(|| panic!("{name} is no longer a workspace member: update PURE"));
        let mut files = Vec::new();
        rust_files(&m.dir.join("src"), &mut files);
        assert!(!files.is_empty(), "{name}: no sources found");
        for f in files {
            if f.file_name().is_some_and(|n| n == "tests.rs") {
                continue;
            }
            let text = std::fs::read_to_string(&f).unwrap_or_default();
            for (no, line) in non_test_lines(&text) {
                for pat in FORBIDDEN {
                    if line.contains(pat) {
                        wrong.push(format!(
                            "{}:{no}: `{pat}` in pure crate {name}",
                            f.display()
                        ));
                    }
                }
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "I/O or clock in a pure crate:\n  {}",
        wrong.join("\n  ")
    );
}

/// The pure crates' normal and build dependencies (any crate, not only the workspace's)
/// include no crate made for I/O ([`IO_CRATES`]): a scratch file, a device or a socket
/// reached through a dependency is I/O all the same.
#[test]
fn the_pure_crates_depend_on_no_io_crate() {
    let members = members();
    let mut wrong = Vec::new();
    for name in PURE {
        let m = members
            .get(name)
            .unwrap_or_else(|| panic!("{name} is no longer a workspace member: update PURE"));
        let manifest: toml::Table = std::fs::read_to_string(m.dir.join("Cargo.toml"))
            .expect("the crate's manifest")
            .parse()
            .expect("the crate's manifest parses");
        let mut tables = vec![
            manifest.get("dependencies"),
            manifest.get("build-dependencies"),
        ];
        if let Some(t) = manifest.get("target").and_then(|t| t.as_table()) {
            for cfg in t.values() {
                tables.push(cfg.get("dependencies"));
                tables.push(cfg.get("build-dependencies"));
            }
        }
        for t in tables.into_iter().flatten().filter_map(|t| t.as_table()) {
            for (k, v) in t {
                let real = v.get("package").and_then(|p| p.as_str()).unwrap_or(k);
                if IO_CRATES.contains(&real) {
                    wrong.push(format!("{name} depends on {real}, an I/O crate"));
                }
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "I/O crate in a pure crate's dependencies:\n  {}",
        wrong.join("\n  ")
    );
}

/// What the station's pilot core (`rov_station::pilot`, sans-IO) must not contain outside
/// its tests, beyond [`FORBIDDEN`]: threads, locks, channels, atomics.
const NOT_IN_THE_PILOT_CORE: [&str; 7] = [
    "std::thread",
    "Mutex",
    "RwLock",
    "mpsc",
    "Atomic",
    "Condvar",
    "std::time::Instant",
];

/// The names of `crate::runtime` the pilot core may use: the plain data types of the
/// runtime's root module (commands, configuration, error) and the live tap it hands back
/// untouched. Anything inside the runtime's modules (threads, devices) is out.
const PILOT_MAY_NAME_FROM_RUNTIME: [&str; 8] = [
    "RuntimeConfig",
    "RuntimeCommand",
    "RuntimeError",
    "CameraCommand",
    "ChecklistCommand",
    "GainCommand",
    "ReplayCommand",
    "foxglove_live::LiveTap",
];

/// The uses of `crate::runtime` in `text` that the pilot core may not make: every path
/// after `crate::runtime::` (one name, or each name of a `{...}` group, which may span
/// lines) must be in [`PILOT_MAY_NAME_FROM_RUNTIME`].
fn runtime_names_outside_the_allowed(text: &str) -> Vec<String> {
    let mut wrong = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("crate::runtime::") {
        rest = &rest[i + "crate::runtime::".len()..];
        let names: Vec<&str> = if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            group[..end].split(',').map(str::trim).collect()
        } else {
            let end = rest
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(rest.len());
            vec![rest[..end].trim_end_matches(':')]
        };
        for n in names.into_iter().filter(|n| !n.is_empty()) {
            if !PILOT_MAY_NAME_FROM_RUNTIME.contains(&n) {
                wrong.push(n.to_string());
            }
        }
    }
    wrong
}

/// The pilot core is a sans-IO state machine (ARCHITECTURE.md, issue 24): no clock, file,
/// socket, thread, lock or channel in `crates/rov_station/src/pilot{.rs,/}` outside its
/// tests, and nothing from the runtime's modules.
#[test]
fn the_pilot_core_does_no_io_and_takes_no_lock() {
    let src = root().join("crates/rov_station/src");
    let mut files = vec![src.join("pilot.rs")];
    rust_files(&src.join("pilot"), &mut files);
    assert!(files.len() > 5, "the pilot core's sources: {files:?}");
    let mut wrong = Vec::new();
    for f in files {
        if f.file_name().is_some_and(|n| n == "tests.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap_or_default();
        let kept: Vec<(usize, &str)> = non_test_lines(&text);
        for (no, line) in &kept {
            for pat in FORBIDDEN.iter().chain(NOT_IN_THE_PILOT_CORE.iter()) {
                if line.contains(pat) {
                    wrong.push(format!("{}:{no}: `{pat}`", f.display()));
                }
            }
        }
        let joined: String = kept.iter().map(|(_, l)| format!("{l}\n")).collect();
        for n in runtime_names_outside_the_allowed(&joined) {
            wrong.push(format!("{}: crate::runtime::{n}", f.display()));
        }
    }
    assert!(
        wrong.is_empty(),
        "the pilot core must stay sans-IO:\n  {}",
        wrong.join("\n  ")
    );
}

#[test]
fn the_runtime_name_check_reads_groups_and_paths() {
    let ok = "use crate::runtime::{\n    RuntimeCommand, RuntimeConfig,\n};\nx: Option<crate::runtime::foxglove_live::LiveTap>";
    assert!(runtime_names_outside_the_allowed(ok).is_empty());
    let bad =
        "use crate::runtime::{Shared, lock};\nlet r = crate::runtime::recorder::Recorder::start();";
    assert_eq!(
        runtime_names_outside_the_allowed(bad),
        vec!["Shared", "lock", "recorder::Recorder::start"]
    );
}

#[test]
fn the_scanner_skips_test_modules_and_sees_the_rest() {
    let src = "fn a() { let t = std::time::Instant::now(); }\n#[cfg(test)]\nmod tests {\n    fn b() {\n        std::fs::read(\"x\");\n    }\n}\nfn c() {}\n";
    let lines: Vec<usize> = non_test_lines(src).iter().map(|(n, _)| *n).collect();
    assert_eq!(lines, vec![1, 8]);
}

/// A crate that lists its test binaries (`autotests = false`: the one-binary
/// `tests/it/main.rs` layout, or the scenarios' explicit `[[test]]`s) would silently skip
/// a test file that nobody declared. Every `tests/*.rs` must be a declared test target,
/// and every `tests/it/*.rs` a `mod` of `tests/it/main.rs`.
#[test]
fn no_test_file_is_left_out_of_a_test_binary() {
    let mut wrong = Vec::new();
    let ws: toml::Table = std::fs::read_to_string(root().join("Cargo.toml"))
        .expect("Cargo.toml")
        .parse()
        .expect("the workspace manifest parses");
    for p in ws["workspace"]["members"].as_array().expect("members") {
        let Some(p) = p.as_str() else { continue };
        let dir = root().join(p);
        let m: toml::Table = std::fs::read_to_string(dir.join("Cargo.toml"))
            .expect("manifest")
            .parse()
            .expect("manifest parses");
        let autotests = m["package"]
            .get("autotests")
            .and_then(toml::Value::as_bool)
            .unwrap_or(true);
        if autotests {
            continue;
        }
        // The scenarios crate keeps its tests beside its manifest.
        let tests_dir = if dir.join("tests").is_dir() {
            dir.join("tests")
        } else {
            dir.clone()
        };
        let declared: BTreeSet<PathBuf> = m
            .get("test")
            .and_then(toml::Value::as_array)
            .map(|a| {
                a.iter()
                    .filter_map(|t| t.get("path").and_then(toml::Value::as_str))
                    .map(|s| dir.join(s))
                    .collect()
            })
            .unwrap_or_default();
        let Ok(rd) = std::fs::read_dir(&tests_dir) else {
            continue;
        };
        for e in rd.flatten() {
            let f = e.path();
            let is_rs = f.extension().is_some_and(|x| x == "rs");
            let is_lib = f
                .file_name()
                .is_some_and(|n| n == "lib.rs" || n == "build.rs");
            if is_rs && !is_lib && !declared.contains(&f) {
                wrong.push(format!(
                    "{}: a test file that no [[test]] of {p}/Cargo.toml declares",
                    f.display()
                ));
            }
        }
        let it = tests_dir.join("it");
        if let Ok(main) = std::fs::read_to_string(it.join("main.rs")) {
            for e in std::fs::read_dir(&it).into_iter().flatten().flatten() {
                let f = e.path();
                let Some(stem) = f.file_stem().and_then(|s| s.to_str()) else {
                    continue;
                };
                let module = if f.is_dir() {
                    f.join("mod.rs").exists()
                } else {
                    f.extension().is_some_and(|x| x == "rs")
                };
                if stem == "main" || !module {
                    continue;
                }
                if !main
                    .lines()
                    .any(|l| l.trim().trim_start_matches("pub ") == format!("mod {stem};"))
                {
                    wrong.push(format!(
                        "{}: not a `mod {stem};` of {}",
                        f.display(),
                        it.join("main.rs").display()
                    ));
                }
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "test files left out:\n  {}",
        wrong.join("\n  ")
    );
}
