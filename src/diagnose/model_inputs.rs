//! The recording as the extended models read it (docs/diagnosis/method.md, step 3;
//! [`super::extended`]):
//! - sensor effects correct the *recorded inputs* before the model sees them (the inverse of the
//!   sensor fault): the slope becomes `tan(atan(s) − δ)` (`grade_offset`), the engine torque
//!   `M(t + τ) − ΔM` (`signal_delay`, `engine_torque_offset`);
//! - the recorded slope, a held column (`schemas/drive-log.toml`: each native sample held on
//!   the grid until the next), lags the road by half its native period `P` on average; the
//!   models read it `P/2` ahead ([`corrected_log`]; `P` read off the rows where the recorded
//!   value changes), the centred hold. On a hill the lag is a grade error `(dα/dt)·P/2` of
//!   one sign while the grade climbs — at 24.5 m/s on a 2.5·10⁻⁴ 1/m grade change and 10 Hz,
//!   3·10⁻⁴ (55 N on the 18.7 t proof truck), 0.06 m/s of speed over a 20 s window — which
//!   the noise floor, drawn about the recording, does not carry. On the 84 no-effect drives of
//!   `fleetdyn prove` seeds 1, 2, 3, 1001, 5001, 7001, 9001 (drawn driving), 0.45 % of the
//!   vehicle-speed windows fall below p = 10⁻⁴ with the slope read as recorded and 0.045 % with
//!   it read ahead, 0.86 % and 0.32 % of engine speed's; the lag is the largest share of most
//!   clean `unexplained` windows read as recorded (`research/studies/truth_residual.rs`);
//! - a service-brake force that never reaches a braking episode's force is a released brake,
//!   except at a standstill ([`corrected_log`]);
//! - the columns a model compares with are read with their gaps filled linearly.
//!
//! Units: the log's SI units (slope tan α, torque N·m, force N); times in s.

use super::effect_parameters::Theta;
use super::extended_error::ExtendedError;
use crate::model::catalogue::Effect;
use crate::signal::interp_linear_at;
use crate::sim::axle_recorded::AxleRecordConfig;
use crate::table::{DriveLog, Signal};

/// The sensor effects: they correct the recorded inputs ([`corrected_log`], and the cured slope
/// of `slope_quantization`) instead of changing a model's plant.
pub const INPUT_EFFECTS: [Effect; 4] = [
    Effect::GradeOffset,
    Effect::SlopeQuantization,
    Effect::SignalDelay,
    Effect::EngineTorqueOffset,
];

/// The recording with the sensor effects of `theta` undone (see the module documentation);
/// `cured_slope` is the recording's slope with `slope_quantization` undone
/// ([`SlopeGrid::cured`]), used when given. The slope (recorded or cured) is read half its
/// native period ahead, which undoes the hold's mean lag (the period is the mean spacing of
/// the recorded slope's changes, over those at most 1.5× their 10th percentile; the cure is
/// built from the held samples, so it carries the same lag). A service-brake force is read
/// as a released brake (0) where no sample within
/// ±[`super::rows::BRAKE_EPISODE_HALFWIDTH_S`] reaches
/// [`super::rows::BRAKE_RELEASED_BELOW_N`]; inside a braking episode every value counts,
/// and so does every value at a standstill (recorded speed below the axle input's
/// [`AxleRecordConfig::standstill_speed_mps`]), where the brakes hold the truck on the grade
/// with whatever force it asks for ([`crate::sim::axle_recorded`]). Read as released, the
/// 0.81 kN holding force of a clean proof drive (18.7 t standing 6 s on 0.44 %) puts the axle
/// model, fed every input at its truth, 2.4 kPa above the rear bellow's true pressure for as
/// long as the truck stands.
///
/// `only` names the columns the caller reads (`None`: every column); the others are left out
/// of the copy, which on a long drive is most of its size.
///
/// [`SlopeGrid::cured`]: super::slope_grid::SlopeGrid::cured
pub fn corrected_log(
    log: &DriveLog,
    theta: &Theta,
    cured_slope: Option<&[f64]>,
    only: Option<&[&str]>,
) -> DriveLog {
    let mut out = log.with_columns(only);
    for c in corrected_columns(log, theta, cured_slope, only) {
        if let Some(s) = out.signals.iter_mut().find(|s| s.name == c.name) {
            *s = c;
        }
    }
    out
}

