//! The explain step's view of one recording (docs/diagnosis/method.md, step 3): which outputs are
//! compared, the train / held-out split, the per-signal weights, the extended models' simulations
//! on those outputs, and the residual statistics the acceptance rule uses (weighted RMSE, MAE, fit
//! %, whiteness, effective number of independent samples).
//!
//! # Compared outputs (channels)
//! - longitudinal model ([`LongitudinalModel`], 20 s windows re-initialised from the measured
//!   state): `vehicle_speed` (m/s) and `engine_speed` (rad/s), on rows where the sample is a real
//!   one (not a filled gap) and the measured speed is at least the model's minimum (1 m/s);
//!   and `shuffle_frequency`, an events channel: `ln f` of the ringing after each
//!   clutch engagement against the linearised driveline's mode, one weighted sample per
//!   engagement ([`super::modal_channel`]), when at least two engagements fall in each part;
//!   and `reversal_relative_speed`, an events channel: the engine's speed against the wheels
//!   at each engine-torque reversal with the clutch closed, one weighted sample per reversal
//!   ([`super::reversal_channel`]), when at least one reversal falls in each part; and
//!   `engine_speed_actuated`: the engine speed on the rows the other two speeds leave out
//!   while the clutch is actuated ([`super::rows::actuation_channel_rows`]), each row
//!   weighted by its own null variance from the noise floor's copies
//!   ([`Problem::with_actuation`]), when the diagnosis computed that floor and each part has
//!   at least [`MIN_SAMPLES_PER_PART`] such rows;
//! - axle model ([`AxleModel`], open loop, stable): `bellow_pressure_front` / `_rear` / `_tag`
//!   (Pa), on rows with a real sample away from shifts ([`super::rows::axle_rows`]).
//!
//! A model is used when the recording has its outputs and inputs; which ones were used is
//! reported ([`Problem::domains`]).
//!
//! # Views
//! The explain step scores channels in groups, [`View`]s: the longitudinal model's speeds,
//! its shuffle modes, its torque reversals, and the axle model's bellow pressures. An effect is
//! fitted and scored on the views it changes materially ([`super::explain`]), so a view that
//! only a few effects can move (the modes: the stiffness and the mass; the reversals: the
//! lash, the stiffness, the torque signal's delay) never dilutes the figures of the others.
//! The speeds and the pressures are pooled in the deviance as largely redundant; the modes,
//! the reversals and the clutch actuation are terms of their own ([`ViewKind::own_term`]).
//! The clutch-actuation view is fitted and scored for `clutch_slip` and `signal_delay` alone
//! ([`ViewKind::only_for`]): it is the worn clutch's catalogue fingerprint and where a
//! delayed torque signal's ramps meet every shift, on rows the nominal model reproduces only
//! to the 10 Hz clutch's timing, and every other longitudinal effect moves them a little
//! without carrying its evidence there.
//!
//! # Train / held-out split: alternating blocks in time
//! The drive is cut into contiguous blocks of whole longitudinal windows (block length
//! [`Split::block_s`], a multiple of the 20 s re-initialisation window), and the blocks alternate
//! train, held-out, train, …. Why this and not "the last 30 %": both parts must see similar
//! conditions, and a drive's end is often a different road (a city approach after a highway, a
//! final stop), whereas alternating blocks give both parts samples from every stretch of the
//! drive — climbs and descents, speeds, gears, stops. Why blocks and not samples: residuals are
//! autocorrelated over seconds (the longitudinal model drifts within a window, the axle model's
//! pressures follow the driving), so a random-sample split would score the fit on samples it
//! has effectively seen. Block boundaries fall on window boundaries, so a longitudinal window
//! (one independent simulation from the measured state) lies wholly in one part. Blocks are one
//! window long for drives shorter than 16 windows (5 min 20 s) and grow with the drive to keep
//! about [`TARGET_BLOCKS`] (8) of them, up to [`MAX_BLOCK_WINDOWS`] windows (5 min) each: a
//! 9-minute drive gets 60 s blocks, a one-hour drive 12 blocks of 5 min. Long blocks also keep
//! a road stretch's own bias (the slope sensor's quantisation error over a long grade) from
//! appearing in both parts; the fit's interval accounts for it through the between-block
//! sample count ([`super::fit`]).
//!
//! # Weights
//! Every signal counts alike: the weighted mean square of a set of channels is the mean over the
//! channels of `MSE_c / σ_c²`, with `σ_c` the noise floor of the channel when one is given
//! (step 2, locate) and otherwise the channel's train RMS residual at the current parameters.
//! The weighted RMSE is its square root. An events channel has `σ_c = 1` and weights each
//! sample by its own `1/s_i²` ([`Channel::events`]), so its mean square is that of the
//! standardised residuals; so does the clutch-actuation channel per row
//! ([`Channel::row_weights`]), whose whiteness and effective sample count are those of its
//! standardised residual series. RMSE, MAE and fit % per signal are unweighted, in the
//! signal's SI unit ([`metrics`]).

use super::extended::{AxleModel, ExtendedError, LongitudinalConfig, LongitudinalModel, Theta};
use super::modal::ModalConfig;
use super::modal_channel::{self, ModeSample};
use super::reversal_channel::{self, ReversalSample};
use crate::model::catalogue::{Domain, Effect};
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::signal::quantization::estimate_quantization;
use crate::signal::stats::index_runs;
use crate::table::DriveLog;
use realfft::RealFftPlanner;
use serde::Serialize;
use std::collections::BTreeMap;
use thiserror::Error;

