//! The Fossen reference trajectories (shared/testdata/fossen_reference) reproduced, plus
//! a constant-current case checked against an independent formulation and an energy
//! conservation check.

use rov_dynamics::integrators::rk4_step;
use rov_dynamics::kinematics::Attitude;
use rov_dynamics::models::ModelState;
use rov_dynamics::process::{CurrentSample, ProcessModel};
use rov_dynamics::{Matrix6, Vector6};
use rov_sim::reference::{
    REFERENCE_HEADER, ReferenceCase, ReferenceIntegrator, ReferenceParams, ReferenceStep,
    reference_csv, run_process_case, run_reference_case,
};

const DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/testdata/fossen_reference"
);

fn params() -> ReferenceParams {
    let path = format!("{DIR}/parameters.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    ReferenceParams::parse(&text, &path).unwrap()
}

fn read_csv(name: &str) -> (String, Vec<Vec<f64>>) {
    let path = format!("{DIR}/{name}");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let rows = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse::<f64>().unwrap()).collect())
        .collect();
    (text, rows)
}

fn max_abs_error_per_column(ours: &str, reference: &[Vec<f64>]) -> Vec<f64> {
    let ours: Vec<Vec<f64>> = ours
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse::<f64>().unwrap()).collect())
        .collect();
    assert_eq!(ours.len(), reference.len(), "row count");
    let mut err = vec![0.0_f64; 19];
    for (a, b) in ours.iter().zip(reference) {
        assert_eq!(a.len(), 19);
        for (j, e) in err.iter_mut().enumerate() {
            *e = e.max((a[j] - b[j]).abs());
        }
    }
    err
}

#[test]
fn reference_cases_reproduced_with_both_integrators() {
    let p = params();
    for (case, file_prefix) in [
        ("a_heave_restoring", "a_heave_restoring"),
        ("b_surge_yaw_coriolis", "b_surge_yaw_coriolis"),
    ] {
        for (integrator, suffix) in [
            (ReferenceIntegrator::Rk4, "rk4"),
            (ReferenceIntegrator::SemiImplicitEuler, "euler"),
        ] {
            let rows = run_reference_case(&p, case, integrator).unwrap();
            let csv = reference_csv(&rows);
            let (text, reference) = read_csv(&format!("{file_prefix}_{suffix}.csv"));
            assert_eq!(csv.lines().next(), text.lines().next(), "header");
            assert_eq!(csv.lines().next(), Some(REFERENCE_HEADER));
            let err = max_abs_error_per_column(&csv, &reference);
            let worst = err.iter().cloned().fold(0.0, f64::max);
            eprintln!("{case} {suffix}: max abs error {worst:e}");
            for (j, e) in err.iter().enumerate() {
                assert!(*e <= 1e-6, "{case} {suffix}: column {j} error {e}");
            }
        }
    }
}

