//! Vehicle definition files: a Fossen vehicle with any number of thrusters (up to
//! [`MAX_THRUSTERS`]) driven through a mixing matrix from named command channels.
//!
//! The three VideoRay models hard-wire the Pro 4's port, starboard and vertical
//! thrusters. A vehicle file describes any vehicle the same way the models describe the
//! Pro 4 — every number a `{ value, unit, source }` table — plus its thrusters and how the
//! pilot's (or autopilot's) command channels reach them:
//!
//! ```toml
//! vehicle = "bluerov2_heavy"
//! description = "..."
//! structure = "fossen6"            # or "fossen4" (surge, sway, heave, yaw), "fossen3"
//! [rigid_body]      mass_kg, inertia_cg_kgm2 [3], products_of_inertia_kgm2 [3], cg_from_co_m [3]
//! [hydrostatics]    volume_m3, water_density_kgpm3, gravity_mps2, cb_from_co_m [3]
//! [added_mass]      diagonal [6]
//! [damping]         linear [6], quadratic [6]
//! [options]         munk_moment = "zeroed" | "full"
//! [hull]            size_m [3] (optional: length, width, height of a box centred on the CO)
//! [commands]        saturation = "clamp" | "scale", gain (optional, default 1)
//! [uncertainty]     thrust_gain, damping, added_mass (relative σ), cg_m, net_weight_n,
//!                   thruster_position_m, command_gain (absolute σ; optional)
//! [thrusters.NAME]  group, position_m [3], direction [3], curve = "quadratic" | "table",
//!                   forward/reverse_linear_n, forward/reverse_quadratic_n (quadratic) or
//!                   forward/reverse_table_n [11] (table, at |u| = 0, 0.1, …, 1),
//!                   lag_s (optional), mix_CHANNEL (one factor per command channel used;
//!                   CHANNEL a built-in or a free name)
//! ```
//!
//! # Commands, mixing, thrust
//!
//! A command vector holds one value per [`CommandChannel`] in percent (−100..100): the
//! built-in channels are the Pro 4's per-thruster commands (`port`, `starboard`,
//! `vertical`, `lateral`) and body-axis demands (`surge`, `sway`, `heave`, `roll`, `pitch`,
//! `yaw`, positive along the body axes: forward, starboard, down, starboard down, nose up,
//! clockwise seen from above). Any other name is a **free channel**: a thruster's
//! `mix_NAME` key declares it (`mix_thr1 = 1.0` drives that thruster directly from channel
//! `thr1`, as a log of per-thruster ESC commands holds them); names are 1..=32 characters
//! of `a-z`, `0-9`, `_` starting with a letter, at most [`MAX_FREE_CHANNELS`] per vehicle.
//! The vehicle's [`ChannelTable`] gives the free channels their indices (sorted by name).
//! Thruster i's command is u_i = g · Σ_c mix_{i,c} · command_c / 100 (g the optional
//! `[commands] gain`, a pilot gain setting), saturated to ±1 either
//! per thruster (`clamp`, ArduSub's behaviour) or by scaling all outputs by the largest
//! (`scale`). Its force along `direction` is the forward curve for u ≥ 0 and minus the
//! reverse curve at |u| for u < 0; a table curve is interpolated linearly between its 11
//! points. A positive command pushes along `direction`.
//!
//! # Structure
//!
//! `fossen6` is the full process plant model ([`crate::process`]). `fossen4` (Arnesen's
//! 4-DOF surge, sway, heave and yaw model with a sway thruster) and `fossen3` (surge, heave,
//! yaw) lock the other degrees of freedom: their velocities and accelerations stay zero and
//! the remaining ones solve the reduced system M_aa ν̇_a = f_a of the same forces.
//!
//! # Uncertainty
//!
//! The `[uncertainty]` table documents how well the file's numbers are known (relative
//! standard deviations for thrust, damping and added mass; absolute for the CG height and
//! the net weight). The model lab uses them as priors when it calibrates the vehicle and
//! when it decides whether a misfit is within what the parameters' uncertainty explains.
//!
//! `thruster_position_m` (default 0) says the thruster positions are not exact: the lab
//! then refits the thrust lines, shifting the non-vertical thrusters together in x, y
//! and z (surge thrust off the centreline yaws the vehicle, sway thrust off the CO's
//! vertical plane yaws it too, height pitches and rolls it) and the vertical ones in x
//! and y, each with that prior.
//!
//! `command_gain` (σ of `[commands] gain`, default 0) says the gain setting itself is not
//! known: the lab then calibrates the gain with that prior. The gain is not a thrust
//! scale: it moves the operating point along a non-linear thrust curve (the T200's force
//! roughly triples from 10 % to 20 % command but grows by a third from 50 % to 70 %), so
//! runs at several demand levels separate it from the thrust gains.

use nalgebra::{Matrix3, Vector3};
use rov_types::{ConfigError, ParamFile};

use super::param_util::{geometry, vec3, vec6};
use crate::error::DynamicsError;
use crate::math::{Matrix6, Vector6, stack};
use crate::process::{
    CurrentSample, Damping, Hydrostatics, MunkMoment, ProcessModel, ProcessParams, RigidBody,
};
use crate::thrusters::{ThrustPair, ThrusterGeometry};

/// Most thrusters a vehicle file may define.
pub const MAX_THRUSTERS: usize = 8;

/// Capacity of a command vector: the ten built-in channels ([`CommandChannel::BUILTIN`])
/// and up to [`MAX_FREE_CHANNELS`] free-named ones ([`ChannelTable`]).
pub const N_COMMANDS: usize = 18;

/// Built-in command channels (indices 0..10 of every command vector).
pub const N_BUILTIN: usize = 10;