/// Why the explain step cannot run on a recording.
#[derive(Debug, Error)]
pub enum ExplainError {
    /// An extended model could not be built or run at the nominal or current parameters.
    #[error(transparent)]
    Extended(#[from] ExtendedError),
    /// Neither model can be driven by the recording.
    #[error("{file}: no model can be compared: {reasons}")]
    NoModel {
        /// Source file.
        file: String,
        /// Why each model was left out.
        reasons: String,
    },
    /// Too few valid samples in the train or held-out part of a compared signal.
    #[error("{file}: {signal}: {train} train and {heldout} held-out valid samples; at least {min} each are needed")]
    TooShort {
        /// Source file.
        file: String,
        /// Signal.
        signal: String,
        /// Valid train samples.
        train: usize,
        /// Valid held-out samples.
        heldout: usize,
        /// Required in each part.
        min: usize,
    },
    /// A configuration value outside its domain.
    #[error("explain configuration: {parameter} = {value} must be {requirement}")]
    BadConfig {
        /// Parameter.
        parameter: &'static str,
        /// Value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
}

/// Longest block of the split, in longitudinal windows (15 × 20 s = 5 min).
pub const MAX_BLOCK_WINDOWS: usize = 15;
/// Blocks the split aims at (half train, half held-out).
pub const TARGET_BLOCKS: usize = 8;
/// Fewest valid samples a compared signal needs in each part.
pub const MIN_SAMPLES_PER_PART: usize = 100;

/// The time split of a recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Split {
    /// Method, in words.
    pub method: String,
    /// Block length, s.
    pub block_s: f64,
    /// Number of blocks (train and held-out together).
    pub blocks: usize,
    /// Duration in the train part, s.
    pub train_s: f64,
    /// Duration in the held-out part, s.
    pub heldout_s: f64,
    /// Per row: in the held-out part.
    #[serde(skip)]
    pub heldout: Vec<bool>,
    /// Per row: block index (0 first; even blocks train, odd held-out).
    #[serde(skip)]
    pub block: Vec<usize>,
}

impl Split {
    /// Alternating blocks of `block_windows` windows of `window_s` over the times `t_s` (s from
    /// the first row); `None` chooses the block length as the module documentation says.
    pub fn alternating(t_s: &[f64], window_s: f64, block_windows: Option<usize>) -> Split {
        let dur = t_s.last().copied().unwrap_or(0.0);
        let n_windows = (dur / window_s).ceil().max(1.0) as usize;
        let k = block_windows
            .unwrap_or((n_windows / TARGET_BLOCKS).clamp(1, MAX_BLOCK_WINDOWS))
            .max(1);
        let block_s = k as f64 * window_s;
        let block: Vec<usize> = t_s
            .iter()
            .map(|&t| (t / block_s).floor().max(0.0) as usize)
            .collect();
        let heldout: Vec<bool> = block.iter().map(|b| b % 2 == 1).collect();
        let dt = if t_s.len() > 1 {
            dur / (t_s.len() - 1) as f64
        } else {
            0.0
        };
        let n_held = heldout.iter().filter(|h| **h).count();
        Split {
            method: format!(
                "alternating blocks of {k} × {window_s} s windows (train, held-out, train, …)"
            ),
            block_s,
            blocks: (dur / block_s).ceil().max(1.0) as usize,
            train_s: (t_s.len() - n_held) as f64 * dt,
            heldout_s: n_held as f64 * dt,
            heldout,
            block,
        }
    }
}

/// One compared output.
#[derive(Debug, Clone)]
pub struct Channel {
    /// Events channel: one sample per event (a clutch engagement) on the event's row, each
    /// with its own weight; `None` for a time series sampled on every valid row.
    pub events: Option<EventWeights>,
    /// Canonical column.
    pub name: String,
    /// SI unit.
    pub unit: &'static str,
    /// Model whose output it is.
    pub domain: Domain,
    /// Measured values (gaps filled; see `valid`).
    pub measured: Vec<f64>,
    /// Rows that count.
    pub valid: Vec<bool>,
    /// Valid train rows.
    pub train_idx: Vec<usize>,
    /// Valid held-out rows.
    pub held_idx: Vec<usize>,
    /// Per-row weights `w_i = 1/σ_i²` of a time series whose rows have their own null
    /// variance (the clutch-actuation view, [`Problem::with_actuation`]; the channel's `σ_c`
    /// is 1); `None`: every row weighs 1.
    pub row_weights: Option<Vec<f64>>,
}

/// The per-sample weights of an events channel ([`Channel::events`]): `w_i = 1/s_i²` for a
/// sample with standard deviation `s_i` (0 on rows without a sample). The channel's own weight
/// `σ_c` is 1, so `w_i r_i²` is the squared standardised residual.
#[derive(Debug, Clone, PartialEq)]
pub struct EventWeights(pub Vec<f64>);

/// Which part of the split.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// Training blocks.
    Train,
    /// Held-out blocks.
    Heldout,
}

impl Channel {
    /// Weight of row `i` within the channel: 1 for a time series, the sample's `1/s_i²` for
    /// an events channel, the row's own `1/σ_i²` for a row-weighted one
    /// ([`Channel::row_weights`]).
    pub fn weight(&self, i: usize) -> f64 {
        match (&self.events, &self.row_weights) {
            (Some(w), _) => w.0[i],
            (None, Some(w)) => w[i],
            (None, None) => 1.0,
        }
    }

    /// The valid rows of `part`.
    pub fn rows(&self, part: Part) -> &[usize] {
        match part {
            Part::Train => &self.train_idx,
            Part::Heldout => &self.held_idx,
        }
    }
}

/// A recording bound to the extended models, split and ready to be explained.
#[derive(Debug)]
pub struct Problem<'a> {
    long: Option<LongitudinalModel<'a>>,
    axle: Option<AxleModel<'a>>,
    log: &'a DriveLog,
    nominal: Theta,
    channels: Vec<Channel>,
    split: Split,
    t_s: Vec<f64>,
    slope_step: Option<f64>,
    left_out: Vec<String>,
    nominal_outputs: Vec<Vec<Vec<f64>>>,
    modes: Vec<ModeSample>,
    tyre_share: f64,
    reversals: Vec<ReversalSample>,
    views: Vec<View>,
}

/// A group of one model's channels that the explain step scores together: the longitudinal
/// model's speeds, its shuffle modes, its torque reversals, the axle model's bellow pressures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct View {
    /// Model whose outputs they are.
    pub domain: Domain,
    /// Which outputs.
    pub kind: ViewKind,
    /// Channels ([`Problem::channels`] indices).
    pub chans: Vec<usize>,
}

/// The views of [`View`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ViewKind {
    /// `vehicle_speed`, `engine_speed`.
    Speeds,
    /// `shuffle_frequency` ([`super::modal_channel`]).
    ShuffleModes,
    /// `reversal_relative_speed` ([`super::reversal_channel`]).
    Reversals,
    /// The three bellow pressures.
    Pressures,
    /// The engine speed while the clutch is actuated ([`Problem::with_actuation`]), scored
    /// for `clutch_slip` and `signal_delay` alone ([`ViewKind::only_for`]).
    ClutchActuation,
}

