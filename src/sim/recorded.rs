//! Recorded drives as simulation inputs: the canonical drive log's engine torque, gear, clutch,
//! slope and brake columns turned into piecewise-linear [`Scenario`] inputs.
//!
//! Rules:
//! - time is counted from the first row of the log, s;
//! - continuous columns (engine torque, clutch position, brake force) are linear between samples,
//!   state-like ones (gear, slope sensor) are held — the interpolation kinds of the schema;
//! - short gaps (NaN; ingest bounds their length) are filled as the column's kind allows;
//! - gear 0 (neutral) is simulated as the clutch fully open in the last engaged gear — the model
//!   has no neutral (Myklebust & Eriksson (2012), §2.3);
//! - the engine torque column is the torque the ECU reports; the scenario drives the
//!   model with the torque the engine produces, that column through the engine's first-order
//!   lag `τ_e Ṁ_e = M_rep − M_e` (`engine_torque_lag_s` of the vehicle file, passed in;
//!   [`crate::signal::first_order_lag`]);
//! - absent optional columns: clutch engaged (x = 0), no service brake (F_b = 0);
//! - cold tyres: when the vehicle passed in states a tyre warm-up
//!   ([`crate::model::tyre_warm_up`]), its extra rolling resistance on every row, from the
//!   recorded vehicle speed's distance, adds to the force that opposes the motion (the scenario's
//!   `brake_n`, which the model takes with the motion's sign and counts at a standstill among
//!   what holds the truck, as it does the rolling resistance);
//! - the slope comes from the named column (e.g. the filtered slope of the slope stage), else
//!   `road_slope`; without any slope column the road is flat, and this is reported;
//! - rolling resistance is unsmoothed and the vehicle's stops are events
//!   ([`Scenario::standstill_events`]), as in the synthetic drives' truth: a recording stands
//!   still for minutes at a time, held by its brakes (`brake_force`, a magnitude ≥ 0) and the
//!   static rolling resistance `c_r1 m g`. The smoothing `f(v) = 1 − exp(−c_sr v²)`
//!   (docs/models/driveline.md, a speed-up for the accurate integrator) removes that resistance
//!   at v = 0 and takes the brake's direction from the sign of a speed that chatters about 0, so
//!   the standstill would rest on the recorded brake force alone; with a brake force of 0 (a log
//!   that clipped the holding force on an uphill stop) the smoothed model rolls backwards at
//!   1.4 m/s² (10 m/s within 7 s on a clean 5 km city-se synthetic drive).

use super::hybrid::{EngineInput, Scenario};
use super::inputs::{Between, Piecewise};
use crate::model::driveline::DrivelineParams;
use crate::model::tyre_warm_up::TyreWarmUp;
use crate::schema::Interpolation;
use crate::signal::distance::{fill_gaps, fill_gaps_borrowed};
use crate::signal::first_order_lag;
use crate::table::{DriveLog, LogView};
use std::borrow::Cow;
use std::sync::Arc;

/// What a recording could not provide.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordedError {
    /// Too few rows to simulate.
    #[error("{file}: {rows} rows; a simulation needs at least 2")]
    TooShort {
        /// Source file.
        file: String,
        /// Rows.
        rows: usize,
    },
    /// A required column is absent or has no value.
    #[error("{file}: no usable {column} column for the driveline simulation")]
    Missing {
        /// Source file.
        file: String,
        /// Column.
        column: String,
    },
    /// A gear the gearbox lacks.
    #[error("{file}: gear {gear} at row {row} is not in the gearbox (0..={max})")]
    Gear {
        /// Source file.
        file: String,
        /// Gear.
        gear: f64,
        /// Row.
        row: usize,
        /// Highest gear.
        max: usize,
    },
}

/// A recorded drive as a scenario, with the time axis it was built on.
#[derive(Debug, Clone)]
pub struct RecordedScenario {
    /// The inputs.
    pub scenario: Scenario,
    /// Sample times relative to the first row, s (shared with the inputs' pieces).
    pub t_s: Arc<[f64]>,
    /// Which slope column was used (`None`: flat road).
    pub slope_column: Option<String>,
}

