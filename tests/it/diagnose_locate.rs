//! Step 2 of the diagnosis, locate, and the noise floor it needs (src/diagnose/locate.rs,
//! src/diagnose/noise.rs; docs/diagnosis/method.md). On synthetic arrays whose answer is known
//! (white noise and quantisation alone, a bump in a known stretch, a residual ∝ v², a delayed
//! input) and on synthetic drives with and without a hidden effect. Measured figures are printed
//! (`--nocapture`).

use crate::common::fixture;
use fleetdyn::diagnose::compare::{Compared, Comparison, Conditions};
use fleetdyn::diagnose::extended::Theta;
use fleetdyn::diagnose::locate::{
    inputs_from_log, locate, shuffle_band_hz, LocateConfig, LocateError, Location, NamedSeries,
};
use fleetdyn::diagnose::noise::{
    estimate_sensor_noise, noise_floors, perturbed_log, sensor_estimates, stream, ModelSet,
    NoiseConfig, NoiseFloor, NoiseFloors, SampleKind, SensorNoise,
};
use fleetdyn::model::catalogue::Effect;
use fleetdyn::model::extended_vehicle::ExtendedVehicle;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::report::sentences::statement_text;
use fleetdyn::rng::Xoshiro256StarStar;
use fleetdyn::synth::drive::{synth_drive, DriveConfig, HiddenEffect, SynthDrive};
use fleetdyn::synth::effects::EffectChoice;
use std::path::Path;

const DT: f64 = 0.02; // 50 Hz grid
const VEHICLE: &str = "fixtures/vehicles/seed002-6x2-diesel.toml";

/// A channel as CAN and ingest deliver it: `truth` sampled every `period` rows at a phase of
/// 0.3 rows (between grid rows), plus N(0, σ), rounded to `q`, linearly interpolated onto the
/// grid.
fn recorded(
    truth: &[f64],
    period: usize,
    sigma: f64,
    q: f64,
    rng: &mut Xoshiro256StarStar,
) -> Vec<f64> {
    let n = truth.len();
    let knots: Vec<(f64, f64)> = (0..n / period + 2)
        .map(|k| {
            let p = 0.3 + (k * period) as f64;
            let i = (p.floor() as usize).min(n - 1);
            let v = truth[i] + sigma * rng.standard_normal();
            (p, if q > 0.0 { (v / q).round() * q } else { v })
        })
        .collect();
    (0..n)
        .map(|i| {
            let x = i as f64;
            let k = knots.partition_point(|kn| kn.0 <= x);
            if k == 0 {
                return knots[0].1;
            }
            let (a, b) = (knots[k - 1], knots[k]);
            a.1 + (x - a.0) / (b.0 - a.0) * (b.1 - a.1)
        })
        .collect()
}

fn conditions(n: usize, speed: Option<&[f64]>) -> Conditions {
    let t_s: Vec<f64> = (0..n).map(|i| i as f64 * DT).collect();
    let v: Vec<f64> = speed.map_or_else(|| vec![10.0; n], |s| s.to_vec());
    let mut d = vec![0.0; n];
    for i in 1..n {
        d[i] = d[i - 1] + 0.5 * (v[i] + v[i - 1]) * DT;
    }
    Conditions {
        t_s,
        distance_m: d,
        speed_mps: v,
        ..Conditions::default()
    }
}

fn one_signal(name: &str, residual: Vec<f64>, cond: Conditions) -> Comparison {
    let n = residual.len();
    Comparison {
        signals: vec![Compared {
            name: name.into(),
            unit: "1".into(),
            measured: residual.into(),
            simulated: vec![0.0; n].into(),
            valid: vec![true; n],
        }],
        conditions: cond,
    }
}

fn floors_of(floor: NoiseFloor) -> NoiseFloors {
    NoiseFloors {
        floors: vec![floor],
        sensors: Vec::new(),
        copies: NoiseConfig::default().copies,
        seed: NoiseConfig::default().seed,
    }
}