impl ViewKind {
    /// Whether the view is its own term of the deviance ([`super::fit::Evaluator::deviance`]):
    /// the modes, the reversals and the clutch-actuated engine speed are other quantities (or
    /// other rows) than the speeds and the pressures, which are pooled as largely redundant.
    pub fn own_term(self) -> bool {
        matches!(
            self,
            ViewKind::ShuffleModes | ViewKind::Reversals | ViewKind::ClutchActuation
        )
    }

    /// The effects a view is fitted and scored for, when it is not every effect that changes it:
    /// the clutch-actuation view serves `clutch_slip`, whose catalogue fingerprint it is
    /// (docs/diagnosis/catalogue.md), and `signal_delay`, whose delayed torque ramps land against
    /// the clutch at every shift — rows the nominal model reproduces only to the 10 Hz clutch's
    /// timing, which every other longitudinal effect moves a little without carrying its evidence
    /// there; scored for all of them it would dilute their held-out figures.
    pub fn only_for(self) -> Option<&'static [Effect]> {
        match self {
            ViewKind::ClutchActuation => Some(&[Effect::ClutchSlip, Effect::SignalDelay]),
            _ => None,
        }
    }
}

fn long_channel_names() -> [(&'static str, &'static str); 2] {
    [("vehicle_speed", "m/s"), ("engine_speed", "rad/s")]
}

/// Bellow pressure columns front, rear, tag.
pub const PRESSURES: [&str; 3] = [
    "bellow_pressure_front",
    "bellow_pressure_rear",
    "bellow_pressure_tag",
];

