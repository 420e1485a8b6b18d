//! Settings and result of step 3 of the diagnosis, explain (docs/diagnosis/method.md): the
//! configuration ([`ExplainConfig`]), the greedy rounds ([`Round`]), the accepted findings
//! ([`Finding`], with the [`Evidence`] the acceptance rule saw), the estimates consistent with
//! the vehicle file ([`ConsistentEstimate`]), the whole [`Explanation`], and the [`verdict`]
//! it gives with step 2's significance test.
//!
//! Parameter values and intervals are in the catalogue's SI units ([`ParameterEstimate::unit`]);
//! the output contract these records feed is docs/diagnosis/contract.md.

use super::acceptance::{AcceptanceRule, CandidateFit, ModelScore};
use super::extended::Theta;
use super::fit::Screen;
use super::linearised::LinearisedEstimate;
use super::problem::{Split, Whiteness};
use super::signal_fits::{SignalFit, SignalMetrics};
use crate::model::catalogue::Domain;
use crate::model::catalogue::{ModelForm, Tolerance};
use crate::model::tolerance::Tolerances;
use serde::Serialize;
use std::collections::BTreeMap;

/// Most findings (greedy rounds that accept).
pub const MAX_FINDINGS: usize = 3;
/// Most greedy rounds that end in an estimate consistent with the vehicle file (rule 4)
/// rather than a finding: such a round sets the parameter to its estimate and searches the
/// remaining residual again.
pub const MAX_CONSISTENT_ROUNDS: usize = 2;

/// Settings of the explain step.
#[derive(Debug, Clone, PartialEq)]
pub struct ExplainConfig {
    /// Noise floor per signal (step 2), signal unit: the weights `σ_c`. Signals without one are
    /// weighted by their train RMS residual.
    pub noise_floor: Option<BTreeMap<String, f64>>,
    /// Most findings (greedy rounds), at most [`MAX_FINDINGS`] by default.
    pub max_findings: usize,
    /// Tolerances of the vehicle file's values: an effect is named only when its parameter's
    /// interval lies outside its band ([`super::acceptance`], rule 4).
    pub tolerances: Tolerances,
    /// Parameters measured outside the models (the slope sensor's offset against the
    /// altitude, [`super::altitude_offset`]; the torque channel's offset on the free engine,
    /// [`super::idle_torque`]): taken before the first round and not fitted.
    pub measured: Vec<Measured>,
}

/// A catalogue parameter measured from a recorded reference rather than fitted: the explain
/// step sets it before the first round, keeps it out of every round's screen, and names its
/// effect when the interval lies outside the vehicle file's own tolerance (no model-form
/// allowance: the measurement does not go through the models).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured {
    /// The effect whose parameter it is.
    pub effect: crate::model::catalogue::Effect,
    /// Value and 95 % interval, in the catalogue's unit.
    pub estimate: ParameterEstimate,
    /// What it was measured on: `"altitude"` (the slope sensor's offset,
    /// [`super::altitude_offset`]) or `"free engine"` (the torque channel's offset,
    /// [`super::idle_torque`]).
    pub source: &'static str,
}

impl Default for ExplainConfig {
    /// No noise floor, [`MAX_FINDINGS`], the default tolerances.
    fn default() -> Self {
        Self {
            noise_floor: None,
            max_findings: MAX_FINDINGS,
            tolerances: Tolerances::default(),
            measured: Vec::new(),
        }
    }
}

