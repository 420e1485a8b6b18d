//! Step 3 of the diagnosis, explain (docs/diagnosis/method.md): which catalogue effect the nominal
//! model left out, fitted, scored on held-out data, accepted only by a rule fixed in advance — or
//! nothing.
//!
//! # Method
//! 1. **Split** the recording in time: alternating train / held-out blocks of whole 20 s
//!    windows ([`super::problem`] says why this and not "the last 30 %").
//! 2. **Screen** every applicable effect by a finite difference of the extended model with a
//!    physically sized step and a least-squares fit of the train residual on its sensitivity,
//!    alone and jointly ([`super::fit`]); candidates are those whose single-effect fit removes
//!    more than [`super::fit::SCREEN_MIN_REDUCTION`] (10 %) of the weighted train SSE (a
//!    switch: any of every row's), ranked, at most [`super::fit::MAX_FULL_FITS`] (6).
//! 3. **Fit** each candidate's parameter on the train part by Levenberg–Marquardt on the
//!    re-simulated extended model (mode-aware: the hybrid simulation switches clutch modes and
//!    gears itself), within its physical domain, in parallel across candidates; 95 % interval
//!    by profile likelihood with an effective number of independent samples
//!    ([`super::fit`]).
//! 4. **Accept** by [`AcceptanceRule::FIXED`] (below), **isolate** (ambiguity sets), and
//!    **repeat** greedily on the remaining residual with the accepted parameter fixed, until no
//!    candidate passes or [`MAX_FINDINGS`] (3) are accepted.
//!
//! # Which signals
//! An effect is fitted on the outputs of every model it changes: its own model, and for the
//! longitudinal effects that also reach the axle model's inputs (mass, the slope and torque
//! sensor effects) the bellow pressures as well — found from the screen's probe (outputs that
//! change), not assumed. The unit is a *view* of a model ([`super::problem::View`]): the
//! longitudinal model's speeds, its shuffle modes (one sample per clutch engagement,
//! [`super::modal_channel`]), its torque reversals (the engine's speed against the wheels,
//! one sample per reversal, [`super::reversal_channel`]), the engine speed while the clutch
//! is actuated (scored for `clutch_slip` and `signal_delay` alone,
//! [`super::problem::ViewKind::only_for`]), the
//! axle model's bellow pressures.
//! An effect is fitted and scored on the views it changes, so the shuffle modes count for the
//! shaft stiffness and the mass (which move them) and the reversals for the lash, the
//! stiffness and the torque signal's delay, and neither dilutes the speeds' figures for an
//! effect that leaves them alone (drag, rolling resistance, …). The cost is the mean over
//! those views of each view's weighted mean square; within a view every signal counts alike
//! (weights `σ_c`: step 2's noise floor when given, else the signal's train RMS residual at
//! the round's parameters; an engagement's own standard error for the modes, a reversal's
//! noise and floor for the reversals, each actuated row's own null variance for the clutch;
//! [`super::problem`]).
//!
//! # Acceptance rule (fixed in advance; docs/diagnosis/method.md)
//! A fitted candidate is accepted only when all four hold:
//! 1. **held-out error falls**: the held-out weighted RMSE of the signals of the effect's own
//!    model falls by at least [`MIN_HELDOUT_GAIN`] (25 %) from the round's parameters (over
//!    the views the rule scores, below: their weighted mean squares averaged);
//! 2. **whiteness improves**: the held-out residual's non-white power on the same views
//!    ([`super::problem::whiteness`]: the root of the Ljung–Box statistic per sample `Q/n` of
//!    the non-centred autocorrelation at lags 0.1…2 s, times the residual's weighted mean
//!    square — the RMS of the weighted autocovariance at those lags) is lower after the fit
//!    than before;
//! 3. **the interval excludes "no effect"**: the 95 % profile-likelihood interval of the
//!    parameter does not contain the round's value (the nominal, "no effect") — tested first
//!    as the likelihood-ratio statistic `N_eff ln(J_before/J_after)` against the interval's
//!    threshold ([`super::fit::deviance_threshold`]: χ²₁(0.95) = 3.84, or t²_{B−1}(0.975) when
//!    the between-block sample count binds), then with the interval itself.
//!    For a **switch** (`slope_quantization`: the recorded slope or its reconstruction at the
//!    lattice step read off the recording, [`super::fit`]) nothing is fitted, so the train
//!    part holds no more right to the test than the held-out part: the statistic is summed
//!    over both parts (`deviance_at_start` + `deviance_heldout_at_start`, each part with its
//!    own `N_eff` and its own profiled variance, so their log-likelihoods add). Its size
//!    stays within the test's: the reconstruction depends on the recorded slope (an input)
//!    alone, so its alternative is fixed before the outputs are looked at, and for a fixed
//!    alternative the Gaussian log-likelihood ratio (known variance) `2 ln Λ` is `N(−D, 4D)`
//!    under "no effect" (`D` the alternative's standardised squared distance), whose chance
//!    of exceeding 3.84 is largest at `D = 3.84`: `P(Z > 1.96)` = 2.5 %. The screen, which
//!    looks at the same rows first (a switch is screened on every row, [`super::fit`]), can
//!    only make passing rarer: for one fixed alternative the chance that the screen selects
//!    it and the test passes is at most the test's own. Tested on the train part alone, as a
//!    fitted parameter is, a cure that passes rules 1 and 2 can fail where the held-out
//!    blocks hold more of the sensor's rounding than the train blocks (train statistics
//!    0.7–3.4 against 3.84 on such proof drives). For the same reason a
//!    switch's rules 1 and 2 score every row too (each part's weighted mean square summed,
//!    each part's non-white power averaged): with nothing fitted, the train rows are as much
//!    held out as the held-out ones, and a whole-percent sensor's rounding shows where the
//!    road crosses its steps, which on a 5 km drive may be mostly in one part (a proof drive
//!    at the truth: the speeds' mean square 0.682 → 0.132 on the train blocks, 0.218 → 0.149
//!    on the held-out ones).
//!
//! 4. **the interval lies outside the vehicle file's tolerance**: the 95 % interval does not
//!    overlap the band `θ₀ ± w` around the file's value ([`crate::model::tolerance`]: the
//!    file's `[tolerance]` entry, else the default of the parameter's kind). A vehicle file's
//!    values are nominal: a healthy truck's drag area or shaft stiffness is never exactly the
//!    file's, and a long drive fits it tightly enough to exclude the file's value. When the
//!    best candidate that passes rules 1 to 3 has an interval inside or across its band, the
//!    round ends in an estimate consistent with the file ([`ConsistentEstimate`], with the
//!    candidates that explain the data alike as its ambiguity set), not a finding: the
//!    parameter takes its estimate, and the next round searches the remaining residual (at
//!    most [`MAX_CONSISTENT_ROUNDS`] such rounds). A lesser candidate is not named in its
//!    place: a reading within the file's tolerance explains the data better. A switch has no
//!    band.
//!
//! Why 25 %: a catalogue effect at fleet magnitudes that the recorded signals can see removes
//! most of the mismatch it causes (with its truth value the extended model reproduces the
//! drive to the clean drive's floor, `tests/it/diagnose_extended.rs`), whereas a wrong effect
//! fitted to a clean drive's remaining mismatch (the whole-percent slope sensor's drift and
//! bias, sensor noise) gains little on held-out blocks. On 16 clean drives, measured before
//! the rule was fixed (city-se 5 km and highway-se 10 km, seeds 1–8, the test suite's
//! `explain_table`), the largest held-out gains of fitted candidates are 0.38 (one highway
//! drive), 0.21, 0.18, 0.14 and below 0.13 on the others; 25 % lies above all but the first.
//! That one drive's mismatch is a real constant force of about 0.1 % of m·g — the partly
//! dithered whole-percent slope sensor's mean quantisation error on that road — which no
//! held-out test can tell from a 0.07° mounting angle or 18 % less rolling resistance: a
//! known false positive, reported, not tuned away.
//!
//! Why the non-white power and not `Q/n` alone: `Q/n` is normalised, and rises whenever a fit
//! removes a fast structured error and leaves a smaller but slower one (measured on
//! `signal_delay` drives: `Q/n` 0.37 → 0.62 while the held-out RMSE falls 57 %); the non-white
//! power falls when less of the residual is structure, and stays 0 for white noise of any
//! level.
//!
//! Why `√(Q/n)·MS` and not `(Q/n)·MS`: with `c_k` the residual's autocovariance, `(Q/n)·MS`
//! is `mean_k c_k² / c_0`, which *grows* when a fit removes an error that is white at the
//! lags (it lowers `c_0` and leaves every `c_k`), whereas `√(Q/n)·MS = √(mean_k c_k²)` is the
//! autocovariance at the lags alone: white noise of any level leaves it as it is, and only
//! less structure lowers it. On a proof drive with a hidden `signal_delay`
//! (`research/studies/whiteness_views.rs`), the fit at the true delay lowers the speeds'
//! held-out mean square 1.94 → 1.32 and the reversals' 61.5 → 0.81, yet `(Q/n)·MS` rises on
//! the speeds (0.47 → 0.60) — the delay's fast error is gone, the sensors' slow drift left —
//! so a rule 2 on `(Q/n)·MS` would reject the truth itself.
//!
//! # Which views the rule scores
//! Rules 1 and 2 score the views of the effect's own model that the fitted change moves by a
//! weighted mean square of at least [`RULE_MIN_CHANGE_MS`] (an RMS change of a tenth of
//! their weights `σ_c`; all the own model's changed views when it moves none that much). A
//! view the fit barely moves cannot fall by itself, and averaged in it only dilutes the
//! figure of the views that carry the effect: the slope cure moves the torque reversals by
//! 1.3·10⁻⁴–4.7·10⁻³ (the screen's threshold of a change is 10⁻⁴, [`super::fit`]), whose
//! mean square is 0.02–5, so on a slope-cure drive of the proof at the truth the rule's gain
//! is 0.01 with the reversals averaged in (held-out 2.404 → 2.410) and 0.17 on the speeds
//! alone (0.162 → 0.112). At the truth on the 336 effect drives of the proof's seven seeds
//! (`fleetdyn prove --seed S`, drawn driving; `research/studies/oracle_folds.rs` prints each
//! view's change), 35 of the 508 changed (effect, view) pairs move less than 10⁻²: the
//! reversals under the slope cure (13 of 13, at most 4.7·10⁻³) and under the mass (15 of
//! 18) and the torque offset (2 of 6), the speeds under three worn clutches that hardly
//! slip on the road, one mass drive's shuffle modes (6.4·10⁻³) and one stiffness drive's
//! reversals (1.6·10⁻³, where their mean square is 0.004). Every other pair moves 0.07 or
//! more, most of them by far more (the lash the reversals by 7.7–180, the clutch the
//! actuated engine speed by 0.17–2400). The fit and rule 3 still use every view the effect
//! changes.
//!
//! # Ranking and isolability
//! Passing candidates are ranked by the held-out mean square they explain summed over every
//! model in use (`Σ_m 1 − MS_after/MS_before`), so effects fitted on different signal sets
//! compete on the same data. The best is reported; other passing candidates that explain at
//! least [`AMBIGUITY_GAIN_RATIO`] (90 %) as much and whose fitted correction (simulated
//! outputs after minus before, weighted, over all valid rows of every model) correlates with
//! the best's by at least [`AMBIGUITY_MIN_CORRELATION`] (0.9) in absolute value are listed in
//! `ambiguous_with` instead of being guessed between — with the recorded signals they explain
//! the data alike — and are not tried again in later rounds.
//!
//! # Verdict
//! [`verdict`] combines the findings with step 2's significance test.