/// One synthetic "drive" of white noise and quantisation on a smooth truth; the floor from the
/// blind estimate of the recorded channel. Sensor A: J1939 wheel speed (σ 0.0139 m/s, step
/// 1/256 km/h, 10 Hz); sensor B: a coarse one (σ = 0.2 step, 10 Hz) whose rounding error
/// persists.
fn null_drive(seed: u64, n: usize, coarse: bool) -> (Comparison, NoiseFloors, f64) {
    let mut rng = Xoshiro256StarStar::seed_from_u64(0xF00D ^ seed);
    let truth: Vec<f64> = (0..n)
        .map(|i| 15.0 + 3.0 * (i as f64 * DT * std::f64::consts::TAU / 60.0).sin())
        .collect();
    let (sigma, q) = if coarse {
        (0.02, 0.1)
    } else {
        (0.05 / 3.6, 1.0 / 256.0 / 3.6)
    };
    let rec = recorded(&truth, 5, sigma, q, &mut rng);
    let sensor = estimate_sensor_noise("x", "1", &rec, DT, SampleKind::Linear).unwrap();
    let residual: Vec<f64> = rec.iter().zip(&truth).map(|(a, b)| a - b).collect();
    let cfg = NoiseConfig {
        seed,
        ..NoiseConfig::default()
    };
    let floor = NoiseFloor::measurement_only("x", &sensor, &vec![true; n], &cfg).unwrap();
    let f = floor.floor;
    (
        one_signal("x", residual, conditions(n, None)),
        floors_of(floor),
        f,
    )
}

#[test]
fn white_noise_and_quantisation_false_positive_rate_is_below_alpha() {
    let cfg = LocateConfig::default(); // α = 0.01, 10 s windows
    let n = 15_000; // 300 s: 30 windows per drive
    let drives = 300u64;
    let (mut any_stat, mut any_full, mut windows, mut ratio_sum) = (0, 0, 0, 0.0);
    for seed in 0..drives {
        let (cmp, floors, floor) = null_drive(seed, n, seed % 2 == 1);
        let loc = locate(&cmp, &floors, &[], &cfg).unwrap();
        let s = &loc.signals[0];
        windows += s.windows.len();
        ratio_sum += s.rms_residual / floor;
        if !(s.rms_residual / floor).is_finite() || s.windows.len() < 30 {
            let se = floors.floors[0].sensor.as_ref().unwrap();
            eprintln!(
                "seed {seed}: residual {} floor {floor} windows {} sensor rate {} σ {} q {:?}",
                s.rms_residual,
                s.windows.len(),
                se.native_rate_hz,
                se.sigma_raw,
                se.quantization_step
            );
        }
        if s.windows.iter().any(|w| w.p_holm <= cfg.alpha) {
            any_stat += 1;
        }
        if loc.any_significant {
            any_full += 1;
        }
    }
    let fpr_stat = any_stat as f64 / drives as f64;
    let fpr_full = any_full as f64 / drives as f64;
    eprintln!(
        "null drives: {drives} × 30 windows ({windows} tests); drives with a Holm-significant \
         window {any_stat} ({fpr_stat:.3}), with a reported mismatch {any_full} ({fpr_full:.3}); \
         mean residual/floor RMS {:.3}",
        ratio_sum / drives as f64
    );
    // the floor is the residual's size
    assert!((ratio_sum / drives as f64 - 1.0).abs() < 0.15);
    // family-wise rate of the statistical test alone: at most α plus two binomial standard
    // errors (0.0115 at 300 drives); with the practical rule: at most α/2
    let se = (cfg.alpha * (1.0 - cfg.alpha) / drives as f64).sqrt();
    assert!(fpr_stat <= cfg.alpha + 2.0 * se, "{fpr_stat}");
    assert!(fpr_full <= cfg.alpha / 2.0, "{fpr_full}");
}

