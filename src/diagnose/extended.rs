//! The nominal models extended by every catalogue effect (docs/diagnosis/method.md, step 3): one
//! parameter vector [`Theta`] whose component per [`Effect`] is that effect's parameter, in the
//! same SI quantity the catalogue names (`c_w_a_f_m2`, `mass_kg`, `slope_offset_rad`, …;
//! [`Effect::parameter`]). At the nominal values ([`Theta::nominal`]) the extended models are the
//! nominal ones.
//!
//! # What each component does to the model
//! - plant parameters (drag area, rolling resistance, mass, shaft stiffness, clutch capacity,
//!   CG height and position, tyre stiffness) and structural extensions (drive-shaft lash,
//!   torque reaction, bellow progression, grade-force height) are set on a
//!   [`ExtendedVehicle`] built from the vehicle file ([`ExtendedVehicle::set`]), the model
//!   layer's one definition of what each catalogue parameter means;
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
//! - `slope_quantization`'s parameter is the slope sensor's resolution `Δ` (tan α per step): a
//!   value above the nominal resolution replaces the recorded slope by its consistent
//!   reconstruction from cells of width `Δ` on the 1 m distance grid, each widened by the
//!   sensor's noise as the recording shows it ([`crate::signal::dequantise`]; a zero-phase
//!   spatial reconstruction, the kind of cure the catalogue names; [`SlopeGrid::cured`]), so
//!   the model does not see the steps. The road-slope low-pass of Myklebust & Eriksson (2012),
//!   §5 (4·10⁻³ 1/m), would remove real grade on city hills (on the proof's seed-1 city drives,
//!   0.013–0.019 rms of grade against 0.005 of quantisation error); the reconstruction never
//!   moves a sample more than `Δ/2` plus the noise's σ.
//!
//! # Outputs
//! [`LongitudinalModel::simulate`]: vehicle and engine speed on the log's rows, from windows
//! re-initialised at the measured state ([`crate::sim::validate`]) every 20 s and after every
//! stretch whose inputs the recording does not determine ([`window_starts`]): open-loop drift cannot
//! accumulate over more than one window. A window starts at the recorded vehicle speed
//! interpolated at its start. (A least-squares line through the second of samples before the
//! start would average the sensor's noise out of the start state, but while the truck
//! accelerates through the gears it puts the windows 0.10–0.13 m/s off, enough to make every
//! clean drive of `fleetdyn prove --seed 1` `unexplained`.) A window starts with the
//! clutch locked when it reads closed and the truck moves, unless the measured engine speed
//! runs more than [`SLIP_START_MIN_RAD_S`] above the locked driveline's (a clutch slipping
//! under load); then, as with an open or actuated clutch, it starts slipping from the measured
//! engine speed. A locked start takes its engine side from the measured engine speed too, the
//! wheel from the vehicle speed, so that it starts in the phase of a running shuffle
//! (`LongitudinalModel::measured_twist_rate`). The driven tyres slip
//! ([`super::tyre_slip`]): the engine speed is reported as the model's times `1 + κ`, `κ` from
//! the model's drive-shaft torque and the drive's fitted slip stiffness, and a window's engine
//! side starts from the measured engine speed divided by `1 + κ`. [`AxleModel::simulate`]: the three bellow
//! pressures on the log's rows, open loop from the steady state (the suspension is stable,
//! nothing drifts).

use crate::model::axle::AxleParams;
use crate::model::catalogue::Effect;
use crate::model::driveline::DrivelineParams;
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::schema::Interpolation;
use crate::signal::dequantise::{dequantise, DequantiseConfig};
use crate::signal::distance::{fill_gaps, resample_to_distance, DistanceMap, ResampleConfig};
use crate::signal::interp_linear;
use crate::signal::sensor_noise::{estimate_sensor_noise, grid_step_s, SampleKind};
use crate::sim::axle::{HalfTruck, Start};
use crate::sim::axle_recorded::{axle_inputs_from_log, AxleRecordConfig};
use crate::sim::fast::FastDriveline;
use crate::sim::hybrid::{steady_state_locked, ClutchMode};
use crate::sim::recorded::{scenario_from_log, RecordedError};
use crate::table::DriveLog;
use std::sync::{Arc, Mutex, OnceLock};
use thiserror::Error;

