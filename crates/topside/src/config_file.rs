//! Where the station's settings come from, so an installed binary (`cargo install --path
//! crates/topside`) runs the same from any directory.
//!
//! * `--config PATH`: that file. It must exist and parse.
//! * Otherwise the user's file in the platform's configuration directory
//!   ([`user_config_path`]: `$XDG_CONFIG_HOME/topside/station.toml` or
//!   `~/.config/topside/station.toml` on Linux, `~/Library/Application
//!   Support/topside/station.toml` on macOS, `%APPDATA%\topside\station.toml` on Windows),
//!   when it exists.
//! * Otherwise the built-in defaults: the repository's `config/station.toml`, compiled
//!   in (the same values as `ControlConfig::default()`), and the station says so on
//!   stderr.
//!
//! A file that exists but cannot be read or does not parse is an error naming the file
//! (and, from the parser, the key, the value and the allowed range): only a missing user
//! file falls back to the defaults. The vehicle models are built in the same way
//! (`rov_dynamics::models::default_model_text`).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use rov_control::ControlConfig;

/// The built-in station settings (the shipped `config/station.toml`).
pub const BUILTIN_STATION_TOML: &str = include_str!("../../../config/station.toml");

/// The user's settings file in the platform's configuration directory (`None` when the
/// platform has no home directory).
pub fn user_config_path() -> Option<PathBuf> {
    directories::ProjectDirs::from("", "", "topside").map(|d| d.config_dir().join("station.toml"))
}

/// The user's models folder (`models/` next to the user's `station.toml`): the autopilot
/// panel offers its `*.toml` model files.
pub fn user_models_dir() -> Option<PathBuf> {
    directories::ProjectDirs::from("", "", "topside").map(|d| d.config_dir().join("models"))
}

/// Settings read, and where from.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The control settings.
    pub control: ControlConfig,
    /// The file's text (recorded with every session).
    pub text: String,
    /// The file read (`None`: the built-in defaults).
    pub path: Option<PathBuf>,
}

fn read(path: &Path) -> anyhow::Result<Loaded> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read the configuration file", path.display()))?;
    // The parser's error names the file, the key, the value and the allowed range.
    let control = ControlConfig::from_toml_str(&text, &path.display().to_string())?;
    Ok(Loaded {
        control,
        text,
        path: Some(path.to_path_buf()),
    })
}

/// The built-in defaults.
pub fn builtin() -> anyhow::Result<Loaded> {
    let control = ControlConfig::from_toml_str(BUILTIN_STATION_TOML, "built-in station.toml")?;
    Ok(Loaded {
        control,
        text: BUILTIN_STATION_TOML.to_string(),
        path: None,
    })
}

/// Resolves the settings (see the module docs): `explicit` is `--config PATH`, `user` the
/// user's file (normally [`user_config_path`]). Says on stderr which file is used.
pub fn load(explicit: Option<&Path>, user: Option<&Path>) -> anyhow::Result<Loaded> {
    if let Some(p) = explicit {
        return read(p);
    }
    match user {
        Some(p) if p.exists() => read(p),
        Some(p) => {
            eprintln!(
                "note: no configuration file at {}; using the built-in defaults (--config PATH chooses a file)",
                p.display()
            );
            builtin()
        }
        None => {
            eprintln!(
                "note: no configuration directory on this platform; using the built-in defaults"
            );
            builtin()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_is_the_default_config() {
        let b = builtin().unwrap();
        assert_eq!(b.control, ControlConfig::default());
        assert!(b.path.is_none());
    }

    #[test]
    fn missing_user_file_uses_defaults_but_a_bad_one_is_an_error() {
        let dir = std::env::temp_dir().join(format!("topside_cfg_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let missing = dir.join("none.toml");
        assert!(load(None, Some(&missing)).unwrap().path.is_none());
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, "[control]\nrate_hz = \"fast\"\n").unwrap();
        let e = format!("{:#}", load(None, Some(&bad)).unwrap_err());
        assert!(e.contains("bad.toml") && e.contains("rate_hz"), "{e}");
        // An explicit file must exist.
        let e = format!("{:#}", load(Some(&missing), None).unwrap_err());
        assert!(e.contains("none.toml") && e.contains("cannot read"), "{e}");
        // A directory where the file should be cannot be read: an error, not defaults.
        let e = format!("{:#}", load(None, Some(&dir)).unwrap_err());
        assert!(e.contains("cannot read"), "{e}");
        let good = dir.join("good.toml");
        std::fs::write(&good, "[control]\nrate_hz = 25.0\n").unwrap();
        let l = load(None, Some(&good)).unwrap();
        assert_eq!(l.control.rate_hz, 25.0);
        assert_eq!(l.path.as_deref(), Some(good.as_path()));
        std::fs::remove_dir_all(&dir).ok();
    }
}
