//! The gamepad map: which pad axis drives surge, yaw and vertical, and which button
//! does what, with a shift layer (hold the shift button for the second function of a
//! button, as ArduSub's BTNn_SFUNCTION). Read from `[gamepad]` of the station
//! configuration (located errors like every table there), edited on the Gamepad page,
//! and applied in the runtime: the gamepad thread only reports raw axes and buttons
//! ([`PadState`]); the control tick maps them (so a virtual pad in tests takes exactly
//! the same path).

use rov_types::params::{ConfigError, ParamFile};
use serde::Serialize;

/// What a button can do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum Action {
    /// Arm (hold about 1 s).
    Arm,
    /// Disarm (one press).
    Disarm,
    /// Depth hold on/off.
    DepthHold,
    /// Heading hold on/off.
    HeadingHold,
    /// Thrust gain one step up.
    GainUp,
    /// Thrust gain one step down.
    GainDown,
    /// Lights +10 %.
    LightsUp,
    /// Lights −10 %.
    LightsDown,
    /// Camera tilt +10°.
    TiltUp,
    /// Camera tilt −10°.
    TiltDown,
    /// Camera tilt to 0°.
    TiltCentre,
    /// Start or stop recording.
    Record,
    /// A marker in the dive log.
    Marker,
    /// Acknowledge every alarm.
    AckAlarms,
    /// Zero the tether turns counter.
    ResetTurns,
}

impl Action {
    /// Every action.
    pub const ALL: [Action; 15] = [
        Action::Arm,
        Action::Disarm,
        Action::DepthHold,
        Action::HeadingHold,
        Action::GainUp,
        Action::GainDown,
        Action::LightsUp,
        Action::LightsDown,
        Action::TiltUp,
        Action::TiltDown,
        Action::TiltCentre,
        Action::Record,
        Action::Marker,
        Action::AckAlarms,
        Action::ResetTurns,
    ];

    /// Name in the configuration file.
    #[must_use]
    pub const fn key(self) -> &'static str {
        match self {
            Action::Arm => "arm",
            Action::Disarm => "disarm",
            Action::DepthHold => "depth_hold",
            Action::HeadingHold => "heading_hold",
            Action::GainUp => "gain_up",
            Action::GainDown => "gain_down",
            Action::LightsUp => "lights_up",
            Action::LightsDown => "lights_down",
            Action::TiltUp => "tilt_up",
            Action::TiltDown => "tilt_down",
            Action::TiltCentre => "tilt_centre",
            Action::Record => "record",
            Action::Marker => "marker",
            Action::AckAlarms => "ack_alarms",
            Action::ResetTurns => "reset_turns",
        }
    }

    /// Text for the pilot.
    #[must_use]
    pub const fn text(self) -> &'static str {
        match self {
            Action::Arm => "arm (hold 1 s)",
            Action::Disarm => "disarm",
            Action::DepthHold => "depth hold on/off",
            Action::HeadingHold => "heading hold on/off",
            Action::GainUp => "gain up",
            Action::GainDown => "gain down",
            Action::LightsUp => "lights +10 %",
            Action::LightsDown => "lights -10 %",
            Action::TiltUp => "camera tilt up 10°",
            Action::TiltDown => "camera tilt down 10°",
            Action::TiltCentre => "camera tilt 0°",
            Action::Record => "record on/off",
            Action::Marker => "dive-log marker",
            Action::AckAlarms => "acknowledge alarms",
            Action::ResetTurns => "reset tether turns",
        }
    }

    fn from_key(k: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|a| a.key() == k)
    }
}

/// A pad button (standard layout, as gilrs names them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
pub enum PadButton {
    /// A / cross.
    South,
    /// B / circle.
    East,
    /// Y / triangle.
    North,
    /// X / square.
    West,
    /// Left bumper.
    LeftBumper,
    /// Right bumper.
    RightBumper,
    /// Left trigger (as a button).
    LeftTrigger,
    /// Right trigger (as a button).
    RightTrigger,
    /// Select / back.
    Select,
    /// Start.
    Start,
    /// Left stick press.
    LeftThumb,
    /// Right stick press.
    RightThumb,
    /// D-pad up.
    DPadUp,
    /// D-pad down.
    DPadDown,
    /// D-pad left.
    DPadLeft,
    /// D-pad right.
    DPadRight,
}