/// Why an extended model cannot be built or run.
#[derive(Debug, Error)]
pub enum ExtendedError {
    /// The recording lacks inputs or has bad ones.
    #[error(transparent)]
    Recorded(#[from] RecordedError),
    /// A parameter value outside its physical domain.
    #[error(transparent)]
    Parameter(#[from] crate::model::extended_vehicle::ParameterError),
    /// The driveline simulation failed.
    #[error("{file}: driveline simulation: {source}")]
    Sim {
        /// Source file.
        file: String,
        /// Cause.
        #[source]
        source: crate::sim::hybrid::SimError,
    },
    /// A column the model compares with is missing.
    #[error("{file}: column {column} is missing or empty")]
    Missing {
        /// Source file.
        file: String,
        /// Column.
        column: String,
    },
    /// Neither model can be driven by the recording with this vehicle file.
    #[error("{file}: nothing to diagnose: longitudinal model: {longitudinal}; axle model: {axle}")]
    NoModel {
        /// Source file.
        file: String,
        /// Why the longitudinal model does not apply.
        longitudinal: String,
        /// Why the axle model does not apply.
        axle: String,
    },
}

/// One parameter per catalogue effect, in [`Effect::ALL`] order, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Theta(pub [f64; 16]);

impl Theta {
    /// The value of `e`'s parameter.
    pub fn get(&self, e: Effect) -> f64 {
        self.0[index(e)]
    }

    /// Sets `e`'s parameter.
    pub fn set(&mut self, e: Effect, v: f64) {
        self.0[index(e)] = v;
    }

    /// The nominal parameter values of `truth` (the vehicle file's, or "absent"), with the
    /// recording's slope resolution `slope_resolution` (tan α per step) as `slope_quantization`'s.
    /// Axle effects of a vehicle without axles get 0.
    pub fn nominal(truth: &ExtendedVehicle, slope_resolution: f64) -> Theta {
        let mut t = [0.0; 16];
        for (i, e) in Effect::ALL.iter().enumerate() {
            t[i] = truth.value_of(*e, slope_resolution).unwrap_or(0.0);
        }
        Theta(t)
    }

    /// Effects whose value differs from `nominal`.
    pub fn changed(&self, nominal: &Theta) -> Vec<Effect> {
        Effect::ALL
            .into_iter()
            .filter(|e| self.get(*e) != nominal.get(*e))
            .collect()
    }
}

/// Position of `e` in [`Effect::ALL`].
pub fn index(e: Effect) -> usize {
    Effect::ALL
        .iter()
        .position(|x| *x == e)
        .expect("every effect is in the catalogue")
}

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
pub fn corrected_log(log: &DriveLog, theta: &Theta, cured_slope: Option<&[f64]>) -> DriveLog {
    let mut out = log.clone();
    let t: Vec<f64> = log.seconds_from_start();
    let delta = theta.get(Effect::GradeOffset);
    let offset = theta.get(Effect::EngineTorqueOffset);
    let tau = theta.get(Effect::SignalDelay);
    let speed = log.signal("vehicle_speed");
    let standstill_mps = AxleRecordConfig::default().standstill_speed_mps;
    for s in out.signals.iter_mut() {
        match s.name.as_str() {
            "road_slope" => {
                // the hold's lag, read off the recorded samples (a cure is smooth)
                let period = held_period_s(&t, &s.values);
                if let Some(f) = cured_slope {
                    s.values = f.to_vec();
                }
                if let Some(p) = period {
                    s.values = shifted(&t, &s.values, 0.5 * p);
                }
                if delta != 0.0 {
                    for v in s.values.iter_mut() {
                        *v = (v.atan() - delta).tan();
                    }
                }
            }
            "engine_torque" => {
                if tau != 0.0 {
                    s.values = shifted(&t, &s.values, tau);
                }
                if offset != 0.0 {
                    for v in s.values.iter_mut() {
                        *v -= offset;
                    }
                }
            }
            "brake_force" => {
                let busy = windowed_max(&t, &s.values, super::rows::BRAKE_EPISODE_HALFWIDTH_S);
                for (k, (v, m)) in s.values.iter_mut().zip(busy).enumerate() {
                    let stands = speed.is_some_and(|u| u[k].abs() < standstill_mps);
                    if m < super::rows::BRAKE_RELEASED_BELOW_N && !stands {
                        *v = 0.0;
                    }
                }
            }
            _ => {}
        }
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
    t.iter().map(|&x| interp_linear(t, v, x + tau)).collect()
}

/// The recorded slope on the 1 m distance grid, for `slope_quantization`'s cure.
#[derive(Debug, Clone)]
pub struct SlopeGrid {
    /// Recorded slope on the grid (held, gaps filled), tan α.
    raw: Vec<f64>,
    /// Grid step, m.
    step_m: f64,
    /// The log's time ↔ distance map.
    map: DistanceMap,
    /// The slope sensor's white noise, estimated blind from the recording
    /// ([`estimate_sensor_noise`]; its flicker rate on a coarse step), tan α (0 when it cannot
    /// be estimated).
    noise_sigma: f64,
    /// The last cure ([`SlopeGrid::cured`]) by the bits of its resolution: a fit that has
    /// accepted `slope_quantization` simulates every later candidate on the same cure.
    last: Arc<Mutex<Option<CachedCure>>>,
}

/// A cure's resolution (its bits) and the cured slope on the log's rows.
type CachedCure = (u64, Vec<f64>);

impl SlopeGrid {
    /// The grid of `log`'s slope (`None` without a slope column or when the drive is too short
    /// to resample).
    pub fn new(log: &DriveLog) -> Option<SlopeGrid> {
        let recorded = log.signal("road_slope")?;
        let d = resample_to_distance(log, &ResampleConfig::default()).ok()?;
        let raw = fill_gaps(d.signal("road_slope")?, Interpolation::Hold)?;
        let noise_sigma = grid_step_s(log)
            .ok()
            .and_then(|dt| {
                estimate_sensor_noise(
                    "road_slope",
                    "1",
                    recorded,
                    dt,
                    SampleKind::of_column("road_slope"),
                )
                .ok()
            })
            .map(|e| e.sigma_white)
            .filter(|s| s.is_finite())
            .unwrap_or(0.0);
        Some(SlopeGrid {
            raw,
            step_m: d.step_m,
            map: d.map,
            noise_sigma,
            last: Arc::default(),
        })
    }

    /// The slope sensor's estimated white noise, tan α.
    pub fn noise_sigma(&self) -> f64 {
        self.noise_sigma
    }

    /// The slope with a sensor resolution of `resolution` (tan α per step) undone, on the
    /// log's rows: [`dequantise`] on the grid with its default settings and every cell widened
    /// by the sensor's estimated noise (a reading flipped by noise lies within about σ of its
    /// cell, not inside it), mapped back through the time ↔ distance map; `None` for a
    /// resolution that is not finite and positive.
    pub fn cured(&self, resolution: f64) -> Option<Vec<f64>> {
        let key = resolution.to_bits();
        // a poisoned lock (a thread panicked while holding it) only loses the kept cure
        if let Ok(g) = self.last.lock() {
            if let Some((k, v)) = g.as_ref() {
                if *k == key {
                    return Some(v.clone());
                }
            }
        }
        let v = self.cured_with(
            resolution,
            &DequantiseConfig {
                cell_margin: self.noise_sigma,
                ..DequantiseConfig::default()
            },
        )?;
        if let Ok(mut g) = self.last.lock() {
            *g = Some((key, v.clone()));
        }
        Some(v)
    }

    /// [`SlopeGrid::cured`] with the reconstruction's settings `cfg` (its cell margin as given).
    pub fn cured_with(&self, resolution: f64, cfg: &DequantiseConfig) -> Option<Vec<f64>> {
        let g = dequantise(&self.raw, resolution, cfg).ok()?;
        Some(self.map.to_time_axis(&g, self.step_m))
    }
}

/// The slope `theta` asks for: the cure of `log`'s slope grid (built in `grid` on first use)
/// at `theta`'s slope resolution when it is above `nominal`'s, else `None` (the recorded
/// slope).
fn cured_slope(
    log: &DriveLog,
    grid: &OnceLock<Option<SlopeGrid>>,
    theta: &Theta,
    nominal: &Theta,
) -> Option<Vec<f64>> {
    let r = theta.get(Effect::SlopeQuantization);
    if r > nominal.get(Effect::SlopeQuantization) {
        grid.get_or_init(|| SlopeGrid::new(log)).as_ref()?.cured(r)
    } else {
        None
    }
}

/// Settings of the windowed longitudinal simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LongitudinalConfig {
    /// Re-initialisation window, s.
    pub window_s: f64,
    /// Integration step, s, outside the spans about the torque reversals ([`fine_spans`], at
    /// [`FINE_STEP_S`]); [`FINE_STEP_S`] everywhere when the drive-shaft lash is non-zero. The
    /// default is 5 ms. Why not 10 ms (the recording's row spacing): the exponential integrator
    /// ([`FastDriveline`]) holds the inputs and the road force over a step and detects clutch
    /// mode switches at step ends. At 10 ms three drives without an effect of the
    /// drawn-driving proof (`fleetdyn prove --seed 1`, `--seed 1001`) are named a 2–3 % weaker
    /// clutch or a lash of 5·10⁻⁵ rad (a lash only switches the step to 1 ms); at 5 ms none of
    /// the 84 no-effect drives of seven seeds is, and 2 ms does the same on seed 1. 1 ms
    /// everywhere costs about 110 s per drive-hour on a proof drive (9.9 s against 3.9 s at
    /// 10 ms; the budget is 60 s); 5 ms costs 4 % more than 10 ms (the seven seeds' median times
    /// per drive-hour).
    pub dt_s: f64,
    /// Samples below this measured speed do not count, m/s.
    pub min_speed_mps: f64,
    /// A locked window start takes its engine side from the measured engine speed (the
    /// module documentation, "Outputs"); `false` starts it at the locked engine
    /// speed of the recorded vehicle speed (the model before that change, kept to show what
    /// it changes).
    pub measured_engine_side: bool,
    /// The spans about the torque reversals integrate at [`FINE_STEP_S`] ([`fine_spans`]);
    /// `false` integrates them at `dt_s` too (kept to show what the fine spans change).
    pub fine_at_reversals: bool,
    /// The driven tyres' slip is part of the model, its stiffness estimated on the drive
    /// ([`super::tyre_slip`]); `false` keeps the wheels at the vehicle's speed.
    pub tyre_slip: bool,
}

impl Default for LongitudinalConfig {
    /// 20 s windows (long enough for drag and mass to show as speed drift, short enough that
    /// the slope sensor's quantisation bias cannot build up), 5 ms steps, 1 m/s, the engine
    /// side of a locked start from the measured engine speed, the tyres' slip modelled.
    fn default() -> Self {
        Self {
            window_s: 20.0,
            dt_s: 0.005,
            min_speed_mps: 1.0,
            measured_engine_side: true,
            fine_at_reversals: true,
            tyre_slip: true,
        }
    }
}

/// Simulated longitudinal outputs on the log's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct LongitudinalOutputs {
    /// Vehicle speed, m/s.
    pub vehicle_speed: Vec<f64>,
    /// Engine speed, rad/s.
    pub engine_speed: Vec<f64>,
}

/// The driveline model of one recording, extended by the catalogue's longitudinal effects.
#[derive(Debug, Clone)]
pub struct LongitudinalModel<'a> {
    log: &'a DriveLog,
    nominal_truth: &'a ExtendedVehicle,
    ratios: &'a [f64],
    nominal: Theta,
    /// The recorded slope's grid, built when a cure first asks for it ([`cured_slope`]).
    slope_grid: OnceLock<Option<SlopeGrid>>,
    t: Vec<f64>,
    starts: Vec<f64>,
    /// Spans integrated at [`FINE_STEP_S`] (the torque reversals'), s, sorted and disjoint.
    fine: Vec<(f64, f64)>,
    v_meas: Vec<f64>,
    w_meas: Vec<f64>,
    slip: super::tyre_slip::SlipEstimate,
    cfg: LongitudinalConfig,
}