use super::extended::Theta;
use super::fit::{
    applicable, deviance_threshold, fit_effect, fit_spec, profile_interval, screen, Eval,
    Evaluator, Screen, ScreenEntry, CHI2_1_95, MAX_FULL_FITS,
};
use super::problem::{metrics, ExplainError, Part, Problem, Split, ViewKind, Whiteness};
use crate::model::catalogue::{Domain, Effect};
use crate::model::tolerance::Tolerances;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;

/// Least relative fall of the held-out weighted RMSE for acceptance (module documentation).
pub const MIN_HELDOUT_GAIN: f64 = 0.25;
/// Ambiguity: held-out gain at least this fraction of the best's.
pub const AMBIGUITY_GAIN_RATIO: f64 = 0.9;
/// Ambiguity: |correlation| of the fitted corrections at least this.
pub const AMBIGUITY_MIN_CORRELATION: f64 = 0.9;
/// Most findings (greedy rounds that accept).
pub const MAX_FINDINGS: usize = 3;
/// Most greedy rounds that end in an estimate consistent with the vehicle file (rule 4)
/// rather than a finding: such a round sets the parameter to its estimate and searches the
/// remaining residual again.
pub const MAX_CONSISTENT_ROUNDS: usize = 2;
/// Least weighted mean square of the change a fitted effect makes to one of its own model's
/// views for that view to be scored by rules 1 and 2: an RMS change of a tenth of the view's
/// weights `σ_c` (module documentation, "Which views the rule scores").
pub const RULE_MIN_CHANGE_MS: f64 = 1e-2;