impl<'a> Problem<'a> {
    /// Binds `log` to the nominal vehicle (`nominal_truth`, gear `ratios`, nominal parameters
    /// `nominal` from [`Theta::nominal`]) and splits it ([`Split::alternating`] with
    /// `block_windows`). Each model is used when a nominal simulation of it succeeds on the
    /// recording; a model the recording cannot drive (missing columns, vehicle without axles) is
    /// left out and named in [`Problem::left_out`].
    ///
    /// # Errors
    /// [`ExplainError::NoModel`] when neither model can run; [`ExplainError::TooShort`] when a
    /// compared signal has fewer than [`MIN_SAMPLES_PER_PART`] valid samples in a part.
    pub fn new(
        log: &'a DriveLog,
        nominal_truth: &'a ExtendedVehicle,
        ratios: &'a [f64],
        nominal: Theta,
        long_cfg: LongitudinalConfig,
        block_windows: Option<usize>,
    ) -> Result<Self, ExplainError> {
        let file = log.meta.source_file.clone();
        if !(long_cfg.window_s.is_finite() && long_cfg.window_s > 0.0) {
            return Err(ExplainError::BadConfig {
                parameter: "window_s",
                value: long_cfg.window_s,
                requirement: "> 0",
            });
        }
        if log.len() < 2 {
            return Err(ExplainError::NoModel {
                file,
                reasons: format!("{} rows", log.len()),
            });
        }
        let t_s: Vec<f64> = log.seconds_from_start();
        let split = Split::alternating(&t_s, long_cfg.window_s, block_windows);
        let mut left_out = Vec::new();
        let (long, axle) = rayon::join(
            || {
                LongitudinalModel::new(log, nominal_truth, ratios, nominal, long_cfg).and_then(
                    |m| {
                        m.simulate(&nominal)
                            .map(|o| (m, vec![o.vehicle_speed, o.engine_speed]))
                    },
                )
            },
            || {
                AxleModel::new(log, nominal_truth, ratios, nominal)
                    .and_then(|m| m.simulate(&nominal).map(|p| (m, Vec::from(p))))
            },
        );
        // (view, its nominal outputs) in view order
        let mut views: Vec<(View, Vec<Vec<f64>>)> = Vec::new();
        let mut long_nominal = Vec::new();
        let mut axle_nominal = Vec::new();
        let long = match long {
            Ok((m, y)) => {
                long_nominal = y;
                Some(m)
            }
            Err(e @ (ExtendedError::Missing { .. } | ExtendedError::Recorded(_))) => {
                left_out.push(format!("longitudinal: {e}"));
                None
            }
            Err(e) => return Err(e.into()),
        };
        let axle = match axle {
            Ok((m, y)) => {
                axle_nominal = y;
                Some(m)
            }
            Err(e @ (ExtendedError::Missing { .. } | ExtendedError::Recorded(_))) => {
                left_out.push(format!("axle: {e}"));
                None
            }
            Err(e) => return Err(e.into()),
        };
        if long.is_none() && axle.is_none() {
            return Err(ExplainError::NoModel {
                file,
                reasons: left_out.join("; "),
            });
        }
        let mut channels = Vec::new();
        let mk = |name: &str,
                  unit: &'static str,
                  domain: Domain,
                  measured: Vec<f64>,
                  valid: Vec<bool>| {
            let (mut train_idx, mut held_idx) = (Vec::new(), Vec::new());
            for (i, v) in valid.iter().enumerate() {
                if *v {
                    if split.heldout[i] {
                        held_idx.push(i);
                    } else {
                        train_idx.push(i);
                    }
                }
            }
            Channel {
                events: None,
                row_weights: None,
                name: name.into(),
                unit,
                domain,
                measured,
                valid,
                train_idx,
                held_idx,
            }
        };
        // an events channel of the longitudinal model from (row, measured value, weight)
        // samples, when at least `min` fall in each part of the split
        let events_channel = |name: &str,
                              unit: &'static str,
                              min: usize,
                              samples: &[(usize, f64, f64)]|
         -> Option<Channel> {
            let held = samples.iter().filter(|s| split.heldout[s.0]).count();
            if held < min || samples.len() - held < min {
                return None;
            }
            let n = log.len();
            let (mut meas, mut valid, mut w) = (vec![0.0; n], vec![false; n], vec![0.0; n]);
            for &(row, value, weight) in samples {
                meas[row] = value;
                valid[row] = true;
                w[row] = weight;
            }
            let mut ch = mk(name, unit, Domain::Longitudinal, meas, valid);
            ch.events = Some(EventWeights(w));
            Some(ch)
        };
        let mut modes = Vec::new();
        let mut tyre_share = 0.0;
        let mut reversals = Vec::new();
        if let Some(m) = &long {
            let steady = super::rows::longitudinal_rows(log);
            let moving: Vec<bool> = m
                .measured_speed()
                .iter()
                .zip(&steady)
                .map(|(v, s)| *v >= long_cfg.min_speed_mps && *s)
                .collect();
            let engine = super::rows::engine_speed_rows(log);
            for ((name, unit), meas) in long_channel_names()
                .into_iter()
                .zip([m.measured_speed(), m.measured_engine_speed()])
            {
                let raw = log.signal(name).unwrap_or(&[]);
                let coupled = |i: usize| name != "engine_speed" || engine[i];
                let valid: Vec<bool> = (0..log.len())
                    .map(|i| moving[i] && coupled(i) && raw.get(i).is_some_and(|x| x.is_finite()))
                    .collect();
                channels.push(mk(name, unit, Domain::Longitudinal, meas.to_vec(), valid));
            }
            views.push((
                View {
                    domain: Domain::Longitudinal,
                    kind: ViewKind::Speeds,
                    chans: vec![0, 1],
                },
                std::mem::take(&mut long_nominal),
            ));
            // the shuffle modes (super::modal_channel), when enough engagements fall in each part
            let samples = modal_channel::measure(
                log,
                m.measured_engine_speed(),
                &nominal_truth.driveline,
                ratios,
                &ModalConfig::default(),
            );
            // how the driven tyres share the main flexibility: model structure estimated on
            // every engagement (modal_channel::fit_tyre_share)
            tyre_share = modal_channel::fit_tyre_share(&samples, &nominal_truth.driveline, ratios);
            let events: Vec<(usize, f64, f64)> = samples
                .iter()
                .map(|s| (s.row, s.ln_frequency, s.weight))
                .collect();
            let min = modal_channel::MIN_ENGAGEMENTS_PER_PART;
            if let Some(ch) = events_channel(modal_channel::NAME, modal_channel::UNIT, min, &events)
            {
                let n = log.len();
                views.push((
                    View {
                        domain: Domain::Longitudinal,
                        kind: ViewKind::ShuffleModes,
                        chans: vec![channels.len()],
                    },
                    vec![modal_channel::simulate(
                        &samples,
                        &nominal_truth.driveline,
                        ratios,
                        tyre_share,
                        n,
                    )],
                ));
                channels.push(ch);
                modes = samples;
            }
            // the driveline's relative speed at torque reversals (super::reversal_channel)
            let samples = reversal_channel::measure(
                log,
                m.measured_speed(),
                m.measured_engine_speed(),
                m.window_starts(),
                &nominal_truth.driveline,
                ratios,
                long_cfg.min_speed_mps,
            );
            let events: Vec<(usize, f64, f64)> =
                samples.iter().map(|s| (s.row, s.value, s.weight)).collect();
            let min = reversal_channel::MIN_REVERSALS_PER_PART;
            let speeds_nominal = &views[0].1;
            let ch = events_channel(reversal_channel::NAME, reversal_channel::UNIT, min, &events);
            if let (Some(ch), 2) = (ch, speeds_nominal.len()) {
                let y = reversal_channel::simulate(
                    &samples,
                    &t_s,
                    &speeds_nominal[1],
                    &speeds_nominal[0],
                );
                views.push((
                    View {
                        domain: Domain::Longitudinal,
                        kind: ViewKind::Reversals,
                        chans: vec![channels.len()],
                    },
                    vec![y],
                ));
                channels.push(ch);
                reversals = samples;
            }
        }
        if axle.is_some() {
            views.push((
                View {
                    domain: Domain::Axle,
                    kind: ViewKind::Pressures,
                    chans: (channels.len()..channels.len() + PRESSURES.len()).collect(),
                },
                std::mem::take(&mut axle_nominal),
            ));
            let steady = super::rows::axle_rows(log);
            for name in PRESSURES {
                let raw = log.signal(name).unwrap_or(&[]);
                let meas =
                    crate::signal::distance::fill_gaps(raw, crate::schema::Interpolation::Linear)
                        .unwrap_or_else(|| vec![f64::NAN; log.len()]);
                let valid: Vec<bool> = (0..log.len())
                    .map(|i| steady[i] && raw.get(i).is_some_and(|x| x.is_finite()))
                    .collect();
                channels.push(mk(name, "Pa", Domain::Axle, meas, valid));
            }
        }
        // the speeds and pressures must have data; an own-term view is used only when it has
        let required = views
            .iter()
            .filter(|(v, _)| !v.kind.own_term())
            .flat_map(|(v, _)| v.chans.iter().map(|&c| &channels[c]));
        for c in required {
            if c.train_idx.len() < MIN_SAMPLES_PER_PART || c.held_idx.len() < MIN_SAMPLES_PER_PART {
                return Err(ExplainError::TooShort {
                    file,
                    signal: c.name.clone(),
                    train: c.train_idx.len(),
                    heldout: c.held_idx.len(),
                    min: MIN_SAMPLES_PER_PART,
                });
            }
        }
        let (views, nominal_outputs): (Vec<View>, Vec<Vec<Vec<f64>>>) = views.into_iter().unzip();
        let slope_step = log
            .signal("road_slope")
            .and_then(estimate_quantization)
            .map(|q| q.step);
        Ok(Self {
            long,
            axle,
            log,
            nominal,
            channels,
            split,
            t_s,
            slope_step,
            left_out,
            nominal_outputs,
            modes,
            tyre_share,
            reversals,
            views,
        })
    }

