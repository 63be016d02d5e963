//! Runner for the Fossen reference trajectories (shared/testdata/fossen_reference).
//!
//! [`ReferenceParams::parse`] reads a parameter file in the format of that directory's
//! `parameters.json`; [`run_reference_case`] runs one of its cases with RK4 or Fossen's
//! semi-implicit Euler exactly as the README describes (t_k = k·dt, τ_k the sum of the
//! steps with round(t_on/dt) ≤ k < round(t_off/dt), held over [t_k, t_k+1), M⁻¹ formed
//! once, all C_A entries kept, a constant current from the case's `Vc` and `beta_c_rad`);
//! [`run_reference_case_with`] hands each row to the caller as it is computed (so a long
//! run streams to a file in constant memory); [`push_reference_row`] formats a row with the
//! reference files' header and columns, numbers in the shortest form that reads back to the
//! same value (`rov_types::number`; the files' `%.15e` text is not reproduced, their
//! values are, to 1e-14).
//!
//! M_RB is built from `m`, `r_bg` and `I_cg_diag` through H(r_bg); when the file has
//! `MRB_CO`, it is cross-checked (|difference| ≤ 1e-9 per entry).

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Vector3};
use rov_dynamics::integrators::{rk4_step, semi_implicit_euler_step};
use rov_dynamics::models::ModelState;
use rov_dynamics::process::{
    CurrentSample, Damping, Hydrostatics, MunkMoment, ProcessModel, ProcessParams, RigidBody,
};
use rov_dynamics::{DynamicsError, Matrix6, Vector6};
use serde_json::Value;

/// The CSV header of the reference files.
pub const REFERENCE_HEADER: &str =
    "t,x,y,z,phi,theta,psi,u,v,w,p,q,r,tau_X,tau_Y,tau_Z,tau_K,tau_M,tau_N";

/// Why a reference case could not be run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ReferenceError {
    /// The text is not JSON.
    #[error("{file}: not valid JSON: {message}")]
    Json {
        /// File label.
        file: String,
        /// Parser message with line and column.
        message: String,
    },
    /// A key is missing or holds the wrong kind of value.
    #[error("{file}: key {key}: {detail}")]
    Key {
        /// File label.
        file: String,
        /// Key path, e.g. `cases.a_heave_restoring.steps[1].tau`.
        key: String,
        /// What is wrong.
        detail: String,
    },
    /// The requested case is not in the file.
    #[error("{file}: key cases.{case} is missing (cases in the file: {available})")]
    UnknownCase {
        /// File label.
        file: String,
        /// Requested case.
        case: String,
        /// Cases present.
        available: String,
    },
    /// The dynamics failed (e.g. a non-finite state or a singular mass matrix).
    #[error("{file}: {source}")]
    Dynamics {
        /// File label.
        file: String,
        /// The error.
        source: DynamicsError,
    },
}

/// One input step of a case.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceStep {
    /// Switch-on time, s.
    pub t_on_s: f64,
    /// Switch-off time, s.
    pub t_off_s: f64,
    /// τ while active.
    pub tau: Vector6,
}

/// One case.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceCase {
    /// η₀.
    pub eta0: Vector6,
    /// ν₀.
    pub nu0: Vector6,
    /// Constant current speed V_c, m/s (0 when the key is absent).
    pub current_speed_mps: f64,
    /// Current direction β_c (towards, from north), rad (0 when absent).
    pub current_direction_rad: f64,
    /// Input steps.
    pub steps: Vec<ReferenceStep>,
}

/// A parsed reference parameter file.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceParams {
    /// File label for errors.
    pub file: String,
    /// g, m/s².
    pub gravity_mps2: f64,
    /// m, kg.
    pub mass_kg: f64,
    /// CG from CO, m.
    pub r_bg_m: Vector3<f64>,
    /// CB from CO, m.
    pub r_bb_m: Vector3<f64>,
    /// (I_x, I_y, I_z) about the CG, kg m².
    pub inertia_cg_diag: Vector3<f64>,
    /// W, N.
    pub weight_n: f64,
    /// B, N.
    pub buoyancy_n: f64,
    /// diag(M_A).
    pub added_mass_diag: Vector6,
    /// diag(D_l).
    pub linear_damping_diag: Vector6,
    /// diag(D_q).
    pub quadratic_damping_diag: Vector6,
    /// `MRB_CO` if present.
    pub mrb_co: Option<Matrix6>,
    /// dt, s.
    pub dt_s: f64,
    /// t_end, s.
    pub t_end_s: f64,
    /// Cases by name.
    pub cases: BTreeMap<String, ReferenceCase>,
}