/// The acceptance rule (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AcceptanceRule {
    /// Least relative fall of the held-out weighted RMSE.
    pub min_heldout_gain: f64,
    /// The held-out whiteness statistic must fall.
    pub whiteness_must_improve: bool,
    /// Deviance threshold of the interval and the likelihood-ratio test when the residual's
    /// autocorrelation sets the effective sample count (χ²₁, 95 %); when the between-block
    /// count binds, `t²_{B−1}(0.975)` ([`super::fit::deviance_threshold`]).
    pub chi2_threshold: f64,
}

impl AcceptanceRule {
    /// The rule fixed in advance.
    pub const FIXED: AcceptanceRule = AcceptanceRule {
        min_heldout_gain: MIN_HELDOUT_GAIN,
        whiteness_must_improve: true,
        chi2_threshold: CHI2_1_95,
    };
}

/// Settings of the explain step.
#[derive(Debug, Clone, PartialEq)]
pub struct ExplainConfig {
    /// Noise floor per signal (step 2), signal unit: the weights `σ_c`. Signals without one are
    /// weighted by their train RMS residual.
    pub noise_floor: Option<BTreeMap<String, f64>>,
    /// Most findings (greedy rounds), at most [`MAX_FINDINGS`] by default.
    pub max_findings: usize,
    /// Tolerances of the vehicle file's values: an effect is named only when its parameter's
    /// interval lies outside its band (module documentation, rule 4).
    pub tolerances: Tolerances,
}

impl Default for ExplainConfig {
    /// No noise floor, [`MAX_FINDINGS`], the default tolerances.
    fn default() -> Self {
        Self {
            noise_floor: None,
            max_findings: MAX_FINDINGS,
            tolerances: Tolerances::default(),
        }
    }
}

/// A fitted parameter whose interval overlaps the vehicle file's tolerance band: an estimate
/// consistent with the file, not a finding (module documentation, rule 4).
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
    /// Plain words.
    pub sentence: String,
}

/// Weighted RMSE of one model's signals before and after a fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ModelScore {
    /// Model.
    pub domain: Domain,
    /// Which of the model's views ([`super::problem::ViewKind`]).
    pub view: ViewKind,
    /// Scored by rules 1 and 2 (module documentation, "Which views the rule scores").
    pub scored: bool,
    /// Weighted train RMSE before.
    pub train_before: f64,
    /// Weighted train RMSE after.
    pub train_after: f64,
    /// Weighted held-out RMSE before.
    pub heldout_before: f64,
    /// Weighted held-out RMSE after.
    pub heldout_after: f64,
}

/// One fully fitted candidate of a round, with the acceptance tests.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateFit {
    /// Catalogue id.
    pub effect: &'static str,
    /// The model the effect extends.
    pub domain: Domain,
    /// Parameter value before (the round's).
    pub start: f64,
    /// Fitted value.
    pub value: f64,
    /// Weighted RMSE per model whose outputs the effect changes (fitted on all of them).
    pub models: Vec<ModelScore>,
    /// Relative fall of the held-out weighted RMSE of the views of the effect's own model that
    /// rule 1 scores (every row for a switch; module documentation).
    pub heldout_gain: f64,
    /// Held-out weighted mean square explained, summed over every model in use
    /// (`Σ_m 1 − MS_after/MS_before`): the ranking of candidates.
    pub explained: f64,
    /// Whiteness before / after of the views rule 2 scores, on the held-out part (both parts
    /// for a switch).
    pub whiteness_before: Whiteness,
    /// See `whiteness_before`.
    pub whiteness_after: Whiteness,
    /// Effective independent train samples (the smaller of the two counts).
    pub n_eff: f64,
    /// Effective samples from the residual's autocorrelation time.
    pub n_eff_autocorrelation: f64,
    /// Train blocks (clusters of the between-block count).
    pub train_blocks: usize,
    /// Deviance threshold of the interval and the likelihood-ratio test.
    pub deviance_threshold: f64,
    /// Likelihood-ratio statistic of the round's value on the train part,
    /// `N_eff ln(J_before/J_after)`.
    pub deviance_at_start: f64,
    /// The same statistic on the held-out part, for a switch (nothing fitted), whose rule 3
    /// tests the sum of both parts; `None` for a fitted parameter.
    pub deviance_heldout_at_start: Option<f64>,
    /// Simulations of the fit.
    pub evaluations: usize,
    /// Rule 1 holds.
    pub passes_heldout: bool,
    /// Rule 2 holds.
    pub passes_whiteness: bool,
    /// Rule 3 (likelihood-ratio form) holds.
    pub passes_interval: bool,
    #[serde(skip)]
    eval: Option<Eval>,
    #[serde(skip)]
    curvature: f64,
    #[serde(skip)]
    active: Vec<bool>,
}