/// Times of a log's rows relative to its first row, s.
///
/// # Errors
/// [`RecordedError::TooShort`] for fewer than 2 rows.
pub(crate) fn relative_times(log: &DriveLog) -> Result<Arc<[f64]>, RecordedError> {
    if log.len() < 2 {
        return Err(RecordedError::TooShort {
            file: log.meta.source_file.clone(),
            rows: log.len(),
        });
    }
    let t0 = log.timestamp_ns[0];
    Ok(log
        .timestamp_ns
        .iter()
        .map(|&x| (x - t0) as f64 * 1e-9)
        .collect())
}

/// The slope input of a log: the named column, else `road_slope`, else a flat road (`None`),
/// gaps filled by holding.
pub(crate) fn slope_input<'a>(
    log: LogView<'a>,
    slope_column: Option<&str>,
) -> (Option<String>, Cow<'a, [f64]>) {
    let column = |name: &str| {
        log.signal(name)
            .and_then(|v| fill_gaps_borrowed(v, Interpolation::Hold))
    };
    match slope_column
        .and_then(|c| column(c).map(|v| (c.to_string(), v)))
        .or_else(|| column("road_slope").map(|v| ("road_slope".to_string(), v)))
    {
        Some((n, v)) => (Some(n), v),
        None => (None, Cow::Owned(vec![0.0; log.len()])),
    }
}

/// Piecewise signal through samples `(t, v)`: linear between them or held, as `interp` says; runs
/// of equal constant pieces stored as one and the time axis shared
/// ([`Piecewise::through_samples`]). A 10-hour drive's scenario would take ~290 MB as one 32-B
/// tuple per row and input (docs/validation/benchmarks.md). Only piece boundaries inside a merged
/// stretch disappear, which matters solely to integrators that restart at breakpoints — recorded
/// scenarios go to the fixed-step exponential integrator, which evaluates values only.
pub(crate) fn pieces(t: &Arc<[f64]>, v: &[f64], interp: Interpolation) -> Piecewise {
    let between = match interp {
        Interpolation::Linear => Between::Linear,
        _ => Between::Held,
    };
    Piecewise::through_samples(t, v, between).expect("strictly increasing times and filled values")
}

/// Builds the scenario of a recorded drive (see the module rules). With
/// `retarder_n_per_nm = i_f / r_w` (1/m) a `retarder_torque` column (N·m on the propeller shaft,
/// positive braking) adds its wheel-equivalent force `T_r i_f / r_w` to the service-brake force:
/// the retarder's torque taken at the wheels, without the propeller shaft's torsion, as the synthetic
/// generator applies it (`synth::retarder`). `None` ignores the column. The engine torque is
/// the recorded one through the engine's lag `engine_lag_s` (s; 0: as recorded). `tyres`, when
/// given, is the vehicle whose tyre warm-up ([`TyreWarmUp::of`]) adds the cold tyres' extra
/// rolling resistance to that force (module rules); `None` or a vehicle without one adds none.
///
/// # Errors
/// [`RecordedError`] for logs shorter than 2 rows, missing engine torque or gear, or gears
/// outside `0..=forward_gears`.
pub fn scenario_from_log(
    log: &DriveLog,
    forward_gears: usize,
    slope_column: Option<&str>,
    retarder_n_per_nm: Option<f64>,
    engine_lag_s: f64,
    tyres: Option<&DrivelineParams>,
) -> Result<RecordedScenario, RecordedError> {
    scenario_from_view(
        LogView::of(log),
        forward_gears,
        slope_column,
        retarder_n_per_nm,
        engine_lag_s,
        tyres,
    )
}