/// A fitted parameter whose interval overlaps the vehicle file's tolerance band: an estimate
/// consistent with the file, not a finding ([`super::acceptance`], rule 4).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConsistentEstimate {
    /// Catalogue id of the effect whose parameter it is.
    pub effect: &'static str,
    /// The estimate.
    pub estimate: ParameterEstimate,
    /// The vehicle file's value.
    pub nominal: f64,
    /// The tolerance band, lower end.
    pub band_low: f64,
    /// The tolerance band, upper end.
    pub band_high: f64,
    /// Whether the band is the file's own (`[tolerance]`) rather than the default.
    pub band_from_file: bool,
    /// The greedy round it was fitted in.
    pub round: usize,
    /// Effects outside their own bands that explain the data alike (as a finding's
    /// `ambiguous_with`): with the recorded signals, "within the file's tolerance" and these
    /// cannot be told apart, and the within-tolerance reading is not overruled.
    pub ambiguous_with: Vec<&'static str>,
    /// The vehicle file's own tolerance of the parameter (the band adds the model-form
    /// allowance to it, except for a measured parameter).
    #[serde(skip)]
    pub file_tolerance: Tolerance,
    /// The catalogue's model-form allowance the band was widened by, for this vehicle file
    /// ([`crate::model::tolerance::Tolerances::model_form`]).
    #[serde(skip)]
    pub model_form: ModelForm,
    /// What the parameter was measured against when it was not fitted ([`Measured`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_by: Option<&'static str>,
}

/// One greedy round.
#[derive(Debug, Clone, Serialize)]
pub struct Round {
    /// The screen.
    pub screen: Screen,
    /// Fully fitted candidates, in screen order.
    pub fits: Vec<CandidateFit>,
    /// The accepted effect, if any.
    pub accepted: Option<&'static str>,
    /// The effect whose within-tolerance estimate the round took instead (rule 4), if any.
    pub consistent: Option<&'static str>,
}

/// A fitted parameter (docs/diagnosis/contract.md).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ParameterEstimate {
    /// Value.
    pub value: f64,
    /// 95 % interval, lower end.
    pub ci_low: f64,
    /// 95 % interval, upper end.
    pub ci_high: f64,
    /// SI unit.
    pub unit: &'static str,
}

/// What the acceptance rule saw for a finding.
#[derive(Debug, Clone, Serialize)]
pub struct Evidence {
    /// Greedy round (0 first).
    pub round: usize,
    /// Model.
    pub domain: Domain,
    /// The parameter's nominal value.
    pub nominal: f64,
    /// The parameter's value before the round.
    pub start: f64,
    /// Weighted RMSE per model the effect changes.
    pub models: Vec<ModelScore>,
    /// Relative fall of the held-out weighted RMSE of the views of the effect's own model that
    /// rule 1 scored (every row for a switch).
    pub heldout_gain: f64,
    /// Held-out weighted mean square explained, summed over the models.
    pub explained: f64,
    /// Whiteness before / after of the views rule 2 scores, on the held-out part (both parts
    /// for a switch).
    pub whiteness_before: Whiteness,
    /// See `whiteness_before`.
    pub whiteness_after: Whiteness,
    /// Effective independent train samples of the interval.
    pub n_eff: f64,
    /// Deviance threshold of the interval.
    pub deviance_threshold: f64,
    /// Likelihood-ratio statistic of the value before, train part.
    pub deviance_at_start: f64,
    /// The same on the held-out part, for a switch ([`CandidateFit::deviance_heldout_at_start`]).
    pub deviance_heldout_at_start: Option<f64>,
    /// Correlation of each ambiguous effect's correction with this one's.
    pub ambiguity_correlation: BTreeMap<String, f64>,
    /// Simulations of the fit and interval.
    pub evaluations: usize,
    /// What the parameter was measured against when it was not fitted ([`Measured`]); the
    /// figures above are then those of the measured value, and the finding stands on the
    /// measurement's interval alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured_by: Option<&'static str>,
}

/// One explained effect (docs/diagnosis/contract.md: `effect`, `ambiguous_with`,
/// `parameters`, `fit`; the report adds the `sentence`; `metrics` and `evidence` add MAE, fit % and the
/// acceptance statistics).
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// Catalogue id.
    pub effect: &'static str,
    /// Effects explaining the data alike (not isolable with the recorded signals).
    pub ambiguous_with: Vec<&'static str>,
    /// Fitted parameter by catalogue name.
    pub parameters: BTreeMap<String, ParameterEstimate>,
    /// Before/after RMSE per signal the finding changes.
    pub fit: BTreeMap<String, SignalFit>,
    /// RMSE, MAE and fit % per signal the finding changes.
    pub metrics: BTreeMap<String, SignalMetrics>,
    /// Acceptance statistics.
    pub evidence: Evidence,
}

