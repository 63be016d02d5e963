//! Discovered terms: physically meaningful generalised-force terms outside the effect
//! catalog, each a regressor (a function of the body velocities, the attitude and the
//! commands) times a coefficient, acting on one degree of freedom.
//!
//! The library ([`library`]) holds what modellab.md §4.5 and issue 13 ask for: linear
//! couplings from another DOF's velocity (cross-damping), products and
//! |·|-weighted products of body velocities and rates, cubes (speed-dependent damping),
//! thruster commands, their signed squares and their products with the velocity along
//! the DOF (thrust that changes with inflow), low-pass filtered commands (slow thruster or
//! wake dynamics), sines and cosines of the attitude, and a constant. The diagnosis
//! searches it by sparse regression on the residual generalised force and confirms each
//! pick in simulation (see [`crate::diagnose`]); a confirmed term joins the model
//! ([`crate::model::LabModel::add_term`]) and is saved with it ([`crate::persist`]).
//!
//! Inputs of the command terms are the model's command signals in fractions of full
//! command (−1..1): the Pro 4's port, starboard and vertical thrusters, or a vehicle
//! file's command channels.

use rov_dynamics::Vector6;
use rov_dynamics::math::sin_cos;

/// A signal a term is built from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Sig {
    /// A body velocity or rate ν_i (0..6 = u, v, w, p, q, r), m/s or rad/s.
    Nu(u8),
    /// Command signal i of the model (fraction of full command).
    Cmd(u8),
}

/// The angle of a trigonometric term.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Angle {
    /// Roll φ.
    Roll,
    /// Pitch θ.
    Pitch,
    /// Heading ψ.
    Heading,
}

impl Angle {
    /// Its index in η.
    #[inline]
    pub fn eta_index(self) -> usize {
        match self {
            Angle::Roll => 3,
            Angle::Pitch => 4,
            Angle::Heading => 5,
        }
    }
}

/// Time constants of the filtered-command terms, s.
pub const FILTER_TAUS_S: [f64; 2] = [0.5, 2.0];

/// The form of a term's regressor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum TermKind {
    /// ν_i alone (a linear coupling from another DOF's velocity: cross-damping).
    Lin(u8),
    /// a · b.
    Prod(Sig, Sig),
    /// a · |b|.
    ProdAbs(Sig, Sig),
    /// a³.
    Cube(Sig),
    /// u (a command).
    Cmd(u8),
    /// u · |u|.
    CmdSq(u8),
    /// u · ν_i (command times a velocity).
    CmdVel(u8, u8),
    /// First-order low-pass of a command with time constant [`FILTER_TAUS_S`][k].
    Filtered(u8, u8),
    /// sin of an angle.
    Sin(Angle),
    /// cos of an angle.
    Cos(Angle),
    /// 1.
    Const,
}

/// Names of ν's components.
pub const NU_NAMES: [&str; 6] = ["u", "v", "w", "p", "q", "r"];
/// Names of the degrees of freedom.
pub const DOF_NAMES: [&str; 6] = ["surge", "sway", "heave", "roll", "pitch", "yaw"];
/// The generalised force of each DOF in words.
pub const DOF_FORCE: [&str; 6] = [
    "surge force",
    "sway force",
    "heave force",
    "roll moment",
    "pitch moment",
    "yaw moment",
];

fn angle_name(a: Angle) -> &'static str {
    match a {
        Angle::Roll => "phi",
        Angle::Pitch => "theta",
        Angle::Heading => "psi",
    }
}

/// What a term evaluates on at one instant.
#[derive(Debug, Clone, Copy)]
pub struct TermInputs<'a> {
    /// η (m, rad).
    pub eta: &'a Vector6,
    /// ν (m/s, rad/s).
    pub nu: &'a Vector6,
    /// Command signals, fractions of full command.
    pub cmd: &'a [f64],
    /// Filtered command signals per (command, filter) as `filt[cmd * 2 + k]`.
    pub filt: &'a [f64],
}