/// Most free-named command channels a vehicle or run may have.
pub const MAX_FREE_CHANNELS: usize = N_COMMANDS - N_BUILTIN;

/// Longest free channel name.
pub const MAX_CHANNEL_NAME: usize = 32;

/// Command values in percent, one per command channel index: the built-in channels at
/// their fixed indices, then the free-named ones in their [`ChannelTable`]'s order. A
/// fixed-capacity array so the simulators' inner loops copy it without allocating.
pub type Commands = [f64; N_COMMANDS];

/// Points of a table thrust curve (|u| = 0, 0.1, …, 1).
pub const TABLE_POINTS: usize = 11;

/// A command channel: an index into a [`Commands`] vector. Indices below [`N_BUILTIN`]
/// are the built-in names (fixed meaning everywhere); the others are named by the
/// [`ChannelTable`] of the vehicle or run that holds them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CommandChannel(u8);

impl CommandChannel {
    /// Pro 4 port thruster, %.
    pub const PORT: Self = Self(0);
    /// Pro 4 starboard thruster, %.
    pub const STARBOARD: Self = Self(1);
    /// Pro 4 vertical thruster, % (positive pushes down).
    pub const VERTICAL: Self = Self(2);
    /// Pro 4 lateral (sway) thruster accessory, % (positive pushes to starboard).
    pub const LATERAL: Self = Self(3);
    /// Body-axis demand: forward.
    pub const SURGE: Self = Self(4);
    /// Body-axis demand: to starboard.
    pub const SWAY: Self = Self(5);
    /// Body-axis demand: down.
    pub const HEAVE: Self = Self(6);
    /// Body-axis demand: roll, starboard side down.
    pub const ROLL: Self = Self(7);
    /// Body-axis demand: pitch, nose up.
    pub const PITCH: Self = Self(8);
    /// Body-axis demand: yaw, clockwise seen from above.
    pub const YAW: Self = Self(9);

    /// The built-in channels, in index order.
    pub const BUILTIN: [CommandChannel; N_BUILTIN] = [
        Self::PORT,
        Self::STARBOARD,
        Self::VERTICAL,
        Self::LATERAL,
        Self::SURGE,
        Self::SWAY,
        Self::HEAVE,
        Self::ROLL,
        Self::PITCH,
        Self::YAW,
    ];

    const BUILTIN_NAMES: [&'static str; N_BUILTIN] = [
        "port",
        "starboard",
        "vertical",
        "lateral",
        "surge",
        "sway",
        "heave",
        "roll",
        "pitch",
        "yaw",
    ];

    /// The channel at a command-vector index (`None` beyond the capacity).
    pub fn from_index(i: usize) -> Option<Self> {
        (i < N_COMMANDS).then_some(Self(i as u8))
    }

    /// Index in a [`Commands`] vector.
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }

    /// Whether this is one of the built-in channels.
    pub fn is_builtin(self) -> bool {
        self.index() < N_BUILTIN
    }

    /// Name of a built-in channel (`None` for a free-named one: ask its [`ChannelTable`]).
    pub fn builtin_name(self) -> Option<&'static str> {
        Self::BUILTIN_NAMES.get(self.index()).copied()
    }

    /// A built-in channel by name.
    pub fn parse_builtin(s: &str) -> Option<Self> {
        Self::BUILTIN_NAMES
            .iter()
            .position(|n| *n == s)
            .and_then(Self::from_index)
    }
}

/// Whether `s` can name a free command channel: 1..=32 characters of `a-z`, `0-9` and `_`,
/// starting with a letter.
pub fn valid_channel_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= MAX_CHANNEL_NAME
        && s.starts_with(|c: char| c.is_ascii_lowercase())
        && s.chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

/// Names of the free command channels of a vehicle or run: free channel `k` has index
/// [`N_BUILTIN`]` + k` in its [`Commands`] vectors. Built-in names always map to their
/// fixed indices. A run and a model meet on names: [`ChannelTable::remap_from`] gives
/// the index map that re-indexes one's commands to the other's table.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct ChannelTable {
    free: Vec<String>,
}

/// Why a channel name was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ChannelError {
    /// Not a valid name.
    #[error(
        "command channel name {0:?} is not 1..=32 characters of a-z, 0-9, _ starting with a letter"
    )]
    BadName(String),
    /// More free channels than a command vector holds.
    #[error(
        "command channel {0:?} is one too many: at most {MAX_FREE_CHANNELS} channels besides the built-in ones (port, starboard, vertical, lateral, surge, sway, heave, roll, pitch, yaw)"
    )]
    TooMany(String),
}

impl ChannelTable {
    /// No free channels (the built-in ones only).
    pub const fn builtin() -> Self {
        Self { free: Vec::new() }
    }

    /// A table of the given names (built-in names keep their indices and are not added;
    /// duplicates are merged).
    pub fn from_names<'a, I: IntoIterator<Item = &'a str>>(names: I) -> Result<Self, ChannelError> {
        let mut t = Self::default();
        for n in names {
            t.intern(n)?;
        }
        Ok(t)
    }

    /// The channel of a name, adding a free one if new.
    pub fn intern(&mut self, name: &str) -> Result<CommandChannel, ChannelError> {
        if let Some(c) = self.index_of(name) {
            return Ok(c);
        }
        if !valid_channel_name(name) {
            return Err(ChannelError::BadName(name.to_string()));
        }
        if self.free.len() >= MAX_FREE_CHANNELS {
            return Err(ChannelError::TooMany(name.to_string()));
        }
        self.free.push(name.to_string());
        CommandChannel::from_index(N_BUILTIN + self.free.len() - 1)
            .ok_or_else(|| ChannelError::TooMany(name.to_string()))
    }

