//! The noise floor of every compared signal (docs/diagnosis/method.md, step 2): the residual
//! `measured − simulated` that a *correct* model would still leave on this recording, so that
//! [`super::locate`] can tell a mismatch from noise.
//!
//! # Two parts
//! 1. **Measurement noise of the recorded output**, estimated blind from the recording
//!    ([`estimate_sensor_noise`]; the method in [`crate::signal::sensor_noise_estimate`]): the
//!    native samples recovered from the grid, their noise σ from a robust spread of the native
//!    second differences, the quantisation step and the persistent part of its error, and the
//!    rest states of actuators at a physical bound.
//! 2. **Input uncertainty propagated through the model** ([`noise_floors`]). The recorded inputs
//!    (engine torque in whole % of the reference torque, slope in whole %, brake force, clutch,
//!    speeds used as initial states …) carry the same kind of errors. Each of `copies`
//!    deterministic Monte-Carlo copies of the log perturbs *every* sensed column — inputs and
//!    outputs alike — by a draw from its estimated sensor error ([`SensorNoise::draw`]: white
//!    noise at the native samples, interpolated or held onto the grid like the recording, plus
//!    the persistent quantisation error), keeps it inside the column's physical range
//!    ([`PerturbedColumn`], e.g. a brake force is never negative, exactly like the sensor), and
//!    runs the models on it. The copy's residual minus the recording's residual,
//!    `e_c = r_c − r`, is one draw of the residual a correct model leaves (a parametric
//!    bootstrap: `r_c − r` has the statistics of `r − r_true` when the error model is right and
//!    the errors are small). Perturbing an output column both as a measurement and as an
//!    initial state in the same copy keeps their correlation (at a window's re-initialisation
//!    the residual is 0 whatever the noise).
//!
//! What the floor carries: [`NoiseFloor`] ([`super::noise_floor`]). Settings: [`NoiseConfig`]
//! ([`super::noise_config`]); the models compared: [`ModelSet`] ([`super::model_set`]). This
//! module runs the Monte-Carlo copies and re-exports those parts and the sensor estimate.
//!
//! # Assumptions
//! - the sensor error is stationary over the drive and independent between channels and of the
//!   true signal (the CAN generator's own model; real sensors may have level-dependent noise);
//! - native samples are regular (CAN messages have fixed rates); dropouts are gaps (NaN);
//! - the model is smooth enough in its inputs that errors of the recorded size act like the
//!   recording's own (parametric bootstrap);
//! - what is *not* in the floor: a model-structure difference that a correct-parameter model
//!   still has on this recording path (e.g. drive-shaft torque reconstructed from engine torque
//!   and speed while the clutch slips). On clean synthetic drives that part is measured by the
//!   tests (tests/it/diagnose_locate.rs) and reported, not hidden.
//!
//! Units: every σ, floor and RMS is in the signal's SI unit; variances in unit²; times in s.
//! Deterministic: every random stream is seeded from [`NoiseConfig::seed`], the copy and the
//! column name.

use super::compare::Compared;
use super::extended::Theta;
use super::long_drive::{is_long, map_in_order};
use crate::table::DriveLog;

pub use super::model_set::ModelSet;
pub use super::noise_config::{NoiseConfig, PerturbedColumn};
pub use super::noise_error::NoiseError;
pub use super::noise_floor::{
    segment_mean_square, segment_mean_square_stream, NoiseFloor, NoiseFloors, NullPsd,
};
pub use crate::signal::sensor_noise::{
    grid_step_s, stream, SampleKind, SensorNoise, SensorNoiseError,
};
pub use crate::signal::sensor_noise_estimate::{estimate_sensor_noise, estimate_sensor_noise_in};