/// [`scenario_from_log`] of a log view: the log with some columns replaced.
///
/// # Errors
/// As [`scenario_from_log`].
pub fn scenario_from_view(
    log: LogView<'_>,
    forward_gears: usize,
    slope_column: Option<&str>,
    retarder_n_per_nm: Option<f64>,
    engine_lag_s: f64,
    tyres: Option<&DrivelineParams>,
) -> Result<RecordedScenario, RecordedError> {
    let file = log.log.meta.source_file.clone();
    let t = relative_times(log.log)?;
    let column =
        |name: &str, interp: Interpolation| log.signal(name).and_then(|v| fill_gaps(v, interp));
    // read only: borrowed from the log when complete
    let column_ref = |name: &str, interp: Interpolation| {
        log.signal(name).and_then(|v| fill_gaps_borrowed(v, interp))
    };
    let missing = |c: &str| RecordedError::Missing {
        file: file.clone(),
        column: c.into(),
    };
    let mut torque = column_ref("engine_torque", Interpolation::Linear)
        .ok_or_else(|| missing("engine_torque"))?;
    if engine_lag_s > 0.0 {
        torque = Cow::Owned(first_order_lag(&t, &torque, engine_lag_s));
    }
    let gear_raw = column_ref("gear", Interpolation::Hold).ok_or_else(|| missing("gear"))?;
    let mut clutch =
        column("clutch_position", Interpolation::Linear).unwrap_or_else(|| vec![0.0; log.len()]);
    let mut brake =
        column("brake_force", Interpolation::Linear).unwrap_or_else(|| vec![0.0; log.len()]);
    if let (Some(k), Some(ret)) = (
        retarder_n_per_nm,
        column_ref("retarder_torque", Interpolation::Linear),
    ) {
        for (b, &r) in brake.iter_mut().zip(ret.iter()) {
            *b += k * r;
        }
    }
    if let Some((p, w)) = tyres.and_then(|p| TyreWarmUp::of(p).map(|w| (p, w))) {
        let v = column("vehicle_speed", Interpolation::Linear)
            .ok_or_else(|| missing("vehicle_speed"))?;
        for (b, f) in brake.iter_mut().zip(w.extra_force_n(p, &t, &v)) {
            *b += f;
        }
    }
    let (slope_name, slope) = slope_input(log, slope_column);
    // neutral: clutch open in the last engaged gear (the first engaged one before any)
    let first_engaged = gear_raw.iter().copied().find(|g| *g >= 1.0).unwrap_or(1.0);
    let mut last = first_engaged;
    let mut gear = Vec::with_capacity(log.len());
    for (row, &g) in gear_raw.iter().enumerate() {
        let g = g.round();
        if g < 0.0 || g > forward_gears as f64 {
            return Err(RecordedError::Gear {
                file: file.clone(),
                gear: g,
                row,
                max: forward_gears,
            });
        }
        if g == 0.0 {
            clutch[row] = 1.0;
            gear.push(last);
        } else {
            last = g;
            gear.push(g);
        }
    }
    let t_end = *t.last().expect("two rows");
    let scenario = Scenario {
        t_end_s: t_end,
        gear: pieces(&t, &gear, Interpolation::Hold),
        clutch_x: pieces(&t, &clutch, Interpolation::Linear),
        slope: pieces(&t, &slope, Interpolation::Hold),
        brake_n: pieces(&t, &brake, Interpolation::Linear),
        engine: EngineInput::Torque(pieces(&t, &torque, Interpolation::Linear)),
        smoothing: false,
        standstill_events: true,
    };
    Ok(RecordedScenario {
        scenario,
        t_s: t,
        slope_column: slope_name,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{DriveMeta, Signal};

    #[test]
    fn merged_constant_pieces_evaluate_exactly_as_the_samples() {
        // runs of equal samples (a closed clutch, a held gear, ±0.0) between changing ones:
        // the merged signal must give the bits of the one-piece-per-sample signal everywhere
        let v = [
            0.0, 0.0, 0.0, 1.5, 1.5, 2.0, -0.0, -0.0, 0.0, 0.0, 0.0, 3.0, 3.0, 3.0,
        ];
        let t: Arc<[f64]> = (0..v.len())
            .map(|k| k as f64 * 0.02 + 0.003 * (k % 3) as f64)
            .collect();
        for interp in [Interpolation::Linear, Interpolation::Hold] {
            let merged = pieces(&t, &v, interp);
            let plain = Piecewise::new(
                t.windows(2)
                    .zip(v.windows(2))
                    .map(|(tw, vw)| match interp {
                        Interpolation::Linear => (tw[0], tw[1], vw[0], vw[1]),
                        _ => (tw[0], tw[1], vw[0], vw[0]),
                    })
                    .collect(),
            )
            .unwrap();
            assert!(merged.piece_count() < plain.piece_count(), "{interp:?}");
            let end = *t.last().unwrap();
            for k in 0..=4000 {
                let x = end * k as f64 / 4000.0;
                assert_eq!(
                    merged.eval(x).to_bits(),
                    plain.eval(x).to_bits(),
                    "{interp:?} t = {x}"
                );
            }
        }
    }

    fn log(n: usize, gear: f64) -> DriveLog {
        let sig = |name: &str, v: f64| Signal {
            name: name.into(),
            unit: "1".into(),
            values: vec![v; n],
        };
        DriveLog {
            meta: DriveMeta {
                drive_id: "d".into(),
                vehicle_id: None,
                source_file: "f".into(),
                segment: None,
            },
            timestamp_ns: (0..n as i64).map(|k| k * 10_000_000).collect(),
            signals: vec![
                sig("vehicle_speed", 5.0),
                sig("engine_torque", 100.0),
                sig("gear", gear),
            ],
        }
    }

    #[test]
    fn zero_length_and_single_row_drives_are_errors() {
        assert!(matches!(
            scenario_from_log(&log(0, 3.0), 12, None, None, 0.0, None),
            Err(RecordedError::TooShort { rows: 0, .. })
        ));
        assert!(matches!(
            scenario_from_log(&log(1, 3.0), 12, None, None, 0.0, None),
            Err(RecordedError::TooShort { rows: 1, .. })
        ));
    }

    #[test]
    fn neutral_is_an_open_clutch_in_the_last_gear_and_bad_gears_are_errors() {
        let mut l = log(4, 3.0);
        l.signals[2].values = vec![3.0, 0.0, 0.0, 4.0];
        let r = scenario_from_log(&l, 12, None, None, 0.0, None).unwrap();
        assert_eq!(r.scenario.gear.eval(0.015), 3.0);
        assert_eq!(r.scenario.clutch_x.eval(0.015), 1.0);
        assert_eq!(r.slope_column, None, "no slope column: flat road, reported");
        assert!(matches!(
            scenario_from_log(&log(4, 13.0), 12, None, None, 0.0, None),
            Err(RecordedError::Gear { row: 0, .. })
        ));
    }

    #[test]
    fn a_stated_tyre_warm_up_adds_the_cold_tyres_force_to_what_opposes_the_motion() {
        // 5 m/s for 2000 rows of 10 ms: 100 m rolled; no brake column
        let l = log(2001, 3.0);
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/vehicles/truck-40t-cold-start.toml"
        ))
        .unwrap();
        let v = crate::model::vehicle::VehicleFile::parse(&text, "t").unwrap();
        let p = v.driveline("t").unwrap();
        let (beta, l_m) = (p.tyre_cold_excess, p.tyre_warm_up_distance_m);
        assert!(beta > 0.0, "the cold-start truck states a warm-up");
        let warm = scenario_from_log(&l, 12, None, None, 0.0, None).unwrap();
        let cold = scenario_from_log(&l, 12, None, None, 0.0, Some(p)).unwrap();
        let mg = p.mass_kg * p.gravity_m_per_s2;
        let rolling = (p.c_r1 + p.c_r2_s_per_m * 5.0) * mg;
        for (t, s) in [(0.0, 0.0), (10.0, 50.0), (20.0, 100.0)] {
            assert_eq!(warm.scenario.brake_n.eval(t), 0.0);
            let want = beta * (-s / l_m).exp() * rolling;
            // the trapezoid of a constant speed is exact up to the sum's rounding
            assert!((cold.scenario.brake_n.eval(t) - want).abs() < 1e-9 * want);
        }
        // a vehicle without a warm-up adds nothing
        let mut off = p.clone();
        off.tyre_cold_excess = 0.0;
        let none = scenario_from_log(&l, 12, None, None, 0.0, Some(&off)).unwrap();
        assert_eq!(none.scenario.brake_n, warm.scenario.brake_n);
    }

    #[test]
    fn short_nan_gaps_in_inputs_are_filled_by_the_column_kind() {
        let mut l = log(5, 3.0);
        l.signals[1].values = vec![100.0, f64::NAN, f64::NAN, 400.0, 500.0]; // engine torque: linear
        l.signals[2].values = vec![3.0, f64::NAN, 4.0, 4.0, 4.0]; // gear: held
        let r = scenario_from_log(&l, 12, None, None, 0.0, None).unwrap();
        let EngineInput::Torque(m) = &r.scenario.engine else {
            panic!()
        };
        assert!((m.eval(0.01) - 200.0).abs() < 1e-9);
        assert_eq!(r.scenario.gear.eval(0.015), 3.0);
        for k in 0..40 {
            let t = k as f64 * 0.001;
            assert!(m.eval(t).is_finite() && r.scenario.gear.eval(t).is_finite());
        }
    }
}
