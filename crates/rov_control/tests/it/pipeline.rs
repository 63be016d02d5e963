//! Whole-pipeline properties: C1 (finite, bounded), C2 (no state poisoning), C3 (slew),
//! C5 (bumpless engage).

use crate::common;

use proptest::prelude::*;
use rov_control::{
    Axis, AxisMode, ControlConfig, Controller, Measurements, ModeCommand, ModelChoice, ModelSet,
    PilotInput,
};

fn wild() -> impl Strategy<Value = f64> {
    prop_oneof![
        6 => -50.0..400.0f64,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(1e300),
        1 => Just(-1e300),
        1 => Just(5e-324),
        1 => Just(-0.0),
        2 => prop::num::f64::ANY,
    ]
}

fn stick() -> impl Strategy<Value = f64> {
    prop_oneof![4 => -1.2..1.2f64, 1 => Just(0.0), 1 => wild()]
}

fn opt(s: impl Strategy<Value = f64>) -> impl Strategy<Value = Option<f64>> {
    prop_oneof![5 => s.prop_map(Some), 1 => Just(None)]
}

#[derive(Debug, Clone)]
struct Step {
    t_override: Option<f64>,
    meas: Measurements,
    pilot: PilotInput,
    cmd: Option<(u8, f64)>,
}

fn step() -> impl Strategy<Value = Step> {
    (
        prop_oneof![9 => Just(None), 1 => wild().prop_map(Some)],
        opt(wild()),
        opt(wild()),
        opt(wild()),
        (stick(), stick(), stick()),
        prop_oneof![6 => Just(None), 1 => (0u8..12, wild()).prop_map(Some)],
    )
        .prop_map(|(t_override, d, h, r, (s, y, v), cmd)| Step {
            t_override,
            meas: Measurements {
                depth_m: d,
                heading_deg: h,
                yaw_rate_rad_s: r,
            },
            pilot: PilotInput {
                surge: s,
                yaw: y,
                vertical: v,
            },
            cmd,
        })
}