/// The sensor estimates of every column of `cfg` present in `log` with a finite value.
///
/// # Errors
/// As [`grid_step_s`].
pub fn sensor_estimates(log: &DriveLog, cfg: &NoiseConfig) -> Result<Vec<SensorNoise>, NoiseError> {
    let dt = grid_step_s(log)?;
    let mut out = Vec::new();
    for c in &cfg.columns {
        let Some(s) = log.signals.iter().find(|s| s.name == c.column) else {
            continue;
        };
        let range = (
            c.min.unwrap_or(f64::NEG_INFINITY),
            c.max.unwrap_or(f64::INFINITY),
        );
        match estimate_sensor_noise_in(
            &s.name,
            &s.unit,
            &s.values,
            dt,
            SampleKind::of_column(&s.name),
            range,
        ) {
            Ok(e) => out.push(e),
            Err(SensorNoiseError::Empty { .. }) => continue,
            Err(e) => return Err(e.into()),
        }
    }
    Ok(out)
}

/// Copy `copy` of `log` with every sensed column perturbed by a draw of its sensor error,
/// clamped into its physical range, rows at rest set to the rest state
/// ([`SensorNoise::draw_in`]; NaN stays NaN). The perturbation of a column:
/// [`column_perturbation`]. With `keep`, the copy holds those columns alone (what the models
/// read: a recording's other columns, GNSS or a bus's further signals, would be copied for
/// nothing).
pub fn perturbed_log(
    log: &DriveLog,
    sensors: &[SensorNoise],
    cfg: &NoiseConfig,
    copy: u64,
    keep: Option<&[&str]>,
) -> DriveLog {
    let mut out = log.with_columns(keep);
    for s in sensors {
        if let Some(col) = out.signals.iter_mut().find(|c| c.name == s.column) {
            perturb_column(&mut col.values, log, s, cfg, copy);
        }
    }
    out
}

/// The perturbation copy `copy` of [`perturbed_log`] applies to the column of `s` (zero
/// where the column is NaN; `None` without the column): the same draw, made again from the
/// copy's seeded stream, so it need not be kept while the copy's models run.
pub fn column_perturbation(
    log: &DriveLog,
    s: &SensorNoise,
    cfg: &NoiseConfig,
    copy: u64,
) -> Option<Vec<f64>> {
    let col = log.signals.iter().find(|c| c.name == s.column)?;
    let mut values = col.values.clone();
    Some(perturb_column(&mut values, log, s, cfg, copy))
}

/// Perturbs `values` (the column of `s` in `log`) as copy `copy` does; returns the change
/// applied to each row.
fn perturb_column(
    values: &mut Vec<f64>,
    log: &DriveLog,
    s: &SensorNoise,
    cfg: &NoiseConfig,
    copy: u64,
) -> Vec<f64> {
    let range = cfg.columns.iter().find(|c| c.column == s.column);
    let (lo, hi) = (
        range.and_then(|r| r.min).unwrap_or(f64::NEG_INFINITY),
        range.and_then(|r| r.max).unwrap_or(f64::INFINITY),
    );
    let (d, rest) = s.draw_in(values.len(), &mut stream(cfg.seed, copy, &s.column), lo, hi);
    let mut applied = vec![0.0; d.len()];
    for (i, v) in values.iter_mut().enumerate() {
        if v.is_finite() {
            let nv = rest[i].unwrap_or_else(|| (*v + d[i]).clamp(lo, hi));
            applied[i] = nv - *v;
            *v = nv;
        }
    }
    if cfg.phase_jitter_columns.contains(&s.column) && s.native_rate_hz > 0.0 {
        // sample-phase uncertainty of an event channel: the copy's samples stand for events
        // up to half a native period earlier or later
        let half = 0.5 / s.native_rate_hz;
        let tau = stream(cfg.seed, copy, &format!("{}/phase", s.column)).uniform(-half, half);
        let t: Vec<f64> = log.seconds_from_start();
        let before = std::mem::take(values);
        *values = super::extended::shifted(&t, &before, tau)
            .into_iter()
            .zip(&before)
            .map(|(x, b)| if b.is_finite() { x.clamp(lo, hi) } else { *b })
            .collect();
        for ((a, b), x) in applied.iter_mut().zip(&before).zip(values.iter()) {
            if b.is_finite() && x.is_finite() {
                *a += x - b;
            }
        }
    }
    applied
}