impl PadButton {
    /// Every button.
    pub const ALL: [PadButton; 16] = [
        PadButton::South,
        PadButton::East,
        PadButton::North,
        PadButton::West,
        PadButton::LeftBumper,
        PadButton::RightBumper,
        PadButton::LeftTrigger,
        PadButton::RightTrigger,
        PadButton::Select,
        PadButton::Start,
        PadButton::LeftThumb,
        PadButton::RightThumb,
        PadButton::DPadUp,
        PadButton::DPadDown,
        PadButton::DPadLeft,
        PadButton::DPadRight,
    ];

    /// Name in the configuration file and on the page.
    #[must_use]
    pub const fn key(self) -> &'static str {
        match self {
            PadButton::South => "south",
            PadButton::East => "east",
            PadButton::North => "north",
            PadButton::West => "west",
            PadButton::LeftBumper => "left_bumper",
            PadButton::RightBumper => "right_bumper",
            PadButton::LeftTrigger => "left_trigger",
            PadButton::RightTrigger => "right_trigger",
            PadButton::Select => "select",
            PadButton::Start => "start",
            PadButton::LeftThumb => "left_thumb",
            PadButton::RightThumb => "right_thumb",
            PadButton::DPadUp => "dpad_up",
            PadButton::DPadDown => "dpad_down",
            PadButton::DPadLeft => "dpad_left",
            PadButton::DPadRight => "dpad_right",
        }
    }

    fn from_key(k: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|b| b.key() == k)
    }

    /// The button's index in [`PadButton::ALL`] (bit in [`PadState::buttons`]).
    #[must_use]
    pub fn bit(self) -> u32 {
        Self::ALL
            .iter()
            .position(|b| *b == self)
            .map_or(0, |i| 1 << i)
    }
}

/// A pad axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum PadAxis {
    /// Left stick, right positive.
    LeftX,
    /// Left stick, up positive.
    LeftY,
    /// Right stick, right positive.
    RightX,
    /// Right stick, up positive.
    RightY,
    /// Left analogue trigger.
    LeftZ,
    /// Right analogue trigger.
    RightZ,
}

impl PadAxis {
    /// Every axis, in [`PadState::axes`] order.
    pub const ALL: [PadAxis; 6] = [
        PadAxis::LeftX,
        PadAxis::LeftY,
        PadAxis::RightX,
        PadAxis::RightY,
        PadAxis::LeftZ,
        PadAxis::RightZ,
    ];

    /// Name in the configuration file.
    #[must_use]
    pub const fn key(self) -> &'static str {
        match self {
            PadAxis::LeftX => "left_x",
            PadAxis::LeftY => "left_y",
            PadAxis::RightX => "right_x",
            PadAxis::RightY => "right_y",
            PadAxis::LeftZ => "left_z",
            PadAxis::RightZ => "right_z",
        }
    }

    fn index(self) -> usize {
        Self::ALL.iter().position(|a| *a == self).unwrap_or(0)
    }
}

/// What a pad reports (raw, before any mapping).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct PadState {
    /// Axes in [`PadAxis::ALL`] order, −1..1.
    pub axes: [f64; 6],
    /// Buttons held, one bit per [`PadButton::ALL`] entry.
    pub buttons: u32,
}

impl PadState {
    /// Whether a button is held.
    #[must_use]
    pub fn held(&self, b: PadButton) -> bool {
        self.buttons & b.bit() != 0
    }

    /// An axis value.
    #[must_use]
    pub fn axis(&self, a: PadAxis) -> f64 {
        self.axes.get(a.index()).copied().unwrap_or(0.0)
    }
}