#[test]
fn a_bump_is_located_to_its_stretch() {
    let n = 15_000;
    let (mut cmp, floors, floor) = null_drive(11, n, false);
    // +5 floor RMS between 40 and 60 s, cosine edges of 1 s
    let r = std::sync::Arc::make_mut(&mut cmp.signals[0].measured);
    for (i, v) in r.iter_mut().enumerate() {
        let t = i as f64 * DT;
        let w = if (41.0..=59.0).contains(&t) {
            1.0
        } else if (40.0..41.0).contains(&t) {
            0.5 - 0.5 * ((t - 40.0) * std::f64::consts::PI).cos()
        } else if (59.0..60.0).contains(&t) {
            0.5 + 0.5 * ((t - 59.0) * std::f64::consts::PI).cos()
        } else {
            0.0
        };
        *v += 5.0 * floor * w;
    }
    let loc = locate(&cmp, &floors, &[], &LocateConfig::default()).unwrap();
    eprintln!("bump: {:?}", loc.mismatch);
    assert_eq!(loc.mismatch.len(), 1, "{:?}", loc.mismatch);
    let m = &loc.mismatch[0];
    assert!(
        (m.start_s - 40.0).abs() < 0.1 && (m.end_s - 60.0).abs() < 0.1,
        "{m:?}"
    );
    // 10 m/s: 400–600 m
    assert!(
        (m.start_m - 400.0).abs() < 2.0 && (m.end_m - 600.0).abs() < 2.0,
        "{m:?}"
    );
    assert_eq!(m.band_hz, [0.0, 0.5], "a 20 s bump is quasi-static");
    assert!(m.significance < 1e-6 && m.rms_residual > 3.0 * m.floor_rms);
    assert!(loc.signals[0].significant && loc.any_significant);
    // the same in distance windows of 100 m
    let cfg = LocateConfig {
        window: fleetdyn::diagnose::locate::WindowAxis::Distance { window_m: 100.0 },
        ..LocateConfig::default()
    };
    let loc = locate(&cmp, &floors, &[], &cfg).unwrap();
    assert_eq!(loc.mismatch.len(), 1, "{:?}", loc.mismatch);
    assert!((loc.mismatch[0].start_m - 400.0).abs() < 2.0);
}

#[test]
fn residual_growing_with_speed_squared_is_stated() {
    let n = 30_000; // 600 s
    let v: Vec<f64> = (0..n)
        .map(|i| 15.0 + 10.0 * (i as f64 * DT * std::f64::consts::TAU / 150.0).sin())
        .collect();
    let sensor = SensorNoise::given("p", "Pa", SampleKind::Linear, n, DT, 5, 300.0, None).unwrap();
    let noise = sensor.draw(n, &mut stream(5, 99, "p"));
    // a pressure-like (instantaneous) residual: 4 Pa per (m/s)² on top of the sensor noise
    let r: Vec<f64> = v.iter().zip(&noise).map(|(v, e)| 4.0 * v * v + e).collect();
    let cfg = NoiseConfig::default();
    let floor = NoiseFloor::measurement_only("bellow_pressure_rear", &sensor, &vec![true; n], &cfg)
        .unwrap();
    let mut cond = conditions(n, Some(&v));
    // competing shapes: acceleration, grade and torque unrelated to the residual
    cond.accel_mps2 = (0..n)
        .map(|i| {
            10.0 * std::f64::consts::TAU / 150.0
                * (i as f64 * DT * std::f64::consts::TAU / 150.0).cos()
        })
        .collect();
    cond.slope = (0..n)
        .map(|i| 0.02 * (i as f64 * DT / 37.0).sin())
        .collect();
    let loc = locate(
        &one_signal("bellow_pressure_rear", r, cond),
        &floors_of(floor),
        &[],
        &LocateConfig::default(),
    )
    .unwrap();
    let st = &loc.signals[0].statements;
    eprintln!("v² statements: {st:#?}");
    let best = st.iter().find(|s| s.best).expect("a statement");
    assert_eq!(best.shape, "speed_squared");
    let words = statement_text(best);
    assert!(words.starts_with("grows with speed²"), "{words}");
    assert!((best.coefficient - 4.0).abs() < 0.1, "{}", best.coefficient);
    assert!(!st.iter().any(|s| s.shape == "grade"));
}

