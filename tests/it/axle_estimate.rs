//! Parameter estimation of the axle-load thesis, §3.3, from a measurement file
//! (`fleetdyn estimate axle`): the round trip through the vehicle file's own static state, the
//! thesis's weighed truck against a hand computation, the CLI on the example file, and bad input (a
//! clear error naming the file and key, exit code 2, no snippet left behind).

use crate::common::fixture;
use fleetdyn::model::axle::{Axle, AxleParams};
use fleetdyn::model::axle_estimate::estimate;
use fleetdyn::model::axle_estimation::EstimationError;
use fleetdyn::model::axle_measurement::{MeasurementError, Measurements};
use fleetdyn::model::vehicle::VehicleFile;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const VEHICLE: &str = "fixtures/vehicles/seed002-6x2.toml";
const EXAMPLE: &str = "fixtures/measurements/seed002-static.toml";

fn seed_truck() -> AxleParams {
    VehicleFile::load(&fixture(VEHICLE))
        .unwrap()
        .axles
        .expect("the thesis truck has an [axles] section")
}

fn rel_err(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// A measurement file at the vehicle file's own state: its scale weights, its static-state
/// pressures (written with `{:?}`, which round-trips an f64 exactly), a bellow test on each axle
/// along its own stiffness, and its rear damper tables as a signed datasheet.
fn round_trip_text(p: &AxleParams) -> String {
    let st = p.static_state();
    let mut s = format!(
        "[scale]\nfront_kg = {:?}\nrear_kg = {:?}\ntag_kg = {:?}\n[static_pressure]\nfront_pa = {:?}\nrear_pa = {:?}\ntag_pa = {:?}\n",
        p.scale_weight_front_kg,
        p.scale_weight_rear_kg,
        p.scale_weight_tag_kg,
        st.pressure_pa[0],
        st.pressure_pa[1],
        st.pressure_pa[2]
    );
    let x = [-0.02, -0.01, 0.0, 0.01, 0.02];
    for (k, a) in Axle::ALL.iter().enumerate() {
        let f: Vec<f64> = x
            .iter()
            .map(|d| st.bellow_n[k] + p.bellow_stiffness(*a) * d)
            .collect();
        s += &format!(
            "[[bellow_test]]\naxle = \"{}\"\ndisplacement_m = {x:?}\nforce_n = {f:?}\n",
            a.name()
        );
    }
    let d = p.damper(Axle::Rear);
    let v: Vec<f64> = d.comp_v.iter().map(|v| -v).chain(d.ext_v.clone()).collect();
    let f: Vec<f64> = d.comp_f.iter().map(|f| -f).chain(d.ext_f.clone()).collect();
    s += &format!(
        "[[damper_datasheet]]\naxle = \"rear\"\nvelocity_m_per_s = {v:?}\nforce_n = {f:?}\n"
    );
    s
}

#[test]
fn round_trip_through_the_static_state_returns_the_vehicle_file() {
    let p = seed_truck();
    let st = p.static_state();
    let m = Measurements::parse(&round_trip_text(&p), "round-trip.toml").unwrap();
    let e = estimate(&m, &p, VEHICLE).unwrap();
    // 1e-9 relative: every step is a few products and quotients of the same numbers
    const REL: f64 = 1e-9;
    for (k, a) in Axle::ALL.iter().enumerate() {
        let area = e.bellow_area_m2[k].expect("a static pressure was given");
        assert!(
            rel_err(area, p.bellow_area(*a)) < REL,
            "{}: area {area} m² vs the file's {}",
            a.name(),
            p.bellow_area(*a)
        );
        assert!(rel_err(e.bellow_force_n[k], st.bellow_n[k]) < REL);
        let k_est = e.bellow_stiffness_n_per_m(*a).unwrap();
        assert!(rel_err(k_est, p.bellow_stiffness(*a)) < REL, "{k_est}");
    }
    assert!(
        rel_err(e.chassis_x_cg_m, st.chassis_x_cg_m) < REL,
        "chassis CG {} m vs the static state's {} m",
        e.chassis_x_cg_m,
        st.chassis_x_cg_m
    );
    assert!(rel_err(e.x_cg_m, st.x_cg_m) < REL);
    assert!(rel_err(e.chassis_mass_kg, p.chassis_mass_kg) < REL);
    assert!(rel_err(e.mass_kg, p.mass_kg()) < REL);
    // the datasheet comes back as the file's own tables
    assert_eq!(e.damper(Axle::Rear).unwrap().table, p.damper(Axle::Rear));
    // and the comparison shows no difference anywhere
    for r in e.comparison(&p).rows {
        let cur = r.vehicle.expect("every row has a vehicle-file value");
        assert!(
            rel_err(r.estimate, cur) < REL,
            "{}: {} vs {cur}",
            r.quantity,
            r.estimate
        );
    }
}

#[test]
fn seed_scale_weights_give_the_hand_computed_cg() {
    let p = seed_truck();
    let m = Measurements::load(&fixture(EXAMPLE)).unwrap();
    assert_eq!(
        m.scale_weight_kg,
        [7600.0, 6800.0, 4300.0],
        "axle-load thesis table 4.2"
    );
    let e = estimate(&m, &p, VEHICLE).unwrap();
    // by hand, rear axle at 4.7 m, tag axle at 6.05 m (the vehicle file):
    // vehicle  x_CG = (6800·4.7 + 4300·6.05)/18700 = 57975/18700
    // chassis  m_c  = 18700 − (850 + 1300 + 750) = 15800 kg
    //          x_c  = ((6800 − 1300)·4.7 + (4300 − 750)·6.05)/15800 = 47327.5/15800
    assert_eq!(e.mass_kg, 18700.0);
    assert!((e.x_cg_m - 57975.0 / 18700.0).abs() < 1e-12, "{}", e.x_cg_m);
    assert_eq!(e.chassis_mass_kg, 15800.0);
    assert!(
        (e.chassis_x_cg_m - 47327.5 / 15800.0).abs() < 1e-12,
        "{}",
        e.chassis_x_cg_m
    );
    // bellow forces by hand: front (7600 − 850)·9.81; rear (6800 − 1300)·9.81·0.6/0.95
    assert!((e.bellow_force_n[0] - 6750.0 * 9.81).abs() < 1e-9);
    assert!((e.bellow_force_n[1] - 5500.0 * 9.81 * 0.6 / 0.95).abs() < 1e-9);
    // the example's pressures are the model's at 7500/6900/4300 kg: the front and rear areas
    // move by the load ratio on their bellows, the tag area (weighed as modelled) stays
    let a = e.bellow_area_m2.map(Option::unwrap);
    assert!((a[0] / p.bellow_area_front_m2 - 6750.0 / 6650.0).abs() < 1e-5);
    assert!((a[1] / p.bellow_area_rear_m2 - 5500.0 / 5600.0).abs() < 1e-5);
    assert!((a[2] / p.bellow_area_tag_m2 - 1.0).abs() < 1e-5);
    // the illustrative tag test returns the file's stiffness to its 0.1 kPa rounding
    let s = &e.stiffness[0];
    assert_eq!((s.axle, s.from_pressure), (Axle::Tag, true));
    assert!(rel_err(s.fit.slope, p.bellow_stiffness_tag_n_per_m) < 2e-3);
    assert!(s.fit.r2 > 0.9999);
}

fn run_cli(measurements: &Path, vehicle: &Path, out: Option<&Path>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_fleetdyn"));
    c.args(["estimate", "axle"])
        .arg(measurements)
        .arg("--vehicle")
        .arg(vehicle);
    if let Some(o) = out {
        c.arg("-o").arg(o);
    }
    c.output().unwrap()
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn cli_prints_the_table_and_writes_a_snippet_the_vehicle_file_accepts() {
    let dir = tempfile::tempdir().unwrap();
    let snippet = dir.path().join("axles-estimate.toml");
    let out = run_cli(&fixture(EXAMPLE), &fixture(VEHICLE), Some(&snippet));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    assert!(lines[1].starts_with("quantity"), "{stdout}");
    for col in ["estimate", "unit", "vehicle file", "difference"] {
        assert!(lines[1].contains(col), "{stdout}");
    }
    // the chassis CG row: estimate 47327.5/15800 m, the vehicle file's static state beside it
    let row = lines
        .iter()
        .find(|l| l.starts_with("chassis CG x"))
        .expect("a chassis CG row");
    assert!(row.contains("2.99541") && row.contains(" m "), "{row}");
    for q in [
        "vehicle CG x",
        "chassis mass",
        "static bellow force rear",
        "bellow area front",
        "bellow area tag",
        "bellow stiffness tag, bellow_test[0]",
        "damper rear extension",
        "damper rear compression",
    ] {
        assert!(stdout.contains(q), "no row {q:?}:\n{stdout}");
    }
    assert_eq!(
        names(dir.path()),
        ["axles-estimate.toml"],
        "no temporary left"
    );

    // merge the snippet into the vehicle file's [axles], replacing those keys
    let text = std::fs::read_to_string(&snippet).unwrap();
    assert!(text.starts_with("# [axles] keys estimated by `fleetdyn estimate axle`"));
    let snip: toml::Table = toml::from_str(&text).unwrap();
    let new = snip["axles"].as_table().unwrap();
    let mut keys: Vec<&str> = new.keys().map(String::as_str).collect();
    keys.sort_unstable();
    let mut want = vec![
        "scale_weight_front_kg",
        "scale_weight_rear_kg",
        "scale_weight_tag_kg",
        "chassis_mass_kg",
        "bellow_area_front_m2",
        "bellow_area_rear_m2",
        "bellow_area_tag_m2",
        "bellow_stiffness_tag_n_per_m",
        "damper_rear_extension_velocity_m_per_s",
        "damper_rear_extension_force_n",
        "damper_rear_compression_velocity_m_per_s",
        "damper_rear_compression_force_n",
    ];
    want.sort_unstable();
    assert_eq!(keys, want);
    let mut doc: toml::Table =
        toml::from_str(&std::fs::read_to_string(fixture(VEHICLE)).unwrap()).unwrap();
    let axles = doc["axles"].as_table_mut().unwrap();
    for (k, v) in new {
        assert!(axles.contains_key(k), "{k} is a vehicle-file key");
        axles.insert(k.clone(), v.clone());
    }
    let merged = VehicleFile::parse(&toml::to_string(&doc).unwrap(), "merged.toml")
        .unwrap()
        .axles
        .unwrap();
    assert_eq!(
        [
            merged.scale_weight_front_kg,
            merged.scale_weight_rear_kg,
            merged.scale_weight_tag_kg
        ],
        [7600.0, 6800.0, 4300.0]
    );
    assert_eq!(merged.chassis_mass_kg, 15800.0);
    // the merged truck's static pressures are the measured ones (areas to 6 digits)
    let st = merged.static_state();
    for (k, p_meas) in [600152.0, 499948.0, 350798.0].iter().enumerate() {
        assert!(
            rel_err(st.pressure_pa[k], *p_meas) < 1e-5,
            "{k}: {}",
            st.pressure_pa[k]
        );
    }
    assert_eq!(merged.damper(Axle::Rear), seed_truck().damper(Axle::Rear));
}

/// Writes `text` as `name` into `dir` and returns its path.
fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The CLI rejects the input with exit code 2 and a message naming `file` and every `needle`,
/// and writes no snippet.
fn assert_rejected(measurements: &Path, vehicle: &Path, file: &Path, needles: &[&str]) {
    let dir = measurements.parent().unwrap();
    let before = names(dir);
    let snippet = dir.join("snippet.toml");
    let out = run_cli(measurements, vehicle, Some(&snippet));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&file.display().to_string()),
        "names the file: {stderr}"
    );
    for n in needles {
        assert!(stderr.contains(n), "{n:?} missing: {stderr}");
    }
    assert!(!snippet.exists(), "snippet written despite: {stderr}");
    assert_eq!(names(dir), before, "a file was left behind");
}