impl TermKind {
    /// The regressor's value.
    #[inline]
    pub fn value(&self, x: &TermInputs<'_>) -> f64 {
        let sig = |s: Sig| -> f64 {
            match s {
                Sig::Nu(i) => x.nu.get(i as usize).copied().unwrap_or(0.0),
                Sig::Cmd(i) => x.cmd.get(i as usize).copied().unwrap_or(0.0),
            }
        };
        let cmd = |i: u8| x.cmd.get(i as usize).copied().unwrap_or(0.0);
        match *self {
            TermKind::Lin(i) => x.nu.get(i as usize).copied().unwrap_or(0.0),
            TermKind::Prod(a, b) => sig(a) * sig(b),
            TermKind::ProdAbs(a, b) => sig(a) * sig(b).abs(),
            TermKind::Cube(a) => sig(a).powi(3),
            TermKind::Cmd(i) => cmd(i),
            TermKind::CmdSq(i) => cmd(i) * cmd(i).abs(),
            TermKind::CmdVel(i, j) => cmd(i) * x.nu.get(j as usize).copied().unwrap_or(0.0),
            TermKind::Filtered(i, k) => x
                .filt
                .get(i as usize * FILTER_TAUS_S.len() + k as usize)
                .copied()
                .unwrap_or(0.0),
            // The dynamics' own sin/cos (about three times faster than libm's, to about
            // one ulp): a term runs on every RK4 stage of every simulation.
            TermKind::Sin(a) => sin_cos(x.eta[a.eta_index()]).0,
            TermKind::Cos(a) => sin_cos(x.eta[a.eta_index()]).1,
            TermKind::Const => 1.0,
        }
    }

    /// The filter this term needs, if any: (command index, filter index).
    pub fn filter(&self) -> Option<(u8, u8)> {
        match *self {
            TermKind::Filtered(i, k) => Some((i, k)),
            _ => None,
        }
    }

    /// The formula, with the model's command names (e.g. `v*|r|`, `cmd_vertical^2s`).
    pub fn formula(&self, cmd_names: &[&str]) -> String {
        let cname = |i: u8| {
            format!(
                "cmd_{}",
                cmd_names.get(i as usize).copied().unwrap_or("unknown")
            )
        };
        let sig = |s: Sig| match s {
            Sig::Nu(i) => NU_NAMES.get(i as usize).copied().unwrap_or("?").to_string(),
            Sig::Cmd(i) => cname(i),
        };
        match *self {
            TermKind::Lin(i) => sig(Sig::Nu(i)),
            TermKind::Prod(a, b) if a == b => format!("{}^2", sig(a)),
            TermKind::Prod(a, b) => format!("{}*{}", sig(a), sig(b)),
            TermKind::ProdAbs(a, b) => format!("{}*|{}|", sig(a), sig(b)),
            TermKind::Cube(a) => format!("{}^3", sig(a)),
            TermKind::Cmd(i) => cname(i),
            TermKind::CmdSq(i) => format!("{}*|{}|", cname(i), cname(i)),
            TermKind::CmdVel(i, j) => format!(
                "{}*{}",
                cname(i),
                NU_NAMES.get(j as usize).copied().unwrap_or("?")
            ),
            TermKind::Filtered(i, k) => format!(
                "lpf({},{}s)",
                cname(i),
                FILTER_TAUS_S.get(k as usize).copied().unwrap_or(0.0)
            ),
            TermKind::Sin(a) => format!("sin({})", angle_name(a)),
            TermKind::Cos(a) => format!("cos({})", angle_name(a)),
            TermKind::Const => "1".into(),
        }
    }

    /// Parses [`TermKind::formula`] back.
    pub fn parse(s: &str, cmd_names: &[&str]) -> Option<Self> {
        let s = s.trim();
        let cmd = |t: &str| -> Option<u8> {
            let n = t.strip_prefix("cmd_")?;
            cmd_names.iter().position(|c| *c == n).map(|i| i as u8)
        };
        let nu = |t: &str| NU_NAMES.iter().position(|c| *c == t).map(|i| i as u8);
        let sig = |t: &str| -> Option<Sig> { nu(t).map(Sig::Nu).or_else(|| cmd(t).map(Sig::Cmd)) };
        let angle = |t: &str| match t {
            "phi" => Some(Angle::Roll),
            "theta" => Some(Angle::Pitch),
            "psi" => Some(Angle::Heading),
            _ => None,
        };
        if s == "1" {
            return Some(TermKind::Const);
        }
        if let Some(inner) = s.strip_prefix("sin(").and_then(|r| r.strip_suffix(')')) {
            return angle(inner).map(TermKind::Sin);
        }
        if let Some(inner) = s.strip_prefix("cos(").and_then(|r| r.strip_suffix(')')) {
            return angle(inner).map(TermKind::Cos);
        }
        if let Some(inner) = s.strip_prefix("lpf(").and_then(|r| r.strip_suffix("s)")) {
            let (c, t) = inner.split_once(',')?;
            let tau: f64 = t.parse().ok()?;
            let k = FILTER_TAUS_S.iter().position(|x| (x - tau).abs() < 1e-9)?;
            return Some(TermKind::Filtered(cmd(c)?, k as u8));
        }
        if let Some(b) = s.strip_suffix("^3") {
            return sig(b).map(TermKind::Cube);
        }
        if let Some(b) = s.strip_suffix("^2") {
            return sig(b).map(|x| TermKind::Prod(x, x));
        }
        if let Some((a, b)) = s.split_once('*') {
            if let Some(b) = b.strip_prefix('|').and_then(|r| r.strip_suffix('|')) {
                if let (Some(ca), Some(cb)) = (cmd(a), cmd(b))
                    && ca == cb
                {
                    return Some(TermKind::CmdSq(ca));
                }
                return Some(TermKind::ProdAbs(sig(a)?, sig(b)?));
            }
            if let (Some(c), Some(j)) = (cmd(a), nu(b)) {
                return Some(TermKind::CmdVel(c, j));
            }
            return Some(TermKind::Prod(sig(a)?, sig(b)?));
        }
        nu(s)
            .map(TermKind::Lin)
            .or_else(|| cmd(s).map(TermKind::Cmd))
    }