/// The map; see the module docs.
#[derive(Debug, PartialEq, Serialize)]
pub struct PadMap {
    /// Axis for surge (forward positive).
    pub surge: PadAxis,
    /// Axis for yaw (turn right positive).
    pub yaw: PadAxis,
    /// Axis for vertical (stick up = rise: the runtime negates it, positive dives).
    pub vertical: PadAxis,
    /// Held for the second function of the buttons (None: no shift layer).
    pub shift: Option<PadButton>,
    /// Button functions.
    pub buttons: Vec<(PadButton, Action)>,
    /// Button functions while shift is held.
    pub shifted: Vec<(PadButton, Action)>,
}

impl Default for PadMap {
    /// Left stick surge/yaw, right stick vertical; Start held = arm, Select = disarm,
    /// Y/X = depth/heading hold, bumpers = gain, d-pad = tilt and lights, B = ack,
    /// A = marker; with the left trigger held: Y = record, X = reset turns, d-pad up/down
    /// = tilt 0°, A = marker too.
    fn default() -> Self {
        use Action as A;
        use PadButton as B;
        let mut m = Self {
            surge: PadAxis::LeftY,
            yaw: PadAxis::LeftX,
            vertical: PadAxis::RightY,
            shift: Some(B::LeftTrigger),
            buttons: vec![
                (B::Start, A::Arm),
                (B::Select, A::Disarm),
                (B::North, A::DepthHold),
                (B::West, A::HeadingHold),
                (B::RightBumper, A::GainUp),
                (B::LeftBumper, A::GainDown),
                (B::DPadUp, A::TiltUp),
                (B::DPadDown, A::TiltDown),
                (B::DPadRight, A::LightsUp),
                (B::DPadLeft, A::LightsDown),
                (B::East, A::AckAlarms),
                (B::South, A::Marker),
            ],
            shifted: vec![
                (B::North, A::Record),
                (B::West, A::ResetTurns),
                (B::DPadUp, A::TiltCentre),
                (B::DPadDown, A::TiltCentre),
                (B::Select, A::Disarm),
                (B::South, A::Marker),
            ],
        };
        // In button order, as the file is read.
        m.buttons.sort_by_key(|(b, _)| *b);
        m.shifted.sort_by_key(|(b, _)| *b);
        m
    }
}

fn axis_choice(f: &ParamFile, key: &str, default: PadAxis) -> Result<PadAxis, ConfigError> {
    let names: Vec<&str> = PadAxis::ALL.iter().map(|a| a.key()).collect();
    let s = f.choice(key, &names, Some(default.key()))?;
    Ok(PadAxis::ALL
        .into_iter()
        .find(|a| a.key() == s)
        .unwrap_or(default))
}

impl PadMap {
    /// The function of `b` with shift held or not (None: nothing). The shift button
    /// itself does nothing else.
    #[must_use]
    pub fn action(&self, b: PadButton, shift: bool) -> Option<Action> {
        if Some(b) == self.shift {
            return None;
        }
        let list = if shift { &self.shifted } else { &self.buttons };
        list.iter().find(|(x, _)| *x == b).map(|(_, a)| *a)
    }

    /// Reads `[gamepad]` (axes, shift button), `[gamepad.buttons]` and
    /// `[gamepad.shift_buttons]` (button name = action name); absent tables keep the
    /// defaults. Errors name the file, the key, the value and the allowed names.
    ///
    /// # Errors
    /// [`ConfigError`] as above.
    pub fn from_param_file(f: &ParamFile) -> Result<Self, ConfigError> {
        let d = Self::default();
        let mut m = Self {
            surge: axis_choice(f, "gamepad.surge_axis", d.surge)?,
            yaw: axis_choice(f, "gamepad.yaw_axis", d.yaw)?,
            vertical: axis_choice(f, "gamepad.vertical_axis", d.vertical)?,
            ..d.clone()
        };
        let mut button_names: Vec<&str> = PadButton::ALL.iter().map(|b| b.key()).collect();
        button_names.push("none");
        let shift = f.choice(
            "gamepad.shift",
            &button_names,
            Some(d.shift.map_or("none", PadButton::key)),
        )?;
        m.shift = PadButton::from_key(&shift);
        let action_names: Vec<&str> = Action::ALL.iter().map(|a| a.key()).collect();
        for (table, list, default) in [
            ("buttons", &mut m.buttons, &d.buttons),
            ("shift_buttons", &mut m.shifted, &d.shifted),
        ] {
            if !f.has(&format!("gamepad.{table}")) {
                list.clone_from(default);
                continue;
            }
            list.clear();
            for b in PadButton::ALL {
                let key = format!("gamepad.{table}.{}", b.key());
                if f.has(&key) {
                    let a = f.choice(&key, &action_names, None)?;
                    if let Some(a) = Action::from_key(&a) {
                        list.push((b, a));
                    }
                }
            }
        }
        Ok(m)
    }