    /// Adds the clutch-actuation view: the engine speed on the rows where the clutch is actuated
    /// ([`super::rows::actuation_channel_rows`], the vehicle at the longitudinal model's minimum
    /// speed or faster), each row weighted by its own null variance `variance` (rad²/s² on the
    /// log's rows, NaN where a row does not count: the noise floor's copies of
    /// [`super::rows::ACTUATION_CHANNEL`], which carry the 10 Hz clutch's sampling phase). The
    /// rows the speeds leave out because the model's clutch closes only to a 0.1 s sample are where
    /// a worn clutch shows (docs/diagnosis/catalogue.md: "engine speed mismatch while clutch
    /// actuated"); weighted by what that timing alone explains, they score about 1 on a drive the
    /// model reproduces. The view is its own deviance term, scored for `clutch_slip` and
    /// `signal_delay` alone ([`ViewKind::only_for`]), and used when each part has at least
    /// [`MIN_SAMPLES_PER_PART`] such rows; otherwise the problem is returned unchanged.
    pub fn with_actuation(mut self, variance: &[f64]) -> Self {
        let Some(m) = &self.long else {
            return self;
        };
        let n = self.log.len();
        if variance.len() != n {
            return self;
        }
        let Some(speeds) = self.views.iter().position(|v| v.kind == ViewKind::Speeds) else {
            return self;
        };
        let act = super::rows::actuation_channel_rows(
            self.log,
            LongitudinalConfig::default().min_speed_mps,
        );
        let w = m.measured_engine_speed();
        let mut weights = vec![0.0; n];
        let mut valid = vec![false; n];
        let (mut train_idx, mut held_idx) = (Vec::new(), Vec::new());
        for i in 0..n {
            let var = variance[i];
            if act[i] && var.is_finite() && var > 0.0 {
                weights[i] = 1.0 / var;
                valid[i] = true;
                if self.split.heldout[i] {
                    held_idx.push(i);
                } else {
                    train_idx.push(i);
                }
            }
        }
        if train_idx.len() < MIN_SAMPLES_PER_PART || held_idx.len() < MIN_SAMPLES_PER_PART {
            return self;
        }
        let engine = self.nominal_outputs[speeds][1].clone();
        let ch = Channel {
            events: None,
            row_weights: Some(weights),
            name: super::rows::ACTUATION_CHANNEL.into(),
            unit: "rad/s",
            domain: Domain::Longitudinal,
            measured: w.to_vec(),
            valid,
            train_idx,
            held_idx,
        };
        // after the longitudinal channels and views, before the axle model's
        let at = self
            .channels
            .iter()
            .take_while(|c| c.domain == Domain::Longitudinal)
            .count();
        for view in self.views.iter_mut() {
            for c in view.chans.iter_mut() {
                if *c >= at {
                    *c += 1;
                }
            }
        }
        self.channels.insert(at, ch);
        let vat = self
            .views
            .iter()
            .take_while(|v| v.domain == Domain::Longitudinal)
            .count();
        self.views.insert(
            vat,
            View {
                domain: Domain::Longitudinal,
                kind: ViewKind::ClutchActuation,
                chans: vec![at],
            },
        );
        self.nominal_outputs.insert(vat, vec![engine]);
        self
    }

    /// Outputs of every view at the nominal parameters ([`Problem::views`] order; per view its
    /// channels' simulations).
    pub fn nominal_outputs(&self) -> &[Vec<Vec<f64>>] {
        &self.nominal_outputs
    }

    /// The views (module documentation), longitudinal first.
    pub fn views(&self) -> &[View] {
        &self.views
    }

    /// The recording.
    pub fn log(&self) -> &DriveLog {
        self.log
    }

    /// Nominal parameters.
    pub fn nominal(&self) -> &Theta {
        &self.nominal
    }

    /// Compared outputs (longitudinal first, then axle).
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The split.
    pub fn split(&self) -> &Split {
        &self.split
    }

    /// Row times, s from the first row.
    pub fn times(&self) -> &[f64] {
        &self.t_s
    }

    /// Mean row spacing, s (1 for fewer than two rows): the lag unit of the whiteness test.
    pub fn row_spacing_s(&self) -> f64 {
        let t = &self.t_s;
        if t.len() > 1 {
            (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64
        } else {
            1.0
        }
    }

    /// Models in use.
    pub fn domains(&self) -> Vec<Domain> {
        let mut d = Vec::new();
        if self.long.is_some() {
            d.push(Domain::Longitudinal);
        }
        if self.axle.is_some() {
            d.push(Domain::Axle);
        }
        d
    }

    /// Why a model was left out (empty when both are used).
    pub fn left_out(&self) -> &[String] {
        &self.left_out
    }

    /// The share of the driveline's main flexibility the driven tyres take, estimated on this
    /// drive's shuffle modes ([`super::modal_channel::fit_tyre_share`]; 0 without enough).
    pub fn tyre_share(&self) -> f64 {
        self.tyre_share
    }

    /// Step of the recorded slope's quantisation lattice (tan α), when it has one.
    pub fn slope_step(&self) -> Option<f64> {
        self.slope_step
    }

    /// Indices (into [`Problem::channels`]) of `domain`'s outputs.
    pub fn channel_indices(&self, domain: Domain) -> Vec<usize> {
        (0..self.channels.len())
            .filter(|&i| self.channels[i].domain == domain)
            .collect()
    }

    /// Simulates `domain`'s model at `theta`: its outputs in [`Problem::channel_indices`]
    /// order (empty for a model not in use).
    ///
    /// # Errors
    /// [`ExtendedError`] from the model.
    pub fn simulate(&self, domain: Domain, theta: &Theta) -> Result<Vec<Vec<f64>>, ExtendedError> {
        let which: Vec<bool> = self.views.iter().map(|v| v.domain == domain).collect();
        Ok(self
            .simulate_views(&which, theta)?
            .into_iter()
            .flatten()
            .flatten()
            .collect())
    }

    /// Simulates the views `which` ([`Problem::views`]) at `theta`: per view its channels'
    /// outputs (`None` for a view not asked for). The shuffle modes need only the linearised
    /// driveline of `theta`, not a simulation.
    ///
    /// # Errors
    /// [`ExtendedError`] from a model.
    pub fn simulate_views(
        &self,
        which: &[bool],
        theta: &Theta,
    ) -> Result<Vec<Option<Vec<Vec<f64>>>>, ExtendedError> {
        let wants = |k: ViewKind| self.views.iter().zip(which).any(|(v, w)| *w && v.kind == k);
        let long = match &self.long {
            Some(m)
                if wants(ViewKind::Speeds)
                    || wants(ViewKind::Reversals)
                    || wants(ViewKind::ClutchActuation) =>
            {
                Some(m.simulate(theta)?)
            }
            _ => None,
        };
        let axle = match &self.axle {
            Some(m) if wants(ViewKind::Pressures) => Some(Vec::from(m.simulate(theta)?)),
            _ => None,
        };
        let modes = match &self.long {
            Some(m) if wants(ViewKind::ShuffleModes) => {
                let p = m.plant(theta)?.driveline;
                Some(modal_channel::simulate(
                    &self.modes,
                    &p,
                    m.ratios(),
                    self.tyre_share,
                    self.log.len(),
                ))
            }
            _ => None,
        };
        let mut out = Vec::with_capacity(self.views.len());
        for (v, w) in self.views.iter().zip(which) {
            out.push(match (w, v.kind) {
                (false, _) => None,
                (true, ViewKind::Speeds) => long
                    .as_ref()
                    .map(|o| vec![o.vehicle_speed.clone(), o.engine_speed.clone()]),
                (true, ViewKind::ShuffleModes) => modes.clone().map(|y| vec![y]),
                (true, ViewKind::Reversals) => long.as_ref().map(|o| {
                    vec![reversal_channel::simulate(
                        &self.reversals,
                        &self.t_s,
                        &o.engine_speed,
                        &o.vehicle_speed,
                    )]
                }),
                (true, ViewKind::Pressures) => axle.clone(),
                (true, ViewKind::ClutchActuation) => {
                    long.as_ref().map(|o| vec![o.engine_speed.clone()])
                }
            });
        }
        Ok(out)
    }

    /// Per-channel weights `σ_c` of the channels `chans` (module documentation; `outputs` one
    /// per channel): 1 for an events channel; the noise floor where `noise_floor` has a finite
    /// positive value for the channel; else its train RMS residual against `outputs` (1 when
    /// that is 0).
    pub fn sigmas(
        &self,
        chans: &[usize],
        outputs: &[Vec<f64>],
        noise_floor: Option<&BTreeMap<String, f64>>,
    ) -> Vec<f64> {
        chans
            .iter()
            .zip(outputs)
            .map(|(&c, y)| {
                let ch = &self.channels[c];
                if ch.events.is_some() || ch.row_weights.is_some() {
                    return 1.0;
                }
                match noise_floor.and_then(|m| m.get(&ch.name)) {
                    Some(&s) if s.is_finite() && s > 0.0 => s,
                    _ => {
                        let r = metrics(ch, y, Part::Train).rmse;
                        if r.is_finite() && r > 0.0 {
                            r
                        } else {
                            1.0
                        }
                    }
                }
            })
            .collect()
    }
}

/// RMSE, MAE and fit % of one channel on one part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Metrics {
    /// Root-mean-square error.
    pub rmse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// `100·(1 − ‖y − ŷ‖/‖y − ȳ‖)` (docs/diagnosis/method.md).
    pub fit_percent: f64,
}