fn filled(log: &DriveLog, name: &str) -> Result<Vec<f64>, ExtendedError> {
    log.signal(name)
        .and_then(|v| crate::signal::distance::fill_gaps(v, crate::schema::Interpolation::Linear))
        .ok_or_else(|| ExtendedError::Missing {
            file: log.meta.source_file.clone(),
            column: name.into(),
        })
}

/// Engine speed above the locked driveline's at which a window with the clutch closed starts
/// slipping instead of locked ([`LongitudinalModel::simulate`]), rad/s (150 rpm). Why that margin:
/// right after a clutch closes the first-gear shuffle swings the engine against the wheels by up to
/// ~100 rpm (docs/diagnosis/events.md), and a window that starts slipping on such a swing locks
/// again within milliseconds under the clutch's full capacity, whereas a clutch that cannot carry
/// the engine torque (`clutch_slip` at full load: measured 100–390 rpm for tens of seconds on the
/// proof) keeps slipping — which a locked start never reproduces.
pub const SLIP_START_MIN_RAD_S: f64 = 150.0 * std::f64::consts::PI / 30.0;

/// Step of the longitudinal model about the torque reversals, and everywhere with a drive-shaft
/// lash, s ([`LongitudinalModel::simulate`]).
pub const FINE_STEP_S: f64 = 1e-3;

