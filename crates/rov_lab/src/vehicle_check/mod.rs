//! `vehicle check`: what a vehicle file says, in numbers an engineer can check against the
//! vehicle before any calibration, and every implausible thing in it.
//!
//! * Statics: mass, displacement, net weight (W − B, positive sinks), CG and CB, and the
//!   static trim: the roll and pitch at which the restoring moment vanishes (Fossen's
//!   g(η) with φ, θ solving g₄ = g₅ = 0: tan φ = (y_g W − y_b B)/(z_g W − z_b B),
//!   tan θ = −(x_g W − x_b B)/(z_g W − z_b B)).
//! * The mixing matrix: each command channel at +100 % and −100 % alone (others 0),
//!   through the file's mix, gain, saturation and thrust curves, as body force and moment
//!   τ = (X, Y, Z, K, M, N); the degree of freedom it moves most (its share of the
//!   largest τ the whole vehicle can produce on that axis) and with which sign.
//! * The largest force and moment per axis and direction the mixing can produce (searched
//!   over every channel at −100, 0 and +100 % for up to 8 channels, each channel alone
//!   beyond).
//! * Issues: a thruster that moves no degree of freedom, the CG (or a thruster) outside
//!   the hull's box (`[hull] size_m`, else the thrusters' bounding box), a body-axis demand
//!   channel that does not produce its axis or produces it with the wrong sign, CG not
//!   below CB (no static stability), a net weight no vertical thrust can hold.
//!
//! With a log, [`sign`] adds the sign and response check per channel.

pub mod sign;

use rov_dynamics::models::vehicle::{CommandChannel, N_COMMANDS, VehicleDef, VehicleDynamics};
use serde::Serialize;

use crate::LabError;

/// Names of the six degrees of freedom (τ and ν order).
pub use crate::terms::DOF_NAMES;

/// A channel's share of an axis below which the file is taken to say it does not move that
/// axis.
pub const SHARE_NEGLIGIBLE: f64 = 0.1;

/// One row of the mixing matrix.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MixRow {
    /// Command channel name.
    pub channel: String,
    /// τ at +100 % (X, Y, Z in N; K, M, N in N·m).
    pub tau_plus_100: [f64; 6],
    /// τ at −100 %.
    pub tau_minus_100: [f64; 6],
    /// |τ at +100 %| over the largest τ of that axis (0..1), per degree of freedom.
    pub share: [f64; 6],
    /// The degree of freedom the channel moves most (a body-axis demand: its own axis).
    pub expected_dof: String,
    /// The sign of τ on it at +100 % (+1, −1).
    pub expected_sign: i8,
    /// The thrusters it drives, with their mix factors.
    pub thrusters: Vec<(String, f64)>,
}

/// The largest force and moment per axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisLimit {
    /// Degree of freedom.
    pub dof: String,
    /// Unit ("N" or "N m").
    pub unit: &'static str,
    /// Largest positive value.
    pub max_positive: f64,
    /// Largest negative value (≤ 0).
    pub max_negative: f64,
}

/// An implausible thing in the file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Issue {
    /// Short kind (`thruster-moves-nothing`, `cg-outside-hull`, ...).
    pub kind: String,
    /// What and where, in words.
    pub message: String,
}

/// Statics of the file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Statics {
    /// Mass in air, kg.
    pub mass_kg: f64,
    /// Displaced volume, m³.
    pub volume_m3: f64,
    /// Displaced water mass ρV, kg.
    pub displacement_kg: f64,
    /// Weight, N.
    pub weight_n: f64,
    /// Buoyancy, N.
    pub buoyancy_n: f64,
    /// W − B, N (positive: the vehicle sinks).
    pub net_weight_n: f64,
    /// CG from the CO, m.
    pub cg_m: [f64; 3],
    /// CB from the CO, m.
    pub cb_m: [f64; 3],
    /// z_g W − z_b B, N·m: the restoring moment per radian of small roll or pitch (> 0:
    /// statically stable).
    pub righting_nm_per_rad: f64,
    /// Static trim: roll where the restoring moment vanishes, deg.
    pub trim_roll_deg: f64,
    /// Static trim: pitch, deg.
    pub trim_pitch_deg: f64,
    /// The hull box the CG is checked against: (min, max) corners from the CO, m.
    pub hull_box_m: ([f64; 3], [f64; 3]),
    /// Where the box comes from (`[hull] size_m` or the thrusters' positions).
    pub hull_box_source: String,
}

