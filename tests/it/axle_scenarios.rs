//! The scripted axle-load scenarios of the axle-load thesis, §4.3, on the thesis truck
//! (fixtures/vehicles/seed002-6x2.toml): the directions the thesis observes (§5.1), the point-mass
//! inputs, the slip-limited auxiliary brake torque, and the `axle_sim` output (Parquet with the
//! schema's columns and units, SVG plots, all-or-nothing writes).

use crate::common::fixture;
use arrow::array::{Array, Float64Array, TimestampNanosecondArray};
use fleetdyn::io::TableMeta;
use fleetdyn::model::axle::{Axle, AxleParams};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::report::axle_scenario::{run_scenario, RunScenarioError, FILES};
use fleetdyn::report::axle_sim::{write_axle_sim, AxleSimExtra, TimeAxis};
use fleetdyn::schema::output_schema;
use fleetdyn::sim::axle::{AxleInputs, AxleTrajectory, HalfTruck};
use fleetdyn::sim::axle_scenarios::{
    full_acceleration, hard_aux_braking, stop_and_go, AxleScenarioConfig, ScenarioError,
    ScenarioInputs,
};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::Path;

fn seed_truck() -> AxleParams {
    VehicleFile::load(&fixture("fixtures/vehicles/seed002-6x2.toml"))
        .unwrap()
        .axles
        .expect("the thesis truck has an [axles] section")
}

fn simulate(p: &AxleParams, sc: &ScenarioInputs) -> AxleTrajectory {
    HalfTruck::new(p).simulate(&sc.inputs, &sc.t_s, sc.start)
}

/// Index of the first sample at or after `t`.
fn at(t_s: &[f64], t: f64) -> usize {
    t_s.partition_point(|&x| x < t - 1e-9)
}

#[test]
fn full_acceleration_loads_the_driven_axle_and_lifts_the_chassis() {
    let p = seed_truck();
    let cfg = AxleScenarioConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let rep = run_scenario("full-acceleration", &p, "SEED002-6X2", dir.path()).unwrap();
    println!("{rep}");
    let [front, rear, _tag] = rep.summary.axles;
    assert!(rear.normal_change_n > 0.0, "{rear:?}");
    assert!(front.normal_change_n < 0.0, "{front:?}");
    assert!(
        (rear.normal_change_kg - rear.normal_change_n / p.gravity_m_per_s2).abs() < 1e-9,
        "kg is N/g"
    );

    let sc = full_acceleration(&p, &cfg).unwrap();
    let tr = simulate(&p, &sc);
    let st = *HalfTruck::new(&p).static_state();
    // at rest before the torque ramp: exactly the static state
    let k0 = at(&tr.t_s, cfg.acceleration_start_s);
    for i in 0..3 {
        assert!((tr.pressure_pa[i][k0] - st.pressure_pa[i]).abs() < 1e-6);
    }
    // thesis §5.1: "at the onset of acceleration, the pressure decreases in all three axes" —
    // the first excursion beyond 1 kPa (10 mbar) after the torque starts is a fall, within 1 s
    for (i, a) in Axle::ALL.iter().enumerate() {
        let k = (k0..tr.t_s.len())
            .find(|&k| (tr.pressure_pa[i][k] - st.pressure_pa[i]).abs() > 1e3)
            .unwrap_or_else(|| panic!("{}: no pressure change", a.name()));
        let dp = tr.pressure_pa[i][k] - st.pressure_pa[i];
        println!(
            "{}: first |dp| > 1 kPa at t = {:.2} s, dp = {dp:.0} Pa",
            a.name(),
            tr.t_s[k]
        );
        assert!(dp < 0.0, "{}: pressure rises first ({dp} Pa)", a.name());
        assert!(tr.t_s[k] < cfg.acceleration_start_s + 1.0, "{}", a.name());
    }
    // the speed rises monotonically from rest to the 90 km/h limiter, never above it
    assert!(sc.speed_mps.windows(2).all(|w| w[1] >= w[0]));
    assert_eq!(sc.speed_mps[k0], 0.0);
    let top = *sc.speed_mps.last().unwrap();
    println!(
        "speed at {} s: {top:.3} m/s; 80 km/h at {:.2} s",
        cfg.acceleration_end_s,
        sc.t_s[sc.speed_mps.partition_point(|&v| v < 80.0 / 3.6)]
    );
    assert!(
        top <= cfg.max_speed_mps && top > 0.95 * cfg.max_speed_mps,
        "{top}"
    );
    // the acceleration input is the point mass's: its integral is the speed trace (trapezoid
    // on the 10 ms grid; the RK4 speed differs from it by the interpolation error only)
    let mut v = 0.0;
    let mut worst: f64 = 0.0;
    for k in 1..sc.t_s.len() {
        let h = sc.t_s[k] - sc.t_s[k - 1];
        v += 0.5
            * h
            * (sc.inputs.accel_mps2.eval(sc.t_s[k - 1]) + sc.inputs.accel_mps2.eval(sc.t_s[k]));
        worst = worst.max((v - sc.speed_mps[k]).abs());
    }
    println!("max |integral of the acceleration input - speed| = {worst:.2e} m/s");
    assert!(worst < 1e-2, "{worst}");
    // the longitudinal forces agree: what the axle model puts at the resistance height is
    // rolling resistance plus drag of the point mass, at every sample where the truck moves
    let model = HalfTruck::new(&p);
    let mg = st.mass_kg * p.gravity_m_per_s2;
    for (k, &t) in sc
        .t_s
        .iter()
        .enumerate()
        .filter(|(k, _)| sc.speed_mps[*k] > 0.0)
    {
        let v = sc.speed_mps[k];
        let want = -(cfg.rolling_resistance_coefficient * mg
            + 0.5 * cfg.air_density_kg_per_m3 * cfg.drag_area_m2 * v * v);
        let got = model.longitudinal(&sc.inputs, t).resistance_n;
        assert!((got - want).abs() < 1e-6, "t = {t}: {got} vs {want}");
    }
    // torques never step: at most one full ramp per ramp time between samples
    let drive = sc.inputs.drive_torque_wheel_nm.as_ref().unwrap();
    let max_step = cfg.max_drive_torque_wheel_nm / cfg.torque_ramp_s / cfg.sample_rate_hz;
    for w in sc.t_s.windows(2) {
        assert!((drive.eval(w[1]) - drive.eval(w[0])).abs() <= max_step * (1.0 + 1e-9));
    }

    check_parquet(&dir.path().join(FILES[0]), tr.t_s.len(), p.gravity_m_per_s2);
    for f in &FILES[1..] {
        let svg = std::fs::read_to_string(dir.path().join(f)).unwrap();
        assert!(svg.starts_with("<svg") || svg.contains("<svg"), "{f}");
        assert!(
            svg.contains("SEED002-6X2") && svg.contains("full-acceleration"),
            "{f}"
        );
    }
}

