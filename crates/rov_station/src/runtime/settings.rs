//! The pilot's settings in the station configuration (`config/station.toml`): the
//! `[alarms]` limits ([`AlarmConfig`]) and the `[station]` table ([`StationSettings`]:
//! units, serial port and baud, recordings folder, recording on connection, simulated
//! link faults). Read with the same located errors as `[control]` (file, key, value,
//! allowed range); written back by [`save`], which replaces only these two tables and
//! keeps every other table and comment of the file (`toml_edit`).

use std::path::{Path, PathBuf};

use rov_types::params::{ConfigError, ParamFile};
use serde::Serialize;

use crate::pilot::alarms::AlarmConfig;
use crate::pilot::pad::PadMap;
use crate::pilot::shaping::StickShaping;

/// Everything the pilot sets in the station configuration.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PilotSettings {
    /// `[alarms]`.
    pub alarms: AlarmConfig,
    /// `[station]`.
    pub station: StationSettings,
    /// `[gamepad]` axes and buttons.
    pub pad: PadMap,
    /// `[gamepad.surge]`, `[gamepad.yaw]`, `[gamepad.vertical]`.
    pub shaping: StickShaping,
    /// `[video]`.
    pub video: crate::runtime::video::VideoSettings,
    /// `[foxglove]`.
    pub foxglove: FoxgloveSettings,
    /// `[autopilot]`.
    pub autopilot: AutopilotSettings,
}

/// The `[autopilot]` table: which model the autopilot uses.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Default)]
pub struct AutopilotSettings {
    /// `model = "model1" | "model2" | "model3" | "FILE.toml"`; `None` when absent (the
    /// `[control]` table's `feedforward_model` then chooses). A relative file is taken
    /// from the settings file's folder (by the caller, which loads it).
    #[serde(skip)]
    pub model: Option<rov_types::ModelId>,
}

impl AutopilotSettings {
    /// Reads `[autopilot]` (every key optional; unknown keys refused).
    ///
    /// # Errors
    /// [`ConfigError`] naming the file, key, value and allowed values.
    pub fn from_param_file(f: &ParamFile) -> Result<Self, ConfigError> {
        let model = if f.has("autopilot.model") {
            let s = f.string("autopilot.model")?;
            Some(
                s.parse::<rov_types::ModelId>()
                    .map_err(|_| ConfigError::OutOfRange {
                        file: f.file().to_string(),
                        key: "autopilot.model".into(),
                        value: format!("{s:?}"),
                        allowed: "model1, model2, model3 or a model file FILE.toml".into(),
                    })?,
            )
        } else {
            None
        };
        f.reject_unknown("autopilot")?;
        Ok(Self { model })
    }
}

/// The `[foxglove]` table: the live Foxglove server (off by default).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct FoxgloveSettings {
    /// Serve live when the station starts.
    pub enabled: bool,
    /// Where, `ADDR:PORT`.
    pub ws: String,
}

/// The live server's default address (Foxglove's usual port, this machine only).
pub const FOXGLOVE_DEFAULT_WS: &str = "127.0.0.1:8765";

impl Default for FoxgloveSettings {
    fn default() -> Self {
        Self {
            enabled: false,
            ws: FOXGLOVE_DEFAULT_WS.into(),
        }
    }
}

impl FoxgloveSettings {
    /// Reads `[foxglove]` (every key optional; unknown keys refused).
    ///
    /// # Errors
    /// [`ConfigError`] naming the file, key, value and allowed range.
    pub fn from_param_file(f: &ParamFile) -> Result<Self, ConfigError> {
        let s = Self {
            enabled: f.bool_or("foxglove.enabled", false)?,
            ws: f.string_or("foxglove.ws", FOXGLOVE_DEFAULT_WS)?,
        };
        f.reject_unknown("foxglove")?;
        Ok(s)
    }

    /// The `[foxglove]` table as TOML.
    #[must_use]
    pub fn to_toml(&self) -> String {
        format!(
            "enabled = {}\nws = {}\n",
            self.enabled,
            toml_edit::Value::from(self.ws.as_str())
        )
    }

    /// The address to serve on when the station starts, if enabled.
    #[must_use]
    pub fn serve_on(&self) -> Option<&str> {
        self.enabled.then_some(self.ws.trim())
    }
}

/// Depth unit shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum DepthUnit {
    /// Metres.
    #[default]
    Metres,
    /// Feet.
    Feet,
}

/// Temperature unit shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum TempUnit {
    /// Degrees Celsius.
    #[default]
    Celsius,
    /// Degrees Fahrenheit.
    Fahrenheit,
}