/// The whole static report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VehicleReport {
    /// Vehicle name.
    pub vehicle: String,
    /// Degrees of freedom the file models.
    pub structure: String,
    /// Statics.
    pub statics: Statics,
    /// One row per command channel some thruster mixes.
    pub mixing: Vec<MixRow>,
    /// Largest force and moment per axis.
    pub limits: Vec<AxisLimit>,
    /// Implausible things.
    pub issues: Vec<Issue>,
}

/// τ for a command vector through the file's mix, saturation and curves.
fn tau_of(def: &VehicleDef, dynm: &VehicleDynamics, cmd: &[f64; N_COMMANDS]) -> [f64; 6] {
    let u = def.thruster_commands(cmd);
    let mut f = [0.0; rov_dynamics::models::vehicle::MAX_THRUSTERS];
    for (i, fi) in f.iter_mut().enumerate().take(def.thrusters.len()) {
        *fi = def.thrust_n(i, u[i]);
    }
    let t = dynm.tau(&f);
    [t[0], t[1], t[2], t[3], t[4], t[5]]
}

fn channel_name(def: &VehicleDef, c: CommandChannel) -> String {
    def.channel_table
        .name(c)
        .map(str::to_string)
        .unwrap_or_else(|| format!("channel{}", c.index()))
}

/// The built-in body-axis demand's axis (surge..yaw → 0..5), if `c` is one.
fn demand_axis(c: CommandChannel) -> Option<usize> {
    const AXES: [CommandChannel; 6] = [
        CommandChannel::SURGE,
        CommandChannel::SWAY,
        CommandChannel::HEAVE,
        CommandChannel::ROLL,
        CommandChannel::PITCH,
        CommandChannel::YAW,
    ];
    AXES.iter().position(|a| *a == c)
}

fn sign_of(x: f64) -> i8 {
    if x < 0.0 { -1 } else { 1 }
}

/// The largest τ per axis and direction: every channel at −100, 0, +100 % (up to 8
/// channels; each alone beyond).
fn axis_limits(
    def: &VehicleDef,
    dynm: &VehicleDynamics,
    chans: &[CommandChannel],
) -> ([f64; 6], [f64; 6]) {
    let mut pos = [0.0f64; 6];
    let mut neg = [0.0f64; 6];
    let mut visit = |cmd: &[f64; N_COMMANDS]| {
        let t = tau_of(def, dynm, cmd);
        for i in 0..6 {
            pos[i] = pos[i].max(t[i]);
            neg[i] = neg[i].min(t[i]);
        }
    };
    if chans.len() <= 8 {
        let combos = 3usize.pow(chans.len() as u32);
        for mut k in 0..combos {
            let mut cmd = [0.0; N_COMMANDS];
            for c in chans {
                if let Some(x) = cmd.get_mut(c.index()) {
                    *x = (k % 3) as f64 * 100.0 - 100.0;
                }
                k /= 3;
            }
            visit(&cmd);
        }
    } else {
        for c in chans {
            for v in [-100.0, 100.0] {
                let mut cmd = [0.0; N_COMMANDS];
                if let Some(x) = cmd.get_mut(c.index()) {
                    *x = v;
                }
                visit(&cmd);
            }
        }
    }
    (pos, neg)
}

