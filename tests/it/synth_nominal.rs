//! Nominal reproduction of clean synthetic drives (docs/diagnosis/method.md, step 1): a drive the
//! truth model makes without any injected effect, logged through the J1939 bus of `synth drive`,
//! must be reproduced by fleetdyn's nominal simulations of the recording — the driveline
//! (`validate_shuffle`, 30 s windows re-initialised from the measured state) and the axle model
//! (`validate_axle`, recorded inputs, drive torque by the driveline's inverse dynamics) — to within
//! what the bus's noise, quantisation and rates explain. Otherwise every clean drive of the
//! diagnosis benchmark would show a spurious mismatch.
//!
//! # Thresholds: an error budget from the bus, not from measured errors
//! Every sensor figure is read from [`CanBus::j1939_truck`] (rate f, resolution q, noise σ,
//! converted to SI). A quantised noisy sensor has the per-frame error
//! `σ_tot = √(σ² + q²/12)` and, for a constant true value, a bias of at most
//! `β(q, σ) = q·Σ_k exp(−2π²k²σ²/q²)/(πk)` (Gaussian dither; the slope sensor's 1 % steps with
//! 0.2 % noise give β = 0.15 %, the engine torque's 1 % with 0.5 % noise 0.002 %).
//!
//! Driveline, per compared (moving) sample, over a window of W = 30 s re-initialised from the
//! measured speed:
//! - the slope bias accelerates the vehicle wrongly by at most `g·β_s` (m_eff ≥ m), a speed
//!   error growing linearly over the window, rms `g β_s W/√3`;
//! - the frames' random errors integrate to random walks, rms over the window
//!   `(σ_tot/m_eff·lever)·√(W/(2f))`: slope (`g σ_s`), brake (`σ_b/m`) and engine torque at the
//!   wheels (`σ_M G/(r_w m)`, G = i_t i_f);
//! - the measured speed's noise enters twice (initial state and comparison): `2σ_v²`;
//! - engine speed: with the clutch engaged it follows the wheels, `(G/r_w)·e_v`; with it open
//!   the engine integrates its own torque frames (`σ_M/J_e`, random walk, plus `β_M/J_e` drift);
//!   plus `2σ_ωe²`.
//!
//! Axle, per axle and segment, against the recorded (noisy) bellow pressure: the pressure
//! sensor's `σ_tot`, plus each input's error times the model's quasi-static sensitivity of that
//! bellow to it (exact for this linear model at steady state, computed from [`HalfTruck`]):
//! - drive torque: the inverse dynamics' frame noise over its ±0.05 s window — engine torque
//!   mean (`σ_M/√(span·f)`), engine and wheel accelerations (`√2 σ/span`, the wheel speed's
//!   frames 0.1 s apart) through G, `J_e`, `J_c G² + J_out` — and what the window cannot
//!   resolve at these rates: the truth's drive-shaft torque minus its own window mean;
//! - acceleration: the ±0.25 s speed difference's noise `√2 σ_v/span` and, likewise, the truth
//!   acceleration minus its ±0.25 s mean;
//! - slope `√(β_s² + σ_s²)`, brake `σ_b`;
//!
//! summed in quadrature (independent sources). The "what the window cannot resolve" terms are
//! computed from the truth alone, never from the simulation under test.
//!
//! The slope input is the sensor as recorded (`road_slope`), not the road-slope zero-phase spatial
//! filter: on the synthetic city roads (12 % grades joined by 300 m vertical curves) the filter's
//! 250 m cut-off removes real grade changes — measured on a 5 km city-se drive (seed 0), slope RMSE
//! 0.016 filtered against 0.0037 raw, and the driveline fit falls from 97 % to 88 % (vehicle speed)
//! and from 94 % to 27 % (engine speed). That is the `slope_quantization` trade-off of the effect
//! catalogue, not a nominal-model error.

use crate::common::fixture;
use fleetdyn::model::axle::{Axle, AxleParams};
use fleetdyn::model::driveline::DrivelineParams;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::sim::axle::{AxleInputs, HalfTruck};
use fleetdyn::sim::axle_validate::{validate_axle, AxleValidationConfig, Segment};
use fleetdyn::sim::inputs::Piecewise;
use fleetdyn::sim::validate::{validate_shuffle, ValidationConfig};
use fleetdyn::synth::can::CanBus;
use fleetdyn::synth::drive::{synth_drive, DriveConfig, SynthDrive, DRIVE_START_NS};
use fleetdyn::units::Conversion;
use std::f64::consts::PI;

const VEHICLE: &str = "fixtures/vehicles/seed002-6x2-diesel.toml";