/// The file has the schema's columns (less the optional `timestamp`) with their units, one row
/// per sample, the tonnes columns equal to N/g/1000, and the table metadata.
fn check_parquet(path: &Path, rows: usize, g: f64) {
    let file = std::fs::File::open(path).unwrap();
    let b = ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
    let schema = b.schema().clone();
    let expected: Vec<_> = output_schema("axle_sim")
        .unwrap()
        .columns
        .iter()
        .filter(|c| !c.optional)
        .collect();
    assert_eq!(schema.fields().len(), expected.len());
    for (f, c) in schema.fields().iter().zip(&expected) {
        assert_eq!(f.name(), &c.name);
        assert_eq!(f.metadata().get("unit"), Some(&c.unit), "{}", c.name);
    }
    assert_eq!(
        schema.metadata().get("table").map(String::as_str),
        Some("axle_sim")
    );
    assert_eq!(
        schema.metadata().get("vehicle_id").map(String::as_str),
        Some("SEED002-6X2")
    );
    let batches: Vec<_> = b.build().unwrap().map(Result::unwrap).collect();
    assert_eq!(batches.iter().map(|b| b.num_rows()).sum::<usize>(), rows);
    let col = |name: &str| -> Vec<f64> {
        batches
            .iter()
            .flat_map(|b| {
                b.column_by_name(name)
                    .unwrap()
                    .as_any()
                    .downcast_ref::<Float64Array>()
                    .unwrap()
                    .values()
                    .to_vec()
            })
            .collect()
    };
    for a in ["front", "rear", "tag"] {
        let n = col(&format!("normal_force_{a}"));
        let t = col(&format!("normal_force_{a}_t"));
        for (x, y) in n.iter().zip(&t) {
            assert!((x / g / 1000.0 - y).abs() <= 1e-12 * y.abs());
        }
    }
    let time = col("time");
    assert_eq!(time[0], 0.0);
}