/// The spans integrated at [`FINE_STEP_S`] whatever the parameters: each torque reversal the
/// reversal channel samples ([`super::reversal_channel::reversal_times`]) with its
/// [`super::reversal_channel::EVENT_SPAN_S`], overlaps merged. Why: the channel compares the
/// engine against the wheels there, a few rpm decide it, and the step moves the feature by
/// up to 3.5 rpm between 5 ms and 1 ms (a drive of `fleetdyn prove --seed 1` with 14
/// reversals; 0.003 rpm with these spans, pinned in the test suite). A lash candidate
/// integrates at the fine step, so with the nominal model coarser there the step alone would be
/// part of what a lash explains; and at 5 ms a clutch a percent weaker reproduces a reversal of
/// an out-of-catalogue drive (`fleetdyn prove --seed 2`: `clutch_slip` at 3422 N·m named), which
/// with these spans no clutch does. A drive has a few reversals, so the spans cost little:
/// 2.4 % of the seven drawn-driving seeds' median diagnosis time per drive-hour (−1 … +6 % per
/// seed).
pub fn fine_spans(log: &DriveLog) -> Vec<(f64, f64)> {
    use super::reversal_channel::{reversal_times, EVENT_SPAN_S};
    let mut out: Vec<(f64, f64)> = Vec::new();
    for t in reversal_times(log) {
        let (a, b) = (t + EVENT_SPAN_S.0, t + EVENT_SPAN_S.1);
        match out.last_mut() {
            Some(last) if a <= last.1 => last.1 = last.1.max(b),
            _ => out.push((a, b)),
        }
    }
    out
}

/// The pieces of `[ta, tb]` with their steps: `dt` outside `fine`, [`FINE_STEP_S`] inside
/// (`fine` sorted and disjoint); every piece boundary on `ta`'s grid of `dt`, so each piece
/// is a whole number of its steps.
fn stepped_pieces(ta: f64, tb: f64, dt: f64, fine: &[(f64, f64)]) -> Vec<(f64, f64, bool)> {
    let snap = |x: f64| (ta + ((x - ta) / dt).round() * dt).clamp(ta, tb);
    let mut out = Vec::new();
    let mut at = ta;
    for &(a, b) in fine {
        let (a, b) = (snap(a), snap(b));
        if b <= at || a >= tb {
            continue;
        }
        if a > at {
            out.push((at, a, false));
        }
        out.push((a.max(at), b, true));
        at = b;
    }
    if tb - at >= 0.5 * dt {
        out.push((at, tb, false));
    }
    out
}

/// How far a regular window start keeps from an engine-torque step, s ([`window_starts`]): the
/// 0.3 s of the step test plus the [`crate::diagnose::reversal_channel`] reference window's
/// 0.5 s and a margin.
pub const STEP_CLEAR_S: f64 = 1.0;