    /// The unit of the regressor (for the coefficient's unit: force per this).
    pub fn regressor_unit(&self) -> String {
        let unit = |s: Sig| match s {
            Sig::Nu(i) if i < 3 => "m/s",
            Sig::Nu(_) => "rad/s",
            Sig::Cmd(_) => "-",
        };
        match *self {
            TermKind::Prod(a, b) | TermKind::ProdAbs(a, b) => {
                if a == b {
                    format!("({})^2", unit(a))
                } else {
                    format!("{}·{}", unit(a), unit(b))
                }
            }
            TermKind::Cube(a) => format!("({})^3", unit(a)),
            TermKind::Lin(j) | TermKind::CmdVel(_, j) => {
                (if j < 3 { "m/s" } else { "rad/s" }).to_string()
            }
            _ => "-".into(),
        }
    }
}

/// A term in a model: the regressor form, the DOF it acts on, its coefficient (N or N m
/// per unit of the regressor) and the regressor's typical size on the data it was found
/// on (the scale of the lab's normalised coefficient parameter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Term {
    /// DOF index 0..6 (surge … yaw).
    pub dof: u8,
    /// Regressor.
    pub kind: TermKind,
    /// Coefficient, N (or N m) per unit of the regressor.
    pub coef: f64,
    /// Typical |regressor| (RMS on the data it was found on), > 0.
    pub scale: f64,
}

impl Term {
    /// Whether the DOF is rotational (coefficient in N m).
    pub fn rotational(&self) -> bool {
        self.dof >= 3
    }

    /// The force unit ("N" or "N m").
    pub fn force_unit(&self) -> &'static str {
        if self.rotational() { "N m" } else { "N" }
    }

    /// The id used in findings and `lab add --terms`: `term:DOF:SLUG`.
    pub fn id(&self, cmd_names: &[&str]) -> String {
        term_id(self.dof, &self.kind, cmd_names)
    }
}

/// `term:DOF:SLUG` for a DOF and a regressor (the slug is the formula with `*` → `_`,
/// `|x|` → `absx`, `^` dropped, parentheses and commas → `_`).
pub fn term_id(dof: u8, kind: &TermKind, cmd_names: &[&str]) -> String {
    let f = kind.formula(cmd_names);
    let mut slug = String::new();
    for c in f.chars() {
        match c {
            '*' => slug.push('_'),
            '|' => {
                if slug.ends_with('_') || slug.is_empty() {
                    slug.push_str("abs");
                }
            }
            '^' => {}
            '(' | ')' | ',' => {
                if !slug.ends_with('_') {
                    slug.push('_');
                }
            }
            '.' => slug.push('p'),
            c => slug.push(c),
        }
    }
    let slug = slug.trim_end_matches('_').to_string();
    format!(
        "term:{}:{}",
        DOF_NAMES.get(dof as usize).copied().unwrap_or("?"),
        slug
    )
}

/// Parses `term:DOF:SLUG` against candidate kinds (`library`): the DOF and the kind whose
/// id matches.
pub fn parse_term_id(
    id: &str,
    candidates: &[(u8, TermKind)],
    cmd_names: &[&str],
) -> Option<(u8, TermKind)> {
    candidates
        .iter()
        .copied()
        .find(|(d, k)| term_id(*d, k, cmd_names) == id.trim())
}