    /// The channel of a name, if the table (or the built-in set) has it.
    pub fn index_of(&self, name: &str) -> Option<CommandChannel> {
        CommandChannel::parse_builtin(name).or_else(|| {
            self.free
                .iter()
                .position(|n| n == name)
                .and_then(|k| CommandChannel::from_index(N_BUILTIN + k))
        })
    }

    /// The name of a channel (`None` for an index this table does not name).
    pub fn name(&self, c: CommandChannel) -> Option<&str> {
        c.builtin_name().or_else(|| {
            self.free
                .get(c.index().wrapping_sub(N_BUILTIN))
                .map(String::as_str)
        })
    }

    /// The free names, in index order.
    pub fn free_names(&self) -> &[String] {
        &self.free
    }

    /// Every channel the table names: the built-in ones, then the free ones.
    pub fn all(&self) -> Vec<CommandChannel> {
        (0..N_BUILTIN + self.free.len())
            .filter_map(CommandChannel::from_index)
            .collect()
    }

    /// For each index of this table, the index in `from` holding the same name (the map
    /// that re-indexes commands written for `from` to this table); `None` where `from`
    /// lacks the name. Built-in indices map to themselves.
    pub fn remap_from(&self, from: &ChannelTable) -> [Option<usize>; N_COMMANDS] {
        let mut out = [None; N_COMMANDS];
        for (i, o) in out.iter_mut().enumerate() {
            if i < N_BUILTIN {
                *o = Some(i);
            } else if let Some(n) = self.free.get(i - N_BUILTIN) {
                *o = from.index_of(n).map(CommandChannel::index);
            }
        }
        out
    }
}

/// A group of thrusters calibrated together (one thrust gain, one reverse ratio).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ThrusterGroup {
    /// Pro 4 port thruster.
    Port,
    /// Pro 4 starboard thruster.
    Starboard,
    /// Vertical thrusters.
    Vertical,
    /// Lateral (sway) thrusters.
    Lateral,
    /// Horizontal (vectored) thrusters.
    Horizontal,
}

impl ThrusterGroup {
    /// Every group, in index order.
    pub const ALL: [ThrusterGroup; 5] = [
        ThrusterGroup::Port,
        ThrusterGroup::Starboard,
        ThrusterGroup::Vertical,
        ThrusterGroup::Lateral,
        ThrusterGroup::Horizontal,
    ];

    /// Index 0..5.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Name used in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            ThrusterGroup::Port => "port",
            ThrusterGroup::Starboard => "starboard",
            ThrusterGroup::Vertical => "vertical",
            ThrusterGroup::Lateral => "lateral",
            ThrusterGroup::Horizontal => "horizontal",
        }
    }
}

/// Which degrees of freedom the vehicle model has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// All six (Fossen 6-DOF).
    Fossen6,
    /// Surge, sway, heave, yaw (Arnesen 2016's 4-DOF model with a sway thruster).
    Fossen4,
    /// Surge, heave, yaw.
    Fossen3,
}

impl Structure {
    /// Which of (u, v, w, p, q, r) move.
    pub fn active(self) -> [bool; 6] {
        match self {
            Structure::Fossen6 => [true; 6],
            Structure::Fossen4 => [true, true, true, false, false, true],
            Structure::Fossen3 => [true, false, true, false, false, true],
        }
    }

    /// Name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Structure::Fossen6 => "fossen6",
            Structure::Fossen4 => "fossen4",
            Structure::Fossen3 => "fossen3",
        }
    }
}

/// How thruster commands beyond ±1 are brought back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Saturation {
    /// Each thruster clamped on its own.
    Clamp,
    /// All thrusters scaled by the largest |u| when it exceeds 1 (keeps the mix's ratios).
    Scale,
}

/// A thruster's command → force curve (one direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ThrustCurve {
    /// F = T_l |u| + T_q u², N.
    Quadratic(ThrustPair),
    /// F interpolated in a table at |u| = 0, 0.1, …, 1, N.
    Table([f64; TABLE_POINTS]),
}

impl ThrustCurve {
    /// The force at |u| (0..1) split into the part a linear-gain scale multiplies and the
    /// part a quadratic-gain scale multiplies, N.
    #[inline]
    pub fn parts(&self, u_abs: f64) -> (f64, f64) {
        match self {
            ThrustCurve::Quadratic(p) => (p.linear_n * u_abs, p.quadratic_n * u_abs * u_abs),
            ThrustCurve::Table(t) => {
                let x = (u_abs.clamp(0.0, 1.0)) * (TABLE_POINTS - 1) as f64;
                let i = (x.floor() as usize).min(TABLE_POINTS - 2);
                let f = x - i as f64;
                let (a, b) = (t.get(i).copied(), t.get(i + 1).copied());
                match (a, b) {
                    (Some(a), Some(b)) => (a + (b - a) * f, 0.0),
                    _ => (0.0, 0.0),
                }
            }
        }
    }

    /// The force at |u|, N.
    #[inline]
    pub fn force_n(&self, u_abs: f64) -> f64 {
        let (a, b) = self.parts(u_abs);
        a + b
    }

    /// Whether the curve has a quadratic part (a separate quadratic gain).
    pub fn is_quadratic(&self) -> bool {
        matches!(self, ThrustCurve::Quadratic(_))
    }
}