/// Start times of the longitudinal model's windows on `log`, s from the first row: every
/// `window_s`, and wherever the recording determines the model's mode again after a stretch it
/// did not ([`super::rows::longitudinal_rows`] switching back on: a clutch transition, a
/// brake step or an input gap has ended) unless a regular start follows within 2 s. Why: the
/// rows inside such a stretch do not count, but an error the model makes there (measured on
/// clean synthetic drives: 0.1 m/s after one upshift on a climb, from the clutch closing
/// between two 10 Hz samples) would otherwise be carried as a speed offset to the window's end.
///
/// A regular start that falls on an engine-torque step (more than
/// [`super::rows::TORQUE_STEP_NM`] within [`super::rows::STEP_WINDOW_S`], detected from 0.3 s
/// before the start to [`STEP_CLEAR_S`] after it) with the clutch closed (≤ 2 %) and a gear held
/// from the new start to [`STEP_CLEAR_S`] after the old one (not a shift's torque recovery) moves
/// to [`STEP_CLEAR_S`] before the step's first detection, if the window before keeps at least 2 s.
/// Why: a window started on a step begins with the new torque's shaft twists, so it never crosses a
/// lash or rings as the drive did (at a proof lash drive's tip-out: +80 rpm of engine-speed
/// residual at the nominal and at the true lash alike, docs/diagnosis/events.md). The moved
/// window's first rows then lie in the block before; they are simulated from the measured state
/// like every window's, so no fitted quantity crosses the split.
pub fn window_starts(log: &DriveLog, window_s: f64) -> Vec<f64> {
    let n = log.len();
    if n == 0 {
        return vec![0.0];
    }
    let t: Vec<f64> = log.seconds_from_start();
    let end = t[n - 1];
    let regular = (end / window_s).ceil().max(1.0) as usize;
    let torque = log
        .signal("engine_torque")
        .and_then(|m| crate::signal::distance::fill_gaps(m, crate::schema::Interpolation::Linear));
    // the first time in [a, b] whose torque differs by more than a step from STEP_WINDOW_S
    // earlier (compare::away_from_steps' test)
    let step_at = |a: f64, b: f64| -> Option<f64> {
        let m = torque.as_ref()?;
        let lo = t.partition_point(|&x| x < a);
        let hi = t.partition_point(|&x| x <= b);
        (lo..hi)
            .find(|&i| {
                let j = t.partition_point(|&x| x < t[i] - super::rows::STEP_WINDOW_S);
                (m[i] - m[j]).abs() > super::rows::TORQUE_STEP_NM
            })
            .map(|i| t[i])
    };
    let ok = super::rows::longitudinal_rows(log);
    let held = |c: &str| {
        log.signal(c)
            .and_then(|g| crate::signal::distance::fill_gaps(g, crate::schema::Interpolation::Hold))
    };
    let (gear, clutch) = (held("gear"), held("clutch_position"));
    // the clutch closed and the gear held over [a, b]: not a shift's torque recovery
    let steady = |a: f64, b: f64| {
        let lo = t.partition_point(|&x| x < a);
        let hi = t.partition_point(|&x| x <= b);
        hi > lo
            && gear
                .as_ref()
                .is_none_or(|g| (lo..hi).all(|i| g[i].round() == g[lo].round() && g[i] >= 0.5))
            && clutch
                .as_ref()
                .is_none_or(|c| (lo..hi).all(|i| c[i] <= 0.02))
    };
    let mut starts: Vec<f64> = (0..regular)
        .map(|k| {
            let s = k as f64 * window_s;
            match step_at(s - 0.3, s + STEP_CLEAR_S) {
                Some(ts)
                    if k > 0
                        && ts - STEP_CLEAR_S > (k - 1) as f64 * window_s + 2.0
                        && steady(ts - STEP_CLEAR_S, s + STEP_CLEAR_S) =>
                {
                    ts - STEP_CLEAR_S
                }
                _ => s,
            }
        })
        .collect();
    for i in 1..n {
        if ok[i] && !ok[i - 1] {
            let next_regular = ((t[i] / window_s).floor() + 1.0) * window_s;
            if next_regular - t[i] > 2.0 && end - t[i] > 2.0 {
                starts.push(t[i]);
            }
        }
    }
    starts.sort_by(f64::total_cmp);
    starts.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    starts
}

impl<'a> LongitudinalModel<'a> {
    /// Binds a recording (vehicle speed, engine speed, engine torque and gear needed), the
    /// nominal vehicle and its gear ratios. `nominal` are the nominal parameters
    /// ([`Theta::nominal`]).
    ///
    /// # Errors
    /// [`ExtendedError::Missing`] for a missing speed column.
    pub fn new(
        log: &'a DriveLog,
        nominal_truth: &'a ExtendedVehicle,
        ratios: &'a [f64],
        nominal: Theta,
        cfg: LongitudinalConfig,
    ) -> Result<Self, ExtendedError> {
        let v_meas = filled(log, "vehicle_speed")?;
        let w_meas = filled(log, "engine_speed")?;
        let t: Vec<f64> = log.seconds_from_start();
        let slip = if cfg.tyre_slip {
            super::tyre_slip::estimate(log, &nominal_truth.driveline, ratios)
        } else {
            super::tyre_slip::SlipEstimate::RIGID
        };
        Ok(Self {
            log,
            nominal_truth,
            ratios,
            nominal,
            slope_grid: OnceLock::new(),
            starts: window_starts(log, cfg.window_s),
            fine: fine_spans(log),
            t,
            v_meas,
            w_meas,
            slip,
            cfg,
        })
    }

    /// The drive's tyre-slip estimate ([`super::tyre_slip::estimate`]).
    pub fn slip(&self) -> super::tyre_slip::SlipEstimate {
        self.slip
    }

    /// The nominal parameters.
    pub fn nominal(&self) -> &Theta {
        &self.nominal
    }

    /// Measured vehicle speed (gaps filled), m/s.
    pub fn measured_speed(&self) -> &[f64] {
        &self.v_meas
    }

    /// Measured engine speed (gaps filled), rad/s.
    pub fn measured_engine_speed(&self) -> &[f64] {
        &self.w_meas
    }

    /// Times of the rows, s from the first.
    pub fn times(&self) -> &[f64] {
        &self.t
    }

    /// Start times of the windows ([`window_starts`]), s from the first row.
    pub fn window_starts(&self) -> &[f64] {
        &self.starts
    }