/// Integration scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReferenceIntegrator {
    /// Classical RK4 on [η; ν], τ frozen over the step.
    Rk4,
    /// Fossen's semi-implicit Euler (ν first, then η with the new ν and the old J).
    SemiImplicitEuler,
}

/// One output row: t_k, η_k, ν_k and τ_k (the input applied during the following step).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceRow {
    /// t_k, s.
    pub t_s: f64,
    /// η_k.
    pub eta: Vector6,
    /// ν_k.
    pub nu: Vector6,
    /// τ_k.
    pub tau: Vector6,
}

struct Reader<'a> {
    file: &'a str,
}

impl Reader<'_> {
    fn err(&self, key: &str, detail: impl Into<String>) -> ReferenceError {
        ReferenceError::Key {
            file: self.file.to_string(),
            key: key.to_string(),
            detail: detail.into(),
        }
    }

    fn get<'v>(
        &self,
        obj: &'v Value,
        parent: &str,
        name: &str,
    ) -> Result<&'v Value, ReferenceError> {
        let key = join(parent, name);
        obj.get(name).ok_or_else(|| self.err(&key, "is missing"))
    }

    fn number(&self, v: &Value, key: &str) -> Result<f64, ReferenceError> {
        match v.as_f64() {
            Some(x) if x.is_finite() => Ok(x),
            _ => Err(self.err(key, format!("expected a finite number, found {v}"))),
        }
    }

    fn f64(&self, obj: &Value, parent: &str, name: &str) -> Result<f64, ReferenceError> {
        let v = self.get(obj, parent, name)?;
        self.number(v, &join(parent, name))
    }

    fn f64_or(
        &self,
        obj: &Value,
        parent: &str,
        name: &str,
        default: f64,
    ) -> Result<f64, ReferenceError> {
        match obj.get(name) {
            None => Ok(default),
            Some(v) => self.number(v, &join(parent, name)),
        }
    }

    fn array<const N: usize>(&self, v: &Value, key: &str) -> Result<[f64; N], ReferenceError> {
        let arr = v
            .as_array()
            .filter(|a| a.len() == N)
            .ok_or_else(|| self.err(key, format!("expected an array of {N} numbers, found {v}")))?;
        let mut out = [0.0; N];
        for (i, (slot, item)) in out.iter_mut().zip(arr).enumerate() {
            *slot = self.number(item, &format!("{key}[{i}]"))?;
        }
        Ok(out)
    }

    fn arr<const N: usize>(
        &self,
        obj: &Value,
        parent: &str,
        name: &str,
    ) -> Result<[f64; N], ReferenceError> {
        let v = self.get(obj, parent, name)?;
        self.array::<N>(v, &join(parent, name))
    }

    fn positive(&self, x: f64, key: &str) -> Result<f64, ReferenceError> {
        if x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(key, format!("must be > 0, found {x}")))
        }
    }
}

fn join(parent: &str, name: &str) -> String {
    if parent.is_empty() {
        name.to_string()
    } else {
        format!("{parent}.{name}")
    }
}