fn command(kind: u8, x: f64) -> ModeCommand {
    match kind {
        0 => ModeCommand::Engage(Axis::Depth),
        1 => ModeCommand::Engage(Axis::Heading),
        2 => ModeCommand::Disengage(Axis::Depth),
        3 => ModeCommand::EngageVehicleAuto(Axis::Heading),
        4 => ModeCommand::SetDepth { depth_m: x },
        5 => ModeCommand::StepDepth { delta_m: x },
        6 => ModeCommand::SetHeading { heading_deg: x },
        7 => ModeCommand::StepHeading { delta_deg: x },
        8 => ModeCommand::SelectModel(ModelChoice::ALL[(x.abs() as usize) % 3]),
        9 => ModeCommand::SetFeedforward(x > 0.0),
        10 => ModeCommand::SetSurfaceTare { pressure_mbar: x },
        _ => ModeCommand::EngageVehicleAuto(Axis::Depth),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// C1 + C3: whatever goes in, every command is finite, within ±100 % and moves by at
    /// most the slew step per tick.
    #[test]
    fn c1_c3_outputs_finite_bounded_rate_limited(steps in prop::collection::vec(step(), 1..300)) {
        let cfg = ControlConfig::default();
        let max_step = cfg.guard.max_step_pct;
        let mut c = Controller::new(cfg, ModelSet::load_default().unwrap()).unwrap();
        let mut t = 0.0;
        let mut prev = [0.0f64; 3];
        for s in &steps {
            if let Some((k, x)) = s.cmd {
                let _ = c.command(command(k, x));
            }
            t += 0.02;
            let out = c.tick(s.t_override.unwrap_or(t), &s.meas, &s.pilot);
            let cmd = out.command;
            let now = [cmd.port_pct(), cmd.starboard_pct(), cmd.vertical_pct()];
            for (a, b) in now.iter().zip(prev.iter()) {
                prop_assert!(a.is_finite() && a.abs() <= 100.0, "{now:?}");
                prop_assert!((a - b).abs() <= max_step + 1e-9, "{prev:?} -> {now:?}");
            }
            prev = now;
        }
    }
}

fn meas(d: f64, h: f64) -> Measurements {
    Measurements {
        depth_m: Some(d),
        heading_deg: Some(h),
        yaw_rate_rad_s: None,
    }
}

/// C2: a NaN sample is exactly a dropout: identical commands afterwards.
#[test]
fn c2_nan_equals_dropout_in_the_whole_tick() {
    let mut rng = common::Rng::new(7);
    let mk =
        || Controller::new(ControlConfig::default(), ModelSet::load_default().unwrap()).unwrap();
    let (mut a, mut b) = (mk(), mk());
    let mut plant = common::AxisPlant::new(
        rov_control::PlantModel::load_default(rov_control::ModelChoice::Model3).unwrap(),
        3.0,
        40.0,
    );
    for k in 0..3000 {
        let t = k as f64 * 0.02;
        if k == 10 {
            for c in [&mut a, &mut b] {
                c.command(ModeCommand::SetDepth { depth_m: 4.0 }).unwrap();
                c.command(ModeCommand::SetHeading { heading_deg: 80.0 })
                    .unwrap();
            }
        }
        let d = plant.depth_m + 0.01 * rng.normal();
        let h = plant.heading_deg() + 0.2 * rng.normal();
        let (ma, mb) = match k % 97 {
            13 => (
                Measurements {
                    depth_m: Some(f64::NAN),
                    ..meas(d, h)
                },
                Measurements {
                    depth_m: None,
                    ..meas(d, h)
                },
            ),
            41 => (
                Measurements {
                    heading_deg: Some(f64::NAN),
                    yaw_rate_rad_s: Some(f64::NAN),
                    ..meas(d, h)
                },
                Measurements {
                    heading_deg: None,
                    ..meas(d, h)
                },
            ),
            _ => (meas(d, h), meas(d, h)),
        };
        let oa = a.tick(t, &ma, &PilotInput::default());
        let ob = b.tick(t, &mb, &PilotInput::default());
        assert_eq!(oa.command, ob.command, "tick {k}");
        assert_eq!(oa.diagnostics.depth.estimate, ob.diagnostics.depth.estimate);
        assert_eq!(
            oa.diagnostics.heading.estimate,
            ob.diagnostics.heading.estimate
        );
        if k % 97 == 13 {
            assert!(oa.diagnostics.depth.sample_invalid);
        }
        let c = oa.command;
        plant.step(c.port_pct(), c.starboard_pct(), c.vertical_pct(), 0.02);
    }
    assert!((plant.depth_m - 4.0).abs() < 0.05);
}

/// C5: engaging with sticks centred after manual flying moves depth by ≤ 0.2 m and
/// heading by ≤ 2° over 10 s, with no thrust step above the slew limit.
#[test]
fn c5_bumpless_engage_in_the_tick() {
    let cfg = ControlConfig::default();
    let max_step = cfg.guard.max_step_pct;
    let mut c = Controller::new(cfg, ModelSet::load_default().unwrap()).unwrap();
    let mut plant = common::AxisPlant::new(
        rov_control::PlantModel::load_default(rov_control::ModelChoice::Model3).unwrap(),
        5.0,
        200.0,
    );
    plant.heave_disturbance_n = 1.0; // slightly heavy
    let mut t = 0.0;
    // Manual: pilot holds 30 % vertical and some yaw for 5 s, then centres.
    let run = |c: &mut Controller,
               plant: &mut common::AxisPlant,
               pilot: PilotInput,
               secs: f64,
               t: &mut f64| {
        let mut out = Vec::new();
        for _ in 0..(secs / 0.02) as usize {
            *t += 0.02;
            let o = c.tick(*t, &meas(plant.depth_m, plant.heading_deg()), &pilot);
            let cmd = o.command;
            plant.step(
                cmd.port_pct(),
                cmd.starboard_pct(),
                cmd.vertical_pct(),
                0.02,
            );
            out.push((cmd, plant.depth_m, plant.heading_deg()));
        }
        out
    };
    run(
        &mut c,
        &mut plant,
        PilotInput {
            vertical: -0.3,
            yaw: 0.2,
            surge: 0.0,
        },
        5.0,
        &mut t,
    );
    // Sticks centred (still manual) for 3 s, then engage: the vehicle is coasting, and
    // sinking slowly because it is heavy.
    run(&mut c, &mut plant, PilotInput::default(), 3.0, &mut t);
    let mut prev = c.last_command();
    c.command(ModeCommand::Engage(Axis::Depth)).unwrap();
    c.command(ModeCommand::Engage(Axis::Heading)).unwrap();
    assert_eq!(c.axis_state(Axis::Depth).mode, AxisMode::Hold);
    let (d0, h0) = (plant.depth_m, plant.heading_deg());
    let trace = run(&mut c, &mut plant, PilotInput::default(), 10.0, &mut t);
    for (cmd, _, _) in &trace {
        for (a, b) in [
            (cmd.port_pct(), prev.port_pct()),
            (cmd.starboard_pct(), prev.starboard_pct()),
            (cmd.vertical_pct(), prev.vertical_pct()),
        ] {
            assert!((a - b).abs() <= max_step + 1e-9);
        }
        prev = *cmd;
    }
    let max_dd = trace
        .iter()
        .map(|(_, d, _)| (d - d0).abs())
        .fold(0.0, f64::max);
    let max_dh = trace
        .iter()
        .map(|(_, _, h)| rov_control::angle::wrap_deg_180(h - h0).abs())
        .fold(0.0, f64::max);
    assert!(max_dd <= 0.2, "depth moved {max_dd} m");
    assert!(max_dh <= 2.0, "heading moved {max_dh}°");
}