impl CandidateFit {
    /// All three rules hold.
    pub fn passes(&self) -> bool {
        self.passes_heldout && self.passes_whiteness && self.passes_interval
    }
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
}

/// One explained effect (docs/diagnosis/contract.md: `effect`, `ambiguous_with`,
/// `sentence`, `parameters`, `fit`; `metrics` and `evidence` add MAE, fit % and the
/// acceptance statistics).
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// Catalogue id.
    pub effect: &'static str,
    /// Effects explaining the data alike (not isolable with the recorded signals).
    pub ambiguous_with: Vec<&'static str>,
    /// One plain sentence with the parameter and its unit.
    pub sentence: String,
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
    /// Final parameters (nominal with the findings' values).
    #[serde(skip)]
    pub theta: Theta,
}

/// Diagnosis verdict (docs/diagnosis/contract.md), the contract's type.
pub use super::contract::Verdict;

/// The verdict from the findings, the estimates consistent with the vehicle file and step 2's
/// `significant_mismatch`: any accepted finding → `explained` (the acceptance rule is a
/// significance test of its own, on held-out data, and may see a small spread-out effect a
/// per-window test does not); otherwise `unexplained` when the mismatch is significant and no
/// estimate within the file's tolerances explains it (passing rules 1 to 3), else
/// `no_significant_mismatch`: nothing is wrong beyond the vehicle file's tolerances.
pub fn verdict(
    findings: &[Finding],
    consistent: &[ConsistentEstimate],
    significant_mismatch: bool,
) -> Verdict {
    if !findings.is_empty() {
        Verdict::Explained
    } else if significant_mismatch && consistent.is_empty() {
        Verdict::Unexplained
    } else {
        Verdict::NoSignificantMismatch
    }
}

/// The acceptance rule's data tests (rules 1 and 2 of [`AcceptanceRule::FIXED`]) at a given
/// parameter value, without a fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RulesAt {
    /// Relative fall of the held-out weighted RMSE of the effect's own model from the nominal
    /// parameters to the value (rule 1's quantity; every row for a switch).
    pub heldout_gain: f64,
    /// The views rules 1 and 2 scored (module documentation, "Which views the rule scores").
    pub views: Vec<ViewKind>,
    /// Held-out non-white power of the residual of the views scored at the nominal
    /// parameters (both parts for a switch).
    pub nonwhite_before: f64,
    /// The same at the value.
    pub nonwhite_after: f64,
    /// Rule 1 holds at the value.
    pub passes_heldout: bool,
    /// Rule 2 holds at the value.
    pub passes_whiteness: bool,
}

impl RulesAt {
    /// Rules 1 and 2 both hold: a fit that found the value exactly would pass them.
    pub fn both_hold(&self) -> bool {
        self.passes_heldout && self.passes_whiteness
    }
}

/// Evaluates rules 1 and 2 of [`AcceptanceRule::FIXED`] with `e`'s parameter set to `value`
/// (all others nominal), weighted as the first round of [`explain`] weights (`noise_floor`):
/// the best any fit of `e` could do on the held-out blocks (a switch: every row) if it found
/// `value` exactly, on the views the rule would score at `value`. Rule 3 (the interval) needs
/// a fit and is not evaluated. Only the effect's own model is simulated (the explain step also
/// fits on the other models an effect reaches; rule 1 and this evaluation score the own model
/// alone). `None` when the effect's model is not in use. With a known true value, this tells
/// an effect the recorded signals cannot show under the fixed rule from a miss of the search.
///
/// # Errors
/// [`ExplainError`] when a model fails at the nominal parameters or at `value`.
pub fn rules_at(
    problem: &Problem<'_>,
    noise_floor: Option<&BTreeMap<String, f64>>,
    e: Effect,
    value: f64,
) -> Result<Option<RulesAt>, ExplainError> {
    let Some(OwnModelAt { ev, own, base, at }) = own_model_at(problem, noise_floor, e, value)?
    else {
        return Ok(None);
    };
    // the own model's views the effect changes, as the screen's probe finds them
    let active: Vec<bool> = (0..ev.models.len())
        .map(|m| own[m] && ev.changed(m, &at, &base))
        .collect();
    let switch = fit_spec(e, problem.nominal().get(e), problem.slope_step()).switch;
    let RuleFigures {
        scored,
        gain,
        whiteness: (wb, wa),
    } = rule_figures(&ev, e, &active, &base, &at, switch);
    let rule = AcceptanceRule::FIXED;
    Ok(Some(RulesAt {
        heldout_gain: gain,
        views: (0..ev.models.len())
            .filter(|&m| scored[m])
            .map(|m| problem.views()[m].kind)
            .collect(),
        nonwhite_before: wb.nonwhite_power,
        nonwhite_after: wa.nonwhite_power,
        passes_heldout: gain >= rule.min_heldout_gain,
        passes_whiteness: !rule.whiteness_must_improve || wa.nonwhite_power < wb.nonwhite_power,
    }))
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

/// `e`'s own model at the nominal parameters and with `e` at `value` (the others nominal).
struct OwnModelAt<'p, 'a> {
    ev: Evaluator<'p, 'a>,
    /// The views of `e`'s own model that serve it.
    own: Vec<bool>,
    base: Eval,
    at: Eval,
}

/// [`OwnModelAt`] for `e` at `value`, weighted by `noise_floor`; `None` when no view of
/// `e`'s model is in use.
fn own_model_at<'p, 'a>(
    problem: &'p Problem<'a>,
    noise_floor: Option<&BTreeMap<String, f64>>,
    e: Effect,
    value: f64,
) -> Result<Option<OwnModelAt<'p, 'a>>, ExplainError> {
    let (ev, base) = Evaluator::at_nominal(problem, noise_floor);
    let own: Vec<bool> = ev
        .models
        .iter()
        .map(|v| v.domain == e.domain() && v.serves(e))
        .collect();
    if !own.contains(&true) {
        return Ok(None);
    }
    let at = ev.eval(&base, &own, e, value)?;
    Ok(Some(OwnModelAt { ev, own, base, at }))
}

/// The views rules 1 and 2 score for `e` between `before` and `after`: of `e`'s own model's
/// views in `active`, those the change from `before` to `after` moves by a weighted mean
/// square of at least [`RULE_MIN_CHANGE_MS`] ([`Evaluator::change_ms`]); when it moves none
/// of them that much, every own-model view in `active`.
fn scored_views(
    ev: &Evaluator<'_, '_>,
    e: Effect,
    active: &[bool],
    before: &Eval,
    after: &Eval,
) -> Vec<bool> {
    let own: Vec<bool> = (0..ev.models.len())
        .map(|m| active[m] && ev.models[m].domain == e.domain())
        .collect();
    let moved: Vec<bool> = (0..ev.models.len())
        .map(|m| own[m] && ev.change_ms(m, after, before) >= RULE_MIN_CHANGE_MS)
        .collect();
    if moved.contains(&true) {
        moved
    } else {
        own
    }
}

/// What rules 1 and 2 see between `before` and `after`.
struct RuleFigures {
    /// The views they score ([`scored_views`]).
    scored: Vec<bool>,
    /// Rule 1's figure ([`rule_gain`]).
    gain: f64,
    /// Rule 2's whiteness before and after, on the scored views and [`rule_parts`].
    whiteness: (Whiteness, Whiteness),
}

/// [`RuleFigures`] of `e` from `before` to `after` over its changed views `active`, a switch
/// scored on every row.
fn rule_figures(
    ev: &Evaluator<'_, '_>,
    e: Effect,
    active: &[bool],
    before: &Eval,
    after: &Eval,
    switch: bool,
) -> RuleFigures {
    let scored = scored_views(ev, e, active, before, after);
    let parts = rule_parts(switch);
    RuleFigures {
        gain: rule_gain(ev, &scored, before, after, switch),
        whiteness: (
            ev.whiteness_on(before, &scored, parts),
            ev.whiteness_on(after, &scored, parts),
        ),
        scored,
    }
}

/// The parts rules 1 and 2 score: the held-out part for a fitted parameter, every row for a
/// switch (module documentation, rule 3).
fn rule_parts(switch: bool) -> &'static [Part] {
    if switch {
        &[Part::Train, Part::Heldout]
    } else {
        &[Part::Heldout]
    }
}