    /// Gear ratios of the nominal vehicle (1st gear first).
    pub fn ratios(&self) -> &[f64] {
        self.ratios
    }

    /// The plant of `theta`: the nominal vehicle with `theta`'s longitudinal model effects
    /// injected (the sensor effects are corrected on the inputs instead, [`corrected_log`]).
    ///
    /// # Errors
    /// [`ExtendedError`] for a parameter outside its domain.
    pub fn plant(&self, theta: &Theta) -> Result<ExtendedVehicle, ExtendedError> {
        let mut tm = self.nominal_truth.clone();
        for e in theta.changed(&self.nominal) {
            if matches!(
                e,
                Effect::GradeOffset
                    | Effect::SlopeQuantization
                    | Effect::SignalDelay
                    | Effect::EngineTorqueOffset
            ) {
                continue; // corrected on the inputs
            }
            if e.domain() == crate::model::catalogue::Domain::Longitudinal {
                tm.set(e, theta.get(e))?;
            }
        }
        Ok(tm)
    }

    /// Sets the shaft twists of a locked-clutch start state `y0` (rigid speeds already set) to
    /// carry the recorded engine torque at `ta` with the measured acceleration: with
    /// `ω̇_w = a/r_w`, `M_c = M_e − (J_e + J_c) i_t i_f ω̇_w`,
    /// `M_p = i_t M_c − b_t ω_p − (J_t + J_p) i_f ω̇_w`, `M_d = i_f M_p − b_f ω_d − (J_f + J_d) ω̇_w`
    /// (docs/models/driveline.md with every shaft rigid), twist = torque / stiffness. The
    /// road-load steady state assumes zero acceleration; under full drive torque its twist is far
    /// from the recording's, and a window started from it rings at the shuffle frequency
    /// (±8 rad/s of engine speed for 0.2 s after a re-initialisation at 0.7 m/s² in 11th gear).
    fn load_twists(
        &self,
        p: &DrivelineParams,
        sc: &crate::sim::hybrid::Scenario,
        gear: usize,
        ta: f64,
        y0: &mut [f64; crate::sim::hybrid::N_STATES],
    ) {
        let crate::sim::hybrid::EngineInput::Torque(m) = &sc.engine else {
            return;
        };
        let Some(it) = gear.checked_sub(1).and_then(|g| self.ratios.get(g)) else {
            return;
        };
        let h = 0.25;
        let (t0, t1) = ((ta - h).max(0.0), ta + h);
        let a = (interp_linear(&self.t, &self.v_meas, t1)
            - interp_linear(&self.t, &self.v_meas, t0))
            / (t1 - t0);
        let fi = p.final_drive_ratio;
        let wdot_w = a / p.wheel_radius_m;
        let m_e = m.eval(ta + 1e-9);
        let m_c = m_e - (p.j_e_kg_m2 + p.j_c_kg_m2) * it * fi * wdot_w;
        let j2 = p.j_t_kg_m2[gear - 1] + p.j_p_kg_m2;
        let m_p = it * m_c - p.b_t_nm_s_per_rad * y0[3] - j2 * fi * wdot_w;
        let m_d = fi * m_p - p.b_f_nm_s_per_rad * y0[5] - (p.j_f_kg_m2 + p.j_d_kg_m2) * wdot_w;
        y0[2] = m_c / p.k_c_nm_per_rad;
        y0[4] = m_p / p.k_p_nm_per_rad;
        y0[6] = m_d / p.k_d_nm_per_rad;
    }

    /// Sets the engine side of a locked-clutch start state `y0` (every speed from the recorded
    /// vehicle speed, [`steady_state_locked`]) to the measured engine speed `we`, rad/s: the engine
    /// and clutch disc at `we`, the gearbox output at `we / i_t` and the final drive's at
    /// `we / (i_t i_f)`, the wheel left at the recorded vehicle speed. The difference between the
    /// two sides is then the drive shafts' twist rate (the most compliant shaft,
    /// docs/models/driveline.md), so a window started during the shuffle starts in its phase. `we`
    /// is clamped to within [`SLIP_START_MIN_RAD_S`] of the locked engine speed (a faster engine
    /// starts the window slipping instead); not finite, the state is left as it is.
    ///
    /// Why: right after a launch the first gear's shuffle swings the wheel speed by ±0.1 m/s at 2–3
    /// Hz; started at the locked engine speed of one such sample, a window keeps the sample's
    /// offset to its end (after a clean launch of `fleetdyn prove --seed 1001`: engine speed 8–11
    /// rad/s and vehicle speed 0.1 m/s below the recording for the 4.7 s to the next window, the
    /// same with every input at its truth). From the measured engine speed the same window stays
    /// within ±3 rad/s.
    fn measured_twist_rate(
        &self,
        p: &DrivelineParams,
        gear: usize,
        we: f64,
        y0: &mut [f64; crate::sim::hybrid::N_STATES],
    ) {
        let Some(&it) = gear.checked_sub(1).and_then(|g| self.ratios.get(g)) else {
            return;
        };
        if !we.is_finite() {
            return;
        }
        let we = we.clamp(y0[0] - SLIP_START_MIN_RAD_S, y0[0] + SLIP_START_MIN_RAD_S);
        y0[0] = we;
        y0[1] = we;
        y0[3] = we / it;
        y0[5] = y0[3] / p.final_drive_ratio;
    }