#[test]
fn bad_measurements_and_vehicle_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let example = std::fs::read_to_string(fixture(EXAMPLE)).unwrap();
    let vehicle_text = std::fs::read_to_string(fixture(VEHICLE)).unwrap();
    let vehicle = fixture(VEHICLE);
    let edit = |from: &str, to: &str| {
        assert!(example.contains(from), "{from}");
        example.replacen(from, to, 1)
    };

    let m = write(
        d,
        "unknown.toml",
        &edit("tag_kg = 4300.0", "tag_kg = 4300.0\nfront_lb = 16755.0"),
    );
    assert_rejected(&m, &vehicle, &m, &["unknown field `front_lb`"]);

    let m = write(
        d,
        "negative.toml",
        &edit("rear_kg = 6800.0", "rear_kg = -6800.0"),
    );
    assert_rejected(&m, &vehicle, &m, &["scale.rear_kg = -6800", "positive"]);

    let m = write(
        d,
        "zero-pressure.toml",
        &edit("rear_pa = 499948.0", "rear_pa = 0.0"),
    );
    assert_rejected(
        &m,
        &vehicle,
        &m,
        &["static_pressure.rear_pa = 0", "positive"],
    );

    let m = write(
        d,
        "no-load.toml",
        &edit("tag_kg = 4300.0", "tag_kg = 700.0"),
    );
    assert_rejected(
        &m,
        &vehicle,
        &m,
        &["scale.tag_kg", "700 kg", "axle mass 750 kg", "no load"],
    );

    let m = fixture(EXAMPLE);
    assert!(vehicle_text.contains("tag_axle_x_m = 6.05"));
    let v = write(
        d,
        "tag-ahead.toml",
        &vehicle_text.replacen("tag_axle_x_m = 6.05", "tag_axle_x_m = 4.0", 1),
    );
    let out = run_cli(&m, &v, Some(&d.join("snippet.toml")));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("tag-ahead.toml") && stderr.contains("axles.tag_axle_x_m = 4"),
        "{stderr}"
    );
    assert!(!d.join("snippet.toml").exists());
}