/// Rule 1's figure: the relative fall from `before` to `after` of the weighted RMSE of the
/// views `scored` ([`scored_views`]; the mean of their weighted mean squares) on the held-out
/// part, or for a switch on both parts (each part's mean square, summed); 0 when `scored`
/// holds no view.
fn rule_gain(
    ev: &Evaluator<'_, '_>,
    scored: &[bool],
    before: &Eval,
    after: &Eval,
    switch: bool,
) -> f64 {
    let (mut b, mut a) = (0.0, 0.0);
    for m in (0..ev.models.len()).filter(|&m| scored[m]) {
        b += before.heldout[m];
        a += after.heldout[m];
        if switch {
            b += before.train[m];
            a += after.train[m];
        }
    }
    if b > 0.0 {
        1.0 - (a / b).sqrt()
    } else {
        0.0
    }
}

/// The passing candidates that explain the data alike with `fits[i]` (module documentation,
/// "Ranking and isolability"): at least [`AMBIGUITY_GAIN_RATIO`] of its explained share and a
/// fitted correction correlated with its own by at least [`AMBIGUITY_MIN_CORRELATION`] in
/// absolute value; each with that correlation, in `passing`'s order.
fn ambiguity_set(
    ev: &Evaluator<'_, '_>,
    base: &Eval,
    fits: &[CandidateFit],
    passing: &[usize],
    i: usize,
) -> Vec<(&'static str, f64)> {
    let f = &fits[i];
    let best = f.eval.as_ref().expect("fits keep their simulation");
    passing
        .iter()
        .filter(|&&j| {
            let floor = AMBIGUITY_GAIN_RATIO * f.explained;
            j != i && fits[j].explained.partial_cmp(&floor) != Some(std::cmp::Ordering::Less)
        })
        .filter_map(|&j| {
            let other = &fits[j];
            let c = ev.correction_correlation(
                base,
                best,
                other.eval.as_ref().expect("fits keep their simulation"),
            );
            (c.abs() >= AMBIGUITY_MIN_CORRELATION).then_some((other.effect, c))
        })
        .collect()
}