/// Noise floors of the signals `residuals` compares on `log` (see the module documentation,
/// part 2): `residuals` is run on the recording and on `cfg.copies` perturbed copies (in
/// parallel, one at a time on a long drive: [`super::long_drive`]; results in copy order, so
/// the outcome does not depend on the thread count), each copy holding the columns `keep`
/// alone when given (those `residuals` reads).
///
/// # Errors
/// [`NoiseError`] from the settings, the sensor estimates or `residuals`.
pub fn noise_floors_with<F>(
    log: &DriveLog,
    cfg: &NoiseConfig,
    keep: Option<&[&str]>,
    residuals: F,
) -> Result<NoiseFloors, NoiseError>
where
    F: Fn(&DriveLog) -> Result<Vec<Compared>, NoiseError> + Sync,
{
    cfg.validate()?;
    let dt = grid_step_s(log)?;
    let sensors = sensor_estimates(log, cfg)?;
    let mut base = residuals(log)?;
    let r0s: Vec<Vec<f64>> = base.iter().map(Compared::residual).collect();
    // past the residuals, only the signals' names, units and rows that count are read
    for b in &mut base {
        b.measured = Default::default();
        b.simulated = Default::default();
    }
    // per copy and compared signal: the residual's change alone, in single precision as the
    // floor keeps it ([`NoiseFloor::from_null_copies`]; a copy's log and its full comparison
    // are dropped as soon as it is read, and the measurement's own change is drawn again for
    // the split below, so a long drive holds one value per signal, copy and row that counts).
    // On a long drive the copies run one after the other, each simulation parallel inside (a
    // copy's perturbed log and simulation are its largest transient: one in flight, not one
    // per thread).
    type Run = Vec<Option<Vec<f32>>>;
    let copies: Vec<u64> = (0..cfg.copies as u64).collect();
    let mut runs: Vec<Run> = map_in_order(is_long(log.len()), &copies, |&c| {
        let plog = perturbed_log(log, &sensors, cfg, c, keep);
        let rs = residuals(&plog)?;
        drop(plog);
        base.iter()
            .zip(&r0s)
            .map(|(b, r0)| {
                let Some(cmp) = rs.iter().find(|x| x.name == b.name) else {
                    return Ok(None);
                };
                let n = r0.len();
                let got = cmp.valid.len();
                if got != n || cmp.measured.len() != n || cmp.simulated.len() != n {
                    return Err(NoiseError::Length {
                        what: format!("residual of {} in a perturbed copy", b.name),
                        expected: n,
                        got: got.min(cmp.measured.len()).min(cmp.simulated.len()),
                    });
                }
                // the copy's residual (Compared::residual) less the recording's, on the rows
                // where the recording's counts (elsewhere the recording's residual is NaN, and
                // so is the change): the clutch-actuation channel counts on a few rows only
                Ok(Some(
                    (0..n)
                        .filter(|&i| b.valid[i])
                        .map(|i| {
                            let rc = if cmp.valid[i] {
                                cmp.measured[i] - cmp.simulated[i]
                            } else {
                                f64::NAN
                            };
                            (rc - r0[i]) as f32
                        })
                        .collect(),
                ))
            })
            .collect()
    })
    .into_iter()
    .collect::<Result<_, _>>()?;
    let mut floors = Vec::new();
    for (k, b) in base.iter().enumerate() {
        let n = r0s[k].len();
        // each copy's change spread onto every row (NaN where the recording's row does not
        // count), one signal's copies at a time
        let (index, copies): (Vec<u64>, Vec<Vec<f32>>) = runs
            .iter_mut()
            .enumerate()
            .filter_map(|(c, r)| {
                r[k].take().map(|e| {
                    let mut on = e.into_iter();
                    let full: Vec<f32> = b
                        .valid
                        .iter()
                        .map(|&v| {
                            if v {
                                on.next().unwrap_or(f32::NAN)
                            } else {
                                f32::NAN
                            }
                        })
                        .collect();
                    (c as u64, full)
                })
            })
            .unzip();
        let mut f = NoiseFloor::from_null_copies(&b.name, &b.unit, dt, copies, &b.valid, cfg)?;
        // measurement / input split (RMS over the rows that count, where the floor keeps the
        // copies)
        let sensor = sensors.iter().find(|s| s.column == b.name);
        let (mut sm, mut si, mut cnt) = (0.0, 0.0, 0usize);
        for (c, e) in index.iter().zip(&f.null_copies) {
            let meas = sensor
                .and_then(|s| column_perturbation(log, s, cfg, *c))
                .unwrap_or_else(|| vec![0.0; n]);
            for i in 0..n {
                if f.null_variance[i].is_finite() {
                    sm += meas[i] * meas[i];
                    si += (f64::from(e[i]) - meas[i]).powi(2);
                    cnt += 1;
                }
            }
        }
        if cnt > 0 {
            f.measurement_rms = Some((sm / cnt as f64).sqrt());
            f.input_rms = Some((si / cnt as f64).sqrt());
        }
        f.sensor = sensor.map(SensorNoise::without_samples);
        floors.push(f);
    }
    Ok(NoiseFloors {
        floors,
        sensors,
        copies: cfg.copies,
        seed: cfg.seed,
    })
}

