//! Per-signal figures of a finding in step 3 of the diagnosis, explain
//! (docs/diagnosis/method.md, "show"): the RMSE, MAE and fit % of each signal a fitted change
//! moves, on the train and held-out parts, before and after ([`SignalFit`], [`SignalMetrics`]),
//! against the recording or against a reference such as a generator's noise-free truth
//! ([`fits_against`]).
//!
//! Unweighted, in each signal's SI unit ([`SignalMetrics::unit`]; `1` for the shuffle
//! frequency's relative error); fit % as `100·(1 − ‖y − ŷ‖/‖y − ȳ‖)`.

use super::acceptance::own_model_at;
use super::problem::{metrics, ExplainError, Part, Problem};
use super::row_column::RowColumn;
use crate::model::catalogue::Effect;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Before/after error of one signal (docs/diagnosis/contract.md: RMSE).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SignalFit {
    /// Train RMSE before.
    pub train_before: f64,
    /// Train RMSE after.
    pub train_after: f64,
    /// Held-out RMSE before.
    pub heldout_before: f64,
    /// Held-out RMSE after.
    pub heldout_after: f64,
    /// `"rmse"`.
    pub metric: &'static str,
}

/// Train and held-out values of one metric before and after.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BeforeAfter {
    /// Train, before.
    pub train_before: f64,
    /// Train, after.
    pub train_after: f64,
    /// Held-out, before.
    pub heldout_before: f64,
    /// Held-out, after.
    pub heldout_after: f64,
}

/// RMSE, MAE and fit % of one signal before and after (docs/diagnosis/method.md, "show").
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SignalMetrics {
    /// SI unit of RMSE and MAE.
    pub unit: &'static str,
    /// Root-mean-square error.
    pub rmse: BeforeAfter,
    /// Mean absolute error.
    pub mae: BeforeAfter,
    /// Fit %, `100·(1 − ‖y − ŷ‖/‖y − ȳ‖)`.
    pub fit_percent: BeforeAfter,
}

/// Before/after RMSE of the signals of `e`'s own model that `e` changes, with `e`'s parameter
/// at `value` (all others nominal, as a first finding is fitted), measured against
/// `reference` instead of the recording: one column per log row for each signal it names
/// (the others are left out), on the rows and train/held-out parts the recording's
/// comparison uses. The models run as the diagnosis runs them (built from the recording,
/// on its inputs); only what their outputs are scored against changes.
///
/// With a generator's noise-free truth of the compared signals as `reference`, a finding's
/// held-out improvement can be read apart from the sensor noise that bounds the recording's
/// own figure; the diagnosis itself never calls it. With the recorded columns as `reference` and a first finding's
/// value, its entries for the signals in that finding's own-model `fit` equal them bit for
/// bit (tests/it/diagnose_explain.rs); it may list more of the own model's signals (those
/// the screen's probe did not count as changed).
///
/// # Errors
/// [`ExplainError`] when a model fails at the nominal parameters or at `value`.
pub fn fits_against(
    problem: &Problem<'_>,
    e: Effect,
    value: f64,
    reference: &BTreeMap<String, Vec<f64>>,
) -> Result<BTreeMap<String, SignalFit>, ExplainError> {
    Ok(match own_model_at(problem, None, e, value)? {
        Some(m) => signal_fits(problem, &m.base.outputs, &m.at.outputs, Some(reference)).0,
        None => BTreeMap::new(),
    })
}

/// Per-signal fits of the signals whose simulation changed from `before` to `after`, against
/// the recording — or, with `reference`, against those columns instead (one value per log
/// row, on the channel's own rows and parts) for the signals it names, the others left out.
pub(super) fn signal_fits(
    problem: &Problem<'_>,
    before: &[Arc<Vec<RowColumn>>],
    after: &[Arc<Vec<RowColumn>>],
    reference: Option<&BTreeMap<String, Vec<f64>>>,
) -> (BTreeMap<String, SignalFit>, BTreeMap<String, SignalMetrics>) {
    let mut fit = BTreeMap::new();
    let mut met = BTreeMap::new();
    for (k, view) in problem.views().iter().enumerate() {
        for (slot, &c) in view.chans.iter().enumerate() {
            let (yb, ya) = (&before[k][slot], &after[k][slot]);
            if yb == ya {
                continue;
            }
            let recorded = &problem.channels()[c];
            let swapped;
            let ch = match reference {
                None => recorded,
                Some(r) => match r.get(&recorded.name) {
                    Some(values) if values.len() == recorded.measured.len() => {
                        swapped = super::problem::Channel {
                            measured: RowColumn::dense(values.clone()),
                            ..recorded.clone()
                        };
                        &swapped
                    }
                    _ => continue,
                },
            };
            let [tb, ta, hb, ha] = [
                metrics(ch, yb, Part::Train),
                metrics(ch, ya, Part::Train),
                metrics(ch, yb, Part::Heldout),
                metrics(ch, ya, Part::Heldout),
            ];
            let ba = |f: fn(&super::problem::Metrics) -> f64| BeforeAfter {
                train_before: f(&tb),
                train_after: f(&ta),
                heldout_before: f(&hb),
                heldout_after: f(&ha),
            };
            fit.insert(
                ch.name.clone(),
                SignalFit {
                    train_before: tb.rmse,
                    train_after: ta.rmse,
                    heldout_before: hb.rmse,
                    heldout_after: ha.rmse,
                    metric: "rmse",
                },
            );
            met.insert(
                ch.name.clone(),
                SignalMetrics {
                    unit: ch.unit,
                    rmse: ba(|m| m.rmse),
                    mae: ba(|m| m.mae),
                    fit_percent: ba(|m| m.fit_percent),
                },
            );
        }
    }
    (fit, met)
}