#[test]
fn a_delayed_input_shows_its_lag() {
    let n = 30_000;
    // a drive-like input: AR(1) with a 1 s correlation time
    let mut rng = Xoshiro256StarStar::seed_from_u64(42);
    let a = (-DT / 1.0f64).exp();
    let mut u = vec![0.0; n];
    for i in 1..n {
        u[i] = a * u[i - 1] + 100.0 * rng.standard_normal();
    }
    let lag_rows = 20; // 0.4 s
    let sensor = SensorNoise::given("x", "1", SampleKind::Linear, n, DT, 1, 5.0, None).unwrap();
    let noise = sensor.draw(n, &mut stream(1, 7, "x"));
    let r: Vec<f64> = (0..n)
        .map(|i| 0.2 * if i >= lag_rows { u[i - lag_rows] } else { 0.0 } + noise[i])
        .collect();
    let floor = NoiseFloor::measurement_only("x", &sensor, &vec![true; n], &NoiseConfig::default())
        .unwrap();
    let inputs = vec![NamedSeries {
        name: "engine_torque".into(),
        unit: "N*m".into(),
        values: u,
    }];
    let loc = locate(
        &one_signal("x", r, conditions(n, None)),
        &floors_of(floor),
        &inputs,
        &LocateConfig::default(),
    )
    .unwrap();
    let l = &loc.signals[0].lags[0];
    eprintln!("lag: {l:?}");
    assert!(l.significant);
    assert!((l.lag_s - 0.4).abs() < 1e-9, "{}", l.lag_s);
    assert!(l.value.abs() > 3.0 * l.zero_lag_value.abs());
    // and the input is coherent with the residual below the noise's corner
    let c = &loc.signals[0].coherence[0];
    assert!(
        c.bands
            .iter()
            .any(|b| b.band == "quasi_static" && b.significant),
        "{c:?}"
    );
}

#[test]
fn bad_and_empty_input_give_errors_or_empty_results() {
    let n = 1000;
    let (cmp, floors, _) = null_drive(1, n, false);
    // all-NaN residual: nothing tested, nothing significant
    let mut nan = cmp.clone();
    nan.signals[0].measured = vec![f64::NAN; n].into();
    let loc = locate(&nan, &floors, &[], &LocateConfig::default()).unwrap();
    assert!(loc.signals[0].windows.is_empty() && loc.mismatch.is_empty() && !loc.any_significant);
    // empty comparison
    let empty = Comparison {
        signals: Vec::new(),
        conditions: Conditions::default(),
    };
    let loc = locate(&empty, &floors, &[], &LocateConfig::default()).unwrap();
    assert!(loc.signals.is_empty() && loc.family_size == 0);
    // lengths that differ
    let mut short = cmp.clone();
    std::sync::Arc::make_mut(&mut short.signals[0].simulated).pop();
    assert!(matches!(
        locate(&short, &floors, &[], &LocateConfig::default()),
        Err(LocateError::Length { .. })
    ));
    let bad_input = vec![NamedSeries {
        name: "engine_torque".into(),
        unit: "N*m".into(),
        values: vec![0.0; 3],
    }];
    assert!(locate(&cmp, &floors, &bad_input, &LocateConfig::default()).is_err());
    let bad_cfg = LocateConfig {
        practical_ratio: 0.5,
        ..LocateConfig::default()
    };
    assert!(matches!(
        locate(&cmp, &floors, &[], &bad_cfg),
        Err(LocateError::BadConfig { .. })
    ));
    // serialisable
    let loc = locate(&cmp, &floors, &[], &LocateConfig::default()).unwrap();
    let back: Location = serde_json::from_str(&serde_json::to_string(&loc).unwrap()).unwrap();
    assert_eq!(back.signals[0].windows.len(), loc.signals[0].windows.len());
}