    /// The map as TOML tables (what [`PadMap::from_param_file`] reads), without the
    /// `[gamepad]` header line: the caller places it.
    #[must_use]
    pub fn to_toml(&self) -> (String, String, String) {
        let head = format!(
            "surge_axis = \"{}\"\nyaw_axis = \"{}\"\nvertical_axis = \"{}\"\nshift = \"{}\"\n",
            self.surge.key(),
            self.yaw.key(),
            self.vertical.key(),
            self.shift.map_or("none", PadButton::key)
        );
        let list = |l: &[(PadButton, Action)]| {
            l.iter()
                .map(|(b, a)| format!("{} = \"{}\"\n", b.key(), a.key()))
                .collect::<String>()
        };
        (head, list(&self.buttons), list(&self.shifted))
    }
}

crate::clone_fields!(PadMap {
    surge,
    yaw,
    vertical,
    shift,
    buttons,
    shifted
});

/// Gamepad state shared with the gamepad thread: the raw pad only (the control tick
/// maps it, see [`pad`]).
#[derive(Debug, Clone, Default)]
pub struct PadSlot {
    /// Raw axes and buttons (zero unless `live`).
    pub state: PadState,
    /// Raw axes and buttons as reported, also before the centre rule (setup page).
    pub raw: PadState,
    /// Last poll of the gamepad thread, µs of the runtime clock.
    pub heartbeat_us: u64,
    /// Sticks usable (connected, passed through centre since connecting).
    pub live: bool,
    /// Status for the GUI.
    pub status: crate::pilot::view::PadStatus,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_reads_writes_and_names_bad_values() {
        let text = "[gamepad]\nshift = \"right_trigger\"\nsurge_axis = \"right_y\"\n[gamepad.buttons]\nsouth = \"record\"\n";
        let f = ParamFile::parse(text, "config/station.toml", false).unwrap();
        let m = PadMap::from_param_file(&f).unwrap();
        assert_eq!(m.shift, Some(PadButton::RightTrigger));
        assert_eq!(m.surge, PadAxis::RightY);
        assert_eq!(m.buttons, vec![(PadButton::South, Action::Record)]);
        assert_eq!(
            m.shifted,
            PadMap::default().shifted,
            "absent table: defaults"
        );
        assert_eq!(m.action(PadButton::South, false), Some(Action::Record));
        assert_eq!(
            m.action(PadButton::RightTrigger, false),
            None,
            "shift itself"
        );
        // Round trip.
        let (h, b, s) = m.to_toml();
        let text = format!("[gamepad]\n{h}[gamepad.buttons]\n{b}[gamepad.shift_buttons]\n{s}");
        let g = ParamFile::parse(&text, "x", false).unwrap();
        assert_eq!(PadMap::from_param_file(&g).unwrap(), m);
        // Bad values: file, key, value, allowed names.
        let bad = "[gamepad.buttons]\nnorth = \"launch\"\n";
        let f = ParamFile::parse(bad, "config/station.toml", false).unwrap();
        let e = PadMap::from_param_file(&f).unwrap_err().to_string();
        assert!(
            e.contains("config/station.toml")
                && e.contains("gamepad.buttons.north")
                && e.contains("launch")
                && e.contains("depth_hold"),
            "{e}"
        );
        let bad = "[gamepad]\nsurge_axis = \"wheel\"\n";
        let f = ParamFile::parse(bad, "s.toml", false).unwrap();
        let e = PadMap::from_param_file(&f).unwrap_err().to_string();
        assert!(
            e.contains("gamepad.surge_axis") && e.contains("left_y"),
            "{e}"
        );
    }
}