/// The columns [`corrected_log`] changes, corrected, alone: the slope and the service-brake
/// force whenever the log has them, the engine torque when `theta` delays or offsets it (among
/// `only`, when given). Read over the log ([`crate::table::LogView`]) they are
/// [`corrected_log`] without a copy of the columns it leaves as they are.
pub fn corrected_columns(
    log: &DriveLog,
    theta: &Theta,
    cured_slope: Option<&[f64]>,
    only: Option<&[&str]>,
) -> Vec<Signal> {
    let t: Vec<f64> = log.seconds_from_start();
    let delta = theta.get(Effect::GradeOffset);
    let offset = theta.get(Effect::EngineTorqueOffset);
    let tau = theta.get(Effect::SignalDelay);
    let speed = log.signal("vehicle_speed");
    let standstill_mps = AxleRecordConfig::default().standstill_speed_mps;
    let mut out = Vec::new();
    for s in &log.signals {
        if only.is_some_and(|k| !k.contains(&s.name.as_str())) {
            continue;
        }
        let values = match s.name.as_str() {
            "road_slope" => {
                // the hold's lag, read off the recorded samples (a cure is smooth)
                let period = held_period_s(&t, &s.values);
                let mut v = match cured_slope {
                    Some(f) => f.to_vec(),
                    None => s.values.clone(),
                };
                if let Some(p) = period {
                    v = shifted(&t, &v, 0.5 * p);
                }
                if delta != 0.0 {
                    for x in v.iter_mut() {
                        *x = (x.atan() - delta).tan();
                    }
                }
                v
            }
            "engine_torque" if tau != 0.0 || offset != 0.0 => {
                let mut v = if tau != 0.0 {
                    shifted(&t, &s.values, tau)
                } else {
                    s.values.clone()
                };
                if offset != 0.0 {
                    for x in v.iter_mut() {
                        *x -= offset;
                    }
                }
                v
            }
            "brake_force" => {
                let busy = windowed_max(&t, &s.values, super::rows::BRAKE_EPISODE_HALFWIDTH_S);
                let mut v = s.values.clone();
                for (k, (x, m)) in v.iter_mut().zip(busy).enumerate() {
                    let stands = speed.is_some_and(|u| u[k].abs() < standstill_mps);
                    if m < super::rows::BRAKE_RELEASED_BELOW_N && !stands {
                        *x = 0.0;
                    }
                }
                v
            }
            _ => continue,
        };
        out.push(Signal {
            name: s.name.clone(),
            unit: s.unit.clone(),
            values,
        });
    }
    out
}

/// Native sample period (s) of a zero-order-held column: the mean spacing of the rows where
/// the value changes, over the spacings at most 1.5× their 10th percentile (a run of equal
/// samples hides a change). `None` with fewer than 8 changes.
fn held_period_s(t: &[f64], v: &[f64]) -> Option<f64> {
    let mut last: Option<f64> = None;
    let mut gaps = Vec::new();
    for i in 1..v.len() {
        if v[i].is_finite() && v[i - 1].is_finite() && v[i] != v[i - 1] {
            if let Some(l) = last {
                gaps.push(t[i] - l);
            }
            last = Some(t[i]);
        } else if !v[i].is_finite() {
            last = None;
        }
    }
    if gaps.len() < 8 {
        return None;
    }
    let mut s = gaps.clone();
    s.sort_by(f64::total_cmp);
    let p10 = s[s.len() / 10];
    let kept: Vec<f64> = gaps.into_iter().filter(|g| *g <= 1.5 * p10).collect();
    Some(kept.iter().sum::<f64>() / kept.len() as f64)
}

