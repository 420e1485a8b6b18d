//! One compared output of step 3 of the diagnosis, explain (docs/diagnosis/method.md): its
//! measured values, the rows that count in each part of the split and their weights
//! ([`Channel`]), and the error figures of a simulation against it: RMSE, MAE and fit % in the
//! signal's SI unit ([`metrics`]) and the weighted mean square of a set of channels
//! ([`weighted_ms`], dimensionless).
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

use super::row_column::RowColumn;
use super::split::Part;
use crate::model::catalogue::Domain;
use std::ops::Index;

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
    /// Measured values (gaps filled; see `valid`): sparse on its samples for an events channel,
    /// shared with the engine speed's channel for the clutch-actuation one.
    pub measured: RowColumn,
    /// Rows that count.
    pub valid: Vec<bool>,
    /// Valid train rows.
    pub train_idx: Vec<usize>,
    /// Valid held-out rows.
    pub held_idx: Vec<usize>,
    /// Per-row weights `w_i = 1/σ_i²` of a time series whose rows have their own null
    /// variance (the clutch-actuation view,
    /// [`Problem::with_actuation`](super::problem::Problem::with_actuation); the channel's
    /// `σ_c` is 1); `None`: every row weighs 1.
    pub row_weights: Option<RowColumn>,
}

/// The per-sample weights of an events channel ([`Channel::events`]): `w_i = 1/s_i²` for a
/// sample with standard deviation `s_i` (0 on rows without a sample). The channel's own weight
/// `σ_c` is 1, so `w_i r_i²` is the squared standardised residual.
#[derive(Debug, Clone, PartialEq)]
pub struct EventWeights(pub RowColumn);

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
pub fn metrics<Y: Index<usize, Output = f64> + ?Sized>(
    ch: &Channel,
    sim: &Y,
    part: Part,
) -> Metrics {
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
pub fn weighted_ms<Y: Index<usize, Output = f64>>(
    channels: &[Channel],
    chans: &[usize],
    sigmas: &[f64],
    outputs: &[Y],
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

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A longitudinal test channel `x` of `measured`, every row valid and in the training part.
    pub(in crate::diagnose) fn channel(measured: Vec<f64>) -> Channel {
        let n = measured.len();
        Channel {
            events: None,
            row_weights: None,
            name: "x".into(),
            unit: "1",
            domain: Domain::Longitudinal,
            measured: RowColumn::dense(measured),
            valid: vec![true; n],
            train_idx: (0..n).collect(),
            held_idx: Vec::new(),
        }
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
