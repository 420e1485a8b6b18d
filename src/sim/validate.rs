//! Validation of the driveline model against a recording: simulate the drive from its recorded
//! inputs and compare with its recorded vehicle and engine speed.
//!
//! **Drift.** An open-loop simulation of a long drive drifts: unmodelled braking, wind and
//! sensor bias integrate into a growing speed error that would swamp the driveline's own error.
//! The drive is therefore cut into windows (default 30 s); each window starts from the measured
//! state — the steady state at the measured vehicle speed, slope and gear, with the clutch locked
//! when the recording says it is engaged and the vehicle moves, else slipping with the measured
//! engine speed — and is simulated open loop with the fast path (exponential integrator).
//!
//! The recorded scenario holds the vehicle at standstill by its brakes and static rolling
//! resistance ([`super::recorded`]); the initial state is the steady state of that unsmoothed
//! model.
//!
//! **Metrics** per signal (vehicle speed, engine speed), overall and per gear, on the samples
//! where the vehicle moves (measured speed ≥ `min_speed_mps`: at standstill the vehicle speed
//! is trivially 0 and the engine idles with the clutch open): RMSE, MAE and
//! fit % = 100·(1 − ‖y − ŷ‖/‖y − ȳ‖).

use super::fast::FastDriveline;
use super::hybrid::{steady_state_locked, ClutchMode, SimError};
use super::recorded::{scenario_from_log, RecordedError, RecordedScenario};
use crate::model::driveline::DrivelineParams;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps_borrowed;
use crate::signal::{butter, interp_linear, sosfiltfilt, BandType, EdgeMode};
use crate::table::DriveLog;
use thiserror::Error;

/// Validation settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ValidationConfig {
    /// Re-initialisation window, s.
    pub window_s: f64,
    /// Fast-path step, s.
    pub dt_s: f64,
    /// Samples below this measured speed are left out of the metrics, m/s.
    pub min_speed_mps: f64,
}

impl Default for ValidationConfig {
    fn default() -> Self {
        Self {
            window_s: 30.0,
            dt_s: 0.01,
            min_speed_mps: 1.0,
        }
    }
}

impl ValidationConfig {
    /// Canonical text of the settings, the driveline `p`, the gear `ratios` and the slope
    /// column, for the config hash of a single-drive simulation.
    pub fn fingerprint(
        &self,
        p: &DrivelineParams,
        ratios: &[f64],
        slope_column: Option<&str>,
    ) -> String {
        crate::io::canonical("shuffle:v2", &(p, ratios, self, slope_column))
    }

    /// Checks the settings: both steps positive, the fast-path step shorter than the window.
    pub fn validate(&self) -> Result<(), crate::settings::InvalidSetting> {
        use crate::settings::require;
        require(
            self.window_s > 0.0,
            "window_s",
            self.window_s,
            "must be positive",
        )?;
        require(self.dt_s > 0.0, "dt_s", self.dt_s, "must be positive")?;
        require(
            self.dt_s < self.window_s,
            "dt_s",
            self.dt_s,
            "must be shorter than window_s",
        )
    }
}