/// Largest finite value of `v` within ±`half_s` of each row (NaN where none), O(n) with a
/// monotonic queue.
fn windowed_max(t: &[f64], v: &[f64], half_s: f64) -> Vec<f64> {
    use std::collections::VecDeque;
    let n = t.len();
    let mut out = vec![f64::NAN; n];
    let mut q: VecDeque<usize> = VecDeque::new();
    let mut hi = 0;
    for i in 0..n {
        while hi < n && t[hi] <= t[i] + half_s {
            if v[hi].is_finite() {
                while q.back().is_some_and(|&b| v[b] <= v[hi]) {
                    q.pop_back();
                }
                q.push_back(hi);
            }
            hi += 1;
        }
        while q.front().is_some_and(|&f| t[f] < t[i] - half_s) {
            q.pop_front();
        }
        if let Some(&f) = q.front() {
            out[i] = v[f];
        }
    }
    out
}

/// `v(t + tau)` on the grid `t` (linear between finite samples, held at the ends, NaN kept).
pub(crate) fn shifted(t: &[f64], v: &[f64], tau: f64) -> Vec<f64> {
    let at: Vec<f64> = t.iter().map(|&x| x + tau).collect();
    interp_linear_at(t, v, &at)
}

pub(super) fn filled(log: &DriveLog, name: &str) -> Result<Vec<f64>, ExtendedError> {
    log.signal(name)
        .and_then(|v| crate::signal::distance::fill_gaps(v, crate::schema::Interpolation::Linear))
        .ok_or_else(|| ExtendedError::Missing {
            file: log.meta.source_file.clone(),
            column: name.into(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{DriveMeta, Signal};

    #[test]
    fn a_small_brake_force_is_released_while_moving_but_holds_at_a_standstill() {
        // 10 s standing on a gentle grade held by 0.8 kN, then 10 s rolling with 0.3 kN of a
        // released brake's clamped noise; no sample reaches the 1 kN of a braking episode
        let n = 1000;
        let speed: Vec<f64> = (0..n).map(|k| if k < 500 { 0.0 } else { 5.0 }).collect();
        let brake: Vec<f64> = (0..n)
            .map(|k| if k < 500 { 800.0 } else { 300.0 })
            .collect();
        let log = DriveLog {
            meta: DriveMeta::default(),
            timestamp_ns: (0..n as i64).map(|k| k * 20_000_000).collect(),
            signals: vec![
                Signal {
                    name: "vehicle_speed".into(),
                    unit: "m/s".into(),
                    values: speed,
                },
                Signal {
                    name: "brake_force".into(),
                    unit: "N".into(),
                    values: brake,
                },
            ],
        };
        // no sensor effect: grade offset, torque offset and delay 0
        let out = corrected_log(&log, &Theta([0.0; 16]), None, None);
        let b = out.signal("brake_force").unwrap();
        assert!(b[..500].iter().all(|&x| x == 800.0), "{:?}", &b[..5]);
        assert!(b[500..].iter().all(|&x| x == 0.0), "{:?}", &b[500..505]);
    }

    #[test]
    fn the_held_slope_is_read_half_a_period_ahead_which_removes_its_lag() {
        // a grade climbing at 2·10⁻³ per s (a hill at speed), sampled at 10 Hz half a row after
        // the grid's rows (the phase a row's rounding leaves on average) and held on a 50 Hz
        // grid, as ingest puts road_slope on the grid
        let n = 3000;
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.02).collect();
        let truth = |x: f64| 0.01 + 2e-3 * x;
        let held: Vec<f64> = t
            .iter()
            .map(|&x| truth(((x - 0.01) * 10.0).floor() / 10.0 + 0.01))
            .collect();
        let period = held_period_s(&t, &held).unwrap();
        assert!((period - 0.1).abs() < 1e-9, "{period}");
        let log = DriveLog {
            meta: DriveMeta::default(),
            timestamp_ns: (0..n as i64).map(|k| k * 20_000_000).collect(),
            signals: vec![Signal {
                name: "road_slope".into(),
                unit: "1".into(),
                values: held.clone(),
            }],
        };
        let out = corrected_log(&log, &Theta([0.0; 16]), None, None);
        let read = out.signal("road_slope").unwrap();
        let mean_err = |v: &[f64]| {
            let r = 10..n - 10;
            r.clone().map(|k| v[k] - truth(t[k])).sum::<f64>() / r.len() as f64
        };
        // held: the rows lag their samples by 10, 30, 50, 70, 90 ms, −(dα/dt)·P/2 = −1·10⁻⁴ on
        // average; read 50 ms ahead the lag is gone (to rounding)
        assert!((mean_err(&held) + 1e-4).abs() < 5e-6, "{}", mean_err(&held));
        assert!(mean_err(read).abs() < 5e-6, "{}", mean_err(read));
    }

    #[test]
    fn the_corrected_columns_read_over_the_log_are_the_corrected_log() {
        // 60 s at 50 Hz: a 10 Hz held slope, a torque with steps, a brake that brakes once and
        // drags a released force elsewhere, a gear column the correction leaves as it is
        let n = 3000;
        let t = |k: usize| k as f64 * 0.02;
        let slope: Vec<f64> = (0..n)
            .map(|k| 0.01 * ((t(k) * 10.0).floor() / 10.0).sin())
            .collect();
        let torque: Vec<f64> = (0..n)
            .map(|k| if k % 700 < 350 { 900.0 } else { -80.0 })
            .collect();
        let brake: Vec<f64> = (0..n)
            .map(|k| {
                if (1000..1200).contains(&k) {
                    8000.0
                } else {
                    300.0
                }
            })
            .collect();
        let log = DriveLog::from_columns(
            20_000_000,
            vec![
                ("vehicle_speed", "m/s", vec![20.0; n]),
                ("road_slope", "1", slope),
                ("engine_torque", "N.m", torque),
                ("brake_force", "N", brake),
                ("gear", "1", vec![12.0; n]),
            ],
        );
        let mut sensors = Theta([0.0; 16]);
        sensors.set(Effect::GradeOffset, 0.003);
        sensors.set(Effect::SignalDelay, 0.13);
        sensors.set(Effect::EngineTorqueOffset, 40.0);
        let cure: Vec<f64> = (0..n).map(|k| 0.01 * t(k).sin()).collect();
        let only = ["road_slope", "engine_torque", "gear", "brake_force"];
        for (theta, cured) in [
            (Theta([0.0; 16]), None),
            (sensors, None),
            (sensors, Some(cure.as_slice())),
        ] {
            // the longitudinal model reads six columns, the axle model every column
            for keep in [Some(&only[..]), None] {
                let copy = corrected_log(&log, &theta, cured, keep);
                let replaced = corrected_columns(&log, &theta, cured, keep);
                let view = crate::table::LogView {
                    log: &log,
                    replaced: &replaced,
                };
                for c in copy.signals.iter().map(|s| s.name.as_str()) {
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(
                        bits(view.signal(c).unwrap()),
                        bits(copy.signal(c).unwrap()),
                        "{c}"
                    );
                }
            }
            let replaced = corrected_columns(&log, &theta, cured, Some(&only));
            // the gear is never copied, nor the torque without a delay or offset
            let names: Vec<&str> = replaced.iter().map(|s| s.name.as_str()).collect();
            assert!(!names.contains(&"gear"));
            assert_eq!(
                names.contains(&"engine_torque"),
                theta.get(Effect::SignalDelay) != 0.0
            );
        }
    }

    #[test]
    fn a_held_period_needs_changes() {
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.02).collect();
        assert_eq!(held_period_s(&t, &[0.03; 100]), None);
        let mut v = vec![0.0; 100];
        v[50] = f64::NAN;
        assert_eq!(held_period_s(&t, &v), None);
    }
}