/// One thruster.
#[derive(Debug, Clone, PartialEq)]
pub struct ThrusterDef {
    /// Name (the file's table name).
    pub name: String,
    /// Calibration group.
    pub group: ThrusterGroup,
    /// Position and direction (a positive command pushes along it).
    pub geometry: ThrusterGeometry,
    /// Curve for u ≥ 0.
    pub forward: ThrustCurve,
    /// Curve for u < 0 (magnitudes).
    pub reverse: ThrustCurve,
    /// First-order lag of the thruster's command, s (0 = none).
    pub lag_s: f64,
    /// Mixing factors from each command channel (index order of the vehicle's
    /// [`ChannelTable`]).
    pub mix: Commands,
}

/// Documented uncertainty of the file's numbers (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Uncertainty {
    /// Thrust gains, relative σ.
    pub thrust_gain_rel: f64,
    /// Damping coefficients, relative σ.
    pub damping_rel: f64,
    /// Added masses, relative σ.
    pub added_mass_rel: f64,
    /// CG position, σ in m.
    pub cg_m: f64,
    /// Net weight W − B, σ in N.
    pub net_weight_n: f64,
    /// Thruster positions, σ in m (0: the positions are taken as exact; otherwise the model
    /// lab calibrates the thrust lines' offsets with this prior: the non-vertical
    /// thrusters' shift in x, y and z, the vertical ones' in x and y).
    pub thruster_position_m: f64,
    /// The command gain, σ (0: the gain is taken as exact; otherwise the model lab
    /// calibrates it with this prior).
    pub command_gain: f64,
}

/// A parsed vehicle definition.
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleDef {
    /// Vehicle name (`vehicle` key).
    pub name: String,
    /// Description.
    pub description: String,
    /// Degrees of freedom.
    pub structure: Structure,
    /// The process plant parameters.
    pub process: ProcessParams,
    /// Displaced volume, m³.
    pub volume_m3: f64,
    /// Water density, kg/m³.
    pub water_density_kgpm3: f64,
    /// Gravity, m/s².
    pub gravity_mps2: f64,
    /// Thrusters.
    pub thrusters: Vec<ThrusterDef>,
    /// Saturation of thruster commands.
    pub saturation: Saturation,
    /// Gain on every command channel before mixing (a pilot gain setting; 1 = none).
    pub command_gain: f64,
    /// Documented uncertainties.
    pub uncertainty: Uncertainty,
    /// Names of the free command channels the thrusters' `mix_NAME` keys declare (sorted).
    pub channel_table: ChannelTable,
    /// Outer size of the hull (length, width, height), m, as a box centred on the CO
    /// (`[hull] size_m`, optional; `vehicle check` tests the CG and thrusters against it).
    pub hull_size_m: Option<[f64; 3]>,
}

/// Table names of the thrusters in a vehicle file, in file order.
fn thruster_names(text: &str, label: &str) -> Result<Vec<String>, ConfigError> {
    let root: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| ConfigError::Syntax {
            file: label.to_string(),
            message: e.to_string().trim().to_string(),
        })?;
    let Some(t) = root.get("thrusters") else {
        return Err(ConfigError::Missing {
            file: label.to_string(),
            key: "thrusters".into(),
            allowed: format!("1..={MAX_THRUSTERS} tables [thrusters.NAME]"),
        });
    };
    let t = t.as_table().ok_or_else(|| ConfigError::WrongType {
        file: label.to_string(),
        key: "thrusters".into(),
        value: t.to_string(),
        expected: "tables [thrusters.NAME]".into(),
    })?;
    if t.is_empty() || t.len() > MAX_THRUSTERS {
        return Err(ConfigError::OutOfRange {
            file: label.to_string(),
            key: "thrusters".into(),
            value: format!("{} thrusters", t.len()),
            allowed: format!("1..={MAX_THRUSTERS}"),
        });
    }
    Ok(t.keys().cloned().collect())
}

/// The command channels the thrusters' `mix_NAME` keys declare: the built-in names keep
/// their indices, the free names follow in sorted order (so two files with the same
/// channels index them alike).
fn mix_channels(text: &str, label: &str) -> Result<ChannelTable, ConfigError> {
    let root: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| ConfigError::Syntax {
            file: label.to_string(),
            message: e.to_string().trim().to_string(),
        })?;
    let mut names = std::collections::BTreeSet::new();
    if let Some(t) = root.get("thrusters").and_then(|t| t.as_table()) {
        for (tn, thr) in t {
            let Some(thr) = thr.as_table() else { continue };
            for k in thr.keys() {
                if let Some(ch) = k.strip_prefix("mix_") {
                    if !valid_channel_name(ch) {
                        return Err(ConfigError::OutOfRange {
                            file: label.to_string(),
                            key: format!("thrusters.{tn}.{k}"),
                            value: ch.to_string(),
                            allowed: "a channel name of 1..=32 characters a-z, 0-9, _ \
                                      starting with a letter"
                                .into(),
                        });
                    }
                    names.insert(ch.to_string());
                }
            }
        }
    }
    let mut table = ChannelTable::builtin();
    for n in &names {
        table.intern(n).map_err(|e| ConfigError::OutOfRange {
            file: label.to_string(),
            key: format!("thrusters.*.mix_{n}"),
            value: format!(
                "{} channels besides the built-in ones",
                names
                    .iter()
                    .filter(|n| CommandChannel::parse_builtin(n).is_none())
                    .count()
            ),
            allowed: e.to_string(),
        })?;
    }
    Ok(table)
}

/// Allowed range of a curve point or coefficient, N.
const THRUST_N: std::ops::RangeInclusive<f64> = 0.0..=500.0;