#[test]
fn aux_braking_unloads_the_driven_axle_and_its_slip_limit() {
    let p = seed_truck();
    let cfg = AxleScenarioConfig::default();
    let dir = tempfile::tempdir().unwrap();
    let rep = run_scenario("aux-braking", &p, "SEED002-6X2", dir.path()).unwrap();
    println!("{rep}");
    let [front, rear, tag] = rep.summary.axles;
    // thesis §5.1: the driven axle's normal force falls, front and tag rise
    assert!(rear.normal_change_n < 0.0, "{rear:?}");
    assert!(front.normal_change_n > 0.0, "{front:?}");
    assert!(tag.normal_change_n > 0.0, "{tag:?}");
    for a in &rep.summary.axles {
        let t = a.normal_peak_time_s;
        assert!(
            t > cfg.braking_start_s && t < cfg.braking_end_s,
            "{}: peak at {t} s",
            a.axle.name()
        );
    }

    let sc = hard_aux_braking(&p, &cfg).unwrap();
    let tr = simulate(&p, &sc);
    let st = *HalfTruck::new(&p).static_state();
    for (i, a) in Axle::ALL.iter().enumerate() {
        println!(
            "{}: steady cruise before braking dN = {:+.1} kg, dp = {:+.4} bar from static",
            a.name(),
            (tr.normal_n[i][0] - st.normal_n[i]) / p.gravity_m_per_s2,
            (tr.pressure_pa[i][0] - st.pressure_pa[i]) / 1e5
        );
    }
    // constant speed before braking, falling while the brake is held
    let k_on = at(&sc.t_s, cfg.braking_start_s);
    let k_off = at(
        &sc.t_s,
        cfg.braking_start_s + cfg.torque_ramp_s + cfg.braking_hold_s,
    );
    assert!(sc.speed_mps[..=k_on]
        .iter()
        .all(|v| (v - cfg.braking_speed_mps).abs() < 1e-9));
    assert!(sc.speed_mps[k_on..=k_off].windows(2).all(|w| w[1] < w[0]));
    println!(
        "speed {:.3} -> {:.3} m/s over the braking",
        sc.speed_mps[k_on], sc.speed_mps[k_off]
    );

    // the slip-limited torque is min(k i_lim, mu) N_rear r_w at every sample (thesis eq. 1.1.1)
    let mu_eff =
        (p.slip_stiffness_normalised * p.slip_ratio_limit).min(p.road_friction_coefficient);
    for (lim, n) in tr.aux_brake_limit_wheel_nm.iter().zip(&tr.normal_n[1]) {
        let want = mu_eff * n.max(0.0) * p.wheel_radius_m;
        assert!((lim - want).abs() <= 1e-9 * want, "{lim} vs {want}");
    }
    // braking lowers it below its static value (the thesis's motivation: the slip-keeping brake
    // force is smaller while braking), and the applied torque stays under it here
    let static_limit = mu_eff * HalfTruck::new(&p).static_state().normal_n[1] * p.wheel_radius_m;
    let during = &tr.aux_brake_limit_wheel_nm[k_on..=k_off];
    let lowest = during.iter().copied().fold(f64::INFINITY, f64::min);
    println!("slip-limited aux torque: static {static_limit:.0} N*m, lowest while braking {lowest:.0} N*m");
    assert!(lowest < static_limit);
    let aux = sc.inputs.aux_brake_torque_wheel_nm.as_ref().unwrap();
    let margin = tr
        .t_s
        .iter()
        .zip(&tr.aux_brake_limit_wheel_nm)
        .map(|(&t, lim)| lim - aux.eval(t))
        .fold(f64::INFINITY, f64::min);
    println!("smallest margin limit - applied: {margin:.0} N*m");
    assert!(margin > 0.0);
}

#[test]
fn acceleration_raises_the_slip_limit_that_braking_lowers() {
    let p = seed_truck();
    let cfg = AxleScenarioConfig::default();
    let acc = simulate(&p, &full_acceleration(&p, &cfg).unwrap());
    let brk = simulate(&p, &hard_aux_braking(&p, &cfg).unwrap());
    let max = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let min = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(min(&brk.aux_brake_limit_wheel_nm) < max(&acc.aux_brake_limit_wheel_nm));
    assert!(min(&brk.normal_n[1]) < max(&acc.normal_n[1]));
}