    /// Simulates the recording with parameters `theta`, window by window from the measured
    /// state (see the module documentation).
    ///
    /// # Errors
    /// [`ExtendedError`] for parameters outside their domain or a failed simulation.
    pub fn simulate(&self, theta: &Theta) -> Result<LongitudinalOutputs, ExtendedError> {
        let tm = self.plant(theta)?;
        let p: &DrivelineParams = &tm.driveline;
        let cured = cured_slope(self.log, &self.slope_grid, theta, &self.nominal);
        let log = corrected_log(self.log, theta, cured.as_deref());
        let file = log.meta.source_file.clone();
        let rec = scenario_from_log(
            &log,
            self.ratios.len(),
            None,
            Some(p.final_drive_ratio / p.wheel_radius_m),
        )?;
        let sc = &rec.scenario;
        // the driven tyres' slip on every row from the corrected torque (super::tyre_slip):
        // a window's engine side starts from the recorded engine speed without it
        let kappa = super::tyre_slip::slip_of_rows(&log, p, self.ratios, self.slip.slip_per_newton);
        let dt = if tm.lash_rad > 0.0 {
            self.cfg.dt_s.min(FINE_STEP_S)
        } else {
            self.cfg.dt_s
        };
        let mut fast = FastDriveline::new(p, self.ratios, dt).with_lash(tm.lash_rad);
        let mut fine = (self.cfg.fine_at_reversals && dt > FINE_STEP_S)
            .then(|| FastDriveline::new(p, self.ratios, FINE_STEP_S).with_lash(tm.lash_rad));
        let fine_spans: &[(f64, f64)] = if fine.is_some() { &self.fine } else { &[] };
        let starts = &self.starts;
        let n_win = starts.len();
        let (mut ts, mut vs, mut ws) = (Vec::new(), Vec::new(), Vec::new());
        // the driven tyres' slip of a sample, from the model's drive-shaft torque
        // M_d = k_d·(twist beyond the lash) + c_d·(ω_d − ω_w), F_x = M_d / r_w
        let slip_of = |y: &[f64; crate::sim::hybrid::N_STATES]| {
            let half = 0.5 * tm.lash_rad;
            let twist = y[6] - y[6].clamp(-half, half);
            let m_d = p.k_d_nm_per_rad * twist + p.c_d_nm_s_per_rad * (y[5] - y[7]);
            (self.slip.slip_per_newton * m_d / p.wheel_radius_m).clamp(-0.2, 0.2)
        };
        for w in 0..n_win {
            let ta = starts[w];
            let tb = starts
                .get(w + 1)
                .copied()
                .unwrap_or(sc.t_end_s)
                .min(sc.t_end_s);
            if tb - ta < dt {
                continue;
            }
            let v0 = interp_linear(&self.t, &self.v_meas, ta).max(0.0);
            let gear = sc.gear.eval(ta + 1e-9).round() as usize;
            let slope = sc.slope.eval(ta + 1e-9);
            let x = sc.clutch_x.eval(ta + 1e-9);
            let (mut y0, _) = steady_state_locked(p, self.ratios, gear, v0, slope, sc.smoothing);
            let engaged = x <= p.clutch_l_lower * p.clutch_x_max;
            // the recorded engine speed without the tyres' slip, which the model adds back on
            // its output (both clutch modes alike); a closed clutch whose engine runs well
            // above the gearbox slips (a worn clutch under full torque): the window starts
            // slipping from it
            let we = interp_linear(&self.t, &self.w_meas, ta)
                / (1.0 + interp_linear(&self.t, &kappa, ta));
            let slipping = we.is_finite() && we - y0[0] > SLIP_START_MIN_RAD_S;
            let mode = if engaged && v0 >= self.cfg.min_speed_mps && !slipping {
                ClutchMode::Locked
            } else {
                let sigma = if we >= y0[1] { 1.0 } else { -1.0 };
                y0[0] = we;
                ClutchMode::Slipping(sigma)
            };
            y0[8] = 0.0;
            if mode == ClutchMode::Locked {
                self.load_twists(p, sc, gear, ta, &mut y0);
                if self.cfg.measured_engine_side {
                    self.measured_twist_rate(p, gear, we, &mut y0);
                }
            }
            if tm.lash_rad > 0.0 {
                // the steady twist carries the drive torque: in contact on its side
                y0[6] += 0.5 * tm.lash_rad * y0[6].signum();
            }
            // the window piece by piece, each from the state and mode the last ended in
            let pieces = stepped_pieces(ta, tb, dt, fine_spans);
            let (mut y, mut mode) = (y0, mode);
            for (j, &(a, b, is_fine)) in pieces.iter().enumerate() {
                let sim = match (is_fine, fine.as_mut()) {
                    (true, Some(f)) => f,
                    _ => &mut fast,
                };
                let tr =
                    sim.simulate_span(sc, a, b, y, mode)
                        .map_err(|source| ExtendedError::Sim {
                            file: file.clone(),
                            source,
                        })?;
                let (Some(&y_end), Some(&m_end)) = (tr.y.last(), tr.mode.last()) else {
                    continue;
                };
                (y, mode) = (y_end, m_end);
                // a piece's last sample is the next piece's (or window's) first
                let keep = if w + 1 == n_win && j + 1 == pieces.len() {
                    tr.t.len()
                } else {
                    tr.t.len() - 1
                };
                for k in 0..keep {
                    ts.push(tr.t[k]);
                    vs.push(p.wheel_radius_m * tr.y[k][7]);
                    // the engine turns faster than the vehicle's speed carries it by the slip
                    ws.push(tr.y[k][0] * (1.0 + slip_of(&tr.y[k])));
                }
            }
        }
        Ok(LongitudinalOutputs {
            vehicle_speed: self
                .t
                .iter()
                .map(|&tt| interp_linear(&ts, &vs, tt))
                .collect(),
            engine_speed: self
                .t
                .iter()
                .map(|&tt| interp_linear(&ts, &ws, tt))
                .collect(),
        })
    }
}