fn curve(pf: &ParamFile, prefix: &str, kind: &str, dir: &str) -> Result<ThrustCurve, ConfigError> {
    Ok(match kind {
        "table" => {
            let key = format!("{prefix}.{dir}_table_n");
            let t = pf.array::<TABLE_POINTS>(&key, THRUST_N)?;
            if t.windows(2).any(|w| w[1] < w[0]) || t[0] != 0.0 {
                return Err(ConfigError::OutOfRange {
                    file: pf.file().to_string(),
                    key,
                    value: format!("{t:?}"),
                    allowed: "thrust starting at 0 N and never decreasing with |u|".into(),
                });
            }
            ThrustCurve::Table(t)
        }
        _ => ThrustCurve::Quadratic(ThrustPair {
            linear_n: pf.f64(&format!("{prefix}.{dir}_linear_n"), THRUST_N)?,
            quadratic_n: pf.f64(&format!("{prefix}.{dir}_quadratic_n"), THRUST_N)?,
        }),
    })
}

impl VehicleDef {
    /// Parses a vehicle file; `label` names it in errors. Every number needs a unit and a
    /// source; unknown keys are refused.
    pub fn parse(text: &str, label: &str) -> Result<Self, ConfigError> {
        let names = thruster_names(text, label)?;
        let pf = ParamFile::parse(text, label, true)?;
        let name = pf.string("vehicle")?;
        let description = pf.string_or("description", "")?;
        let structure = match pf
            .choice(
                "structure",
                &["fossen6", "fossen4", "fossen3"],
                Some("fossen6"),
            )?
            .as_str()
        {
            "fossen4" => Structure::Fossen4,
            "fossen3" => Structure::Fossen3,
            _ => Structure::Fossen6,
        };
        let mass_kg = pf.f64("rigid_body.mass_kg", 0.1..=5000.0)?;
        let [ix, iy, iz] = pf.array::<3>("rigid_body.inertia_cg_kgm2", 1e-4..=1000.0)?;
        let [ixy, ixz, iyz] =
            pf.array::<3>("rigid_body.products_of_inertia_kgm2", -1000.0..=1000.0)?;
        let cg = vec3(&pf, "rigid_body.cg_from_co_m", -1.0..=1.0)?;
        let volume_m3 = pf.f64("hydrostatics.volume_m3", 1e-5..=10.0)?;
        let rho = pf.f64("hydrostatics.water_density_kgpm3", 900.0..=1100.0)?;
        let g = pf.f64("hydrostatics.gravity_mps2", 9.7..=9.9)?;
        let cb = vec3(&pf, "hydrostatics.cb_from_co_m", -1.0..=1.0)?;
        let added = vec6(&pf, "added_mass.diagonal", 0.0..=1000.0)?;
        let lin = vec6(&pf, "damping.linear", 0.0..=10000.0)?;
        let quad = vec6(&pf, "damping.quadratic", 0.0..=10000.0)?;
        let munk = match pf
            .choice("options.munk_moment", &["zeroed", "full"], Some("zeroed"))?
            .as_str()
        {
            "full" => MunkMoment::Full,
            _ => MunkMoment::Zeroed,
        };
        let saturation = match pf
            .choice("commands.saturation", &["clamp", "scale"], Some("clamp"))?
            .as_str()
        {
            "scale" => Saturation::Scale,
            _ => Saturation::Clamp,
        };
        let command_gain = pf.f64_or("commands.gain", 0.01..=10.0, 1.0)?;
        let uncertainty = Uncertainty {
            thrust_gain_rel: pf.f64_or("uncertainty.thrust_gain", 0.0..=5.0, 0.3)?,
            damping_rel: pf.f64_or("uncertainty.damping", 0.0..=5.0, 0.5)?,
            added_mass_rel: pf.f64_or("uncertainty.added_mass", 0.0..=5.0, 0.5)?,
            cg_m: pf.f64_or("uncertainty.cg_m", 0.0..=1.0, 0.01)?,
            net_weight_n: pf.f64_or("uncertainty.net_weight_n", 0.0..=1000.0, 1.0)?,
            thruster_position_m: pf.f64_or("uncertainty.thruster_position_m", 0.0..=1.0, 0.0)?,
            command_gain: pf.f64_or("uncertainty.command_gain", 0.0..=10.0, 0.0)?,
        };
        let group_names: Vec<&str> = ThrusterGroup::ALL.iter().map(|g| g.name()).collect();
        let channel_table = mix_channels(text, label)?;
        let hull_size_m = if pf.has("hull.size_m") {
            Some(pf.array::<3>("hull.size_m", 0.01..=20.0)?)
        } else {
            None
        };
        let mut thrusters = Vec::with_capacity(names.len());
        for n in &names {
            let prefix = format!("thrusters.{n}");
            let group_s = pf.choice(&format!("{prefix}.group"), &group_names, None)?;
            let group = ThrusterGroup::ALL
                .iter()
                .copied()
                .find(|g| g.name() == group_s)
                .unwrap_or(ThrusterGroup::Horizontal);
            let kind = pf.choice(&format!("{prefix}.curve"), &["quadratic", "table"], None)?;
            let mut mix = [0.0; N_COMMANDS];
            for c in channel_table.all() {
                let Some(cn) = channel_table.name(c) else {
                    continue;
                };
                if let Some(m) = mix.get_mut(c.index()) {
                    *m = pf.f64_or(&format!("{prefix}.mix_{cn}"), -10.0..=10.0, 0.0)?;
                }
            }
            if mix.iter().all(|m| *m == 0.0) {
                return Err(ConfigError::Missing {
                    file: label.to_string(),
                    key: format!("{prefix}.mix_*"),
                    allowed: "at least one non-zero mixing factor mix_CHANNEL (CHANNEL a built-in \
                              channel: port, starboard, vertical, lateral, surge, sway, heave, \
                              roll, pitch, yaw; or any name of a-z, 0-9, _ that the vehicle's \
                              log carries)"
                        .into(),
                });
            }
            thrusters.push(ThrusterDef {
                name: n.clone(),
                group,
                geometry: geometry(&pf, &prefix)?,
                forward: curve(&pf, &prefix, &kind, "forward")?,
                reverse: curve(&pf, &prefix, &kind, "reverse")?,
                lag_s: pf.f64_or(&format!("{prefix}.lag_s"), 0.0..=5.0, 0.0)?,
                mix,
            });
        }
        pf.reject_unknown("")?;
        let process = ProcessParams {
            rigid_body: RigidBody {
                mass_kg,
                inertia_cg_kgm2: RigidBody::inertia_tensor(ix, iy, iz, ixy, ixz, iyz),
                cg_from_co_m: cg,
            },
            added_mass: Matrix6::from_diagonal(&added),
            damping: Damping::diagonal(lin, quad),
            hydrostatics: Hydrostatics {
                weight_n: mass_kg * g,
                buoyancy_n: rho * g * volume_m3,
                cg_from_co_m: cg,
                cb_from_co_m: cb,
            },
            munk,
        };
        let def = Self {
            name,
            description,
            structure,
            process,
            volume_m3,
            water_density_kgpm3: rho,
            gravity_mps2: g,
            thrusters,
            saturation,
            command_gain,
            uncertainty,
            channel_table,
            hull_size_m,
        };
        VehicleDynamics::new(&def).map_err(|e| ConfigError::Inconsistent {
            file: label.to_string(),
            message: e.to_string(),
        })?;
        Ok(def)
    }