/// The `[station]` table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StationSettings {
    /// Depth unit.
    pub depth_unit: DepthUnit,
    /// Temperature unit.
    pub temp_unit: TempUnit,
    /// Serial port of the Pro 4 (empty: the simulator).
    pub serial_port: String,
    /// Baud rate (the Pro 4 talks 115200).
    pub baud: u32,
    /// Where recordings go.
    pub recordings_dir: PathBuf,
    /// Start recording on every new connection.
    pub record_on_connect: bool,
    /// Simulated vehicle only: replies dropped, % (0: a clean link; fault injection
    /// for training).
    pub sim_link_errors_pct: f64,
}

impl Default for StationSettings {
    fn default() -> Self {
        Self {
            depth_unit: DepthUnit::Metres,
            temp_unit: TempUnit::Celsius,
            serial_port: String::new(),
            baud: 115_200,
            recordings_dir: PathBuf::from("recordings"),
            record_on_connect: true,
            sim_link_errors_pct: 0.0,
        }
    }
}

/// Baud rates offered.
pub const BAUDS: [u32; 5] = [9_600, 19_200, 38_400, 57_600, 115_200];

impl StationSettings {
    /// Reads `[station]` (every key optional).
    ///
    /// # Errors
    /// [`ConfigError`] naming the file, key, value and allowed range.
    pub fn from_param_file(f: &ParamFile) -> Result<Self, ConfigError> {
        let d = Self::default();
        let depth_unit = match f
            .choice("station.depth_unit", &["m", "ft"], Some("m"))?
            .as_str()
        {
            "ft" => DepthUnit::Feet,
            _ => DepthUnit::Metres,
        };
        let temp_unit = match f
            .choice("station.temp_unit", &["c", "f"], Some("c"))?
            .as_str()
        {
            "f" => TempUnit::Fahrenheit,
            _ => TempUnit::Celsius,
        };
        let baud = f.f64_or("station.baud", 1200.0..=4_000_000.0, f64::from(d.baud))?;
        let s = Self {
            depth_unit,
            temp_unit,
            serial_port: f.string_or("station.serial_port", "")?,
            baud: baud.round() as u32,
            recordings_dir: PathBuf::from(f.string_or("station.recordings_dir", "recordings")?),
            record_on_connect: f.bool_or("station.record_on_connect", true)?,
            sim_link_errors_pct: f.f64_or("station.sim_link_errors_pct", 0.0..=50.0, 0.0)?,
        };
        f.reject_unknown("station")?;
        Ok(s)
    }

    /// The `[station]` table as TOML.
    #[must_use]
    pub fn to_toml(&self) -> String {
        let q = |s: &str| toml_edit::Value::from(s).to_string();
        format!(
            "depth_unit = {}\ntemp_unit = {}\nserial_port = {}\nbaud = {}\nrecordings_dir = {}\nrecord_on_connect = {}\nsim_link_errors_pct = {:?}\n",
            q(match self.depth_unit {
                DepthUnit::Metres => "m",
                DepthUnit::Feet => "ft",
            }),
            q(match self.temp_unit {
                TempUnit::Celsius => "c",
                TempUnit::Fahrenheit => "f",
            }),
            q(&self.serial_port),
            self.baud,
            q(&self.recordings_dir.display().to_string()),
            self.record_on_connect,
            self.sim_link_errors_pct
        )
    }
}

/// Reads the pilot's tables of a station configuration text.
///
/// # Errors
/// [`ConfigError`] naming the file, key, value and allowed range.
pub fn load(text: &str, label: &str) -> Result<(AlarmConfig, StationSettings), ConfigError> {
    let p = load_all(text, label)?;
    Ok((p.alarms, p.station))
}

/// Reads every pilot table (alarms, station, gamepad map and stick shaping); unknown
/// keys under `[gamepad]` are refused.
///
/// # Errors
/// [`ConfigError`] naming the file, key, value and allowed range.
pub fn load_all(text: &str, label: &str) -> Result<PilotSettings, ConfigError> {
    let f = ParamFile::parse(text, label, false)?;
    let p = PilotSettings {
        alarms: AlarmConfig::from_param_file(&f)?,
        station: StationSettings::from_param_file(&f)?,
        pad: PadMap::from_param_file(&f)?,
        shaping: StickShaping::from_param_file(&f)?,
        video: crate::runtime::video::VideoSettings::from_param_file(&f)?,
        foxglove: FoxgloveSettings::from_param_file(&f)?,
        autopilot: AutopilotSettings::from_param_file(&f)?,
    };
    f.reject_unknown("gamepad")?;
    Ok(p)
}

/// Writes `[alarms]` and `[station]` into the file at `path` (created if absent),
/// keeping its other tables and comments; atomically (a temporary file renamed).
///
/// # Errors
/// [`SaveError`] naming the file or folder and what failed.
pub fn save(path: &Path, alarms: &AlarmConfig, station: &StationSettings) -> Result<(), SaveError> {
    let fresh = format!(
        "[alarms]\n{}\n[station]\n{}",
        alarms.to_toml(),
        station.to_toml()
    );
    save_tables(path, &fresh, &["alarms", "station"])
}