/// A bus channel in SI: rate f (Hz), resolution q and noise σ.
#[derive(Debug, Clone, Copy)]
struct Sensor {
    rate_hz: f64,
    q: f64,
    sigma: f64,
}

impl Sensor {
    fn of(bus: &CanBus, column: &str) -> Sensor {
        let (m, c) = bus
            .channels()
            .find(|(_, c)| c.column == column)
            .unwrap_or_else(|| panic!("the bus carries {column}"));
        let Conversion::Linear { factor, .. } = bus.conversion(c).unwrap() else {
            panic!("{column}: linear conversion expected")
        };
        Sensor {
            rate_hz: m.rate_hz,
            q: c.resolution * factor.abs(),
            sigma: c.noise_sigma * factor.abs(),
        }
    }

    /// Per-frame error, `√(σ² + q²/12)`.
    fn sigma_tot(&self) -> f64 {
        (self.sigma * self.sigma + self.q * self.q / 12.0).sqrt()
    }

    /// Bound of the bias of a constant true value after Gaussian dither and rounding,
    /// `q Σ_k exp(−2π²k²σ²/q²)/(πk)` (Fourier series of the expected rounding error; without
    /// noise, q/2).
    fn bias_bound(&self) -> f64 {
        if self.sigma == 0.0 {
            return 0.5 * self.q;
        }
        let s = self.sigma / self.q;
        self.q
            * (1..=20)
                .map(|k| {
                    let k = k as f64;
                    (-2.0 * PI * PI * k * k * s * s).exp() / (PI * k)
                })
                .sum::<f64>()
                .min(0.5)
    }
}

/// Mean over `idx` of `f(k)`.
fn mean_over(idx: &[usize], f: impl Fn(usize) -> f64) -> f64 {
    idx.iter().map(|&k| f(k)).sum::<f64>() / idx.len().max(1) as f64
}

/// Centred window mean of `v` on the uniform grid `dt` over ±`half`.
fn window_mean(v: &[f64], dt: f64, half: f64) -> Vec<f64> {
    let h = (half / dt + 1e-9).floor() as usize;
    let mut cum = vec![0.0; v.len() + 1];
    for (i, x) in v.iter().enumerate() {
        cum[i + 1] = cum[i] + x;
    }
    (0..v.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + h + 1).min(v.len()));
            (cum[b] - cum[a]) / (b - a) as f64
        })
        .collect()
}

/// Centred difference of `v` on the uniform grid `dt` over ±`half`.
fn window_derivative(v: &[f64], dt: f64, half: f64) -> Vec<f64> {
    let h = ((half / dt + 1e-9).floor() as usize).max(1);
    (0..v.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + h).min(v.len() - 1));
            (v[b] - v[a]) / ((b - a) as f64 * dt)
        })
        .collect()
}

/// Quasi-static sensitivities of the three bellow pressures (Pa per unit) to drive torque at the
/// wheels (N·m), acceleration (m/s²), slope (1) and service-brake force (N), about level,
/// steady driving: the model is linear at steady state, so these are exact there.
fn sensitivities(p: &AxleParams) -> [[f64; 3]; 4] {
    let m = HalfTruck::new(p);
    let t_end = 1.0;
    let pressure = |torque: f64, accel: f64, slope: f64, brake: f64| -> [f64; 3] {
        let u = AxleInputs {
            accel_mps2: Piecewise::constant(t_end, accel),
            slope: Piecewise::constant(t_end, slope),
            drive_torque_wheel_nm: Some(Piecewise::constant(t_end, torque)),
            aux_brake_torque_wheel_nm: None,
            service_brake_n: Some(Piecewise::constant(t_end, brake)),
        };
        let q = m.steady_state(&m.longitudinal(&u, 0.5));
        let b = m.bellow_forces(&q);
        Axle::ALL.map(|a| b[a.index()] / p.bellow_area(a))
    };
    let base = pressure(0.0, 0.0, 0.0, 0.0);
    let d = |x: [f64; 3], unit: f64| [0, 1, 2].map(|i| ((x[i] - base[i]) / unit).abs());
    [
        d(pressure(1000.0, 0.0, 0.0, 0.0), 1000.0),
        d(pressure(0.0, 0.1, 0.0, 0.0), 0.1),
        d(pressure(0.0, 0.0, 0.01, 0.0), 0.01),
        d(pressure(0.0, 0.0, 0.0, 1000.0), 1000.0),
    ]
}