/// Why a drive could not be validated.
#[derive(Debug, Error)]
pub enum ValidationError {
    /// The recording lacks inputs.
    #[error(transparent)]
    Recorded(#[from] RecordedError),
    /// The simulation failed.
    #[error("{file}: {source}")]
    Sim {
        /// Source file.
        file: String,
        /// Cause.
        #[source]
        source: SimError,
    },
    /// Nothing to compare.
    #[error("{file}: the vehicle never reaches {min_speed_mps} m/s; nothing to validate")]
    NeverMoves {
        /// Source file.
        file: String,
        /// Threshold.
        min_speed_mps: f64,
    },
}

/// One row of the validation table.
#[derive(Debug, Clone, PartialEq)]
pub struct Metric {
    /// `vehicle_speed` or `engine_speed`.
    pub signal: &'static str,
    /// Gear, or `None` for all gears.
    pub gear: Option<usize>,
    /// Root-mean-square error, in the signal's unit.
    pub rmse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// Fit, % (100 = perfect; can be negative).
    pub fit_percent: f64,
    /// Samples compared.
    pub samples: usize,
}

/// A simulated drive on the recording's time axis, with its validation metrics.
#[derive(Debug, Clone)]
pub struct ShuffleValidation {
    /// Recording times, ns.
    pub timestamp_ns: Vec<i64>,
    /// Simulated vehicle speed, m/s.
    pub vehicle_speed: Vec<f64>,
    /// Simulated engine speed, rad/s.
    pub engine_speed: Vec<f64>,
    /// Simulated clutch, propeller and drive-shaft torques (M_c, M_p, M_d), N·m.
    pub shaft_torques: [Vec<f64>; 3],
    /// Simulated torsions (φ_c, φ_p, φ_d), rad.
    pub torsions: [Vec<f64>; 3],
    /// 1 when the clutch is locked, 0 when slipping.
    pub clutch_locked: Vec<f64>,
    /// Shuffle indicator: simulated vehicle speed band-passed 1–5 Hz (zero phase), m/s.
    pub shuffle_indicator: Vec<f64>,
    /// Window index of each sample.
    pub window: Vec<f64>,
    /// The metrics.
    pub metrics: Vec<Metric>,
    /// Slope column used (`None`: flat road).
    pub slope_column: Option<String>,
}

/// RMSE, MAE, fit % (`100 (1 − ‖y − ŷ‖/‖y − mean y‖)`, NaN for a constant y) of `yh` against
/// `y` — the metrics every validation table of fleetdyn reports.
pub fn error_metrics(y: &[f64], yh: &[f64]) -> (f64, f64, f64) {
    error_metrics_of(
        || y.iter().copied(),
        || y.iter().copied().zip(yh.iter().copied()),
    )
}

/// [`error_metrics`] of the samples `ys()` and pairs `(y, ŷ)` `pairs()` yield, in that order
/// (the same sums in the same order as on slices of them: the same bits), without collecting
/// them.
fn error_metrics_of<Y, P>(ys: impl Fn() -> Y, pairs: impl Fn() -> P) -> (f64, f64, f64)
where
    Y: Iterator<Item = f64>,
    P: Iterator<Item = (f64, f64)>,
{
    let n = ys().count().max(1) as f64;
    let mean = ys().sum::<f64>() / n;
    let (mut se, mut ae, mut ss) = (0.0, 0.0, 0.0);
    for (a, b) in pairs() {
        se += (a - b) * (a - b);
        ae += (a - b).abs();
        ss += (a - mean) * (a - mean);
    }
    let fit = if ss > 0.0 {
        100.0 * (1.0 - (se / ss).sqrt())
    } else {
        f64::NAN
    };
    ((se / n).sqrt(), ae / n, fit)
}

/// The metric of `sim` against `meas` on the samples `rows()` yields (increasing indices).
fn metric<R: Iterator<Item = usize>>(
    signal: &'static str,
    gear: Option<usize>,
    meas: &[f64],
    sim: &[f64],
    rows: impl Fn() -> R,
) -> Metric {
    let (rmse, mae, fit_percent) = error_metrics_of(
        || rows().map(|k| meas[k]),
        || rows().map(|k| (meas[k], sim[k])),
    );
    Metric {
        signal,
        gear,
        rmse,
        mae,
        fit_percent,
        samples: rows().count(),
    }
}

/// Values kept per simulated sample: vehicle speed, engine speed, the three torsions, the three
/// shaft torques, clutch locked (1/0).
const EMITTED: usize = 9;

/// Appends to `out`, for the recording's times `t[*next..]`, the linear interpolation of the
/// simulated samples `(bt, bv)` — a contiguous stretch of the whole trajectory that starts at
/// or before `t[*next]` — as [`interp_linear`] on the whole trajectory gives it. Without `all` it
/// stops at the first time not before the stretch's last sample (the next stretch brackets
/// it); with `all` (the last stretch) later times take the last sample.
fn emit(
    t: &[f64],
    next: &mut usize,
    bt: &[f64],
    bv: &[[f64; EMITTED]],
    all: bool,
    out: &mut [Vec<f64>; EMITTED],
) {
    let Some(&last) = bt.last() else {
        if all {
            for o in out.iter_mut() {
                o.resize(t.len(), f64::NAN);
            }
            *next = t.len();
        }
        return;
    };
    while let Some(&tt) = t.get(*next) {
        if !all && tt >= last {
            break;
        }
        let k = bt.partition_point(|&x| x <= tt);
        for (j, o) in out.iter_mut().enumerate() {
            o.push(if k == 0 {
                bv[0][j]
            } else if k >= bt.len() {
                bv[bt.len() - 1][j]
            } else {
                let w = (tt - bt[k - 1]) / (bt[k] - bt[k - 1]);
                bv[k - 1][j] + w * (bv[k][j] - bv[k - 1][j])
            });
        }
        *next += 1;
    }
}

/// Simulates `log` window by window and compares it with the recording (see the module doc).
///
/// # Errors
/// [`ValidationError`] for recordings without the needed columns, gears outside the gearbox,
/// or a vehicle that never moves.
pub fn validate_shuffle(
    log: &DriveLog,
    p: &DrivelineParams,
    ratios: &[f64],
    slope_column: Option<&str>,
    cfg: &ValidationConfig,
) -> Result<ShuffleValidation, ValidationError> {
    let file = log.meta.source_file.clone();
    let rec = scenario_from_log(
        log,
        ratios.len(),
        slope_column,
        Some(p.final_drive_ratio / p.wheel_radius_m),
        p.engine_torque_lag_s,
        Some(p),
    )?;
    let measured = |column: &str| {
        log.signal(column)
            .and_then(|v| fill_gaps_borrowed(v, Interpolation::Linear))
            .ok_or_else(|| RecordedError::Missing {
                file: file.clone(),
                column: column.into(),
            })
    };
    let v_meas = measured("vehicle_speed")?;
    let w_meas = measured("engine_speed")?;
    if !v_meas.iter().any(|&v| v >= cfg.min_speed_mps) {
        return Err(ValidationError::NeverMoves {
            file,
            min_speed_mps: cfg.min_speed_mps,
        });
    }
    let RecordedScenario {
        scenario: sc,
        t_s: t,
        slope_column,
    } = rec;
    let mut fast = FastDriveline::new(p, ratios, cfg.dt_s);
    let n_win = (sc.t_end_s / cfg.window_s).ceil().max(1.0) as usize;
    // Each window's trajectory is interpolated onto the recording's times as soon as the
    // samples around them are known (a window's samples plus the last one before it), so
    // memory holds one window of the fine simulation grid, not the whole drive's (a 10-hour
    // drive at dt = 0.01 s is 3.6 M states). The values equal linear interpolation in the
    // whole concatenated trajectory (`emit`).
    let mut out: [Vec<f64>; EMITTED] = std::array::from_fn(|_| Vec::with_capacity(t.len()));
    let mut next = 0usize;
    let (mut bt, mut bv): (Vec<f64>, Vec<[f64; EMITTED]>) = (Vec::new(), Vec::new());
    for w in 0..n_win {
        let ta = w as f64 * cfg.window_s;
        let tb = ((w + 1) as f64 * cfg.window_s).min(sc.t_end_s);
        if tb - ta < cfg.dt_s {
            continue;
        }
        let v0 = interp_linear(&t, &v_meas, ta).max(0.0);
        let gear = sc.gear.eval(ta + 1e-9).round() as usize;
        let slope = sc.slope.eval(ta + 1e-9);
        let x = sc.clutch_x.eval(ta + 1e-9);
        let (mut y0, _) = steady_state_locked(p, ratios, gear, v0, slope, sc.smoothing);
        let engaged = x <= p.clutch_l_lower * p.clutch_x_max;
        let mode = if engaged && v0 >= cfg.min_speed_mps {
            ClutchMode::Locked
        } else {
            let we = interp_linear(&t, &w_meas, ta);
            let sigma = if we >= y0[1] { 1.0 } else { -1.0 };
            y0[0] = we;
            ClutchMode::Slipping(sigma)
        };
        y0[8] = 0.0;
        let tr = fast
            .simulate_span(&sc, ta, tb, y0, mode)
            .map_err(|e| ValidationError::Sim {
                file: file.clone(),
                source: e,
            })?;
        // keep [ta, tb) of each window (the last window keeps its end)
        let keep = if w + 1 == n_win {
            tr.t.len()
        } else {
            tr.t.len() - 1
        };
        // carry the last sample of the earlier windows
        if bt.len() > 1 {
            bt.drain(..bt.len() - 1);
            bv.drain(..bv.len() - 1);
        }
        for k in 0..keep {
            let y = &tr.y[k];
            bt.push(tr.t[k]);
            bv.push([
                p.wheel_radius_m * y[7],
                y[0],
                y[2],
                y[4],
                y[6],
                tr.torques[k][1],
                tr.torques[k][2],
                tr.torques[k][3],
                if tr.mode[k] == ClutchMode::Locked {
                    1.0
                } else {
                    0.0
                },
            ]);
        }
        emit(&t, &mut next, &bt, &bv, false, &mut out);
    }
    emit(&t, &mut next, &bt, &bv, true, &mut out);
    drop((bt, bv));
    let gears: Vec<usize> = t
        .iter()
        .map(|&tt| sc.gear.eval(tt).round() as usize)
        .collect();
    let t_end_s = sc.t_end_s;
    drop(sc); // the inputs are not needed after this: freed before the tables are made
    let [vehicle_speed, engine_speed, phi_c, phi_p, phi_d, m_c, m_p, m_d, mut clutch_locked] = out;
    let torsions = [phi_c, phi_p, phi_d];
    let shaft_torques = [m_c, m_p, m_d];
    for x in &mut clutch_locked {
        *x = x.round();
    }
    let window: Vec<f64> = t
        .iter()
        .map(|&tt| (tt / cfg.window_s).floor().min((n_win - 1) as f64))
        .collect();
    let fs = (t.len() - 1) as f64 / t_end_s;
    let shuffle_indicator = if fs > 10.0 && t.len() > 64 {
        let hp = butter(2, 1.0, fs, BandType::Highpass).expect("valid band");
        let lp = butter(2, 5.0, fs, BandType::Lowpass).expect("valid band");
        let e = EdgeMode::default();
        sosfiltfilt(&hp, &vehicle_speed, &e)
            .and_then(|x| sosfiltfilt(&lp, &x, &e))
            .unwrap_or_else(|_| vec![f64::NAN; t.len()])
    } else {
        vec![f64::NAN; t.len()]
    };
    // metrics on moving samples, overall and per gear (the samples are visited where they lie,
    // not gathered: a 10-hour drive's would be 14 MB per list)
    let moving = |k: &usize| v_meas[*k] >= cfg.min_speed_mps;
    let gears = &gears;
    let in_gear = |g: usize| move |k: &usize| moving(k) && gears[*k] == g;
    let mut metrics = Vec::new();
    for (name, meas, sim) in [
        ("vehicle_speed", &*v_meas, &vehicle_speed),
        ("engine_speed", &*w_meas, &engine_speed),
    ] {
        metrics.push(metric(name, None, meas, sim, || {
            (0..t.len()).filter(moving)
        }));
        for g in 1..=ratios.len() {
            if (0..t.len()).filter(in_gear(g)).count() >= 10 {
                metrics.push(metric(name, Some(g), meas, sim, || {
                    (0..t.len()).filter(in_gear(g))
                }));
            }
        }
    }
    Ok(ShuffleValidation {
        timestamp_ns: log.timestamp_ns.clone(),
        vehicle_speed,
        engine_speed,
        shaft_torques,
        torsions,
        clutch_locked,
        shuffle_indicator,
        window,
        metrics,
        slope_column,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_over_picked_rows_have_the_bits_of_metrics_over_gathered_copies() {
        // uneven values (so sums round), a quarter of the rows left out, one run of a gear
        let n = 997;
        let meas: Vec<f64> = (0..n)
            .map(|k| (k as f64 * 0.37).sin() * 20.0 + 0.1 * k as f64)
            .collect();
        let sim: Vec<f64> = meas
            .iter()
            .enumerate()
            .map(|(k, y)| y + (k as f64 * 1.3).cos() * 0.7)
            .collect();
        let keep = |k: &usize| k % 4 != 1;
        let m = metric("vehicle_speed", Some(3), &meas, &sim, || {
            (0..n).filter(keep)
        });
        let (y, yh): (Vec<f64>, Vec<f64>) = (0..n).filter(keep).map(|k| (meas[k], sim[k])).unzip();
        let (rmse, mae, fit) = error_metrics(&y, &yh);
        assert_eq!(m.samples, y.len());
        assert_eq!(m.rmse.to_bits(), rmse.to_bits());
        assert_eq!(m.mae.to_bits(), mae.to_bits());
        assert_eq!(m.fit_percent.to_bits(), fit.to_bits());
        // and error_metrics itself against the definitions, written out independently here
        // (relative 1e-12 / absolute 1e-9 %: rounding of a differently grouped formulation)
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let se: f64 = y.iter().zip(&yh).map(|(a, b)| (a - b) * (a - b)).sum();
        let ss: f64 = y.iter().map(|a| (a - mean) * (a - mean)).sum();
        assert!((rmse - (se / y.len() as f64).sqrt()).abs() <= 1e-12 * rmse);
        assert!((fit - 100.0 * (1.0 - (se / ss).sqrt())).abs() <= 1e-9);
        // no rows: NaN fit, zero errors, no division by zero
        let e = metric("engine_speed", None, &meas, &sim, || {
            (0..n).filter(|_| false)
        });
        assert_eq!((e.samples, e.rmse, e.mae), (0, 0.0, 0.0));
        assert!(e.fit_percent.is_nan());
    }
}