/// Explains `problem` (module documentation).
///
/// # Errors
/// [`ExplainError`] when a model fails at the round's parameters (a candidate's failure only
/// removes that candidate) or the configuration is out of its domain.
pub fn explain(problem: &Problem<'_>, cfg: &ExplainConfig) -> Result<Explanation, ExplainError> {
    use rayon::prelude::*;
    if cfg.max_findings > 16 {
        return Err(ExplainError::BadConfig {
            parameter: "max_findings",
            value: cfg.max_findings as f64,
            requirement: "at most the catalogue's 16 effects",
        });
    }
    let mut theta = *problem.nominal();
    let nominal = *problem.nominal();
    let dt_s = problem.row_spacing_s();
    let mut excluded: Vec<Effect> = Vec::new();
    let mut rounds = Vec::new();
    let mut findings: Vec<Finding> = Vec::new();
    let mut consistent: Vec<ConsistentEstimate> = Vec::new();
    let domains = problem.domains();
    let mut probes: BTreeMap<Effect, Arc<super::fit::Probe>> = BTreeMap::new();
    // outputs of every model at the round's parameters
    let mut bases: Vec<Arc<Vec<Vec<f64>>>> = problem
        .nominal_outputs()
        .iter()
        .map(|y| Arc::new(y.clone()))
        .collect();
    for round in 0..cfg.max_findings + MAX_CONSISTENT_ROUNDS {
        if findings.len() >= cfg.max_findings {
            break;
        }
        let ev = Evaluator::new(problem, theta, &bases, cfg.noise_floor.as_ref(), dt_s);
        let base = ev.eval_outputs(f64::NAN, bases.clone());
        let effects: Vec<Effect> = Effect::ALL
            .into_iter()
            .filter(|e| !excluded.contains(e) && applicable(problem, *e))
            .collect();
        let scr = screen(&ev, &base, &effects, &mut probes);
        // candidates ranked by the share of every model's train SSE they remove
        let mut cands: Vec<usize> = (0..scr.entries.len())
            .filter(|&k| scr.entries[k].candidate)
            .collect();
        cands.sort_by(|&a, &b| {
            scr.entries[b]
                .overall_reduction
                .total_cmp(&scr.entries[a].overall_reduction)
        });
        cands.truncate(MAX_FULL_FITS);
        let fits: Vec<CandidateFit> = cands
            .par_iter()
            .map(|&k| candidate_fit(&ev, &base, &scr.entries[k], theta))
            .collect();
        // passing, most explained first (ties: screen rank)
        let mut passing: Vec<usize> = (0..fits.len()).filter(|&i| fits[i].passes()).collect();
        passing.sort_by(|&a, &b| fits[b].explained.total_cmp(&fits[a].explained));
        let mut accepted = None;
        for &i in &passing {
            let f = &fits[i];
            let e = Effect::from_id(f.effect).expect("catalogue id");
            let best = f.eval.as_ref().expect("fits keep their simulation");
            let ci = profile_interval(
                &ev,
                e,
                &f.active,
                &base,
                best,
                f.curvature,
                f.n_eff,
                f.deviance_threshold,
            );
            let switch = fit_spec(e, nominal.get(e), None).switch;
            if !switch && ci.lo <= f.start && f.start <= ci.hi {
                continue; // the interval contradicts the likelihood-ratio test: not accepted
            }
            let (band_low, band_high) = cfg.tolerances.band(e, nominal.get(e));
            let inside = !switch && ci.lo <= band_high && ci.hi >= band_low;
            accepted = Some((i, ci, inside));
            break;
        }
        // rule 4: the best passing candidate inside the file's tolerance is an estimate, not a
        // finding; its value is taken and the remaining residual searched again
        if let Some(&(i, ref ci, true)) = accepted.as_ref() {
            let f = &fits[i];
            let e = Effect::from_id(f.effect).expect("catalogue id");
            let best = f.eval.as_ref().expect("fits keep their simulation");
            let (band_low, band_high) = cfg.tolerances.band(e, nominal.get(e));
            let estimate = ParameterEstimate {
                value: f.value,
                ci_low: ci.lo,
                ci_high: ci.hi,
                unit: e.unit(),
            };
            let ambiguous: Vec<&'static str> = ambiguity_set(&ev, &base, &fits, &passing, i)
                .into_iter()
                .map(|(a, _)| a)
                .collect();
            let mut sentence =
                consistent_sentence(e, nominal.get(e), &estimate, cfg.tolerances.of_effect(e));
            if !ambiguous.is_empty() {
                sentence.push_str(&format!(
                    "; the recorded signals cannot tell it from {}",
                    ambiguous.join(", ")
                ));
            }
            consistent.push(ConsistentEstimate {
                effect: e.id(),
                sentence,
                estimate,
                nominal: nominal.get(e),
                band_low,
                band_high,
                band_from_file: cfg.tolerances.is_given(e),
                round,
                ambiguous_with: ambiguous.clone(),
            });
            bases = best.outputs.clone();
            theta.set(e, f.value);
            excluded.push(e);
            for a in &ambiguous {
                excluded.push(Effect::from_id(a).expect("catalogue id"));
            }
            rounds.push(Round {
                screen: scr,
                fits,
                accepted: None,
                consistent: Some(e.id()),
            });
            continue;
        }
        let accepted = accepted.map(|(i, ci, _)| (i, ci));
        let Some((i, ci)) = accepted else {
            rounds.push(Round {
                screen: scr,
                fits,
                accepted: None,
                consistent: None,
            });
            break;
        };
        let f = &fits[i];
        let e = Effect::from_id(f.effect).expect("catalogue id");
        let best = f.eval.as_ref().expect("fits keep their simulation");
        let set = ambiguity_set(&ev, &base, &fits, &passing, i);
        let ambiguous: Vec<&'static str> = set.iter().map(|(a, _)| *a).collect();
        let corr: BTreeMap<String, f64> = set.iter().map(|(a, c)| (a.to_string(), *c)).collect();
        // accept: new parameters; the fit's simulation holds every model's new outputs
        let before = std::mem::replace(&mut bases, best.outputs.clone());
        theta.set(e, f.value);
        let (fit, met) = signal_fits(problem, &before, &bases, None);
        let evidence = Evidence {
            round,
            domain: f.domain,
            nominal: nominal.get(e),
            start: f.start,
            models: f.models.clone(),
            heldout_gain: f.heldout_gain,
            explained: f.explained,
            whiteness_before: f.whiteness_before,
            whiteness_after: f.whiteness_after,
            n_eff: f.n_eff,
            deviance_threshold: f.deviance_threshold,
            deviance_at_start: f.deviance_at_start,
            deviance_heldout_at_start: f.deviance_heldout_at_start,
            ambiguity_correlation: corr,
            evaluations: f.evaluations + ci.evaluations,
        };
        let est = ParameterEstimate {
            value: f.value,
            ci_low: ci.lo,
            ci_high: ci.hi,
            unit: e.unit(),
        };
        let sentence = sentence(e, nominal.get(e), &est, &met, &ambiguous);
        let mut parameters = BTreeMap::new();
        parameters.insert(e.parameter().to_string(), est);
        excluded.push(e);
        for a in &ambiguous {
            excluded.push(Effect::from_id(a).expect("catalogue id"));
        }
        findings.push(Finding {
            effect: e.id(),
            ambiguous_with: ambiguous,
            sentence,
            parameters,
            fit,
            metrics: met,
            evidence,
        });
        rounds.push(Round {
            screen: scr,
            fits,
            accepted: Some(e.id()),
            consistent: None,
        });
    }
    Ok(Explanation {
        split: problem.split().clone(),
        domains,
        left_out: problem.left_out().to_vec(),
        rule: AcceptanceRule::FIXED,
        rounds,
        findings,
        consistent,
        theta,
    })
}