/// Row times of the log on the truth's clock, s, and the truth sample index of each row.
fn row_times(sd: &SynthDrive) -> (Vec<f64>, Vec<usize>) {
    let dt = sd.drive.t_s[1] - sd.drive.t_s[0];
    let n = sd.drive.t_s.len();
    let t: Vec<f64> = sd
        .log
        .timestamp_ns
        .iter()
        .map(|&x| (x - DRIVE_START_NS) as f64 * 1e-9)
        .collect();
    let k = t
        .iter()
        .map(|&x| ((x / dt).round() as usize).min(n - 1))
        .collect();
    (t, k)
}

struct Vehicle {
    file: VehicleFile,
    bus: CanBus,
}

impl Vehicle {
    fn load() -> Self {
        let file = VehicleFile::load(&fixture(VEHICLE)).unwrap();
        let reference = file
            .driveline
            .as_ref()
            .unwrap()
            .engine_max_torque_nm
            .iter()
            .fold(0.0f64, |m, &x| m.max(x));
        Self {
            file,
            bus: CanBus::j1939_truck(reference),
        }
    }
    fn d(&self) -> &DrivelineParams {
        self.file.driveline.as_ref().unwrap()
    }
    fn a(&self) -> &AxleParams {
        self.file.axles.as_ref().unwrap()
    }
}

/// Checks the driveline reproduction of `sd` against its budget; returns (v rmse, budget,
/// ω_e rmse, budget).
fn check_driveline(veh: &Vehicle, sd: &SynthDrive, label: &str) -> [f64; 4] {
    let (p, bus) = (veh.d(), &veh.bus);
    let ratios = &veh.file.gearbox.ratios;
    let cfg = ValidationConfig::default();
    let val = validate_shuffle(&sd.log, p, ratios, None, &cfg).unwrap();
    let metric = |s: &str| {
        val.metrics
            .iter()
            .find(|m| m.signal == s && m.gear.is_none())
            .unwrap()
            .clone()
    };
    let (mv, mw) = (metric("vehicle_speed"), metric("engine_speed"));
    // the compared samples: moving, as the validation selects them
    let v_meas = sd.log.signal("vehicle_speed").unwrap();
    let gear = sd.log.signal("gear").unwrap();
    let clutch = sd
        .log
        .signal("clutch_position")
        .expect("the synthetic log carries the clutch position the truth used");
    let idx: Vec<usize> = (0..sd.log.len())
        .filter(|&k| v_meas[k] >= cfg.min_speed_mps)
        .collect();
    assert_eq!(idx.len(), mv.samples);
    let (speed, slope, brake, torque, w_e) = (
        Sensor::of(bus, "vehicle_speed"),
        Sensor::of(bus, "road_slope"),
        Sensor::of(bus, "brake_force"),
        Sensor::of(bus, "engine_torque"),
        Sensor::of(bus, "engine_speed"),
    );
    let (g, m, r, w) = (
        p.gravity_m_per_s2,
        p.mass_kg,
        p.wheel_radius_m,
        cfg.window_s,
    );
    let walk = |s: Sensor| (w / (2.0 * s.rate_hz)).sqrt() * s.sigma_tot();
    let big_g = |k: usize| {
        let gk = gear[k].round().max(1.0) as usize;
        ratios[gk - 1] * p.final_drive_ratio
    };
    let drift_v = g * slope.bias_bound() * w / 3f64.sqrt();
    let e_v2 = |k: usize| {
        drift_v.powi(2)
            + (g * walk(slope)).powi(2)
            + (walk(brake) / m).powi(2)
            + (walk(torque) * big_g(k) / (r * m)).powi(2)
    };
    let budget_v = (mean_over(&idx, e_v2) + 2.0 * speed.sigma_tot().powi(2)).sqrt();
    let engaged = |k: usize| clutch[k] <= p.clutch_l_lower;
    let free_engine2 = (torque.bias_bound() / p.j_e_kg_m2 * w / 3f64.sqrt()).powi(2)
        + (walk(torque) / p.j_e_kg_m2).powi(2);
    let budget_w = (mean_over(&idx, |k| {
        if engaged(k) {
            (big_g(k) / r).powi(2) * (e_v2(k) + speed.sigma_tot().powi(2))
        } else {
            free_engine2
        }
    }) + 2.0 * w_e.sigma_tot().powi(2))
    .sqrt();
    eprintln!(
        "{label} driveline: vehicle speed rmse {:.3} m/s (budget {budget_v:.3}), fit {:.1} %; \
         engine speed rmse {:.2} rad/s (budget {budget_w:.2}), fit {:.1} %; {} samples",
        mv.rmse, mv.fit_percent, mw.rmse, mw.fit_percent, mv.samples
    );
    assert!(
        mv.rmse <= budget_v,
        "{label}: vehicle speed rmse {} > {budget_v}",
        mv.rmse
    );
    assert!(
        mw.rmse <= budget_w,
        "{label}: engine speed rmse {} > {budget_w}",
        mw.rmse
    );
    [mv.rmse, budget_v, mw.rmse, budget_w]
}