/// The CSV reads back to exactly the rows computed (shortest round-trip numbers).
#[test]
fn csv_reads_back_bit_for_bit() {
    let p = params();
    let rows = run_reference_case(&p, "b_surge_yaw_coriolis", ReferenceIntegrator::Rk4).unwrap();
    let csv = reference_csv(&rows);
    for (line, row) in csv.lines().skip(1).zip(&rows) {
        let cells: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
        let want: Vec<f64> = std::iter::once(row.t_s)
            .chain(row.eta.iter().copied())
            .chain(row.nu.iter().copied())
            .chain(row.tau.iter().copied())
            .collect();
        assert_eq!(
            cells.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            want.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
    }
    assert_eq!(csv.lines().count(), rows.len() + 1);
}

#[test]
fn m_rb_is_built_from_h_and_matches_the_file() {
    let p = params();
    let pm = p.process_model().unwrap();
    let given = p.mrb_co.unwrap();
    assert!((pm.m_rb() - given).abs().max() < 1e-15);
    let mut tampered = p.clone();
    tampered.mrb_co = Some(given + Matrix6::identity() * 1e-3);
    assert!(
        tampered
            .process_model()
            .unwrap_err()
            .to_string()
            .contains("MRB_CO")
    );
}

/// ν_r-state formulation for a current constant in NED (Fossen's Property 8.1 and eq. 27):
/// M ν̇_r + C(ν_r) ν_r + D(ν_r) ν_r + g(η) = τ, η̇ = [R ν_r1 + v_c^n ; T ν_r2].
/// Written independently of the ν̇ = ν̇_c + M⁻¹(…) form used by the library.
fn relative_formulation_derivative(
    pm: &ProcessModel,
    eta: &Vector6,
    nu_r: &Vector6,
    tau: &Vector6,
    vc_ned: &nalgebra::Vector3<f64>,
) -> (Vector6, Vector6) {
    let m = pm.mass_matrix();
    let c = rov_dynamics::math::m2c(m, nu_r);
    let d = pm.params().damping.matrix(nu_r);
    let g = pm.restoring(eta);
    let nu_r_dot = m.lu().solve(&(tau - c * nu_r - d * nu_r - g)).unwrap();
    let att = Attitude::from_eta(eta);
    let p_dot = att.ned_from_body() * nu_r.fixed_rows::<3>(0) + vc_ned;
    let e_dot = att.euler_rates_from_body_rates() * nu_r.fixed_rows::<3>(3);
    (
        Vector6::new(p_dot.x, p_dot.y, p_dot.z, e_dot.x, e_dot.y, e_dot.z),
        nu_r_dot,
    )
}

#[test]
fn constant_current_case_matches_relative_velocity_formulation() {
    let p = params();
    let pm = p.process_model().unwrap();
    let mut case: ReferenceCase = p.case("b_surge_yaw_coriolis").unwrap().clone();
    case.current_speed_mps = 0.3;
    case.current_direction_rad = 0.7;
    case.eta0 = Vector6::new(0.0, 0.0, 1.0, 0.1, -0.05, 0.2);
    case.steps.push(ReferenceStep {
        t_on_s: 2.0,
        t_off_s: 8.0,
        tau: Vector6::new(0.0, 0.0, 3.0, 0.0, 0.0, 0.0),
    });
    let dt = 0.001;
    let t_end = 20.0;
    let rows = run_process_case(&pm, &case, dt, t_end, ReferenceIntegrator::Rk4).unwrap();
    let current = CurrentSample::constant(0.3, 0.7);
    // Independent run on (η, ν_r).
    let vc_b0 = Attitude::from_eta(&case.eta0).ned_from_body().transpose() * current.vel_ned_mps;
    let nu_r0 = case.nu0 - Vector6::new(vc_b0.x, vc_b0.y, vc_b0.z, 0.0, 0.0, 0.0);
    let mut x = ModelState::new(case.eta0, nu_r0);
    let n = (t_end / dt).round() as i64;
    let mut worst: f64 = 0.0;
    for k in 0..n {
        let tau = case.tau_at_step(k, dt);
        x = rk4_step(
            |_, s: &ModelState| {
                let (a, b) =
                    relative_formulation_derivative(&pm, &s.eta, &s.nu, &tau, &current.vel_ned_mps);
                ModelState::new(a, b)
            },
            k as f64 * dt,
            &x,
            dt,
        );
        let row = &rows[(k + 1) as usize];
        let vc_b = Attitude::from_eta(&x.eta).ned_from_body().transpose() * current.vel_ned_mps;
        let nu = x.nu + Vector6::new(vc_b.x, vc_b.y, vc_b.z, 0.0, 0.0, 0.0);
        worst = worst
            .max((row.eta - x.eta).amax())
            .max((row.nu - nu).amax());
    }
    eprintln!("constant current: max difference to the nu_r formulation {worst:e}");
    assert!(worst < 1e-9, "max difference {worst}");
    // The current really moved the vehicle: drift towards 0.7 rad.
    let last = rows.last().unwrap();
    assert!(last.eta[1] > 1.0, "east drift {}", last.eta[1]);
}

#[test]
fn energy_is_conserved_without_damping_and_forcing() {
    let p = params();
    let mut pp = p.process_params();
    pp.damping.linear = Matrix6::zeros();
    pp.damping.quadratic = Vector6::zeros();
    let pm = ProcessModel::new(pp).unwrap();
    let case = ReferenceCase {
        eta0: Vector6::new(0.0, 0.0, 2.0, 0.3, -0.2, 0.5),
        nu0: Vector6::new(0.4, -0.2, 0.1, 0.5, -0.3, 0.8),
        current_speed_mps: 0.0,
        current_direction_rad: 0.0,
        steps: vec![],
    };
    let rows = run_process_case(&pm, &case, 1e-3, 20.0, ReferenceIntegrator::Rk4).unwrap();
    let e0 = pm.energy(&rows[0].eta, &rows[0].nu);
    let scale = e0
        .abs()
        .max(0.5 * rows[0].nu.dot(&(pm.mass_matrix() * rows[0].nu)));
    let worst = rows
        .iter()
        .map(|r| (pm.energy(&r.eta, &r.nu) - e0).abs() / scale)
        .fold(0.0, f64::max);
    eprintln!("relative energy drift over 20 s: {worst:e}");
    assert!(worst < 1e-9, "relative energy drift {worst}");
    // Sanity: the motion is not trivial (the energy moves between terms).
    let ke_last = 0.5
        * rows
            .last()
            .unwrap()
            .nu
            .dot(&(pm.mass_matrix() * rows.last().unwrap().nu));
    let ke_first = 0.5 * rows[0].nu.dot(&(pm.mass_matrix() * rows[0].nu));
    assert!((ke_last - ke_first).abs() > 1e-4);
}