    /// The command channels some thruster mixes (index order).
    pub fn channels(&self) -> Vec<CommandChannel> {
        self.channel_table
            .all()
            .into_iter()
            .filter(|c| self.thrusters.iter().any(|t| t.mix[c.index()] != 0.0))
            .collect()
    }

    /// The thruster groups present (index order).
    pub fn groups(&self) -> Vec<ThrusterGroup> {
        ThrusterGroup::ALL
            .iter()
            .copied()
            .filter(|g| self.thrusters.iter().any(|t| t.group == *g))
            .collect()
    }

    /// Thruster commands (−1..1) for command values in percent: the mix, saturated.
    #[inline]
    pub fn thruster_commands(&self, cmd: &Commands) -> [f64; MAX_THRUSTERS] {
        let mut u = [0.0; MAX_THRUSTERS];
        let mut largest: f64 = 0.0;
        for (ui, t) in u.iter_mut().zip(&self.thrusters) {
            let mut s = 0.0;
            for (m, c) in t.mix.iter().zip(cmd) {
                if *m != 0.0 && c.is_finite() {
                    s += m * c * 0.01;
                }
            }
            s *= self.command_gain;
            *ui = s;
            largest = largest.max(s.abs());
        }
        match self.saturation {
            Saturation::Clamp => {
                for x in &mut u {
                    *x = x.clamp(-1.0, 1.0);
                }
            }
            Saturation::Scale if largest > 1.0 => {
                for x in &mut u {
                    *x /= largest;
                }
            }
            Saturation::Scale => {}
        }
        u
    }

    /// Force of thruster `i` at command `u` (−1..1) along its direction, N.
    #[inline]
    pub fn thrust_n(&self, i: usize, u: f64) -> f64 {
        let Some(t) = self.thrusters.get(i) else {
            return 0.0;
        };
        if u >= 0.0 {
            t.forward.force_n(u)
        } else {
            -t.reverse.force_n(-u)
        }
    }
}

/// A vehicle definition ready to simulate: the process model, the thrusters' τ columns and
/// the reduced mass matrix of a locked structure.
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleDynamics {
    process: ProcessModel,
    /// τ per newton of each thruster ([d; r × d]).
    columns: [Vector6; MAX_THRUSTERS],
    /// Active degrees of freedom.
    active: [bool; 6],
    /// M_aa⁻¹ embedded in 6×6 (zeros in locked rows and columns), when some DOF is locked.
    reduced_inv: Option<Matrix6>,
}

impl VehicleDynamics {
    /// Precomputes the dynamics (fails if M or its reduced block is not positive definite).
    pub fn new(def: &VehicleDef) -> Result<Self, DynamicsError> {
        Self::with_process(def, def.process)
    }

    /// As [`VehicleDynamics::new`] with other process parameters (calibrated values).
    pub fn with_process(def: &VehicleDef, params: ProcessParams) -> Result<Self, DynamicsError> {
        let process = ProcessModel::new(params)?;
        let mut columns = [Vector6::zeros(); MAX_THRUSTERS];
        for (c, t) in columns.iter_mut().zip(&def.thrusters) {
            *c = t.geometry.tau(1.0);
        }
        let active = def.structure.active();
        let reduced_inv = if active.iter().all(|a| *a) {
            None
        } else {
            let idx: Vec<usize> = (0..6).filter(|i| active[*i]).collect();
            let m = process.mass_matrix();
            let k = idx.len();
            let sub = nalgebra::DMatrix::from_fn(k, k, |r, c| m[(idx[r], idx[c])]);
            let inv = sub
                .cholesky()
                .ok_or_else(|| DynamicsError::InvalidParameter {
                    what: "reduced mass matrix".into(),
                    detail: "not positive definite".into(),
                })?
                .inverse();
            let mut full = Matrix6::zeros();
            for (r, &i) in idx.iter().enumerate() {
                for (c, &j) in idx.iter().enumerate() {
                    full[(i, j)] = inv[(r, c)];
                }
            }
            Some(full)
        };
        Ok(Self {
            process,
            columns,
            active,
            reduced_inv,
        })
    }