/// Checks the axle reproduction of `sd` (all and acceleration segments, three bellows).
fn check_axles(veh: &Vehicle, sd: &SynthDrive, label: &str) {
    let (p, a, bus) = (veh.d(), veh.a(), &veh.bus);
    let ratios = &veh.file.gearbox.ratios;
    let cfg = AxleValidationConfig::default();
    let val = validate_axle(
        &sd.log,
        a,
        ratios,
        veh.file.final_drive_ratio(),
        Some(p),
        None,
        &cfg,
    )
    .unwrap();
    let (speed, slope, brake, torque, w_e, bellow) = (
        Sensor::of(bus, "vehicle_speed"),
        Sensor::of(bus, "road_slope"),
        Sensor::of(bus, "brake_force"),
        Sensor::of(bus, "engine_torque"),
        Sensor::of(bus, "engine_speed"),
        Sensor::of(bus, "bellow_pressure_rear"),
    );
    let r = p.wheel_radius_m;
    let (t_rows, truth_k) = row_times(sd);
    let row_dt = t_rows[1] - t_rows[0];
    // spans of the centred windows on the log's rows (first to last row inside ±half)
    let span = |half: f64| 2.0 * (half / row_dt + 1e-9).floor() * row_dt;
    let (h_t, h_a) = (
        cfg.record.torque_half_window_s,
        cfg.record.speed_derivative_half_window_s,
    );
    let (span_t, span_a) = (span(h_t), span(h_a));
    let frames = (span_t * torque.rate_hz).max(1.0);
    let s_mean = torque.sigma_tot() / frames.sqrt();
    let s_dwe = 2f64.sqrt() * w_e.sigma_tot() / span_t;
    let s_dww = 2f64.sqrt() * speed.sigma_tot() / span_t.max(1.0 / speed.rate_hz) / r;
    let s_a = 2f64.sqrt() * speed.sigma_tot() / span_a;
    // what the windows cannot resolve, from the truth alone
    let d = &sd.drive;
    let dt = d.t_s[1] - d.t_s[0];
    let md_mean = window_mean(&d.drive_torque_nm, dt, h_t);
    let a_truth = window_derivative(&d.speed_mps, dt, 0.05);
    let a_window = window_derivative(&d.speed_mps, dt, h_a);
    let gear = sd.log.signal("gear").unwrap();
    let clutch = sd
        .log
        .signal("clutch_position")
        .expect("the synthetic log carries the clutch position the truth used");
    let sens = sensitivities(a);
    for seg in [Segment::All, Segment::Acceleration] {
        let idx: Vec<usize> = (0..sd.log.len())
            .filter(|&k| seg == Segment::All || val.segment[k] == seg)
            .collect();
        let e_t2 = mean_over(&idx, |k| {
            let gk = gear[k].round().max(1.0) as usize;
            let big_g = ratios[gk - 1] * p.final_drive_ratio;
            let j_out = (p.j_t_kg_m2[gk - 1] + p.j_p_kg_m2) * p.final_drive_ratio.powi(2)
                + p.j_f_kg_m2
                + p.j_d_kg_m2;
            let noise = if clutch[k] >= p.clutch_l_upper {
                (j_out * s_dww).powi(2)
            } else {
                big_g.powi(2) * (s_mean.powi(2) + (p.j_e_kg_m2 * s_dwe).powi(2))
                    + ((p.j_c_kg_m2 * big_g * big_g + j_out) * s_dww).powi(2)
            };
            let tk = truth_k[k];
            noise + (d.drive_torque_nm[tk] - md_mean[tk]).powi(2)
        });
        let e_a2 = s_a.powi(2)
            + mean_over(&idx, |k| {
                (a_truth[truth_k[k]] - a_window[truth_k[k]]).powi(2)
            });
        let e_s2 = slope.bias_bound().powi(2) + slope.sigma_tot().powi(2);
        for ax in Axle::ALL {
            let i = ax.index();
            let name = format!("bellow_pressure_{}", ax.name());
            let m = val
                .metrics
                .iter()
                .find(|m| m.signal == name && m.segment == seg)
                .unwrap();
            let budget = (bellow.sigma_tot().powi(2)
                + sens[0][i].powi(2) * e_t2
                + sens[1][i].powi(2) * e_a2
                + sens[2][i].powi(2) * e_s2
                + (sens[3][i] * brake.sigma_tot()).powi(2))
            .sqrt();
            eprintln!(
                "{label} axle {:5} {:12}: rmse {:.2} kPa (budget {:.2}), bias {:+.2} kPa, fit {:.1} %, {} samples",
                ax.name(),
                seg.name(),
                m.rmse / 1e3,
                budget / 1e3,
                m.bias / 1e3,
                m.fit_percent,
                m.samples
            );
            assert!(
                m.rmse <= budget,
                "{label} {name} {}: rmse {} Pa > budget {budget} Pa",
                seg.name(),
                m.rmse
            );
        }
    }
}

