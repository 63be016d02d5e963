//! Corpus of bad model parameter files: each case mutates one line of a shipped
//! config/models/*.toml and checks that the error names the file, the key path, the
//! offending value and the allowed range.

use rov_dynamics::models::{default_model_text, load_model};
use rov_types::ConfigError;

struct Case {
    model: &'static str,
    /// Text to replace (must occur in the shipped file) and its replacement.
    find: &'static str,
    replace: &'static str,
    /// Substrings the message must contain (besides the file label).
    expect: &'static [&'static str],
}

const CASES: &[Case] = &[
    // Missing key.
    Case {
        model: "model3",
        find: r#"mass_kg = { value = 6.1, unit = "kg", source = "paper (seed 000: VideoRay spec sheet)" }"#,
        replace: "",
        expect: &["key rigid_body.mass_kg is missing", "allowed 0.1..=100"],
    },
    // NaN.
    Case {
        model: "model1",
        find: "surge_quadratic_ns2pm2 = { value = 7.9,",
        replace: "surge_quadratic_ns2pm2 = { value = nan,",
        expect: &["key drag.surge_quadratic_ns2pm2 = NaN", "allowed 0..=1000"],
    },
    // Out of range.
    Case {
        model: "model2",
        find: "mass_kg = { value = 6.1,",
        replace: "mass_kg = { value = -6.1,",
        expect: &["key rigid_body.mass_kg = -6.1", "allowed 0.1..=100"],
    },
    // Wrong sign for a Fossen-signed derivative.
    Case {
        model: "model2",
        find: "x_udot_kg = { value = -2.5,",
        replace: "x_udot_kg = { value = 2.5,",
        expect: &["key added_mass.x_udot_kg = 2.5", "allowed -100..=0"],
    },
    // Array entry out of range.
    Case {
        model: "model3",
        find: "cg_from_co_m = { value = [0.0, 0.0, 0.00559],",
        replace: "cg_from_co_m = { value = [0.0, 0.0, 0.9],",
        expect: &["key rigid_body.cg_from_co_m[2] = 0.9", "allowed -0.5..=0.5"],
    },
    // Infinite thrust coefficient.
    Case {
        model: "model1",
        find: "forward_quadratic_n = { value = 9.0,",
        replace: "forward_quadratic_n = { value = inf,",
        expect: &[
            "key thrusters.vertical.forward_quadratic_n = inf",
            "allowed 0..=200",
        ],
    },
    // Bad option.
    Case {
        model: "model3",
        find: r#"munk_moment = "zeroed""#,
        replace: r#"munk_moment = "half""#,
        expect: &[
            "key options.munk_moment = \"half\"",
            "allowed one of zeroed, full",
        ],
    },
    // Thruster direction not a unit vector.
    Case {
        model: "model3",
        find: "direction = { value = [0.0, 0.0, 1.0],",
        replace: "direction = { value = [0.0, 0.5, 1.0],",
        expect: &[
            "key thrusters.vertical.direction = [0, 0.5, 1]",
            "allowed a unit vector",
        ],
    },
    // Missing provenance.
    Case {
        model: "model2",
        find: r#"g2_n_per_pct = { value = 0.10, unit = "N/%", source = "estimate: 10 N vertical at 100 % (parameters.md s.3)" }"#,
        replace: r#"g2_n_per_pct = { value = 0.10, unit = "N/%" }"#,
        expect: &["key thrust_map.g2_n_per_pct lacks its source"],
    },
    // Typo in a key.
    Case {
        model: "model1",
        find: "yaw_radius_m = {",
        replace: "yaw_radius_mm = {",
        expect: &["geometry.yaw_radius_m is missing"],
    },
    // Wrong type.
    Case {
        model: "model1",
        find: "alpha_w = { value = 1.0,",
        replace: "alpha_w = { value = \"one\",",
        expect: &[
            "key tuning.alpha_w = \"one\" has the wrong type",
            "a number",
        ],
    },
];

#[test]
fn every_bad_file_names_file_key_value_and_range() {
    for (i, c) in CASES.iter().enumerate() {
        let good = default_model_text(c.model).unwrap();
        assert!(
            good.contains(c.find),
            "case {i}: pattern not in {}.toml: {}",
            c.model,
            c.find
        );
        let bad = good.replacen(c.find, c.replace, 1);
        let label = format!("bad/{}_{i}.toml", c.model);
        let Err(err) = load_model(c.model, &bad, &label) else {
            panic!("case {i} must fail");
        };
        let msg = err.to_string();
        assert!(msg.starts_with(&format!("{label}: ")), "case {i}: {msg}");
        for e in c.expect {
            assert!(msg.contains(e), "case {i}: {msg:?} lacks {e:?}");
        }
    }
}

#[test]
fn unknown_keys_and_name_mismatch_are_rejected() {
    let good = default_model_text("model3").unwrap();
    let bad = format!(
        "{good}\n[extra]\nspeed_knots = {{ value = 4.0, unit = \"kn\", source = \"x\" }}\n"
    );
    let err = load_model("model3", &bad, "m3.toml").unwrap_err();
    assert!(
        matches!(err, ConfigError::UnknownKey { ref key, .. } if key == "extra.speed_knots"),
        "{err}"
    );
    let err = load_model("model2", good, "m3.toml").unwrap_err();
    assert!(
        err.to_string()
            .contains("key model = \"model3\" but the file was loaded as \"model2\""),
        "{err}"
    );
    let err = load_model("model9", good, "m3.toml").unwrap_err();
    assert!(
        err.to_string().contains("one of model1, model2, model3"),
        "{err}"
    );
}

#[test]
fn shipped_files_load() {
    for name in ["model1", "model2", "model3"] {
        let m = load_model(name, default_model_text(name).unwrap(), name).unwrap();
        assert_eq!(m.name(), name);
    }
}