fn recorded<'a>(ts: &'a [i64], inputs: &'a AxleInputs, g: f64) -> AxleSimExtra<'a> {
    AxleSimExtra {
        time: TimeAxis::Recorded { timestamp_ns: ts },
        inputs,
        vehicle_speed_mps: None,
        gravity_m_per_s2: g,
    }
}

#[test]
fn recorded_time_axis_writes_timestamps_and_rejects_wrong_lengths() {
    let p = seed_truck();
    let cfg = AxleScenarioConfig {
        acceleration_end_s: 4.0,
        sample_rate_hz: 10.0,
        ..Default::default()
    };
    let sc = full_acceleration(&p, &cfg).unwrap();
    let tr = simulate(&p, &sc);
    let t0 = crate::common::T0_NS;
    let ts: Vec<i64> = tr
        .t_s
        .iter()
        .map(|t| t0 + (t * 1e9).round() as i64)
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("axle_sim.parquet");
    let extra = |ts| recorded(ts, &sc.inputs, p.gravity_m_per_s2);
    write_axle_sim(&path, &tr, &extra(&ts), &TableMeta::default()).unwrap();
    let b = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(&path).unwrap()).unwrap();
    let fields = b.schema().fields().clone();
    assert_eq!(fields[0].name(), "timestamp");
    assert_eq!(fields[1].name(), "time");
    let batch = b.build().unwrap().next().unwrap().unwrap();
    let got = batch
        .column(0)
        .as_any()
        .downcast_ref::<TimestampNanosecondArray>()
        .unwrap();
    assert_eq!(got.values().as_ref(), ts.as_slice());
    let speed = batch.column_by_name("vehicle_speed").unwrap();
    assert_eq!(speed.null_count(), speed.len(), "no speed given: nulls");

    let bad = dir.path().join("bad.parquet");
    let short = &ts[..ts.len() - 1];
    assert!(write_axle_sim(&bad, &tr, &extra(short), &TableMeta::default()).is_err());
    assert!(!bad.exists());
}

#[test]
fn unknown_scenario_or_bad_config_writes_nothing() {
    let p = seed_truck();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let e = run_scenario("emergency-stop", &p, "SEED002-6X2", &out).unwrap_err();
    assert!(matches!(
        e,
        RunScenarioError::Scenario(ScenarioError::Unknown(_))
    ));
    assert!(!out.exists());
    let cfg = AxleScenarioConfig {
        sample_rate_hz: 0.0,
        ..Default::default()
    };
    assert!(matches!(
        hard_aux_braking(&p, &cfg),
        Err(ScenarioError::Config {
            field: "sample_rate_hz",
            ..
        })
    ));
}

#[test]
fn stop_and_go_drive_stops_every_cycle_and_keeps_the_axle_model_finite() {
    // the benchmark's drive-hour (benches/axle.rs): check it is what it claims to be
    let p = seed_truck();
    let sc = stop_and_go(&p, &AxleScenarioConfig::default(), 3600.0, 10.0).unwrap();
    assert_eq!(sc.t_s.len(), 36_001);
    for c in 0..36 {
        let k = |tau: f64| at(&sc.t_s, c as f64 * 100.0 + tau);
        let top = sc.speed_mps[k(8.0)..k(60.0)]
            .iter()
            .copied()
            .fold(0.0, f64::max);
        assert!(top > 8.0, "cycle {c}: top speed {top}");
        assert_eq!(sc.speed_mps[k(99.0)], 0.0, "cycle {c} ends at rest");
        let aux = sc.inputs.aux_brake_torque_wheel_nm.as_ref().unwrap();
        assert!(
            aux.eval(c as f64 * 100.0 + 70.0) > 0.0,
            "cycle {c} brakes with the motor"
        );
    }
    let slope_max = sc
        .t_s
        .iter()
        .map(|&t| sc.inputs.slope.eval(t).abs())
        .fold(0.0, f64::max);
    assert!(slope_max > 0.01 && slope_max <= 0.03, "{slope_max}");
    // the first 10 minutes through the axle model
    let n = at(&sc.t_s, 600.0);
    let tr = HalfTruck::new(&p).simulate(&sc.inputs, &sc.t_s[..=n], sc.start);
    for i in 0..3 {
        assert!(tr.normal_n[i].iter().all(|x| x.is_finite() && *x > 0.0));
        assert!(tr.pressure_pa[i].iter().all(|x| x.is_finite() && *x > 0.0));
    }
}
