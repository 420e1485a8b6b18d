//! The acceptance rule of step 3 of the diagnosis, explain (docs/diagnosis/method.md): what a
//! fitted candidate must show on data it was not fitted on before it is named, fixed in advance
//! ([`AcceptanceRule::FIXED`]); the figures rules 1 and 2 score ([`rules_at`] evaluates them at
//! a given parameter value without a fit), the views they score, and the candidates that explain
//! the data alike (isolability). A candidate's fit and its tests are a [`CandidateFit`].
//!
//! Weighted RMSE and mean squares are those of [`super::problem`] (each view's channels
//! weighted by `σ_c`, dimensionless); parameter values are in the catalogue's SI units.
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
//!    than before, unless it is zero on both sides (no scored view long enough to measure it,
//!    [`AcceptanceRule::whiteness_passes`]);
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
//!    file's `[tolerance]` entry, else the default of the parameter's kind), each side widened
//!    by the catalogue's model-form allowance of that side. A vehicle file's
//!    values are nominal: a healthy truck's drag area or shaft stiffness is never exactly the
//!    file's, and a long drive fits it tightly enough to exclude the file's value. When the
//!    best candidate that passes rules 1 to 3 has an interval inside or across its band, the
//!    round ends in an estimate consistent with the file
//!    ([`ConsistentEstimate`](super::explanation::ConsistentEstimate), with the candidates
//!    that explain the data alike as its ambiguity set), not a finding: the parameter takes
//!    its estimate, and the next round searches the remaining residual (at most
//!    [`MAX_CONSISTENT_ROUNDS`](super::explanation::MAX_CONSISTENT_ROUNDS) such rounds). A
//!    lesser candidate is not named in its place: a reading within the file's tolerance
//!    explains the data better. A switch has no band.
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
//! view's change; the mass's shuffle modes counted, though the rules do not score them for the
//! mass: [`super::problem::ViewKind::only_for`]), 35 of the 508 changed (effect, view) pairs
//! move less than 10⁻²: the
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

use super::fit::{fit_spec, Eval, Evaluator, CHI2_1_95};
use super::problem::{ExplainError, Part, Problem, ViewKind, Whiteness};
use crate::model::catalogue::{Domain, Effect};
use serde::Serialize;
use std::collections::BTreeMap;

/// Least relative fall of the held-out weighted RMSE for acceptance (module documentation).
pub const MIN_HELDOUT_GAIN: f64 = 0.25;
/// Ambiguity: held-out gain at least this fraction of the best's.
pub const AMBIGUITY_GAIN_RATIO: f64 = 0.9;
/// Ambiguity: |correlation| of the fitted corrections at least this.
pub const AMBIGUITY_MIN_CORRELATION: f64 = 0.9;

/// Least weighted mean square of the change a fitted effect makes to one of its own model's
/// views for that view to be scored by rules 1 and 2: an RMS change of a tenth of the view's
/// weights `σ_c` (module documentation, "Which views the rule scores").
pub const RULE_MIN_CHANGE_MS: f64 = 1e-2;

/// The acceptance rule (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AcceptanceRule {
    /// Least relative fall of the held-out weighted RMSE.
    pub min_heldout_gain: f64,
    /// The held-out whiteness statistic must fall ([`AcceptanceRule::whiteness_passes`]).
    pub whiteness_must_improve: bool,
    /// Deviance threshold of the interval and the likelihood-ratio test when the residual's
    /// autocorrelation sets the effective sample count (χ²₁, 95 %); when the between-block
    /// count binds, `t²_{B−1}(0.975)` ([`super::fit::deviance_threshold`]).
    pub chi2_threshold: f64,
}

impl AcceptanceRule {
    /// Rule 2 on the held-out non-white power before (`before`) and after the fit: it must
    /// fall. Zero on both sides means no scored view holds a residual long enough for the
    /// statistic (an events view with too few held-out events): rule 2 cannot judge and does
    /// not refuse; rules 1 and 3 still must hold.
    pub fn whiteness_passes(&self, before: f64, after: f64) -> bool {
        !self.whiteness_must_improve || after < before || (before == 0.0 && after == 0.0)
    }

    /// The rule fixed in advance.
    pub const FIXED: AcceptanceRule = AcceptanceRule {
        min_heldout_gain: MIN_HELDOUT_GAIN,
        whiteness_must_improve: true,
        chi2_threshold: CHI2_1_95,
    };
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
    /// The simulation at the fitted value, kept while the round decides and only for a
    /// candidate that passes (the interval and the ambiguity set read passing candidates'
    /// simulations alone; a simulation holds every model's outputs on every row).
    #[serde(skip)]
    pub(super) eval: Option<Eval>,
    #[serde(skip)]
    pub(super) curvature: f64,
    #[serde(skip)]
    pub(super) active: Vec<bool>,
}

impl CandidateFit {
    /// All three rules hold.
    pub fn passes(&self) -> bool {
        self.passes_heldout && self.passes_whiteness && self.passes_interval
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
/// (all others nominal), weighted as the first round of [`explain`](super::explain::explain)
/// weights (`noise_floor`): the best any fit of `e` could do on the held-out blocks (a switch:
/// every row) if it found `value` exactly, on the views the rule would score at `value`. Rule 3
/// (the interval) needs a fit and is not evaluated. Only the effect's own model is simulated (the explain step also
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
        passes_whiteness: rule.whiteness_passes(wb.nonwhite_power, wa.nonwhite_power),
    }))
}

/// `e`'s own model at the nominal parameters and with `e` at `value` (the others nominal).
pub(super) struct OwnModelAt<'p, 'a> {
    pub(super) ev: Evaluator<'p, 'a>,
    /// The views of `e`'s own model that serve it.
    pub(super) own: Vec<bool>,
    pub(super) base: Eval,
    pub(super) at: Eval,
}

/// [`OwnModelAt`] for `e` at `value`, weighted by `noise_floor`; `None` when no view of
/// `e`'s model is in use.
pub(super) fn own_model_at<'p, 'a>(
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
pub(super) struct RuleFigures {
    /// The views they score ([`scored_views`]).
    pub(super) scored: Vec<bool>,
    /// Rule 1's figure ([`rule_gain`]).
    pub(super) gain: f64,
    /// Rule 2's whiteness before and after, on the scored views and [`rule_parts`].
    pub(super) whiteness: (Whiteness, Whiteness),
}

/// [`RuleFigures`] of `e` from `before` to `after` over its changed views `active`, a switch
/// scored on every row.
pub(super) fn rule_figures(
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
pub(super) fn ambiguity_set(
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whiteness_must_fall_unless_it_cannot_be_measured() {
        let r = AcceptanceRule::FIXED;
        assert!(r.whiteness_passes(0.30, 0.20));
        assert!(!r.whiteness_passes(0.20, 0.20));
        assert!(!r.whiteness_passes(0.20, 0.21));
        // zero on both sides: no scored view long enough for the statistic
        assert!(r.whiteness_passes(0.0, 0.0));
        assert!(!r.whiteness_passes(0.0, 0.01));
    }
}