/// Full fit of one screened candidate and its acceptance tests.
fn candidate_fit(
    ev: &Evaluator<'_, '_>,
    base: &Eval,
    en: &ScreenEntry,
    theta: Theta,
) -> CandidateFit {
    let e = Effect::from_id(en.effect).expect("screen ids are catalogue ids");
    let active = en.active();
    let mut base_v = base.clone();
    base_v.value = theta.get(e);
    let fr = fit_effect(ev, e, &base_v, en);
    let best = fr.best;
    let n_acf = ev.n_eff(&best, active, Part::Train);
    let (n_eff, threshold) = deviance_threshold(n_acf, fr.cluster);
    let dev = ev.deviance(base, &best, active, n_eff, Part::Train);
    // a switch fits nothing on the train part: its fixed alternative is tested on every row
    // (module documentation, rule 3), and so are rules 1 and 2
    let switch = fit_spec(e, ev.problem.nominal().get(e), ev.problem.slope_step()).switch;
    let dev_heldout = switch.then(|| {
        let n = ev.n_eff(&best, active, Part::Heldout);
        ev.deviance(base, &best, active, n, Part::Heldout)
    });
    let RuleFigures {
        scored,
        gain,
        whiteness: (wb, wa),
    } = rule_figures(ev, e, active, base, &best, switch);
    let explained: f64 = (0..ev.models.len())
        .map(|m| 1.0 - best.heldout[m] / base.heldout[m])
        .sum();
    let models = (0..ev.models.len())
        .filter(|&m| active[m])
        .map(|m| ModelScore {
            domain: ev.models[m].domain,
            view: ev.problem.views()[m].kind,
            scored: scored[m],
            train_before: base.train[m].sqrt(),
            train_after: best.train[m].sqrt(),
            heldout_before: base.heldout[m].sqrt(),
            heldout_after: best.heldout[m].sqrt(),
        })
        .collect();
    let rule = AcceptanceRule::FIXED;
    CandidateFit {
        effect: e.id(),
        domain: e.domain(),
        start: theta.get(e),
        value: best.value,
        models,
        heldout_gain: gain,
        explained,
        whiteness_before: wb,
        whiteness_after: wa,
        n_eff,
        n_eff_autocorrelation: n_acf,
        train_blocks: fr.cluster.map_or(0, |c| c.1),
        deviance_threshold: threshold,
        deviance_at_start: dev,
        deviance_heldout_at_start: dev_heldout,
        evaluations: fr.evaluations,
        passes_heldout: gain >= rule.min_heldout_gain,
        passes_whiteness: !rule.whiteness_must_improve || wa.nonwhite_power < wb.nonwhite_power,
        passes_interval: dev + dev_heldout.unwrap_or(0.0) > threshold,
        eval: Some(best),
        curvature: fr.curvature,
        active: active.to_vec(),
    }
}

/// Per-signal fits of the signals whose simulation changed from `before` to `after`, against
/// the recording — or, with `reference`, against those columns instead (one value per log
/// row, on the channel's own rows and parts) for the signals it names, the others left out.
fn signal_fits(
    problem: &Problem<'_>,
    before: &[Arc<Vec<Vec<f64>>>],
    after: &[Arc<Vec<Vec<f64>>>],
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
                            measured: values.clone(),
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

fn signal_words(name: &str) -> &str {
    match name {
        "vehicle_speed" => "speed",
        "engine_speed" => "engine speed",
        "shuffle_frequency" => "shuffle frequency (after clutch engagements)",
        "reversal_relative_speed" => "engine-against-wheel speed at torque reversals",
        "bellow_pressure_front" => "front bellow pressure",
        "bellow_pressure_rear" => "rear bellow pressure",
        "bellow_pressure_tag" => "tag bellow pressure",
        other => other,
    }
}

/// `x` with three significant figures (no exponent between 1e-4 and 1e6).
fn num(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{x:.2e}");
    }
    let decimals = (2 - mag).max(0) as usize;
    format!("{x:.decimals$}")
}

/// The plain sentence of an estimate within the vehicle file's tolerance: "mass_kg = 40800 kg
/// (95 % CI 40500 to 41100 kg), within the vehicle file's 40000 kg ± 3 %".
fn consistent_sentence(
    e: Effect,
    nominal: f64,
    est: &ParameterEstimate,
    tol: crate::model::catalogue::Tolerance,
) -> String {
    use crate::model::catalogue::Tolerance;
    let unit = if e.unit() == "1" {
        String::new()
    } else {
        format!(" {}", e.unit())
    };
    let band = match tol {
        Tolerance::Relative(r) => format!("{}{unit} ± {} %", num(nominal), num(100.0 * r)),
        Tolerance::Absolute(a) => format!("{}{unit} ± {}{unit}", num(nominal), num(a)),
        Tolerance::None => format!("{}{unit}", num(nominal)),
    };
    format!(
        "{} = {}{unit} (95 % CI {} to {}{unit}), within the vehicle file's {band}: consistent \
         with the file, not named",
        e.parameter(),
        num(est.value),
        num(est.ci_low),
        num(est.ci_high)
    )
}