/// The axle-load model of one recording, extended by the catalogue's axle effects (and by the
/// longitudinal ones that change its inputs or masses).
#[derive(Debug, Clone)]
pub struct AxleModel<'a> {
    log: &'a DriveLog,
    nominal_truth: &'a ExtendedVehicle,
    ratios: &'a [f64],
    nominal: Theta,
    /// The recorded slope's grid, built when a cure first asks for it ([`cured_slope`]).
    slope_grid: OnceLock<Option<SlopeGrid>>,
    cfg: AxleRecordConfig,
}

impl<'a> AxleModel<'a> {
    /// Binds a recording with bellow pressures and the nominal vehicle (with axles).
    ///
    /// # Errors
    /// [`ExtendedError::Missing`] for missing pressures or axles.
    pub fn new(
        log: &'a DriveLog,
        nominal_truth: &'a ExtendedVehicle,
        ratios: &'a [f64],
        nominal: Theta,
    ) -> Result<Self, ExtendedError> {
        if nominal_truth.axles.is_none() {
            return Err(ExtendedError::Missing {
                file: log.meta.source_file.clone(),
                column: "[axles] of the vehicle file".into(),
            });
        }
        for c in [
            "bellow_pressure_front",
            "bellow_pressure_rear",
            "bellow_pressure_tag",
        ] {
            filled(log, c)?;
        }
        Ok(Self {
            log,
            nominal_truth,
            ratios,
            nominal,
            slope_grid: OnceLock::new(),
            cfg: AxleRecordConfig::default(),
        })
    }

    /// Simulated bellow pressures front, rear, tag on the log's rows, Pa.
    ///
    /// # Errors
    /// [`ExtendedError`] for parameters outside their domain or inputs that cannot be built.
    pub fn simulate(&self, theta: &Theta) -> Result<[Vec<f64>; 3], ExtendedError> {
        let mut tm = self.nominal_truth.clone();
        for e in theta.changed(&self.nominal) {
            if matches!(
                e,
                Effect::GradeOffset
                    | Effect::SlopeQuantization
                    | Effect::SignalDelay
                    | Effect::EngineTorqueOffset
            ) {
                continue;
            }
            tm.set(e, theta.get(e))?;
        }
        let a: &AxleParams = tm.axles.as_ref().expect("checked in new");
        let d = &tm.driveline;
        let cured = cured_slope(self.log, &self.slope_grid, theta, &self.nominal);
        let log = corrected_log(self.log, theta, cured.as_deref());
        let rec = axle_inputs_from_log(
            &log,
            a.mass_kg(),
            a.wheel_radius_m,
            a.gravity_m_per_s2,
            self.ratios,
            Some(d.final_drive_ratio),
            Some(d),
            None,
            &self.cfg,
        )?;
        let traj = HalfTruck::new(a).with_extensions(tm.axle_ext).simulate(
            &rec.inputs,
            &rec.t_s,
            Start::Steady,
        );
        Ok(traj.pressure_pa)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{DriveMeta, Signal};

    #[test]
    fn a_window_is_cut_at_the_fine_spans_on_its_own_step_grid() {
        // a 20 s window from 3.0 s at 5 ms; one span inside, one across its end, one before it
        let fine = [(1.0, 2.0), (7.2023, 8.4023), (22.5, 24.0)];
        let p = stepped_pieces(3.0, 23.0, 0.005, &fine);
        let kinds: Vec<bool> = p.iter().map(|x| x.2).collect();
        assert_eq!(kinds, [false, true, false, true], "{p:?}");
        // contiguous, from the window's start to its end
        assert_eq!(p[0].0, 3.0);
        assert_eq!(p[3].1, 23.0);
        for w in p.windows(2) {
            assert_eq!(w[0].1, w[1].0, "{p:?}");
        }
        // boundaries on the window's 5 ms grid: the span's 7.2023 s snaps to 7.200 s
        for &(a, _, _) in &p {
            let k = (a - 3.0) / 0.005;
            assert!((k - k.round()).abs() < 1e-6, "{a}");
        }
        assert!(
            (p[1].0 - 7.2).abs() < 1e-9 && (p[1].1 - 8.4).abs() < 1e-9,
            "{p:?}"
        );
        assert!((p[3].0 - 22.5).abs() < 1e-9, "{p:?}");
        // no span: one coarse piece
        assert_eq!(stepped_pieces(3.0, 23.0, 0.005, &[]), [(3.0, 23.0, false)]);
    }

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
        let out = corrected_log(&log, &Theta([0.0; 16]), None);
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
        let out = corrected_log(&log, &Theta([0.0; 16]), None);
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
    fn a_held_period_needs_changes() {
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.02).collect();
        assert_eq!(held_period_s(&t, &[0.03; 100]), None);
        let mut v = vec![0.0; 100];
        v[50] = f64::NAN;
        assert_eq!(held_period_s(&t, &v), None);
    }
}