/// Writes `[foxglove]` into the file at `path` like [`save`].
///
/// # Errors
/// [`SaveError`] naming the file or folder and what failed.
pub fn save_foxglove(path: &Path, foxglove: &FoxgloveSettings) -> Result<(), SaveError> {
    save_tables(
        path,
        &format!("[foxglove]\n{}", foxglove.to_toml()),
        &["foxglove"],
    )
}

/// Writes `[gamepad]` (axes, shift, buttons, shift buttons, stick shaping) into the file
/// at `path` like [`save`].
///
/// # Errors
/// [`SaveError`] naming the file or folder and what failed.
pub fn save_gamepad(path: &Path, pad: &PadMap, shaping: &StickShaping) -> Result<(), SaveError> {
    let (head, buttons, shifted) = pad.to_toml();
    let fresh = format!(
        "[gamepad]\n{head}[gamepad.surge]\n{}[gamepad.yaw]\n{}[gamepad.vertical]\n{}[gamepad.buttons]\n{buttons}[gamepad.shift_buttons]\n{shifted}",
        StickShaping::axis_toml(&shaping.surge),
        StickShaping::axis_toml(&shaping.yaw),
        StickShaping::axis_toml(&shaping.vertical),
    );
    // The button tables are replaced whole (a button unmapped must disappear).
    save_tables(path, &fresh, &["gamepad"])
}

/// Writes `[video]` into the file at `path` like [`save`].
///
/// # Errors
/// [`SaveError`] naming the file or folder and what failed.
pub fn save_video(
    path: &Path,
    video: &crate::runtime::video::VideoSettings,
) -> Result<(), SaveError> {
    save_tables(path, &format!("[video]\n{}", video.to_toml()), &["video"])
}

fn save_tables(path: &Path, fresh: &str, tables: &[&str]) -> Result<(), SaveError> {
    // A missing file is created (with its folder: the user's configuration directory may
    // not exist yet); a file that exists but cannot be read is never overwritten.
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|source| SaveError::CreateDir {
                    dir: dir.to_path_buf(),
                    source,
                })?;
            }
            String::new()
        }
        Err(source) => {
            return Err(SaveError::Read {
                path: path.to_path_buf(),
                source,
            });
        }
    };
    let mut doc: toml_edit::DocumentMut = text.parse().map_err(|source| SaveError::NotToml {
        path: path.to_path_buf(),
        source,
    })?;
    let fresh: toml_edit::DocumentMut = fresh.parse().map_err(SaveError::Fresh)?;
    for &table in tables {
        if table == "gamepad" {
            let new = fresh.get(table).cloned().unwrap_or_else(toml_edit::table);
            doc.insert(table, new);
            continue;
        }
        let new = fresh.get(table).cloned().unwrap_or_else(toml_edit::table);
        match doc.get_mut(table).and_then(toml_edit::Item::as_table_mut) {
            // Keep the table's and the keys' comments: replace the values only.
            Some(t) => {
                if let Some(n) = new.as_table() {
                    for (k, v) in n {
                        match (
                            t.get_mut(k).and_then(toml_edit::Item::as_value_mut),
                            v.as_value(),
                        ) {
                            (Some(old), Some(nv)) => {
                                let decor = old.decor().clone();
                                *old = nv.clone();
                                *old.decor_mut() = decor;
                            }
                            _ => {
                                t.insert(k, v.clone());
                            }
                        }
                    }
                }
            }
            None => {
                doc.insert(table, new);
            }
        }
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| SaveError::CreateDir {
            dir: dir.to_path_buf(),
            source,
        })?;
    }
    let tmp = path.with_extension("toml.tmp");
    std::fs::write(&tmp, doc.to_string()).map_err(|source| SaveError::Write {
        path: tmp.clone(),
        source,
    })?;
    std::fs::rename(&tmp, path).map_err(|source| SaveError::Replace {
        path: path.to_path_buf(),
        source,
    })
}