/// [`noise_floors_with`] for the extended models of `models` at parameters `theta`
/// ([`ModelSet::compared`]).
///
/// # Errors
/// As [`noise_floors_with`].
pub fn noise_floors(
    log: &DriveLog,
    models: &ModelSet<'_>,
    theta: &Theta,
    cfg: &NoiseConfig,
) -> Result<NoiseFloors, NoiseError> {
    let read = ModelSet::read_columns();
    noise_floors_with(log, cfg, Some(&read), |l| models.compared(l, theta))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_copy_moves_the_engine_torques_steps_within_half_its_sample_period() {
        // a 1 000 N·m tip-in at 10 s, 50 Hz samples on the 50 Hz grid, no noise: each copy
        // reads the torque up to ±10 ms off, so only the two rows about the step change, by at
        // most half the step
        let n = 1000;
        let torque: Vec<f64> = (0..n).map(|i| if i < 500 { 0.0 } else { 1000.0 }).collect();
        let log = DriveLog {
            meta: crate::table::DriveMeta::default(),
            timestamp_ns: (0..n as i64).map(|k| k * 20_000_000).collect(),
            signals: vec![crate::table::Signal {
                name: "engine_torque".into(),
                unit: "N*m".into(),
                values: torque,
            }],
        };
        let s = SensorNoise::given(
            "engine_torque",
            "N*m",
            SampleKind::Linear,
            n,
            0.02,
            1,
            0.0,
            None,
        )
        .unwrap();
        let cfg = NoiseConfig::default();
        let mut moved = 0;
        for copy in 0..12 {
            let plog = perturbed_log(&log, std::slice::from_ref(&s), &cfg, copy, None);
            let d = column_perturbation(&log, &s, &cfg, copy).expect("the column");
            for ((p, v), x) in plog.signals[0]
                .values
                .iter()
                .zip(&log.signals[0].values)
                .zip(&d)
            {
                // the copy's column is the recording's plus its perturbation (to rounding)
                assert!(
                    (p - (v + x)).abs() <= 1e-9,
                    "copy {copy}: {p} against {v} + {x}"
                );
            }
            for (i, x) in d.iter().enumerate() {
                if i == 499 || i == 500 {
                    assert!(x.abs() <= 500.0 + 1e-9, "copy {copy} row {i}: {x}");
                } else {
                    assert_eq!(*x, 0.0, "copy {copy} row {i}");
                }
            }
            moved += usize::from(d.iter().any(|x| *x != 0.0));
        }
        assert!(moved >= 11, "{moved} of 12 copies moved the step");
    }
}
