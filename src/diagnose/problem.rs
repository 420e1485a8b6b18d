//! The explain step's view of one recording (docs/diagnosis/method.md, step 3): which outputs are
//! compared and the extended models' simulations on those outputs ([`Problem`]). The parts it is
//! built from: the train / held-out split ([`super::split`]), the compared channels with their
//! weights and error figures ([`super::channel`]), the views that group them
//! ([`super::view`]), and the residual statistics the acceptance rule uses
//! ([`super::whiteness`]: whiteness, effective number of independent samples).
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

use super::extended::{AxleModel, ExtendedError, LongitudinalConfig, LongitudinalModel, Theta};
use super::modal::ModalConfig;
use super::modal_channel::{self, ModeSample};
use super::reversal_channel::{self, ReversalSample};
use super::row_column::RowColumn;
use crate::model::catalogue::Domain;
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::signal::quantization::estimate_quantization;
use crate::table::DriveLog;
use std::collections::BTreeMap;
use std::sync::Arc;
use thiserror::Error;

pub use super::channel::{metrics, weighted_ms, Channel, EventWeights, Metrics};
pub use super::split::{Part, Split, MAX_BLOCK_WINDOWS, TARGET_BLOCKS};
pub use super::view::{View, ViewKind};
pub use super::whiteness::{
    effective_samples, event_whiteness, whiteness, Whiteness, WHITENESS_LAGS, WHITENESS_LAG_STEP_S,
};

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

/// Fewest valid samples a compared signal needs in each part.
pub const MIN_SAMPLES_PER_PART: usize = 100;

/// How far from a torque reversal's row its feature reads the simulated speeds, s, at most:
/// the reference window's 0.5 s before it and the peak window's 0.4 s after, each widened by
/// the 0.04 s smoothing ([`super::reversal_channel`]), rounded up.
pub const REVERSAL_READ_S: f64 = 1.0;

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
    nominal_outputs: Vec<Vec<RowColumn>>,
    modes: Vec<ModeSample>,
    /// The rows of the shuffle modes' samples (sorted, unique): their view's stored rows.
    mode_rows: Arc<[usize]>,
    tyre_share: f64,
    reversals: Vec<ReversalSample>,
    /// The rows of the torque reversals' samples (sorted, unique).
    reversal_rows: Arc<[usize]>,
    views: Vec<View>,
    train_windows: std::sync::OnceLock<Vec<bool>>,
}