/// Why the settings could not be written back to the station configuration.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SaveError {
    /// The file's folder does not exist and cannot be made.
    #[error("{}: cannot create the folder: {source}", dir.display())]
    CreateDir {
        /// The folder.
        dir: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The file exists but cannot be read (it is then never overwritten).
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The file is not TOML (it is then never overwritten).
    #[error("{}: not valid TOML: {source}", path.display())]
    NotToml {
        /// The file.
        path: PathBuf,
        /// The parser's error (line and column).
        #[source]
        source: toml_edit::TomlError,
    },
    /// The tables written do not parse: a bug of this module, not of the file.
    #[error("settings: {0}")]
    Fresh(#[source] toml_edit::TomlError),
    /// The temporary file beside the configuration cannot be written.
    #[error("{}: {source}", path.display())]
    Write {
        /// The temporary file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The temporary file cannot replace the configuration.
    #[error("{}: {source}", path.display())]
    Replace {
        /// The configuration file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_round_trip_and_keep_the_rest_of_the_file() {
        let dir = std::env::temp_dir().join(format!("rov_settings_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("station.toml");
        std::fs::write(
            &path,
            "# Station settings.\n[control]\n# rate\nrate_hz = 50.0\n\n[alarms]\n# the pilot's limits\ndepth_warn_m = 10.0\n",
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let (mut alarms, mut station) = load(&text, "station.toml").unwrap();
        assert_eq!(alarms.depth_m.warn, 10.0);
        alarms.depth_m.alarm = 12.0;
        station.depth_unit = DepthUnit::Feet;
        station.serial_port = "/dev/ttyUSB0".into();
        save(&path, &alarms, &station).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("# rate\nrate_hz = 50.0"), "{text}");
        assert!(text.contains("# the pilot's limits"), "{text}");
        let (a2, s2) = load(&text, "station.toml").unwrap();
        assert_eq!((a2, s2), (alarms, station));
        // A bad value names file, key, value and range.
        let e = load("[station]\nbaud = 12\n", "config/station.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("config/station.toml") && e.contains("station.baud") && e.contains("12"),
            "{e}"
        );
        let e = load("[station]\ndepth_unit = \"yards\"\n", "s.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("station.depth_unit") && e.contains("one of m, ft"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn foxglove_table_is_off_by_default_round_trips_and_names_bad_keys() {
        let p = load_all("", "s.toml").unwrap();
        assert_eq!(p.foxglove, FoxgloveSettings::default());
        assert_eq!(p.foxglove.serve_on(), None);
        let dir = std::env::temp_dir().join(format!("rov_settings_fox_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("station.toml");
        std::fs::write(&path, "[station]\n# kept\nbaud = 115200\n").unwrap();
        let on = FoxgloveSettings {
            enabled: true,
            ws: "0.0.0.0:9000".into(),
        };
        save_foxglove(&path, &on).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("# kept"), "{text}");
        let back = load_all(&text, "station.toml").unwrap().foxglove;
        assert_eq!(back, on);
        assert_eq!(back.serve_on(), Some("0.0.0.0:9000"));
        let e = load_all("[foxglove]\nport = 1\n", "config/station.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("foxglove.port"), "{e}");
        let e = load_all("[foxglove]\nenabled = \"yes\"\n", "config/station.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("foxglove.enabled"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_settings_file_that_cannot_be_written_is_named_with_the_reason() {
        let root = tempfile::tempdir().unwrap();
        let (alarms, station) = (AlarmConfig::default(), StationSettings::default());
        // A file where a folder should be: the file is named, and not created.
        std::fs::write(root.path().join("file"), b"x").unwrap();
        let inside = root.path().join("file/sub/station.toml");
        let e = save(&inside, &alarms, &station).unwrap_err();
        assert!(
            matches!(&e, SaveError::Read { path, .. } if path == &inside),
            "{e:?}"
        );
        assert!(e.to_string().contains("cannot read"), "{e}");
        assert!(std::error::Error::source(&e).is_some());
        // A folder that cannot be made (Linux: nothing can be created under /proc).
        #[cfg(target_os = "linux")]
        {
            let e = save(
                Path::new("/proc/topside-no-such/station.toml"),
                &alarms,
                &station,
            )
            .unwrap_err();
            assert!(
                matches!(&e, SaveError::CreateDir { dir, .. } if dir == Path::new("/proc/topside-no-such")),
                "{e:?}"
            );
            assert!(e.to_string().contains("cannot create the folder"), "{e}");
        }
        // A file that is not TOML is named and left as it was.
        let bad = root.path().join("bad.toml");
        std::fs::write(&bad, "[alarms\n").unwrap();
        let e = save(&bad, &alarms, &station).unwrap_err();
        assert!(
            matches!(&e, SaveError::NotToml { path, .. } if path == &bad),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .starts_with(&format!("{}: not valid TOML", bad.display())),
            "{e}"
        );
        assert_eq!(std::fs::read_to_string(&bad).unwrap(), "[alarms\n");
        // A path that cannot be read (a folder) is never overwritten.
        let e = save_video(
            root.path(),
            &crate::runtime::video::VideoSettings::default(),
        )
        .unwrap_err();
        assert!(
            matches!(&e, SaveError::Read { path, .. } if path == root.path()),
            "{e:?}"
        );
    }
}
