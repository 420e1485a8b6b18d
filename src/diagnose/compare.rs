//! Step 1 of the diagnosis, compare (docs/diagnosis/method.md): the recording's outputs next to the
//! nominal model's, on the recording's rows, with what the later steps need to locate a mismatch —
//! time, distance, which rows count, and the operating condition of every row.
//!
//! Comparison method (docs/diagnosis/method.md, step 1): the longitudinal model runs in windows
//! re-initialised from the measured state ([`super::extended::LongitudinalModel`], 20 s), so
//! open-loop drift never spans more than one window; the axle model runs open loop (it is
//! stable). Both see the recording's own inputs.

use super::extended::{AxleModel, ExtendedError, LongitudinalModel, Theta};
use super::rows::BRAKE_RELEASED_BELOW_N;
use crate::table::DriveLog;
use std::sync::Arc;

/// One compared signal on the recording's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Compared {
    /// Canonical column (`vehicle_speed`, `engine_speed`, `bellow_pressure_rear`, …).
    pub name: String,
    /// SI unit.
    pub unit: String,
    /// Measured values (gaps filled linearly; see `valid`); shared storage, as the explain
    /// step's problem may hold the same values.
    pub measured: Arc<Vec<f64>>,
    /// Simulated values; shared storage, as `measured`.
    pub simulated: Arc<Vec<f64>>,
    /// Rows that count: finite, a real sample (not a filled gap), and for longitudinal signals
    /// the vehicle moving.
    pub valid: Vec<bool>,
}

impl Compared {
    /// Residual `measured − simulated` (NaN where not valid).
    pub fn residual(&self) -> Vec<f64> {
        self.measured
            .iter()
            .zip(self.simulated.iter())
            .zip(&self.valid)
            .map(|((m, s), v)| if *v { m - s } else { f64::NAN })
            .collect()
    }
}

/// Points each signal's measured and simulated values at a column of `pool` that holds the
/// same values bit for bit, so the two holders share one storage; a column without such a
/// twin keeps its own. (The explain step's problem holds the recording's speeds and their
/// nominal simulation, which the comparison makes again: on a 10-hour drive at 50 Hz each is
/// 14.4 MB.)
pub fn share_storage(signals: &mut [Compared], pool: &[&Arc<Vec<f64>>]) {
    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
    };
    for s in signals {
        for v in [&mut s.measured, &mut s.simulated] {
            if let Some(p) = pool.iter().find(|p| !Arc::ptr_eq(p, v) && same(p, v)) {
                *v = Arc::clone(p);
            }
        }
    }
}

/// The operating condition of every row, for locating by condition.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Conditions {
    /// Times, s from the first row.
    pub t_s: Vec<f64>,
    /// Travelled distance, m (∫ v dt of the measured speed).
    pub distance_m: Vec<f64>,
    /// Engaged gear (0 = neutral).
    pub gear: Vec<f64>,
    /// Engine torque as recorded, N·m (its sign: drive or engine brake).
    pub engine_torque_nm: Vec<f64>,
    /// Measured vehicle speed, m/s.
    pub speed_mps: Vec<f64>,
    /// Recorded slope, tan α.
    pub slope: Vec<f64>,
    /// Longitudinal acceleration from the measured speed, m/s².
    pub accel_mps2: Vec<f64>,
    /// Service brake or retarder active.
    pub braking: Vec<bool>,
    /// Clutch not fully engaged (position above 5 %).
    pub clutch_actuated: Vec<bool>,
}

impl Conditions {
    /// The operating condition of every row of `log` (gaps filled as the schema's kind says;
    /// a column the log lacks stays empty): times from the first row; distance the trapezoidal
    /// integral of the measured speed (negative speeds count 0); acceleration the centred
    /// difference of the measured speed over ±0.5 s; braking when the service-brake force
    /// exceeds 1 kN (5× the 0.2 kN noise of a J1939 brake-force channel, which a brake at rest
    /// never reaches) or the retarder torque 50 N·m (above its 1 %-of-reference step); clutch
    /// actuated above 5 % of its travel.
    pub fn from_log(log: &DriveLog) -> Conditions {
        use crate::schema::Interpolation;
        use crate::signal::distance::fill_gaps;
        let n = log.len();
        let col = |c: &str, k: Interpolation| log.signal(c).and_then(|v| fill_gaps(v, k));
        let t_s: Vec<f64> = log.seconds_from_start();
        let speed = col("vehicle_speed", Interpolation::Linear).unwrap_or_default();
        let mut distance_m = vec![0.0; if speed.is_empty() { 0 } else { n }];
        for i in 1..distance_m.len() {
            distance_m[i] = distance_m[i - 1]
                + 0.5 * (speed[i].max(0.0) + speed[i - 1].max(0.0)) * (t_s[i] - t_s[i - 1]);
        }
        let accel_mps2 = if speed.is_empty() {
            Vec::new()
        } else {
            (0..n)
                .map(|i| {
                    let a = t_s.partition_point(|&x| x < t_s[i] - 0.5);
                    let b = t_s
                        .partition_point(|&x| x <= t_s[i] + 0.5)
                        .saturating_sub(1);
                    if b > a {
                        (speed[b] - speed[a]) / (t_s[b] - t_s[a])
                    } else {
                        0.0
                    }
                })
                .collect()
        };
        let brake = col("brake_force", Interpolation::Linear);
        let retarder = col("retarder_torque", Interpolation::Linear);
        let braking = if brake.is_none() && retarder.is_none() {
            Vec::new()
        } else {
            (0..n)
                .map(|i| {
                    brake
                        .as_ref()
                        .is_some_and(|b| b[i] > BRAKE_RELEASED_BELOW_N)
                        || retarder.as_ref().is_some_and(|r| r[i] > 50.0)
                })
                .collect()
        };
        let clutch_actuated = col("clutch_position", Interpolation::Linear)
            .map(|c| c.iter().map(|x| *x > 0.05).collect())
            .unwrap_or_default();
        Conditions {
            distance_m,
            gear: col("gear", Interpolation::Hold).unwrap_or_default(),
            engine_torque_nm: col("engine_torque", Interpolation::Linear).unwrap_or_default(),
            speed_mps: speed,
            slope: col("road_slope", Interpolation::Hold).unwrap_or_default(),
            accel_mps2,
            braking,
            clutch_actuated,
            t_s,
        }
    }
}