    /// The process plant model.
    pub fn process(&self) -> &ProcessModel {
        &self.process
    }

    /// Active degrees of freedom (u, v, w, p, q, r).
    pub fn active(&self) -> [bool; 6] {
        self.active
    }

    /// τ of per-thruster forces (N).
    #[inline]
    pub fn tau(&self, forces_n: &[f64; MAX_THRUSTERS]) -> Vector6 {
        let mut tau = Vector6::zeros();
        for (c, f) in self.columns.iter().zip(forces_n) {
            if *f != 0.0 {
                tau += c * *f;
            }
        }
        tau
    }

    /// τ per newton of thruster `i`.
    pub fn column(&self, i: usize) -> Vector6 {
        self.columns.get(i).copied().unwrap_or_else(Vector6::zeros)
    }

    /// (η̇, ν̇) for ZYX Euler angles, with locked degrees of freedom held still.
    #[inline]
    pub fn state_derivative(
        &self,
        eta: &Vector6,
        nu: &Vector6,
        tau: &Vector6,
        current: &CurrentSample,
    ) -> (Vector6, Vector6) {
        let Some(inv) = &self.reduced_inv else {
            return self.process.state_derivative(eta, nu, tau, current);
        };
        let mut nu_a = *nu;
        for (i, a) in self.active.iter().enumerate() {
            if !a {
                nu_a[i] = 0.0;
            }
        }
        let (mut eta_dot, nu_dot_full) = self.process.state_derivative(eta, &nu_a, tau, current);
        // The full solution is ν̇ = ν̇_c + M⁻¹ f; recover f and solve the reduced system.
        let att = crate::kinematics::Attitude::from_eta(eta);
        let r: Matrix3<f64> = att.ned_from_body();
        let vc = r.transpose() * current.vel_ned_mps;
        let omega = Vector3::new(nu_a[3], nu_a[4], nu_a[5]);
        let vc_dot = vc.cross(&omega);
        let vc6 = stack(&vc_dot, &Vector3::zeros());
        let f = self.process.mass_matrix() * (nu_dot_full - vc6);
        let mut nu_dot = inv * f;
        for i in 0..3 {
            if self.active[i] {
                nu_dot[i] += vc6[i];
            }
        }
        for (i, a) in self.active.iter().enumerate().skip(3) {
            if !a {
                eta_dot[i] = 0.0;
            }
        }
        (eta_dot, nu_dot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL: &str = r#"
vehicle = "test"
structure = "fossen6"
[rigid_body]
mass_kg = { value = 10.0, unit = "kg", source = "test" }
inertia_cg_kgm2 = { value = [0.2, 0.2, 0.3], unit = "kg m^2", source = "test" }
products_of_inertia_kgm2 = { value = [0.0, 0.0, 0.0], unit = "kg m^2", source = "test" }
cg_from_co_m = { value = [0.0, 0.0, 0.01], unit = "m", source = "test" }
[hydrostatics]
volume_m3 = { value = 0.01, unit = "m^3", source = "test" }
water_density_kgpm3 = { value = 1000.0, unit = "kg/m^3", source = "test" }
gravity_mps2 = { value = 9.81, unit = "m/s^2", source = "test" }
cb_from_co_m = { value = [0.0, 0.0, 0.0], unit = "m", source = "test" }
[added_mass]
diagonal = { value = [5.0, 5.0, 10.0, 0.1, 0.1, 0.1], unit = "kg, kg m^2", source = "test" }
[damping]
linear = { value = [10.0, 10.0, 20.0, 0.5, 0.5, 0.5], unit = "N s/m, N m s", source = "test" }
quadratic = { value = [100.0, 100.0, 150.0, 1.0, 1.0, 1.0], unit = "N s^2/m^2, N m s^2", source = "test" }
[thrusters.left]
group = "horizontal"
curve = "quadratic"
position_m = { value = [-0.2, -0.1, 0.0], unit = "m", source = "test" }
direction = { value = [1.0, 0.0, 0.0], unit = "-", source = "test" }
forward_linear_n = { value = 2.0, unit = "N", source = "test" }
forward_quadratic_n = { value = 18.0, unit = "N", source = "test" }
reverse_linear_n = { value = 1.0, unit = "N", source = "test" }
reverse_quadratic_n = { value = 9.0, unit = "N", source = "test" }
mix_surge = { value = 1.0, unit = "-", source = "test" }
mix_yaw = { value = 1.0, unit = "-", source = "test" }
[thrusters.right]
group = "horizontal"
curve = "table"
position_m = { value = [-0.2, 0.1, 0.0], unit = "m", source = "test" }
direction = { value = [1.0, 0.0, 0.0], unit = "-", source = "test" }
forward_table_n = { value = [0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20], unit = "N", source = "test" }
reverse_table_n = { value = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10], unit = "N", source = "test" }
mix_surge = { value = 1.0, unit = "-", source = "test" }
mix_yaw = { value = -1.0, unit = "-", source = "test" }
"#;

    #[test]
    fn parses_mixes_and_applies_curves_by_direction() {
        let d = VehicleDef::parse(SMALL, "small.toml").unwrap();
        assert_eq!(d.thrusters.len(), 2);
        assert_eq!(
            d.channels(),
            vec![CommandChannel::SURGE, CommandChannel::YAW]
        );
        let mut cmd = [0.0; N_COMMANDS];
        cmd[CommandChannel::SURGE.index()] = 50.0;
        cmd[CommandChannel::YAW.index()] = 80.0;
        let u = d.thruster_commands(&cmd);
        // left: 0.5 + 0.8 = 1.3 → clamped to 1; right: 0.5 − 0.8 = −0.3.
        assert!(
            (u[0] - 1.0).abs() < 1e-12 && (u[1] + 0.3).abs() < 1e-12,
            "{u:?}"
        );
        assert!((d.thrust_n(0, 1.0) - 20.0).abs() < 1e-12);
        assert!((d.thrust_n(0, -0.5) + (0.5 + 9.0 * 0.25)).abs() < 1e-12);
        assert!((d.thrust_n(1, 0.35) - 7.0).abs() < 1e-12);
        assert!((d.thrust_n(1, -0.3) + 3.0).abs() < 1e-12);
        // Equal thrust ahead on both sides: pure surge, no yaw.
        let dynm = VehicleDynamics::new(&d).unwrap();
        let mut f = [0.0; MAX_THRUSTERS];
        f[0] = 5.0;
        f[1] = 5.0;
        let tau = dynm.tau(&f);
        assert!((tau[0] - 10.0).abs() < 1e-12 && tau[5].abs() < 1e-12);
    }

    #[test]
    fn bad_files_name_the_key() {
        let e = VehicleDef::parse(
            &SMALL.replace(
                "group = \"horizontal\"\ncurve = \"table\"",
                "group = \"sideways\"\ncurve = \"table\"",
            ),
            "x.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("thrusters.right.group") && e.contains("horizontal"),
            "{e}"
        );
        let e = VehicleDef::parse(
            &SMALL.replace(
                "[0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20]",
                "[0, 2, 4, 6, 8, 10, 12, 11, 16, 18, 20]",
            ),
            "x.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("forward_table_n"), "{e}");
        let e = VehicleDef::parse(
            &SMALL.replace("mix_yaw = { value = -1.0", "mix_Yaw-2 = { value = -1.0"),
            "x.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("mix_Yaw-2") && e.contains("a-z"), "{e}");
        let seven: String = (1..=9)
            .map(|k| format!("mix_thr{k} = {{ value = 1.0, unit = \"-\", source = \"test\" }}\n"))
            .collect();
        let e = VehicleDef::parse(
            &SMALL.replace(
                "[thrusters.right]\n",
                &format!("[thrusters.right]\n{seven}"),
            ),
            "x.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("mix_thr9") && e.contains("at most 8"), "{e}");
    }

    #[test]
    fn free_channel_names_drive_thrusters_directly() {
        // The right thruster driven from its own channel `thr_b`, the left from `thr_a`
        // and the built-in surge demand together.
        let text = SMALL
            .replace(
                "mix_surge = { value = 1.0, unit = \"-\", source = \"test\" }\nmix_yaw = { value = 1.0",
                "mix_thr_a = { value = 1.0, unit = \"-\", source = \"test\" }\nmix_surge = { value = 0.5",
            )
            .replace(
                "mix_surge = { value = 1.0, unit = \"-\", source = \"test\" }\nmix_yaw = { value = -1.0",
                "mix_thr_b = { value = -1.0",
            );
        let d = VehicleDef::parse(&text, "free.toml").unwrap();
        let t = &d.channel_table;
        let (a, b) = (t.index_of("thr_a").unwrap(), t.index_of("thr_b").unwrap());
        assert_eq!((a.index(), b.index()), (N_BUILTIN, N_BUILTIN + 1));
        assert_eq!(t.name(b), Some("thr_b"));
        assert_eq!(d.channels(), vec![CommandChannel::SURGE, a, b]);
        let mut cmd = [0.0; N_COMMANDS];
        cmd[a.index()] = 40.0;
        cmd[CommandChannel::SURGE.index()] = 20.0;
        cmd[b.index()] = 30.0;
        let u = d.thruster_commands(&cmd);
        assert!(
            (u[0] - 0.5).abs() < 1e-12 && (u[1] + 0.3).abs() < 1e-12,
            "{u:?}"
        );
        // A run that names the channels in another order is re-indexed by name.
        let run_table = ChannelTable::from_names(["thr_b", "extra", "thr_a"]).unwrap();
        let map = t.remap_from(&run_table);
        assert_eq!(map[a.index()], Some(N_BUILTIN + 2));
        assert_eq!(map[b.index()], Some(N_BUILTIN));
        assert_eq!(
            map[CommandChannel::YAW.index()],
            Some(CommandChannel::YAW.index())
        );
        assert_eq!(map[N_BUILTIN + 2], None);
    }

    #[test]
    fn a_locked_structure_keeps_its_locked_dofs_still() {
        let text = SMALL
            .replace("fossen6", "fossen4")
            .replace("[0.0, 0.0, 0.01]", "[0.0, 0.0, 0.0]");
        let d = VehicleDef::parse(&text, "s4.toml").unwrap();
        let dynm = VehicleDynamics::new(&d).unwrap();
        let eta = Vector6::new(0.0, 0.0, 2.0, 0.0, 0.0, 0.3);
        let nu = Vector6::new(0.5, 0.1, 0.0, 0.0, 0.0, 0.2);
        let tau = Vector6::new(5.0, 1.0, 2.0, 0.3, 0.4, 0.1);
        let (ed, nd) = dynm.state_derivative(&eta, &nu, &tau, &CurrentSample::none());
        assert_eq!(nd[3], 0.0);
        assert_eq!(nd[4], 0.0);
        assert_eq!(ed[3], 0.0);
        assert_eq!(ed[4], 0.0);
        // With a diagonal M the locked system is just the active rows.
        let (_, full) = ProcessModel::new(d.process).unwrap().state_derivative(
            &eta,
            &nu,
            &tau,
            &CurrentSample::none(),
        );
        assert!((nd[0] - full[0]).abs() < 1e-9, "{} {}", nd[0], full[0]);
    }
}