/// [`Metrics`] of `sim` against the channel's measurement on `part`.
pub fn metrics(ch: &Channel, sim: &[f64], part: Part) -> Metrics {
    let rows = ch.rows(part);
    let n = rows.len().max(1) as f64;
    let mean = rows.iter().map(|&i| ch.measured[i]).sum::<f64>() / n;
    let (mut se, mut ae, mut ss) = (0.0, 0.0, 0.0);
    for &i in rows {
        let e = ch.measured[i] - sim[i];
        se += e * e;
        ae += e.abs();
        ss += (ch.measured[i] - mean).powi(2);
    }
    Metrics {
        rmse: (se / n).sqrt(),
        mae: ae / n,
        fit_percent: if ss > 0.0 {
            100.0 * (1.0 - (se / ss).sqrt())
        } else {
            f64::NAN
        },
    }
}

/// Weighted mean square (module documentation) of `outputs` (one per channel of `chans`) with
/// weights `sigmas`, on `part`.
pub fn weighted_ms(
    channels: &[Channel],
    chans: &[usize],
    sigmas: &[f64],
    outputs: &[Vec<f64>],
    part: Part,
) -> f64 {
    let mut j = 0.0;
    for ((&c, s), y) in chans.iter().zip(sigmas).zip(outputs) {
        let ch = &channels[c];
        let rows = ch.rows(part);
        let se: f64 = rows
            .iter()
            .map(|&i| ch.weight(i) * (ch.measured[i] - y[i]).powi(2))
            .sum();
        j += se / (rows.len().max(1) as f64 * s * s);
    }
    j / chans.len().max(1) as f64
}

/// Lags (s) of the whiteness statistic: 0.1 s to 2 s in 0.1 s steps — from the driveline's
/// shuffle band (a few Hz) to the seconds over which a missing force drifts the speed.
pub const WHITENESS_LAG_STEP_S: f64 = 0.1;
/// Number of lags of the whiteness statistic.
pub const WHITENESS_LAGS: usize = 20;

/// Whiteness of a residual (see [`whiteness`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Whiteness {
    /// Mean over channels of the Ljung–Box statistic per sample, `Q/n`: the mean squared
    /// non-centred autocorrelation at the lags; 0 for white noise, 1 for a constant.
    pub q_per_n: f64,
    /// Non-white (autocorrelated) power: mean over channels of `√(Q/n)` times the channel's
    /// weighted mean square `MS_c / σ_c²` — the RMS of the weighted autocovariance at the
    /// lags. White noise of any level scores 0 (up to the autocorrelation's sampling noise).
    pub nonwhite_power: f64,
}