#[test]
fn a_noise_copy_of_the_columns_the_models_read_compares_bit_for_bit_as_the_whole_copy() {
    // a drive with both models (driveline and axle loads) and columns they do not read (GNSS):
    // every compared signal of a copy restricted to ModelSet::read_columns equals, bit for bit,
    // that of the whole copy; so the noise floor does not depend on what else the log carries
    let dir = tempfile::tempdir().unwrap();
    let d = synth_drive(
        &fixture(VEHICLE),
        "city-se",
        2.0,
        5,
        &dir.path().join("d"),
        &DriveConfig::default(),
        None,
    )
    .unwrap();
    let vf = VehicleFile::load(&fixture(VEHICLE)).unwrap();
    let ratios = vf.gearbox.ratios.clone();
    let truth = ExtendedVehicle::nominal(vf.driveline.as_ref().unwrap(), vf.axles.as_ref());
    let nominal = Theta::nominal(&truth, 0.01);
    let models = ModelSet {
        actuation: true,
        ..ModelSet::for_log(&d.log, &truth, &ratios, nominal)
    };
    assert!(models.longitudinal.is_some() && models.axle);
    let cfg = NoiseConfig::default();
    let sensors = sensor_estimates(&d.log, &cfg).unwrap();
    // every signal's name, then its measured and simulated values' bits and its valid rows
    let bits = |c: &[Compared]| -> (Vec<String>, Vec<u64>) {
        let names = c.iter().map(|x| x.name.clone()).collect();
        let values = c
            .iter()
            .flat_map(|x| {
                let m = x
                    .measured
                    .iter()
                    .chain(x.simulated.iter())
                    .map(|v| v.to_bits());
                m.chain(x.valid.iter().map(|&v| u64::from(v)))
            })
            .collect();
        (names, values)
    };
    for copy in 0..2 {
        let whole = perturbed_log(&d.log, &sensors, &cfg, copy, None);
        let read = ModelSet::read_columns();
        let kept = perturbed_log(&d.log, &sensors, &cfg, copy, Some(&read));
        assert!(
            kept.signals.len() < whole.signals.len(),
            "the drive has columns the models do not read: {:?}",
            whole.signals.iter().map(|s| &s.name).collect::<Vec<_>>()
        );
        let a = models.compared(&whole, &nominal).unwrap();
        let b = models.compared(&kept, &nominal).unwrap();
        // the two speeds, the clutch-actuated engine speed and the three bellow pressures
        assert_eq!(a.len(), 6);
        assert!(
            bits(&a) == bits(&b),
            "copy {copy}: the restricted copy compares differently"
        );
    }
}

/// A 2 km city drive (seed 5) with `effect` hidden, its floors and location.
fn located(dir: &Path, effect: Option<(Effect, f64)>) -> (SynthDrive, NoiseFloors, Location) {
    let hidden = effect.map(|(e, v)| HiddenEffect {
        choice: EffectChoice::Given(e, Some(v)),
        answer_path: dir.join("answer.json"),
    });
    let d = synth_drive(
        &fixture(VEHICLE),
        "city-se",
        2.0,
        5,
        &dir.join("d"),
        &DriveConfig::default(),
        hidden.as_ref(),
    )
    .unwrap();
    let vf = VehicleFile::load(&fixture(VEHICLE)).unwrap();
    let ratios = vf.gearbox.ratios.clone();
    let truth = ExtendedVehicle::nominal(vf.driveline.as_ref().unwrap(), vf.axles.as_ref());
    let nominal = Theta::nominal(&truth, 0.01);
    let models = ModelSet::for_log(&d.log, &truth, &ratios, nominal);
    assert!(models.longitudinal.is_some() && models.axle);
    let floors = noise_floors(&d.log, &models, &nominal, &NoiseConfig::default()).unwrap();
    let cmp = Comparison {
        signals: models.compared(&d.log, &nominal).unwrap(),
        conditions: Conditions::from_log(&d.log),
    };
    let cfg = LocateConfig {
        shuffle_band_hz: shuffle_band_hz(&truth.driveline, &ratios),
        gear_ratios: ratios.clone(),
        ..LocateConfig::default()
    };
    let loc = locate(&cmp, &floors, &inputs_from_log(&d.log), &cfg).unwrap();
    (d, floors, loc)
}

fn summary(label: &str, floors: &NoiseFloors, loc: &Location) {
    for s in &loc.signals {
        let f = floors.get(&s.signal).unwrap();
        eprintln!(
            "{label}: {:<22} residual {:>10.4} floor {:>10.4} (measurement {:.4}, inputs {:.4}) \
             ratio {:.2}; significant windows {}/{}; best statement {:?}",
            s.signal,
            s.rms_residual,
            s.floor_rms,
            f.measurement_rms.unwrap_or(f64::NAN),
            f.input_rms.unwrap_or(f64::NAN),
            s.rms_residual / s.floor_rms,
            s.windows.iter().filter(|w| w.significant).count(),
            s.windows.len(),
            s.statements.first().map(statement_text)
        );
    }
    for m in &loc.mismatch {
        eprintln!(
            "{label}: mismatch {} {:.0}–{:.0} s {:.0}–{:.0} m band {:.2?} Hz rms {:.3e} \
             (floor {:.3e}) p {:.1e}: {}",
            m.signal,
            m.start_s,
            m.end_s,
            m.start_m,
            m.end_m,
            m.band_hz,
            m.rms_residual,
            m.floor_rms,
            m.significance,
            m.condition
        );
    }
}