/// The explain step's result.
#[derive(Debug, Clone, Serialize)]
pub struct Explanation {
    /// The split used.
    pub split: Split,
    /// Models compared.
    pub domains: Vec<Domain>,
    /// Why a model was left out.
    pub left_out: Vec<String>,
    /// The acceptance rule.
    pub rule: AcceptanceRule,
    /// Greedy rounds (screens, fits, acceptance).
    pub rounds: Vec<Round>,
    /// Accepted findings, in acceptance order.
    pub findings: Vec<Finding>,
    /// Fitted parameters that passed rules 1 to 3 with an interval overlapping the vehicle
    /// file's tolerance band, in the order they were met.
    pub consistent: Vec<ConsistentEstimate>,
    /// Every parameter the drive informs, linearised from the first round's screen
    /// ([`super::linearised`]).
    pub linearised: Vec<LinearisedEstimate>,
    /// Final parameters (nominal with the findings' values).
    #[serde(skip)]
    pub theta: Theta,
}

/// The drive-level verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A significant mismatch, explained by accepted findings.
    Explained,
    /// Nothing above the noise floor.
    NoSignificantMismatch,
    /// A significant mismatch that no catalogue effect explains.
    Unexplained,
}

impl Verdict {
    /// The contract's spelling.
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Explained => "explained",
            Verdict::NoSignificantMismatch => "no_significant_mismatch",
            Verdict::Unexplained => "unexplained",
        }
    }
}

/// The verdict from the findings, the estimates consistent with the vehicle file and step 2's
/// `significant_mismatch`: any accepted finding → `explained` (the acceptance rule is a
/// significance test of its own, on held-out data, and may see a small spread-out effect a
/// per-window test does not); otherwise `unexplained` when the mismatch is significant and no
/// fitted estimate within the file's tolerances explains it (passing rules 1 to 3; a measured
/// one, [`Measured`], is not fitted to the residual and does not count), or when
/// `channel_mismatch` (a stretch located by one of the tests on the recorded channels alone,
/// which parameters constant over the drive cannot produce whatever their values, so no
/// estimate explains it); else `no_significant_mismatch`: nothing is wrong beyond the vehicle
/// file's tolerances.
pub fn verdict(
    findings: &[Finding],
    consistent: &[ConsistentEstimate],
    significant_mismatch: bool,
    channel_mismatch: bool,
) -> Verdict {
    // a measured parameter is not a fit to the located residual: it explains nothing of it
    let fitted = consistent.iter().any(|c| c.measured_by.is_none());
    if !findings.is_empty() {
        Verdict::Explained
    } else if channel_mismatch || (significant_mismatch && !fitted) {
        Verdict::Unexplained
    } else {
        Verdict::NoSignificantMismatch
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdict_combines_findings_and_significance() {
        assert_eq!(
            verdict(&[], &[], false, false),
            Verdict::NoSignificantMismatch
        );
        assert_eq!(verdict(&[], &[], true, false), Verdict::Unexplained);
        let within = ConsistentEstimate {
            effect: "aero_drag",
            estimate: ParameterEstimate {
                value: 5.6,
                ci_low: 5.5,
                ci_high: 5.7,
                unit: "m2",
            },
            nominal: 5.5,
            band_low: 5.225,
            band_high: 5.775,
            band_from_file: false,
            round: 0,
            ambiguous_with: Vec::new(),
            file_tolerance: Tolerance::Relative(0.05),
            model_form: ModelForm::NONE,
            measured_by: None,
        };
        assert_eq!(
            verdict(&[], std::slice::from_ref(&within), true, false),
            Verdict::NoSignificantMismatch
        );
        // a stretch from a channel test is not what an estimate within the tolerances explains
        assert_eq!(
            verdict(&[], std::slice::from_ref(&within), true, true),
            Verdict::Unexplained
        );
        assert_eq!(
            serde_json::to_string(&Verdict::NoSignificantMismatch).unwrap(),
            "\"no_significant_mismatch\""
        );
    }
}