/// Whiteness of `outputs`' residual on `part` over the channels `chans` (weights `sigmas`).
///
/// For each channel, the squared *non-centred* autocorrelation `ρ(k) = Σ r_i r_{i+k} / Σ r_i²`
/// (pairs within contiguous valid runs) at the lags `k·0.1 s`, k = 1…20 — from the driveline's
/// shuffle band (a few Hz) to the seconds over which a missing force drifts the speed — is
/// averaged: the Ljung–Box statistic per sample `Q/n` on a 10 Hz lag grid; a bias counts as
/// non-white (the model's residual should be zero-mean noise). The acceptance rule compares the
/// non-white power, `√(Q/n)` scaled by the residual's weighted mean square (the RMS of the
/// autocovariance at the lags): the normalised `Q/n` alone rises whenever a fit removes a fast
/// structured error and leaves a smaller but slower one (the whole-percent slope sensor's
/// drift), although less of the residual is structure, and `Q/n` scaled by the mean square
/// still rises when the error removed is white at the lags (`super::explain`, rule 2).
///
/// An events channel ([`Channel::events`]; engagements tens of seconds apart, no time lags
/// between them) is scored on its standardised residuals `z_i = r_i √w_i` in event order, at
/// the lags of 1 … min(20, n − 1) events ([`event_whiteness`]): a shift common to the events
/// (a wrong shaft stiffness moves every engagement's frequency) is non-white as a bias is.
pub fn whiteness(
    channels: &[Channel],
    chans: &[usize],
    sigmas: &[f64],
    outputs: &[Vec<f64>],
    part: Part,
    dt_s: f64,
) -> Whiteness {
    let step = ((WHITENESS_LAG_STEP_S / dt_s.max(1e-9)).round() as usize).max(1);
    let (mut qn, mut pw) = (0.0, 0.0);
    for ((&c, y), sg) in chans.iter().zip(outputs).zip(sigmas) {
        let ch = &channels[c];
        let rows = ch.rows(part);
        if ch.events.is_some() {
            let z: Vec<f64> = rows
                .iter()
                .map(|&i| (ch.measured[i] - y[i]) * ch.weight(i).sqrt())
                .collect();
            let q = event_whiteness(&z);
            let ms = z.iter().map(|x| x * x).sum::<f64>() / z.len().max(1) as f64;
            qn += q;
            pw += q.sqrt() * ms / (sg * sg);
            continue;
        }
        // standardised by the row's own weight (1 but for a row-weighted channel)
        let r: Vec<f64> = rows
            .iter()
            .map(|&i| (ch.measured[i] - y[i]) * ch.weight(i).sqrt())
            .collect();
        let e0: f64 = r.iter().map(|x| x * x).sum();
        if e0 <= 0.0 {
            continue;
        }
        // positions of the runs in `r`
        let mut bounds = Vec::new();
        let mut pos = 0;
        for run in index_runs(rows) {
            bounds.push((pos, pos + run.len()));
            pos += run.len();
        }
        let mut q = 0.0;
        for k in 1..=WHITENESS_LAGS {
            let lag = k * step;
            let mut s = 0.0;
            for &(a, b) in &bounds {
                if b - a > lag {
                    s += r[a..b - lag]
                        .iter()
                        .zip(&r[a + lag..b])
                        .map(|(x, y)| x * y)
                        .sum::<f64>();
                }
            }
            q += (s / e0).powi(2);
        }
        let q = q / WHITENESS_LAGS as f64;
        qn += q;
        pw += q.sqrt() * e0 / (r.len() as f64 * sg * sg);
    }
    let n = chans.len().max(1) as f64;
    Whiteness {
        q_per_n: qn / n,
        nonwhite_power: pw / n,
    }
}

/// `Q/n` of a sequence of event residuals `z` ([`whiteness`] for an events channel): the mean
/// over the lags `k` = 1 … min([`WHITENESS_LAGS`], n − 1) of the squared non-centred
/// autocorrelation `(Σ z_i z_{i+k} / Σ z_i²)²`; 0 for fewer than 2 events or a zero residual.
pub fn event_whiteness(z: &[f64]) -> f64 {
    let e0: f64 = z.iter().map(|x| x * x).sum();
    let lags = WHITENESS_LAGS.min(z.len().saturating_sub(1));
    if e0 <= 0.0 || lags == 0 {
        return 0.0;
    }
    let q: f64 = (1..=lags)
        .map(|k| {
            let s: f64 = z[..z.len() - k]
                .iter()
                .zip(&z[k..])
                .map(|(a, b)| a * b)
                .sum();
            (s / e0).powi(2)
        })
        .sum();
    q / lags as f64
}