/// The candidate library for a model with `n_cmd` command signals, over the DOFs in
/// `dofs` and the velocities in `nu_active` (those the model's state can have non-zero):
/// every (DOF, regressor) pair, without duplicates. `quad_calibrated[d]`: the base
/// calibrates DOF d's own quadratic drag, so ν_d|ν_d| on d is a base parameter too.
pub fn library(
    dofs: &[usize],
    nu_active: &[bool; 6],
    n_cmd: usize,
    quad_calibrated: &[bool; 6],
) -> Vec<(u8, TermKind)> {
    let vel: Vec<u8> = (0..6u8).filter(|i| nu_active[*i as usize]).collect();
    let mut forms: Vec<TermKind> = Vec::new();
    for (ia, a) in vel.iter().enumerate() {
        forms.push(TermKind::Lin(*a));
        for b in vel.iter().skip(ia) {
            forms.push(TermKind::Prod(Sig::Nu(*a), Sig::Nu(*b)));
        }
        for b in &vel {
            forms.push(TermKind::ProdAbs(Sig::Nu(*a), Sig::Nu(*b)));
        }
        forms.push(TermKind::Cube(Sig::Nu(*a)));
    }
    for c in 0..n_cmd.min(16) as u8 {
        forms.push(TermKind::Cmd(c));
        forms.push(TermKind::CmdSq(c));
        for k in 0..FILTER_TAUS_S.len() as u8 {
            forms.push(TermKind::Filtered(c, k));
        }
        for j in &vel {
            forms.push(TermKind::CmdVel(c, *j));
        }
    }
    for a in [Angle::Roll, Angle::Pitch, Angle::Heading] {
        forms.push(TermKind::Sin(a));
        forms.push(TermKind::Cos(a));
    }
    forms.push(TermKind::Const);
    let mut out = Vec::new();
    for d in dofs {
        for f in &forms {
            // A DOF's own linear damping is a base parameter, not a term; so is its own
            // quadratic drag when the base calibrates it (a term there would only
            // compete with the calibration: a coefficient whose interval spans zero).
            let own_quad = TermKind::ProdAbs(Sig::Nu(*d as u8), Sig::Nu(*d as u8));
            let calibrated = quad_calibrated.get(*d).copied().unwrap_or(false);
            if *f != TermKind::Lin(*d as u8) && !(calibrated && *f == own_quad) {
                out.push((*d as u8, *f));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formulas_and_ids_round_trip() {
        let names = ["port", "starboard", "vertical"];
        let lib = library(
            &[2, 5],
            &[true, false, true, false, false, true],
            3,
            &[false; 6],
        );
        for (d, k) in &lib {
            let f = k.formula(&names);
            assert_eq!(TermKind::parse(&f, &names), Some(*k), "{f}");
            let id = term_id(*d, k, &names);
            assert_eq!(parse_term_id(&id, &lib, &names), Some((*d, *k)), "{id}");
        }
        assert_eq!(
            term_id(5, &TermKind::ProdAbs(Sig::Nu(1), Sig::Nu(5)), &names),
            "term:yaw:v_absr"
        );
        assert_eq!(
            TermKind::Prod(Sig::Nu(5), Sig::Nu(5)).formula(&names),
            "r^2"
        );
    }

    #[test]
    fn own_quadratic_drag_is_a_term_only_when_the_base_does_not_calibrate_it() {
        let active = [true, false, true, false, false, true];
        let own = |d: u8| (d, TermKind::ProdAbs(Sig::Nu(d), Sig::Nu(d)));
        let free = library(&[2, 5], &active, 3, &[false; 6]);
        assert!(free.contains(&own(2)) && free.contains(&own(5)));
        let mut cal = [false; 6];
        cal[2] = true;
        let lib = library(&[2, 5], &active, 3, &cal);
        assert!(
            !lib.contains(&own(2)),
            "heave's calibrated w|w| offered as a term"
        );
        assert!(
            lib.contains(&own(5)),
            "yaw's uncalibrated r|r| must stay a candidate"
        );
        // Cross-coupled drag on the calibrated DOF stays a candidate.
        assert!(lib.contains(&(2, TermKind::ProdAbs(Sig::Nu(5), Sig::Nu(5)))));
        assert_eq!(lib.len() + 1, free.len());
    }

    #[test]
    fn values_follow_the_formulas() {
        let eta = Vector6::new(0.0, 0.0, 1.0, 0.1, -0.2, 1.0);
        let nu = Vector6::new(0.5, -0.1, 0.2, 0.0, 0.0, -0.3);
        let cmd = [0.5, -0.25, 0.8];
        let filt = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let x = TermInputs {
            eta: &eta,
            nu: &nu,
            cmd: &cmd,
            filt: &filt,
        };
        assert!((TermKind::ProdAbs(Sig::Nu(1), Sig::Nu(5)).value(&x) - (-0.1 * 0.3)).abs() < 1e-12);
        assert!((TermKind::CmdSq(1).value(&x) + 0.0625).abs() < 1e-12);
        assert!((TermKind::CmdVel(2, 0).value(&x) - 0.4).abs() < 1e-12);
        assert!((TermKind::Filtered(1, 1).value(&x) - 0.4).abs() < 1e-12);
        assert!((TermKind::Sin(Angle::Pitch).value(&x) - (-0.2f64).sin()).abs() < 1e-12);
        assert!((TermKind::Cube(Sig::Nu(2)).value(&x) - 0.008).abs() < 1e-12);
        assert!((TermKind::Lin(5).value(&x) + 0.3).abs() < 1e-12);
    }
}