#[test]
fn tag_axle_ahead_of_the_driven_axle_is_a_geometry_error_in_the_library() {
    // the vehicle-file check above stops this first; the estimation itself refuses it too
    let mut p = seed_truck();
    p.tag_axle_x_m = 4.0;
    let m = Measurements::load(&fixture(EXAMPLE)).unwrap();
    match estimate(&m, &p, "v.toml") {
        Err(MeasurementError::Estimate {
            file,
            key,
            source: EstimationError::Geometry(why),
        }) => {
            assert_eq!(
                (file.as_str(), key.as_str()),
                ("v.toml", "axles.tag_axle_x_m")
            );
            assert!(why.contains("not behind the driven axle"), "{why}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn inconsistent_tests_and_datasheets_name_their_entry() {
    let p = seed_truck();
    let base = "[scale]\nfront_kg = 7600.0\nrear_kg = 6800.0\ntag_kg = 4300.0\n";
    let err = |extra: &str| {
        let text = format!("{base}{extra}");
        match Measurements::parse(&text, "m.toml") {
            Err(e) => e.to_string(),
            Ok(m) => match estimate(&m, &p, "v.toml") {
                Err(e) => e.to_string(),
                Ok(_) => panic!("accepted:\n{text}"),
            },
        }
    };
    // a pressure test needs the axle's static pressure for A_eff
    let e = err("[[bellow_test]]\naxle = \"rear\"\ndisplacement_m = [0.0, 0.01]\npressure_pa = [5e5, 5.2e5]\n");
    assert!(
        e.starts_with("m.toml: bellow_test[0].pressure_pa")
            && e.contains("static_pressure.rear_pa"),
        "{e}"
    );
    // both a force and a pressure
    let e = err("[[bellow_test]]\naxle = \"rear\"\ndisplacement_m = [0.0, 0.01]\nforce_n = [1.0, 2.0]\npressure_pa = [5e5, 5.2e5]\n");
    assert!(
        e.starts_with("m.toml: bellow_test[0] ") && e.contains("exactly one"),
        "{e}"
    );
    // displacement as extension: the force falls
    let e = err("[[bellow_test]]\naxle = \"tag\"\ndisplacement_m = [0.0, 0.01]\nforce_n = [22000.0, 21000.0]\n");
    assert!(
        e.contains("bellow_test[0].displacement_m") && e.contains("compression"),
        "{e}"
    );
    // too few points for a line
    let e = err("[[bellow_test]]\naxle = \"tag\"\ndisplacement_m = [0.0]\nforce_n = [22000.0]\n");
    assert!(
        e.starts_with("m.toml: bellow_test[0]: bellow force-displacement fit"),
        "{e}"
    );
    // an unknown axle
    let e = err(
        "[[bellow_test]]\naxle = \"middle\"\ndisplacement_m = [0.0, 0.1]\nforce_n = [1.0, 2.0]\n",
    );
    assert!(e.contains("m.toml") && e.contains("middle"), "{e}");
    // two datasheets for one axle
    let sheet = "[[damper_datasheet]]\naxle = \"front\"\nvelocity_m_per_s = [-0.1, -0.05, 0.05, 0.1]\nforce_n = [-2.0, -1.0, 1.0, 2.0]\n";
    let e = err(&format!("{sheet}{sheet}"));
    assert!(
        e.contains("damper_datasheet[1].axle") && e.contains("damper_datasheet[0]"),
        "{e}"
    );
    // a compression force written positive
    let e = err("[[damper_datasheet]]\naxle = \"front\"\nvelocity_m_per_s = [-0.1, -0.05, 0.05, 0.1]\nforce_n = [2.0, 1.0, 1.0, 2.0]\n");
    assert!(
        e.contains("damper_datasheet[0].force_n") && e.contains("sign"),
        "{e}"
    );
    // one compression point only: the vehicle file's tables need two
    let e = err("[[damper_datasheet]]\naxle = \"front\"\nvelocity_m_per_s = [-0.05, 0.05, 0.1]\nforce_n = [-1.0, 1.0, 2.0]\n");
    assert!(
        e.contains("damper_datasheet[0].velocity_m_per_s") && e.contains("compression"),
        "{e}"
    );
}

#[test]
fn estimates_the_vehicle_file_cannot_take_are_not_written() {
    // a bellow test with a 500 N/m slope: a valid estimate, below the schema's 1000 N/m
    let dir = tempfile::tempdir().unwrap();
    let m = write(
        dir.path(),
        "soft.toml",
        "[scale]\nfront_kg = 7600.0\nrear_kg = 6800.0\ntag_kg = 4300.0\n[[bellow_test]]\naxle = \"tag\"\ndisplacement_m = [0.0, 0.02]\nforce_n = [22000.0, 22010.0]\n",
    );
    let vehicle = fixture(VEHICLE);
    // without -o the table is printed and the run succeeds
    let out = run_cli(&m, &vehicle, None);
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout).contains("bellow stiffness tag"));
    assert_rejected(
        &m,
        &vehicle,
        &vehicle,
        &["axles.bellow_stiffness_tag_n_per_m = 500", "within [1000"],
    );
}