/// Effective number of independent samples of the residual of one channel on `part`:
/// `N / τ` with `τ = 1 + 2 Σ_{k=1}^{M} ρ(k)` the integrated autocorrelation time of the
/// (centred) residual, `ρ` pooled over the contiguous valid runs (computed by FFT), and `M`
/// Sokal's automatic window (the smallest `M ≥ 5 τ(M)`), `τ ≥ 1`. The samples of an events
/// channel ([`Channel::events`]: engagements tens of seconds apart, each from its own fit)
/// count as independent: `N`.
pub fn effective_samples(ch: &Channel, sim: &[f64], part: Part) -> f64 {
    let rows = ch.rows(part);
    let n = rows.len();
    if n < 2 || ch.events.is_some() {
        return n as f64;
    }
    let r: Vec<f64> = rows
        .iter()
        .map(|&i| (ch.measured[i] - sim[i]) * ch.weight(i).sqrt())
        .collect();
    let mean = r.iter().sum::<f64>() / n as f64;
    let mut planner = RealFftPlanner::<f64>::new();
    let mut acov: Vec<f64> = Vec::new();
    let mut pos = 0;
    for run in index_runs(rows) {
        let len = run.len();
        let x: Vec<f64> = r[pos..pos + len].iter().map(|v| v - mean).collect();
        pos += len;
        let m = (2 * len).next_power_of_two();
        let fwd = planner.plan_fft_forward(m);
        let inv = planner.plan_fft_inverse(m);
        let mut buf = vec![0.0; m];
        buf[..len].copy_from_slice(&x);
        let mut spec = fwd.make_output_vec();
        if fwd.process(&mut buf, &mut spec).is_err() {
            continue;
        }
        for c in spec.iter_mut() {
            *c = num_complex::Complex::new(c.norm_sqr(), 0.0);
        }
        let mut out = inv.make_output_vec();
        if inv.process(&mut spec, &mut out).is_err() {
            continue;
        }
        if acov.len() < len {
            acov.resize(len, 0.0);
        }
        for k in 0..len {
            acov[k] += out[k] / m as f64;
        }
    }
    if acov.is_empty() || acov[0] <= 0.0 {
        return n as f64;
    }
    let mut tau = 1.0;
    for (m, a) in acov.iter().enumerate().skip(1) {
        tau += 2.0 * a / acov[0];
        if m as f64 >= 5.0 * tau {
            break;
        }
    }
    n as f64 / tau.max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro256StarStar;

    fn channel(measured: Vec<f64>) -> Channel {
        let n = measured.len();
        Channel {
            events: None,
            row_weights: None,
            name: "x".into(),
            unit: "1",
            domain: Domain::Longitudinal,
            measured,
            valid: vec![true; n],
            train_idx: (0..n).collect(),
            held_idx: Vec::new(),
        }
    }

    fn gauss(rng: &mut Xoshiro256StarStar) -> f64 {
        // Box–Muller
        let (u, v) = (rng.next_f64().max(1e-300), rng.next_f64());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    #[test]
    fn split_alternates_whole_windows() {
        let t: Vec<f64> = (0..10_000).map(|i| i as f64 * 0.02).collect(); // 200 s
        let s = Split::alternating(&t, 20.0, None);
        assert_eq!(s.block_s, 20.0);
        assert_eq!(s.blocks, 10);
        assert!(!s.heldout[0] && s.heldout[1000] && !s.heldout[2000]);
        assert!((s.train_s - 100.0).abs() < 0.1 && (s.heldout_s - 100.0).abs() < 0.1);
        // an hour: 12 blocks of 5 min
        let t: Vec<f64> = (0..180_000).map(|i| i as f64 * 0.02).collect();
        let s = Split::alternating(&t, 20.0, None);
        assert_eq!((s.block_s, s.blocks), (300.0, 12));
    }

    #[test]
    fn whiteness_is_zero_for_noise_and_one_for_a_bias() {
        let mut rng = Xoshiro256StarStar::seed_from_u64(1);
        let noise: Vec<f64> = (0..20_000).map(|_| gauss(&mut rng)).collect();
        let zero = vec![vec![0.0; noise.len()]];
        let w = whiteness(&[channel(noise)], &[0], &[1.0], &zero, Part::Train, 0.02);
        assert!(w.q_per_n < 1e-3, "{w:?}");
        let w = whiteness(
            &[channel(vec![0.5; 20_000])],
            &[0],
            &[1.0],
            &[vec![0.0; 20_000]],
            Part::Train,
            0.02,
        );
        assert!((w.q_per_n - 1.0).abs() < 0.05 && (w.nonwhite_power - 0.25).abs() < 0.02);
    }

    #[test]
    fn white_error_on_top_of_slow_structure_leaves_the_non_white_power_alone() {
        // a fit that removes a fast error leaves the sensors' slow drift: slow structure (a
        // 0.05 Hz sine, power 0.125) with and without white noise of power 1. The non-white
        // power is the autocovariance at the lags, which the white part does not change; the
        // other form, (Q/n)·MS = mean c_k² / c_0, rises about 9-fold when it is removed
        let n = 50_000;
        let mut rng = Xoshiro256StarStar::seed_from_u64(3);
        let slow: Vec<f64> = (0..n)
            .map(|i| 0.5 * (std::f64::consts::TAU * 0.05 * i as f64 * 0.02).sin())
            .collect();
        let mixed: Vec<f64> = slow.iter().map(|s| s + gauss(&mut rng)).collect();
        let zero = vec![vec![0.0; n]];
        let w = |r: Vec<f64>| whiteness(&[channel(r)], &[0], &[1.0], &zero, Part::Train, 0.02);
        let ms = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>() / r.len() as f64;
        let (ms_mixed, ms_slow) = (ms(&mixed), ms(&slow));
        let (with, without) = (w(mixed), w(slow));
        let ratio = without.nonwhite_power / with.nonwhite_power;
        // the lag sums' sampling noise with the white part: a few per cent at 50 000 rows
        assert!((ratio - 1.0).abs() < 0.08, "{with:?} -> {without:?}");
        let old = (without.q_per_n * ms_slow) / (with.q_per_n * ms_mixed);
        assert!(old > 5.0, "(Q/n)·MS rose only {old}×");
    }

    #[test]
    fn effective_samples_of_ar1_noise() {
        // AR(1), φ = 0.9: τ = (1 + φ)/(1 − φ) = 19
        let mut rng = Xoshiro256StarStar::seed_from_u64(2);
        let mut x = 0.0;
        let v: Vec<f64> = (0..200_000)
            .map(|_| {
                x = 0.9 * x + gauss(&mut rng);
                x
            })
            .collect();
        let n = v.len() as f64;
        let ne = effective_samples(&channel(v), &vec![0.0; n as usize], Part::Train);
        assert!((n / ne / 19.0 - 1.0).abs() < 0.2, "τ = {}", n / ne);
    }

    #[test]
    fn an_events_channel_is_weighted_per_sample_and_its_whiteness_is_over_events() {
        // 6 events on rows 0, 10, …, 50 of 60; weights 1/s² with s = 0.01 and 0.02
        let n = 60;
        let mut measured = vec![0.0; n];
        let mut valid = vec![false; n];
        let mut w = vec![0.0; n];
        for k in 0..6 {
            let i = 10 * k;
            measured[i] = 0.05; // a common shift of 5 %
            valid[i] = true;
            w[i] = if k % 2 == 0 { 1e4 } else { 2.5e3 };
        }
        let mut ch = channel(measured);
        ch.valid = valid;
        ch.train_idx = (0..6).map(|k| 10 * k).collect();
        ch.events = Some(EventWeights(w));
        let zero = vec![vec![0.0; n]];
        // mean of w r²: (3·1e4 + 3·2.5e3)·0.0025 / 6 = 15.625
        let ms = weighted_ms(std::slice::from_ref(&ch), &[0], &[1.0], &zero, Part::Train);
        assert!((ms - 15.625).abs() < 1e-9, "{ms}");
        // a common shift is non-white: lag-k autocorrelation of z = (5, 2.5, 5, 2.5, 5, 2.5)
        let z = [5.0, 2.5, 5.0, 2.5, 5.0, 2.5];
        let e0: f64 = z.iter().map(|x| x * x).sum();
        let expect: f64 = (1..=5)
            .map(|k| {
                let s: f64 = z[..6 - k].iter().zip(&z[k..]).map(|(a, b)| a * b).sum();
                (s / e0).powi(2)
            })
            .sum::<f64>()
            / 5.0;
        let wh = whiteness(
            std::slice::from_ref(&ch),
            &[0],
            &[1.0],
            &zero,
            Part::Train,
            0.02,
        );
        assert!(
            (wh.q_per_n - expect).abs() < 1e-12 && wh.q_per_n > 0.2,
            "{wh:?}"
        );
        assert!((wh.nonwhite_power - expect.sqrt() * 15.625).abs() < 1e-9);
        // a single event has no lag at all, a zero residual no structure
        assert_eq!(event_whiteness(&[3.0]), 0.0);
        assert_eq!(event_whiteness(&[0.0, 0.0]), 0.0);
        // events are independent samples
        assert_eq!(effective_samples(&ch, &zero[0], Part::Train), 6.0);
    }

    #[test]
    fn metrics_of_a_perfect_and_a_mean_fit() {
        let ch = channel(vec![1.0, 2.0, 3.0, 4.0]);
        let m = metrics(&ch, &[1.0, 2.0, 3.0, 4.0], Part::Train);
        assert_eq!((m.rmse, m.mae, m.fit_percent), (0.0, 0.0, 100.0));
        let m = metrics(&ch, &[2.5; 4], Part::Train);
        assert!(m.fit_percent.abs() < 1e-12 && (m.mae - 1.0).abs() < 1e-12);
    }
}