/// The plain sentence of a finding: what is wrong by how much, its fingerprint, and the
/// held-out RMSE of the signal it improves most.
fn sentence(
    e: Effect,
    nominal: f64,
    est: &ParameterEstimate,
    met: &BTreeMap<String, SignalMetrics>,
    ambiguous: &[&'static str],
) -> String {
    use Effect::*;
    let v = est.value;
    let unit = if e.unit() == "1" {
        String::new()
    } else {
        format!(" {}", e.unit())
    };
    let ci = format!(
        "{} = {}{unit} (95 % CI {} to {}{unit})",
        e.parameter(),
        num(v),
        num(est.ci_low),
        num(est.ci_high)
    );
    let pct = if nominal != 0.0 {
        100.0 * (v / nominal - 1.0)
    } else {
        0.0
    };
    let more = |hi: &'static str, lo: &'static str| if pct >= 0.0 { hi } else { lo };
    let head = match e {
        AeroDrag => format!(
            "aerodynamic drag is {:.0} % {} than the vehicle file says, {ci}: residual force grows with v²",
            pct.abs(),
            more("higher", "lower")
        ),
        RollingResistance => format!(
            "rolling resistance is {:.0} % {} than the vehicle file says, {ci}: residual force is constant plus ∝ v, with load",
            pct.abs(),
            more("higher", "lower")
        ),
        VehicleMass => format!(
            "the vehicle is {:.0} kg ({:.0} %) {} than the vehicle file says, {ci}: residual force ∝ a + g·sin α",
            (v - nominal).abs(),
            pct.abs(),
            more("heavier", "lighter")
        ),
        GradeOffset => format!(
            "the slope sensor reads {:.2}° too {} (mounting angle), {ci}: residual force ∝ m·g, constant along the road",
            v.abs().to_degrees(),
            if v >= 0.0 { "nose-up" } else { "nose-down" }
        ),
        SlopeQuantization => format!(
            "the slope sensor resolves only {:.2} % steps, coarser than the model assumes ({:.2} %), {ci}: fed the sensor's steps the model sees grade the road does not have (and shuffle the steps excite); the slope reconstructed within the sensor's cells, widened by its noise, fits better",
            100.0 * v,
            100.0 * nominal
        ),
        SignalDelay => format!(
            "the engine-torque channel lags the driveline by {:.2} s, {ci}: input–residual cross-correlation peaks at a non-zero lag",
            v
        ),
        DrivelineBacklash => format!(
            "the driveline has {:.1}° of lash, {ci}: mismatch concentrated at torque sign changes",
            v.to_degrees()
        ),
        DrivelineCompliance => format!(
            "the drive shaft is {:.0} % {} than the vehicle file says, {ci}: the shuffle rings {} after clutch engagements than the nominal driveline's mode",
            pct.abs(),
            more("stiffer", "softer"),
            more("faster", "slower")
        ),
        EngineTorqueOffset => format!(
            "the reported engine torque is {:.0} N·m {} the delivered torque, {ci}: residual force ∝ gear ratio, constant in torque",
            v.abs(),
            if v >= 0.0 { "above" } else { "below" }
        ),
        ClutchSlip => format!(
            "the clutch transmits at most {:.0} N·m, {:.0} % {} than the vehicle file says, {ci}: the engine speed runs away from the gearbox's where the clutch slips (engagements, full load)",
            v,
            pct.abs(),
            more("more", "less")
        ),
        BogieTorqueReaction => format!(
            "a fraction {:.2} of the driven axle's torque reacts through the trailing arms, {ci}: driven-axle pressure residual ∝ axle torque, mirrored in braking",
            v
        ),
        LoadTransferHeight => format!(
            "the centre of gravity is {:.2} m {} than the vehicle file says, {ci}: pressure residual ∝ longitudinal acceleration",
            (v - nominal).abs(),
            if v >= nominal { "higher" } else { "lower" }
        ),
        AirSpringNonlinearity => format!(
            "the air springs are progressive, {ci}: pressure residual ∝ travel², asymmetric"
        ),
        CgPosition => format!(
            "the static centre of gravity sits {:.2} m {} of where the vehicle file puts it, {ci}: constant pressure offset front vs rear and tag, opposite signs",
            v.abs(),
            if v >= 0.0 { "rearwards" } else { "forwards" }
        ),
        TyreStiffness => format!(
            "the tyres are {:.0} % {} than the vehicle file says, {ci}: axle-hop band phase and amplitude mismatch",
            pct.abs(),
            more("stiffer", "softer")
        ),
        GradeLoadTransfer => format!(
            "the gravity component on grades acts {:.2} m {} the centre of gravity, {ci}: pressure residual ∝ sin α",
            v.abs(),
            if v >= 0.0 { "above" } else { "below" }
        ),
    };
    // the signal of the effect's own model improved most (relative held-out RMSE)
    let own = |name: &str| (e.domain() == Domain::Axle) == name.starts_with("bellow_pressure");
    let best = met
        .iter()
        .filter(|(name, m)| own(name) && m.rmse.heldout_before > 0.0)
        .max_by(|a, b| {
            let ga = 1.0 - a.1.rmse.heldout_after / a.1.rmse.heldout_before;
            let gb = 1.0 - b.1.rmse.heldout_after / b.1.rmse.heldout_before;
            ga.total_cmp(&gb)
        });
    let mut s = head;
    if let Some((name, m)) = best {
        if m.unit == "1" {
            // a relative error (the shuffle frequency's ln f residual), in per cent
            s.push_str(&format!(
                "; held-out {} RMS error {:.1} % → {:.1} %",
                signal_words(name),
                100.0 * m.rmse.heldout_before,
                100.0 * m.rmse.heldout_after,
            ));
        } else {
            s.push_str(&format!(
                "; held-out {} RMSE {} → {} {}",
                signal_words(name),
                num(m.rmse.heldout_before),
                num(m.rmse.heldout_after),
                m.unit
            ));
        }
    }
    if !ambiguous.is_empty() {
        s.push_str(&format!(
            " (not isolable from {} with the recorded signals)",
            ambiguous.join(", ")
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_three_significant_figures() {
        assert_eq!(num(0.007548), "0.00755");
        assert_eq!(num(21737.52), "21738");
        assert_eq!(num(-94.47), "-94.5");
        assert_eq!(num(1.5777), "1.58");
        assert_eq!(num(2.5e-6), "2.50e-6");
    }

    #[test]
    fn verdict_combines_findings_and_significance() {
        assert_eq!(verdict(&[], &[], false), Verdict::NoSignificantMismatch);
        assert_eq!(verdict(&[], &[], true), Verdict::Unexplained);
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
            sentence: String::new(),
        };
        assert_eq!(
            verdict(&[], std::slice::from_ref(&within), true),
            Verdict::NoSignificantMismatch
        );
        assert_eq!(
            serde_json::to_string(&Verdict::NoSignificantMismatch).unwrap(),
            "\"no_significant_mismatch\""
        );
    }
}