/// The rows of a view's samples below `n`, sorted and unique: where its simulation writes
/// ([`RowColumn::sparse`]).
fn sample_rows(rows: impl Iterator<Item = usize>, n: usize) -> Arc<[usize]> {
    let mut r: Vec<usize> = rows.filter(|&i| i < n).collect();
    r.sort_unstable();
    r.dedup();
    Arc::from(r)
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
                        m.simulate(&nominal).map(|o| {
                            let y = vec![
                                RowColumn::dense(o.vehicle_speed),
                                RowColumn::dense(o.engine_speed),
                            ];
                            (m, y)
                        })
                    },
                )
            },
            || {
                AxleModel::new(log, nominal_truth, ratios, nominal).and_then(|m| {
                    m.simulate(&nominal)
                        .map(|p| (m, Vec::from(p).into_iter().map(RowColumn::dense).collect()))
                })
            },
        );
        // (view, its nominal outputs) in view order
        let mut views: Vec<(View, Vec<RowColumn>)> = Vec::new();
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
                  measured: RowColumn,
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
        // samples, when at least `min` fall in each part of the split, with the samples' rows
        // (sorted, unique: where its view's simulation writes)
        let events_channel = |name: &str,
                              unit: &'static str,
                              min: usize,
                              samples: &[(usize, f64, f64)]|
         -> Option<(Channel, Arc<[usize]>)> {
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
            // stored on the samples' rows alone (0 on every other)
            let rows = sample_rows(samples.iter().map(|s| s.0), n);
            let meas = RowColumn::sparse(&meas, rows.clone(), 0.0);
            let mut ch = mk(name, unit, Domain::Longitudinal, meas, valid);
            ch.events = Some(EventWeights(RowColumn::sparse(&w, rows.clone(), 0.0)));
            Some((ch, rows))
        };
        let mut modes = Vec::new();
        let mut mode_rows: Arc<[usize]> = Arc::from(Vec::new());
        let mut tyre_share = 0.0;
        let mut reversals = Vec::new();
        let mut reversal_rows: Arc<[usize]> = Arc::from(Vec::new());
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
                let meas = RowColumn::dense(meas.to_vec());
                channels.push(mk(name, unit, Domain::Longitudinal, meas, valid));
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
            if let Some((ch, rows)) =
                events_channel(modal_channel::NAME, modal_channel::UNIT, min, &events)
            {
                let n = log.len();
                mode_rows = rows;
                let y = modal_channel::simulate(
                    &samples,
                    &nominal_truth.driveline,
                    ratios,
                    tyre_share,
                    n,
                );
                views.push((
                    View {
                        domain: Domain::Longitudinal,
                        kind: ViewKind::ShuffleModes,
                        chans: vec![channels.len()],
                    },
                    vec![RowColumn::sparse(
                        &y,
                        mode_rows.clone(),
                        modal_channel::FILL,
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
            if let (Some((ch, rows)), 2) = (ch, speeds_nominal.len()) {
                let y = reversal_channel::simulate(
                    &samples,
                    &t_s,
                    &speeds_nominal[1].values(),
                    &speeds_nominal[0].values(),
                );
                reversal_rows = rows;
                views.push((
                    View {
                        domain: Domain::Longitudinal,
                        kind: ViewKind::Reversals,
                        chans: vec![channels.len()],
                    },
                    vec![RowColumn::sparse(
                        &y,
                        reversal_rows.clone(),
                        reversal_channel::FILL,
                    )],
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
                channels.push(mk(name, "Pa", Domain::Axle, RowColumn::dense(meas), valid));
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
        let (views, nominal_outputs): (Vec<View>, Vec<Vec<RowColumn>>) = views.into_iter().unzip();
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
            mode_rows,
            reversal_rows,
            modes,
            tyre_share,
            reversals,
            views,
            train_windows: std::sync::OnceLock::new(),
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
        if self.long.is_none() {
            return self;
        }
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
        let mut weights = vec![0.0; n];
        let mut valid = vec![false; n];
        let mut rows = Vec::new();
        let (mut train_idx, mut held_idx) = (Vec::new(), Vec::new());
        for i in 0..n {
            let var = variance[i];
            if act[i] && var.is_finite() && var > 0.0 {
                weights[i] = 1.0 / var;
                valid[i] = true;
                rows.push(i);
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
        // the measured engine speed is the speeds view's (shared); the weights are stored on
        // the actuated rows alone (0 on every other)
        let measured = self.channels[self.views[speeds].chans[1]].measured.clone();
        let ch = Channel {
            events: None,
            row_weights: Some(RowColumn::sparse(&weights, Arc::from(rows), 0.0)),
            name: super::rows::ACTUATION_CHANNEL.into(),
            unit: "rad/s",
            domain: Domain::Longitudinal,
            measured,
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
        // the new channel's train rows may need windows the old ones did not
        self.train_windows = std::sync::OnceLock::new();
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
    pub fn nominal_outputs(&self) -> &[Vec<RowColumn>] {
        &self.nominal_outputs
    }

    /// The nominal outputs of `domain`'s views, flattened as [`Problem::simulate`] returns
    /// them: the nominal simulation itself, shared, not made again.
    pub fn nominal_of(&self, domain: Domain) -> Vec<RowColumn> {
        self.views
            .iter()
            .zip(&self.nominal_outputs)
            .filter(|(v, _)| v.domain == domain)
            .flat_map(|(_, y)| y.iter().cloned())
            .collect()
    }

    /// The views ([`super::view`]), longitudinal first.
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

    /// The drive's tyre-slip fit the longitudinal model uses ([`super::tyre_slip::estimate`]);
    /// `None` without the longitudinal model.
    pub fn slip(&self) -> Option<super::tyre_slip::SlipEstimate> {
        self.long.as_ref().map(LongitudinalModel::slip)
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
    pub fn simulate(&self, domain: Domain, theta: &Theta) -> Result<Vec<RowColumn>, ExtendedError> {
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
    ) -> Result<Vec<Option<Vec<RowColumn>>>, ExtendedError> {
        self.simulate_views_on(which, theta, false)
    }

    /// The longitudinal model's windows a train cost reads ([`Problem::simulate_views_on`]):
    /// those holding a train row of one of its channels, and for a torque reversal's sample
    /// every window within [`REVERSAL_READ_S`] of it (its feature reads the simulated speeds
    /// around the reversal). Empty without the longitudinal model.
    pub fn train_windows(&self) -> &[bool] {
        self.train_windows.get_or_init(|| {
            let Some(m) = &self.long else {
                return Vec::new();
            };
            let mut need = vec![false; m.window_starts().len()];
            let reversal_chans: Vec<usize> = self
                .views
                .iter()
                .filter(|v| v.kind == ViewKind::Reversals)
                .flat_map(|v| v.chans.iter().copied())
                .collect();
            for (c, ch) in self.channels.iter().enumerate() {
                if ch.domain != Domain::Longitudinal {
                    continue;
                }
                let reach = if reversal_chans.contains(&c) {
                    REVERSAL_READ_S
                } else {
                    0.0
                };
                for &i in &ch.train_idx {
                    let t = self.t_s[i];
                    let (a, b) = (m.window_of(t - reach), m.window_of(t + reach));
                    for w in need.iter_mut().take(b + 1).skip(a) {
                        *w = true;
                    }
                }
            }
            need
        })
    }

    /// [`Problem::simulate_views`], with `train_only` the longitudinal model on
    /// [`Problem::train_windows`] alone (its outputs elsewhere NaN): what a cost of the train
    /// part reads (a fit's grid points and trials, an interval's probes).
    ///
    /// # Errors
    /// [`ExtendedError`] from a model.
    pub fn simulate_views_on(
        &self,
        which: &[bool],
        theta: &Theta,
        train_only: bool,
    ) -> Result<Vec<Option<Vec<RowColumn>>>, ExtendedError> {
        let wants = |k: ViewKind| self.views.iter().zip(which).any(|(v, w)| *w && v.kind == k);
        let long = match &self.long {
            Some(m)
                if wants(ViewKind::Speeds)
                    || wants(ViewKind::Reversals)
                    || wants(ViewKind::ClutchActuation) =>
            {
                let needed = train_only.then(|| self.train_windows());
                Some(m.simulate_windows(theta, needed)?)
            }
            _ => None,
        };
        let axle = match &self.axle {
            Some(m) if wants(ViewKind::Pressures) => Some(
                Vec::from(m.simulate(theta)?)
                    .into_iter()
                    .map(RowColumn::dense)
                    .collect::<Vec<_>>(),
            ),
            _ => None,
        };
        // the reversals' feature reads the simulated speeds, which the speeds view and the
        // clutch-actuation view then share
        let reversal = match &long {
            Some(o) if wants(ViewKind::Reversals) => {
                let y = reversal_channel::simulate(
                    &self.reversals,
                    &self.t_s,
                    &o.engine_speed,
                    &o.vehicle_speed,
                );
                Some(RowColumn::sparse(
                    &y,
                    self.reversal_rows.clone(),
                    reversal_channel::FILL,
                ))
            }
            _ => None,
        };
        let long = long.map(|o| {
            (
                RowColumn::dense(o.vehicle_speed),
                RowColumn::dense(o.engine_speed),
            )
        });
        let modes = match &self.long {
            Some(m) if wants(ViewKind::ShuffleModes) => {
                let p = m.plant(theta)?.driveline;
                let y = modal_channel::simulate(
                    &self.modes,
                    &p,
                    m.ratios(),
                    self.tyre_share,
                    self.log.len(),
                );
                Some(RowColumn::sparse(
                    &y,
                    self.mode_rows.clone(),
                    modal_channel::FILL,
                ))
            }
            _ => None,
        };
        let mut out = Vec::with_capacity(self.views.len());
        for (v, w) in self.views.iter().zip(which) {
            out.push(match (w, v.kind) {
                (false, _) => None,
                (true, ViewKind::Speeds) => long.as_ref().map(|(v, w)| vec![v.clone(), w.clone()]),
                (true, ViewKind::ShuffleModes) => modes.clone().map(|y| vec![y]),
                (true, ViewKind::Reversals) => reversal.clone().map(|y| vec![y]),
                (true, ViewKind::Pressures) => axle.clone(),
                (true, ViewKind::ClutchActuation) => long.as_ref().map(|(_, w)| vec![w.clone()]),
            });
        }
        Ok(out)
    }

    /// Per-channel weights `σ_c` of the channels `chans` ([`super::channel`]; `outputs` one
    /// per channel): 1 for an events channel; the noise floor where `noise_floor` has a finite
    /// positive value for the channel; else its train RMS residual against `outputs` (1 when
    /// that is 0).
    pub fn sigmas<Y: std::ops::Index<usize, Output = f64>>(
        &self,
        chans: &[usize],
        outputs: &[Y],
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