#[test]
fn clean_drive_floor_explains_the_longitudinal_residual() {
    let dir = tempfile::tempdir().unwrap();
    let (_, floors, loc) = located(dir.path(), None);
    summary("clean", &floors, &loc);
    for s in &loc.signals {
        let ratio = s.rms_residual / s.floor_rms;
        match s.signal.as_str() {
            "vehicle_speed" | "engine_speed" => {
                // the floor is of the residual's size and no window stands out
                assert!((0.6..=1.4).contains(&ratio), "{}: {ratio}", s.signal);
                assert!(!s.significant, "{}", s.signal);
            }
            _ => {
                // bellow pressures: the floor explains the steady driving, not the launches and
                // stops, where the recording path's drive-torque and acceleration reconstruction
                // differs from the truth even with exact inputs (measured 1.6–2.1× overall).
                // Pinned so that a change shows.
                assert!(ratio < 2.5, "{}: {ratio}", s.signal);
                let steady = s
                    .windows
                    .iter()
                    .filter(|w| w.start_s >= 35.0 && w.end_s <= 80.0)
                    .collect::<Vec<_>>();
                assert!(!steady.is_empty());
                assert!(
                    steady.iter().all(|w| !w.significant),
                    "{}: {steady:?}",
                    s.signal
                );
            }
        }
    }
}

#[test]
fn hidden_effects_are_located_in_the_right_signals() {
    let dir = tempfile::tempdir().unwrap();
    // reported engine torque 150 N·m above the delivered one: every longitudinal signal
    let (_, floors, loc) = located(
        &dir.path().join("eto"),
        Some((Effect::EngineTorqueOffset, 150.0)),
    );
    summary("engine_torque_offset=150", &floors, &loc);
    for name in ["vehicle_speed", "engine_speed"] {
        let s = loc.signals.iter().find(|s| s.signal == name).unwrap();
        let sig = s.windows.iter().filter(|w| w.significant).count();
        assert!(
            s.significant && sig * 10 >= s.windows.len() * 8,
            "{name}: {sig}/{}",
            s.windows.len()
        );
    }
    assert!(loc.mismatch.iter().any(|m| m.signal == "vehicle_speed"));
    // static CG 0.3 m off: the bellow pressures, a constant offset of opposite sign front and
    // rear; the longitudinal signals untouched
    let (_, floors, loc) = located(&dir.path().join("cg"), Some((Effect::CgPosition, 0.3)));
    summary("cg_position=0.3", &floors, &loc);
    let mut coef = Vec::new();
    for s in &loc.signals {
        if s.signal.starts_with("bellow_pressure") {
            assert!(s.windows.iter().all(|w| w.significant), "{}", s.signal);
            let best = s.statements.iter().find(|x| x.best).unwrap();
            assert_eq!(best.shape, "constant", "{}", s.signal);
            coef.push(best.coefficient);
            let m: Vec<_> = loc
                .mismatch
                .iter()
                .filter(|m| m.signal == s.signal)
                .collect();
            // every tested window lies in a stretch; stretches split only where no window
            // could be tested (launches and stops, whose shift rows the comparison leaves out)
            let merged: usize = m.iter().map(|x| x.windows).sum();
            assert_eq!(merged, s.windows.len(), "stretches cover every window");
            for pair in m.windows(2) {
                assert!(
                    !s.windows
                        .iter()
                        .any(|w| w.start_s >= pair[0].end_s && w.end_s <= pair[1].start_s),
                    "a tested window between two stretches"
                );
            }
            assert!(m.iter().all(|x| x.band_hz[0] == 0.0));
        } else {
            assert!(!s.significant, "{}", s.signal);
        }
    }
    assert!(
        coef[0] * coef[1] < 0.0,
        "front and rear offsets of opposite sign: {coef:?}"
    );
}