/// The static report of a parsed vehicle file.
pub fn check_vehicle(def: &VehicleDef) -> Result<VehicleReport, LabError> {
    let dynm = VehicleDynamics::new(def).map_err(|e| LabError::Data {
        run: def.name.clone(),
        detail: e.to_string(),
    })?;
    let h = &def.process.hydrostatics;
    let (w, b) = (h.weight_n, h.buoyancy_n);
    let (cg, cb) = (h.cg_from_co_m, h.cb_from_co_m);
    let bz = cg[2] * w - cb[2] * b;
    let trim_roll_deg = (cg[1] * w - cb[1] * b).atan2(bz).to_degrees();
    let trim_pitch_deg = (-(cg[0] * w - cb[0] * b)).atan2(bz).to_degrees();
    let mut issues = Vec::new();

    // Hull box.
    let (hull_box_m, hull_box_source) = match def.hull_size_m {
        Some([l, wd, ht]) => (
            (
                [-l / 2.0, -wd / 2.0, -ht / 2.0],
                [l / 2.0, wd / 2.0, ht / 2.0],
            ),
            "[hull] size_m (a box centred on the CO)".to_string(),
        ),
        None => {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for t in &def.thrusters {
                let p = t.geometry.position_m();
                for i in 0..3 {
                    lo[i] = lo[i].min(p[i] - 0.02);
                    hi[i] = hi[i].max(p[i] + 0.02);
                }
            }
            (
                (lo, hi),
                "the thrusters' positions ± 2 cm (no [hull] size_m in the file)".to_string(),
            )
        }
    };
    let inside = |p: [f64; 3]| (0..3).all(|i| p[i] >= hull_box_m.0[i] && p[i] <= hull_box_m.1[i]);
    let cg_a = [cg[0], cg[1], cg[2]];
    if !inside(cg_a) {
        issues.push(Issue {
            kind: "cg-outside-hull".into(),
            message: format!(
                "CG at ({:.3}, {:.3}, {:.3}) m from the CO lies outside the hull box ({})",
                cg[0], cg[1], cg[2], hull_box_source
            ),
        });
    }
    if def.hull_size_m.is_some() {
        for t in &def.thrusters {
            let p = t.geometry.position_m();
            // A thruster may sit on the hull's edge: 5 cm of slack.
            let slack = |i: usize| p[i] < hull_box_m.0[i] - 0.05 || p[i] > hull_box_m.1[i] + 0.05;
            if (0..3).any(slack) {
                issues.push(Issue {
                    kind: "thruster-outside-hull".into(),
                    message: format!(
                        "thruster {} at ({:.3}, {:.3}, {:.3}) m lies outside the hull box",
                        t.name, p[0], p[1], p[2]
                    ),
                });
            }
        }
    }
    if bz <= 0.0 {
        issues.push(Issue {
            kind: "no-static-stability".into(),
            message: format!(
                "z_g W − z_b B = {bz:.3} N m: the CG is not below the CB, so roll and pitch have no restoring moment"
            ),
        });
    }
    for (i, t) in def.thrusters.iter().enumerate() {
        let col = dynm.column(i);
        let full = def.thrust_n(i, 1.0).abs().max(def.thrust_n(i, -1.0).abs());
        if col.norm() * full < 1e-9 {
            issues.push(Issue {
                kind: "thruster-moves-nothing".into(),
                message: format!(
                    "thruster {} produces no force or moment (zero thrust curve)",
                    t.name
                ),
            });
        }
    }

    let chans = def.channels();
    let (pos, neg) = axis_limits(def, &dynm, &chans);
    let axis_max: Vec<f64> = (0..6).map(|i| pos[i].max(-neg[i])).collect();
    let mut mixing = Vec::new();
    for c in &chans {
        let mut plus = [0.0; N_COMMANDS];
        let mut minus = [0.0; N_COMMANDS];
        if let (Some(p), Some(m)) = (plus.get_mut(c.index()), minus.get_mut(c.index())) {
            *p = 100.0;
            *m = -100.0;
        }
        let tp = tau_of(def, &dynm, &plus);
        let tm = tau_of(def, &dynm, &minus);
        let mut share = [0.0; 6];
        for i in 0..6 {
            share[i] = if axis_max[i] > 1e-9 {
                tp[i].abs() / axis_max[i]
            } else {
                0.0
            };
        }
        let name = channel_name(def, *c);
        // The DOF it moves most among those the structure models (ties: the first, so a
        // force wins over the moment it brings along).
        let active = def.structure.active();
        let mut best = 0;
        for i in 0..6 {
            if active[i] && (!active[best] || share[i] > share[best] + 1e-9) {
                best = i;
            }
        }
        let dof = demand_axis(*c).unwrap_or(best);
        if share.iter().all(|s| *s < 1e-9) {
            issues.push(Issue {
                kind: "channel-moves-nothing".into(),
                message: format!("command channel {name} moves no degree of freedom"),
            });
        } else if let Some(a) = demand_axis(*c) {
            if share[a] < SHARE_NEGLIGIBLE {
                issues.push(Issue {
                    kind: "demand-not-produced".into(),
                    message: format!(
                        "the {name} demand produces {:.2} of the vehicle's largest {} (it mostly moves {})",
                        share[a], DOF_NAMES[a], DOF_NAMES[best]
                    ),
                });
            } else if tp[a] < 0.0 {
                issues.push(Issue {
                    kind: "demand-wrong-sign".into(),
                    message: format!(
                        "a positive {name} demand pushes the vehicle in negative {} ({:.2})",
                        DOF_NAMES[a], tp[a]
                    ),
                });
            }
        }
        let thrusters = def
            .thrusters
            .iter()
            .filter_map(|t| {
                let m = t.mix.get(c.index()).copied().unwrap_or(0.0);
                (m != 0.0).then(|| (t.name.clone(), m))
            })
            .collect();
        mixing.push(MixRow {
            channel: name,
            tau_plus_100: tp,
            tau_minus_100: tm,
            share,
            expected_dof: DOF_NAMES[dof].to_string(),
            expected_sign: sign_of(tp[dof]),
            thrusters,
        });
    }
    if (w - b).abs() > pos[2].max(-neg[2]) && def.structure.active()[2] {
        issues.push(Issue {
            kind: "net-weight-exceeds-thrust".into(),
            message: format!(
                "net weight W − B = {:.1} N exceeds the largest vertical thrust {:.1} N",
                w - b,
                if w > b { -neg[2] } else { pos[2] }
            ),
        });
    }
    let limits = (0..6)
        .map(|i| AxisLimit {
            dof: DOF_NAMES[i].to_string(),
            unit: if i < 3 { "N" } else { "N m" },
            max_positive: pos[i],
            max_negative: neg[i],
        })
        .collect();
    Ok(VehicleReport {
        vehicle: def.name.clone(),
        structure: def.structure.name().to_string(),
        statics: Statics {
            mass_kg: def.process.rigid_body.mass_kg,
            volume_m3: def.volume_m3,
            displacement_kg: def.water_density_kgpm3 * def.volume_m3,
            weight_n: w,
            buoyancy_n: b,
            net_weight_n: w - b,
            cg_m: cg_a,
            cb_m: [cb[0], cb[1], cb[2]],
            righting_nm_per_rad: bz,
            trim_roll_deg,
            trim_pitch_deg,
            hull_box_m,
            hull_box_source,
        },
        mixing,
        limits,
        issues,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped(file: &str) -> VehicleDef {
        let p = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../config/vehicles")
            .join(file);
        let text = std::fs::read_to_string(&p).unwrap();
        VehicleDef::parse(&text, file).unwrap()
    }

    #[test]
    fn the_lateral_pro4s_mixing_matrix_is_its_thrusters_geometry() {
        let r = check_vehicle(&shipped("videoray_pro4_lateral.toml")).unwrap();
        assert!(r.issues.is_empty(), "{:?}", r.issues);
        let row = |n: &str| r.mixing.iter().find(|m| m.channel == n).unwrap().clone();
        // Port at +100 %: τ = [d; r × d] with r = (−0.13, −0.10, 0) m, d = (17, 0, 0) N:
        // N = r_x d_y − r_y d_x = 1.7 N m (port thrust turns the vehicle clockwise).
        let p = row("port");
        assert!(
            (p.tau_plus_100[0] - 17.0).abs() < 1e-9,
            "{:?}",
            p.tau_plus_100
        );
        assert!(
            (p.tau_plus_100[5] - 1.7).abs() < 1e-9,
            "{:?}",
            p.tau_plus_100
        );
        let s = row("starboard");
        assert!((s.tau_plus_100[5] + 1.7).abs() < 1e-9);
        let v = row("vertical");
        assert_eq!((v.expected_dof.as_str(), v.expected_sign), ("heave", 1));
        let l = row("lateral");
        assert_eq!((l.expected_dof.as_str(), l.expected_sign), ("sway", 1));
        // Lateral thrust 8 cm below the CO rolls the vehicle: K = −z·Y < 0 (port down).
        assert!(l.tau_plus_100[3] < 0.0);
        // Both horizontal thrusters together: 34 N of surge.
        let surge = &r.limits[0];
        assert!((surge.max_positive - 34.0).abs() < 1e-9, "{surge:?}");
        // CG 5.59 mm under the CB: stable, level trim.
        assert!(r.statics.righting_nm_per_rad > 0.0);
        assert!(r.statics.trim_pitch_deg.abs() < 1e-9);
    }

    #[test]
    fn the_heavys_demands_produce_their_axes_with_the_right_sign() {
        let r = check_vehicle(&shipped("bluerov2_heavy.toml")).unwrap();
        assert!(r.issues.is_empty(), "{:?}", r.issues);
        for (row, dof) in r.mixing.iter().zip(DOF_NAMES) {
            assert_eq!(row.channel, dof);
            assert_eq!((row.expected_dof.as_str(), row.expected_sign), (dof, 1));
            let i = DOF_NAMES.iter().position(|d| *d == dof).unwrap();
            assert!(row.tau_plus_100[i] > 0.0 && row.share[i] > 0.3, "{row:?}");
        }
        // Pure yaw from the yaw demand: no surge or sway.
        let yaw = &r.mixing[5];
        assert!(yaw.tau_plus_100[0].abs() < 1e-9 && yaw.tau_plus_100[1].abs() < 1e-9);
        assert_eq!(yaw.thrusters.len(), 4);
    }

    #[test]
    fn implausible_files_are_named() {
        let text = std::fs::read_to_string(
            std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../../config/vehicles/bluerov2_heavy.toml"),
        )
        .unwrap();
        // The yaw factors of the two front thrusters flipped: the yaw demand no longer
        // turns the vehicle; the CG moved 2 m aft; the CB below the CG.
        let bad = text
            .replace(
                "mix_yaw = { value = 1.0, unit = \"-\", source = \"[AS] Vectored-6DOF motor factors: yaw factor of motor 1\" }",
                "mix_yaw = { value = -1.0, unit = \"-\", source = \"x\" }",
            )
            .replace(
                "mix_yaw = { value = -1.0, unit = \"-\", source = \"[AS] Vectored-6DOF motor factors: yaw factor of motor 2\" }",
                "mix_yaw = { value = 1.0, unit = \"-\", source = \"x\" }",
            )
            .replace(
                "cg_from_co_m = { value = [0.0, 0.0, 0.01]",
                "cg_from_co_m = { value = [-0.9, 0.0, -0.01]",
            );
        let def = VehicleDef::parse(&bad, "bad.toml").unwrap();
        let r = check_vehicle(&def).unwrap();
        let kinds: Vec<&str> = r.issues.iter().map(|i| i.kind.as_str()).collect();
        assert!(kinds.contains(&"cg-outside-hull"), "{kinds:?}");
        assert!(kinds.contains(&"no-static-stability"), "{kinds:?}");
        assert!(
            kinds.contains(&"demand-not-produced") || kinds.contains(&"demand-wrong-sign"),
            "{kinds:?}"
        );
    }
}
