//! Bad axle-model input: inconsistent geometry, negative levers, bellows that cannot carry the
//! static load, masses that contradict the scale weights, missing pressure channels when validation
//! is asked for — each a clear error naming the key.

use crate::common::fixture;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::sim::axle_validate::{validate_axle, AxleValidationConfig, AxleValidationError};
use fleetdyn::table::{DriveLog, DriveMeta, Signal};

fn seed_text() -> String {
    std::fs::read_to_string(fixture("fixtures/vehicles/seed002-6x2.toml")).unwrap()
}

/// The seed vehicle file with one `key = value` line replaced; the parse error text.
fn error_with(key: &str, value: &str) -> String {
    let text = seed_text();
    let line = text
        .lines()
        .find(|l| l.starts_with(&format!("{key} =")))
        .unwrap_or_else(|| panic!("{key} in the fixture"));
    let changed = text.replace(line, &format!("{key} = {value}"));
    match VehicleFile::parse(&changed, "v.toml") {
        Ok(_) => panic!("{key} = {value} was accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn inconsistent_geometry_is_an_error_naming_the_key() {
    let e = error_with("tag_axle_x_m", "4.0");
    assert!(
        e.contains("v.toml") && e.contains("axles.tag_axle_x_m"),
        "{e}"
    );
    assert!(e.contains("behind the driven axle"), "{e}");
    let e = error_with("rear_arm_l_b_m", "-0.95");
    assert!(
        e.contains("axles.rear_arm_l_b_m") && e.contains("-0.95"),
        "{e}"
    );
    // a 2.9 m arm would make the given arm inertia smaller than its axle's own m l_a²
    let e = error_with("rear_arm_l_a_m", "2.9");
    assert!(e.contains("axles.arm_inertia_rear_kg_m2"), "{e}");
    let e = error_with("tag_arm_l_a_m", "6.5");
    assert!(
        e.contains("axles.tag_arm_l_a_m") && e.contains("[0.05, 3] m"),
        "{e}"
    );
    let e = error_with("arm_inertia_rear_kg_m2", "100.0");
    assert!(
        e.contains("axles.arm_inertia_rear_kg_m2") && e.contains("own inertia"),
        "{e}"
    );
}

#[test]
fn bellows_that_cannot_carry_the_static_load_are_an_error() {
    let e = error_with("bellow_area_rear_m2", "0.02");
    assert!(e.contains("axles.bellow_area_rear_m2"), "{e}");
    assert!(e.contains("cannot carry the static load"), "{e}");
    // an axle heavier than its scale weight leaves the bellows nothing to carry
    let text = seed_text()
        .replace("axle_mass_tag_kg = 750.0", "axle_mass_tag_kg = 4400.0")
        .replace("chassis_mass_kg = 15800.0", "chassis_mass_kg = 12150.0")
        .replace(
            "arm_inertia_tag_kg_m2 = 400.0",
            "arm_inertia_tag_kg_m2 = 2500.0",
        );
    let e = VehicleFile::parse(&text, "v.toml").unwrap_err().to_string();
    assert!(
        e.contains("scale_weight_tag_kg") && e.contains("no load"),
        "{e}"
    );
}

#[test]
fn masses_must_agree_with_the_scale_weights_and_brake_shares_sum_to_one() {
    let e = error_with("chassis_mass_kg", "12000.0");
    assert!(
        e.contains("axles.chassis_mass_kg") && e.contains("1 %"),
        "{e}"
    );
    let e = error_with("service_brake_share_tag", "0.5");
    assert!(e.contains("sum to 1"), "{e}");
    let e = error_with(
        "damper_rear_extension_velocity_m_per_s",
        "[0.05, 0.03, 0.26, 0.52]",
    );
    assert!(
        e.contains("damper_rear_extension_velocity_m_per_s") && e.contains("increasing"),
        "{e}"
    );
    let e = error_with("damper_rear_extension_force_n", "[3000.0, 6800.0]");
    assert!(e.contains("as many values"), "{e}");
    let e = error_with("bellow_stiffness_front_n_per_m", "nan");
    assert!(e.contains("bellow_stiffness_front_n_per_m"), "{e}");
    let e = VehicleFile::parse(&(seed_text() + "\ncolour_rgb = 1\n"), "v.toml").unwrap_err();
    assert!(e.to_string().contains("colour_rgb"), "{e}");
}

#[test]
fn validation_without_pressure_channels_is_a_clear_error() {
    let v = VehicleFile::load(&fixture("fixtures/vehicles/seed002-6x2.toml")).unwrap();
    let n = 50;
    let log = DriveLog {
        meta: DriveMeta {
            drive_id: "d".into(),
            source_file: "drive.parquet".into(),
            segment: None,
            ..Default::default()
        },
        timestamp_ns: (0..n).map(|k| k as i64 * 100_000_000).collect(),
        signals: vec![
            Signal {
                name: "vehicle_speed".into(),
                unit: "m/s".into(),
                values: vec![10.0; n],
            },
            Signal {
                name: "bellow_pressure_rear".into(),
                unit: "Pa".into(),
                values: vec![5e5; n],
            },
            Signal {
                name: "bellow_pressure_tag".into(),
                unit: "Pa".into(),
                values: vec![f64::NAN; n],
            },
        ],
    };
    let e = validate_axle(
        &log,
        v.axles.as_ref().unwrap(),
        &v.gearbox.ratios,
        v.final_drive_ratio(),
        v.driveline.as_ref(),
        None,
        &AxleValidationConfig::default(),
    )
    .unwrap_err();
    match &e {
        AxleValidationError::MissingPressures { file, columns } => {
            assert_eq!(file, "drive.parquet");
            assert_eq!(columns, &["bellow_pressure_front", "bellow_pressure_tag"]);
        }
        other => panic!("{other}"),
    }
    assert!(e
        .to_string()
        .contains("bellow_pressure_front, bellow_pressure_tag"));
}