/// What the nominal models say about one recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Compared signals (longitudinal and/or axle, as the recording allows).
    pub signals: Vec<Compared>,
    /// Operating conditions.
    pub conditions: Conditions,
}

/// Simulated outputs of the extended models at `theta`, as [`Compared`] signals with the
/// measured ones (`None` for a model the recording cannot drive); `long_valid` holds the rows
/// of both longitudinal signals, `engine_valid` further restricts the engine speed.
///
/// # Errors
/// [`ExtendedError`] from the simulations.
pub fn compare_at(
    long: Option<&LongitudinalModel<'_>>,
    axle: Option<&AxleModel<'_>>,
    theta: &Theta,
    long_valid: &[bool],
    engine_valid: &[bool],
    axle_measured: Option<&[Vec<f64>; 3]>,
    axle_valid: Option<&[Vec<bool>; 3]>,
) -> Result<Vec<Compared>, ExtendedError> {
    let mut out = Vec::new();
    if let Some(m) = long {
        let o = m.simulate(theta)?;
        out.push(Compared {
            name: "vehicle_speed".into(),
            unit: "m/s".into(),
            measured: Arc::new(m.measured_speed().to_vec()),
            simulated: Arc::new(o.vehicle_speed),
            valid: long_valid.to_vec(),
        });
        out.push(Compared {
            name: "engine_speed".into(),
            unit: "rad/s".into(),
            measured: Arc::new(m.measured_engine_speed().to_vec()),
            simulated: Arc::new(o.engine_speed),
            valid: long_valid
                .iter()
                .zip(engine_valid)
                .map(|(a, b)| *a && *b)
                .collect(),
        });
    }
    if let (Some(m), Some(meas), Some(valid)) = (axle, axle_measured, axle_valid) {
        let p = m.simulate(theta)?;
        for (i, axle_name) in ["front", "rear", "tag"].iter().enumerate() {
            out.push(Compared {
                name: format!("bellow_pressure_{axle_name}"),
                unit: "Pa".into(),
                measured: Arc::new(meas[i].clone()),
                simulated: Arc::new(p[i].clone()),
                valid: valid[i].clone(),
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_signal_shares_the_pools_column_only_when_its_bits_are_the_same() {
        let col = |v: &[f64]| Arc::new(v.to_vec());
        let twin = col(&[1.0, f64::NAN, 3.0]);
        let other = col(&[1.0, 2.0, 3.0]);
        let signed_zero = col(&[-0.0]);
        let mut signals = vec![
            Compared {
                name: "vehicle_speed".into(),
                unit: "m/s".into(),
                measured: col(&[1.0, f64::NAN, 3.0]),
                simulated: col(&[1.0, 2.0, 3.5]),
                valid: vec![true; 3],
            },
            Compared {
                name: "engine_speed".into(),
                unit: "rad/s".into(),
                measured: col(&[0.0]),
                simulated: col(&[1.0, 2.0]),
                valid: vec![true],
            },
        ];
        let before = signals.clone();
        share_storage(&mut signals, &[&other, &twin, &signed_zero]);
        // the same bits, NaN included: shared
        assert!(Arc::ptr_eq(&signals[0].measured, &twin));
        // a value apart, a different length, 0.0 against −0.0: each keeps its own
        assert!(!Arc::ptr_eq(&signals[0].simulated, &other));
        assert!(!Arc::ptr_eq(&signals[1].measured, &signed_zero));
        assert!(!Arc::ptr_eq(&signals[1].simulated, &other));
        for (a, b) in signals.iter().zip(&before) {
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a.measured), bits(&b.measured));
            assert_eq!(bits(&a.simulated), bits(&b.simulated));
        }
    }
}