fn drive(rules: &str, km: f64, seed: u64, dir: &std::path::Path) -> SynthDrive {
    synth_drive(
        &fixture(VEHICLE),
        rules,
        km,
        seed,
        dir,
        &DriveConfig::default(),
        None,
    )
    .unwrap()
}

#[test]
fn clean_city_drive_is_reproduced_by_the_nominal_driveline_and_axle_models() {
    let dir = tempfile::tempdir().unwrap();
    let veh = Vehicle::load();
    let sd = drive("city-se", 2.0, 3, dir.path());
    assert!(sd.drive.launches.len() >= 2 && sd.drive.shifts.len() >= 15);
    check_driveline(&veh, &sd, "city-se 2 km seed 3");
    check_axles(&veh, &sd, "city-se 2 km seed 3");
}

#[test]
fn clean_highway_drive_is_reproduced_by_the_nominal_driveline_and_axle_models() {
    let dir = tempfile::tempdir().unwrap();
    let veh = Vehicle::load();
    let sd = drive("highway-se", 2.0, 3, dir.path());
    check_driveline(&veh, &sd, "highway-se 2 km seed 3");
    check_axles(&veh, &sd, "highway-se 2 km seed 3");
}

/// The engine's torque lag (`engine_torque_lag_s`): a drive made with it records the ECU's
/// figure and drives its plant with the lagged torque; the driveline simulation of the
/// recording reads the recorded torque through the file's lag and reproduces the engine speed
/// as well as on the same drive made without a lag, and far better than when it reads the
/// torque as recorded. City drive, 2 km, seed 3, the seed-002 truck; measured engine-speed RMSE
/// (30 s windows): 1.839 rad/s on the drive without a lag, 1.883 rad/s on the drive with a
/// 0.1 s lag read through it, 4.285 rad/s read without it. Bounds: within 10 % of the lag-free
/// drive's (the lag read from the 50 Hz record of a command that steps every 0.1 s), and at
/// least twice as large without the lag.
#[test]
fn a_lagged_engine_is_reproduced_through_the_files_lag() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = ValidationConfig::default();
    // (the drive made with `lag_s`, its vehicle file's driveline)
    let made = |lag_s: f64| {
        let text = std::fs::read_to_string(fixture(VEHICLE)).unwrap().replace(
            "[driveline]\n",
            &format!("[driveline]\nengine_torque_lag_s = {lag_s:?}\n"),
        );
        let file = dir.path().join(format!("lag-{lag_s}.toml"));
        std::fs::write(&file, &text).unwrap();
        let vf = VehicleFile::load(&file).unwrap();
        let sd = synth_drive(
            &file,
            "city-se",
            2.0,
            3,
            &dir.path().join(format!("drive-{lag_s}")),
            &DriveConfig::default(),
            None,
        )
        .unwrap();
        (sd, vf)
    };
    let rmse = |sd: &SynthDrive, vf: &VehicleFile, lag_s: f64| {
        let p = DrivelineParams {
            engine_torque_lag_s: lag_s,
            ..vf.driveline.clone().unwrap()
        };
        let val = validate_shuffle(&sd.log, &p, &vf.gearbox.ratios, None, &cfg).unwrap();
        val.metrics
            .iter()
            .find(|m| m.signal == "engine_speed" && m.gear.is_none())
            .unwrap()
            .rmse
    };
    let (plain, vf0) = made(0.0);
    let (lagged, vf1) = made(0.1);
    assert_eq!(vf1.driveline.as_ref().unwrap().engine_torque_lag_s, 0.1);
    let reference = rmse(&plain, &vf0, 0.0);
    let (with, without) = (rmse(&lagged, &vf1, 0.1), rmse(&lagged, &vf1, 0.0));
    eprintln!(
        "engine-speed RMSE {reference:.3} rad/s without a lag; with a 0.1 s lag {with:.3} rad/s \
         read through it, {without:.3} rad/s read without"
    );
    assert!(with < 1.1 * reference, "{with} vs {reference}");
    assert!(without > 2.0 * reference, "{without} vs {reference}");
}