fn v3(a: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

fn v6(a: [f64; 6]) -> Vector6 {
    Vector6::from_column_slice(&a)
}

impl ReferenceParams {
    /// Parses the JSON text; `file` labels errors.
    pub fn parse(text: &str, file: &str) -> Result<Self, ReferenceError> {
        let root: Value = serde_json::from_str(text).map_err(|e| ReferenceError::Json {
            file: file.to_string(),
            message: e.to_string(),
        })?;
        let r = Reader { file };
        if !root.is_object() {
            return Err(r.err("(root)", "expected a JSON object"));
        }
        let mrb_co = match root.get("MRB_CO") {
            None => None,
            Some(v) => {
                let rows = v
                    .as_array()
                    .filter(|a| a.len() == 6)
                    .ok_or_else(|| r.err("MRB_CO", "expected 6 rows of 6 numbers"))?;
                let mut m = Matrix6::zeros();
                for (i, row) in rows.iter().enumerate() {
                    let vals = r.array::<6>(row, &format!("MRB_CO[{i}]"))?;
                    for (j, x) in vals.iter().enumerate() {
                        m[(i, j)] = *x;
                    }
                }
                Some(m)
            }
        };
        let cases_v = r.get(&root, "", "cases")?;
        let cases_obj = cases_v
            .as_object()
            .ok_or_else(|| r.err("cases", "expected an object of named cases"))?;
        let mut cases = BTreeMap::new();
        for (name, c) in cases_obj {
            let p = format!("cases.{name}");
            let steps_v = r.get(c, &p, "steps")?;
            let steps_arr = steps_v
                .as_array()
                .ok_or_else(|| r.err(&format!("{p}.steps"), "expected an array of steps"))?;
            let mut steps = Vec::with_capacity(steps_arr.len());
            for (i, s) in steps_arr.iter().enumerate() {
                let sp = format!("{p}.steps[{i}]");
                steps.push(ReferenceStep {
                    t_on_s: r.f64(s, &sp, "t_on")?,
                    t_off_s: r.f64(s, &sp, "t_off")?,
                    tau: v6(r.arr::<6>(s, &sp, "tau")?),
                });
            }
            cases.insert(
                name.clone(),
                ReferenceCase {
                    eta0: v6(r.arr::<6>(c, &p, "eta0")?),
                    nu0: v6(r.arr::<6>(c, &p, "nu0")?),
                    current_speed_mps: r.f64_or(c, &p, "Vc", 0.0)?,
                    current_direction_rad: r.f64_or(c, &p, "beta_c_rad", 0.0)?,
                    steps,
                },
            );
        }
        let dt_s = r.positive(r.f64(&root, "", "dt")?, "dt")?;
        let t_end_s = r.positive(r.f64(&root, "", "t_end")?, "t_end")?;
        Ok(Self {
            file: file.to_string(),
            gravity_mps2: r.f64(&root, "", "g")?,
            mass_kg: r.positive(r.f64(&root, "", "m")?, "m")?,
            r_bg_m: v3(r.arr::<3>(&root, "", "r_bg")?),
            r_bb_m: v3(r.arr::<3>(&root, "", "r_bb")?),
            inertia_cg_diag: v3(r.arr::<3>(&root, "", "I_cg_diag")?),
            weight_n: r.f64(&root, "", "W")?,
            buoyancy_n: r.f64(&root, "", "B")?,
            added_mass_diag: v6(r.arr::<6>(&root, "", "MA_diag")?),
            linear_damping_diag: v6(r.arr::<6>(&root, "", "Dl_diag")?),
            quadratic_damping_diag: v6(r.arr::<6>(&root, "", "Dq_diag")?),
            mrb_co,
            dt_s,
            t_end_s,
            cases,
        })
    }

    /// The process plant parameters (all C_A entries kept, as in the reference).
    pub fn process_params(&self) -> ProcessParams {
        let rigid_body = RigidBody {
            mass_kg: self.mass_kg,
            inertia_cg_kgm2: Matrix3::from_diagonal(&self.inertia_cg_diag),
            cg_from_co_m: self.r_bg_m,
        };
        ProcessParams {
            rigid_body,
            added_mass: Matrix6::from_diagonal(&self.added_mass_diag),
            damping: Damping::diagonal(self.linear_damping_diag, self.quadratic_damping_diag),
            hydrostatics: Hydrostatics {
                weight_n: self.weight_n,
                buoyancy_n: self.buoyancy_n,
                cg_from_co_m: self.r_bg_m,
                cb_from_co_m: self.r_bb_m,
            },
            munk: MunkMoment::Full,
        }
    }

    /// The process plant model, with M_RB cross-checked against `MRB_CO` if present.
    pub fn process_model(&self) -> Result<ProcessModel, ReferenceError> {
        let pm = ProcessModel::new(self.process_params()).map_err(|source| {
            ReferenceError::Dynamics {
                file: self.file.clone(),
                source,
            }
        })?;
        if let Some(given) = &self.mrb_co {
            let diff = (given - pm.m_rb()).abs().max();
            if diff > 1e-9 {
                return Err(ReferenceError::Key {
                    file: self.file.clone(),
                    key: "MRB_CO".into(),
                    detail: format!(
                        "differs from H(r_bg)^T diag(m, m, m, I_cg) H(r_bg) built from m, r_bg, I_cg_diag by {diff:e}"
                    ),
                });
            }
        }
        Ok(pm)
    }

    /// A case by name.
    pub fn case(&self, name: &str) -> Result<&ReferenceCase, ReferenceError> {
        self.cases
            .get(name)
            .ok_or_else(|| ReferenceError::UnknownCase {
                file: self.file.clone(),
                case: name.to_string(),
                available: self.cases.keys().cloned().collect::<Vec<_>>().join(", "),
            })
    }
}

impl ReferenceCase {
    /// τ_k: the sum of the steps with round(t_on/dt) ≤ k < round(t_off/dt) (Python's
    /// round-half-to-even).
    pub fn tau_at_step(&self, k: i64, dt_s: f64) -> Vector6 {
        self.steps
            .iter()
            .filter(|s| {
                let on = (s.t_on_s / dt_s).round_ties_even() as i64;
                let off = (s.t_off_s / dt_s).round_ties_even() as i64;
                on <= k && k < off
            })
            .fold(Vector6::zeros(), |acc, s| acc + s.tau)
    }

    /// The constant current of the case.
    pub fn current(&self) -> CurrentSample {
        CurrentSample::constant(self.current_speed_mps, self.current_direction_rad)
    }
}

/// Runs a case of `params` with the given integrator; returns the round(t_end/dt) + 1 rows.
pub fn run_reference_case(
    params: &ReferenceParams,
    case_name: &str,
    integrator: ReferenceIntegrator,
) -> Result<Vec<ReferenceRow>, ReferenceError> {
    let mut rows = Vec::new();
    run_reference_case_with(params, case_name, integrator, |r| {
        rows.push(*r);
        Ok::<(), ReferenceError>(())
    })?;
    Ok(rows)
}

/// [`run_reference_case`], handing each row to `sink` as it is computed instead of
/// keeping them; a sink error stops the run and is returned.
pub fn run_reference_case_with<E: From<ReferenceError>>(
    params: &ReferenceParams,
    case_name: &str,
    integrator: ReferenceIntegrator,
    sink: impl FnMut(&ReferenceRow) -> Result<(), E>,
) -> Result<(), E> {
    let case = params.case(case_name)?;
    let pm = params.process_model()?;
    let mut err: Option<E> = None;
    let mut sink = sink;
    let res =
        run_process_case_with(
            &pm,
            case,
            params.dt_s,
            params.t_end_s,
            integrator,
            |r| match sink(r) {
                Ok(()) => true,
                Err(e) => {
                    err = Some(e);
                    false
                }
            },
        );
    if let Some(e) = err {
        return Err(e);
    }
    res.map_err(|source| {
        E::from(ReferenceError::Dynamics {
            file: params.file.clone(),
            source,
        })
    })
}

/// Runs a case on a given process model (used by tests with modified models).
pub fn run_process_case(
    pm: &ProcessModel,
    case: &ReferenceCase,
    dt_s: f64,
    t_end_s: f64,
    integrator: ReferenceIntegrator,
) -> Result<Vec<ReferenceRow>, DynamicsError> {
    let n = (t_end_s / dt_s).round_ties_even() as i64;
    let mut rows = Vec::with_capacity(usize::try_from(n + 1).unwrap_or(0));
    run_process_case_with(pm, case, dt_s, t_end_s, integrator, |r| {
        rows.push(*r);
        true
    })?;
    Ok(rows)
}

/// [`run_process_case`], handing each row to `sink`; the run stops when it returns false.
pub fn run_process_case_with(
    pm: &ProcessModel,
    case: &ReferenceCase,
    dt_s: f64,
    t_end_s: f64,
    integrator: ReferenceIntegrator,
    mut sink: impl FnMut(&ReferenceRow) -> bool,
) -> Result<(), DynamicsError> {
    let n = (t_end_s / dt_s).round_ties_even() as i64;
    let current = case.current();
    let mut x = ModelState::new(case.eta0, case.nu0);
    for k in 0..=n {
        let t = k as f64 * dt_s;
        let tau = case.tau_at_step(k, dt_s);
        let row = ReferenceRow {
            t_s: t,
            eta: x.eta,
            nu: x.nu,
            tau,
        };
        if !sink(&row) || k == n {
            break;
        }
        x = match integrator {
            ReferenceIntegrator::Rk4 => rk4_step(
                |_, s: &ModelState| {
                    let (eta_dot, nu_dot) = pm.state_derivative(&s.eta, &s.nu, &tau, &current);
                    ModelState::new(eta_dot, nu_dot)
                },
                t,
                &x,
                dt_s,
            ),
            ReferenceIntegrator::SemiImplicitEuler => {
                let (eta, nu) = semi_implicit_euler_step(
                    |eta, nu| pm.nu_dot(eta, nu, &tau, &current),
                    &x.eta,
                    &x.nu,
                    dt_s,
                );
                ModelState::new(eta, nu)
            }
        };
        if !x.is_finite() {
            return Err(DynamicsError::NonFinite {
                time_s: t + dt_s,
                state: format!("eta = {:?}, nu = {:?}", x.eta.as_slice(), x.nu.as_slice()),
            });
        }
    }
    Ok(())
}

/// Appends one row as a CSV line (the columns of [`REFERENCE_HEADER`], numbers in the
/// shortest form that reads back exactly, `\n` at the end).
pub fn push_reference_row(out: &mut String, row: &ReferenceRow) {
    rov_types::number::push_f64(out, row.t_s);
    for x in row.eta.iter().chain(row.nu.iter()).chain(row.tau.iter()) {
        out.push(',');
        rov_types::number::push_f64(out, *x);
    }
    out.push('\n');
}

/// The rows as CSV text with [`REFERENCE_HEADER`] (short runs and tests; long ones
/// stream with [`run_reference_case_with`] and [`push_reference_row`]).
pub fn reference_csv(rows: &[ReferenceRow]) -> String {
    let mut out = String::with_capacity(64 + rows.len() * 19 * 12);
    out.push_str(REFERENCE_HEADER);
    out.push('\n');
    for row in rows {
        push_reference_row(&mut out, row);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_json_and_missing_keys_name_the_key() {
        let e = ReferenceParams::parse("{", "p.json").unwrap_err();
        assert!(matches!(e, ReferenceError::Json { .. }), "{e}");
        let e = ReferenceParams::parse(r#"{"cases": {}}"#, "p.json").unwrap_err();
        assert_eq!(e.to_string(), "p.json: key dt: is missing");
        let text = r#"{"g": 9.81, "m": 6.1, "r_bg": [0,0,0], "r_bb": [0,0,0], "I_cg_diag": [1,1,1],
            "W": 1, "B": 1, "MA_diag": [1,1,1,1,1,1], "Dl_diag": [1,1,1,1,1,1], "Dq_diag": [1,1,1,1,1,1],
            "dt": 0.01, "t_end": 1.0,
            "cases": {"c": {"eta0": [0,0,0,0,0,0], "nu0": [0,0,0,0,0,0],
                            "steps": [{"t_on": 0, "t_off": 1, "tau": [1,2,3]}]}}}"#;
        let e = ReferenceParams::parse(text, "p.json").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("p.json: key cases.c.steps[0].tau: expected an array of 6 numbers"),
            "{e}"
        );
        let ok = text.replace("[1,2,3]", "[1,2,3,0,0,0]");
        let p = ReferenceParams::parse(&ok, "p.json").unwrap();
        let e = run_reference_case(&p, "nope", ReferenceIntegrator::Rk4).unwrap_err();
        assert_eq!(
            e.to_string(),
            "p.json: key cases.nope is missing (cases in the file: c)"
        );
        let rows = run_reference_case(&p, "c", ReferenceIntegrator::Rk4).unwrap();
        assert_eq!(rows.len(), 101);
        assert_eq!(rows[0].tau[1], 2.0);
        assert_eq!(rows[100].tau, Vector6::zeros(), "t_off is exclusive");
    }
}
