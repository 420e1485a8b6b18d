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
//!    gears itself), within its physical domain, in parallel across candidates (one at a time
//!    on a long drive: [`super::long_drive`]); 95 % interval
//!    by profile likelihood with an effective number of independent samples
//!    ([`super::fit`]).
//! 4. **Accept** by [`AcceptanceRule::FIXED`] ([`super::acceptance`]), **isolate** (ambiguity
//!    sets), and **repeat** greedily on the remaining residual with the accepted parameter
//!    fixed, until no candidate passes or [`MAX_FINDINGS`] (3) are accepted.
//!
//! Before the first round, each parameter measured outside the models
//! ([`ExplainConfig::measured`]: the slope sensor's offset against the altitude, the torque
//! channel's offset on the free engine) is set to
//! its measured value and kept out of the screens; its effect is named when the measured
//! interval lies outside the vehicle file's own tolerance, and reported as consistent with the
//! file otherwise (`measured_round`).
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
//! shaft stiffness (the mass moves them too, but is read off the speeds:
//! [`super::problem::ViewKind::only_for`]) and the reversals for the lash, the
//! stiffness and the torque signal's delay, and neither dilutes the speeds' figures for an
//! effect that leaves them alone (drag, rolling resistance, …). The cost is the mean over
//! those views of each view's weighted mean square; within a view every signal counts alike
//! (weights `σ_c`: step 2's noise floor when given, else the signal's train RMS residual at
//! the round's parameters; an engagement's own standard error for the modes, a reversal's
//! noise and floor for the reversals, each actuated row's own null variance for the clutch;
//! [`super::problem`]).
//!
//! # The parts
//! The acceptance rule, the views it scores and isolability: [`super::acceptance`]. Settings,
//! rounds, findings and the result: [`super::explanation`]. Per-signal RMSE, MAE and fit %:
//! [`super::signal_fits`]. The plain sentences are the report's (`report::sentences`).
//!
//! # Verdict
//! [`verdict`] combines the findings with step 2's significance test.

use super::acceptance::{ambiguity_set, rule_figures, RuleFigures};
use super::extended::Theta;
use super::fit::{
    applicable, deviance_threshold, fit_effect, fit_spec, profile_interval, screen, Eval,
    Evaluator, ScreenEntry, MAX_FULL_FITS,
};
use super::linearised::linearised_estimates;
use super::long_drive::{is_long, map_in_order};
use super::problem::{ExplainError, Part, Problem};
use super::row_column::RowColumn;
use super::signal_fits::signal_fits;
use crate::model::catalogue::{Effect, ModelForm};
use std::collections::BTreeMap;
use std::sync::Arc;

pub use super::acceptance::{
    rules_at, AcceptanceRule, CandidateFit, ModelScore, RulesAt, AMBIGUITY_GAIN_RATIO,
    AMBIGUITY_MIN_CORRELATION, MIN_HELDOUT_GAIN, RULE_MIN_CHANGE_MS,
};
pub use super::explanation::{
    verdict, ConsistentEstimate, Evidence, ExplainConfig, Explanation, Finding, Measured,
    ParameterEstimate, Round, Verdict, MAX_CONSISTENT_ROUNDS, MAX_FINDINGS,
};
pub use super::signal_fits::{fits_against, BeforeAfter, SignalFit, SignalMetrics};

/// Explains `problem` (module documentation).
///
/// # Errors
/// [`ExplainError`] when a model fails at the round's parameters (a candidate's failure only
/// removes that candidate) or the configuration is out of its domain.
pub fn explain(problem: &Problem<'_>, cfg: &ExplainConfig) -> Result<Explanation, ExplainError> {
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
    let mut linearised = Vec::new();
    // outputs of every model at the round's parameters
    let mut bases: Vec<Arc<Vec<RowColumn>>> = problem
        .nominal_outputs()
        .iter()
        .map(|y| Arc::new(y.clone()))
        .collect();
    for m in &cfg.measured {
        let e = m.effect;
        let ev = Evaluator::new(problem, theta, &bases, cfg.noise_floor.as_ref(), dt_s);
        let base = ev.eval_outputs(f64::NAN, bases.clone());
        let (best, taken) = measured_round(&ev, &base, m, &cfg.tolerances)?;
        match taken {
            Taken::Finding(f) => findings.push(*f),
            Taken::Consistent(c) => consistent.push(c),
        }
        bases = best.outputs;
        theta.set(e, m.estimate.value);
        excluded.push(e);
    }
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
        if round == 0 {
            linearised = linearised_estimates(&ev, &base, &scr);
        }
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
        // the candidates in parallel, one at a time on a long drive (super::long_drive)
        let fits: Vec<CandidateFit> = map_in_order(is_long(problem.times().len()), &cands, |&k| {
            candidate_fit(&ev, &base, &scr.entries[k], theta)
        });
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
            consistent.push(ConsistentEstimate {
                effect: e.id(),
                file_tolerance: cfg.tolerances.of_effect(e),
                model_form: cfg.tolerances.model_form(e),
                estimate,
                nominal: nominal.get(e),
                band_low,
                band_high,
                band_from_file: cfg.tolerances.is_given(e),
                round,
                ambiguous_with: ambiguous.clone(),
                measured_by: None,
            });
            bases = best.outputs.clone();
            theta.set(e, f.value);
            excluded.push(e);
            for a in &ambiguous {
                excluded.push(Effect::from_id(a).expect("catalogue id"));
            }
            rounds.push(Round {
                screen: scr.without_probes(),
                fits: without_simulations(fits),
                accepted: None,
                consistent: Some(e.id()),
            });
            continue;
        }
        let accepted = accepted.map(|(i, ci, _)| (i, ci));
        let Some((i, ci)) = accepted else {
            rounds.push(Round {
                screen: scr.without_probes(),
                fits: without_simulations(fits),
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
            measured_by: None,
        };
        let est = ParameterEstimate {
            value: f.value,
            ci_low: ci.lo,
            ci_high: ci.hi,
            unit: e.unit(),
        };
        let mut parameters = BTreeMap::new();
        parameters.insert(e.parameter().to_string(), est);
        excluded.push(e);
        for a in &ambiguous {
            excluded.push(Effect::from_id(a).expect("catalogue id"));
        }
        findings.push(Finding {
            effect: e.id(),
            ambiguous_with: ambiguous,
            parameters,
            fit,
            metrics: met,
            evidence,
        });
        rounds.push(Round {
            screen: scr.without_probes(),
            fits: without_simulations(fits),
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
        linearised,
        theta,
    })
}

/// What a measured parameter becomes.
enum Taken {
    Finding(Box<Finding>),
    Consistent(ConsistentEstimate),
}

/// The measured parameter `m` taken before the first round: every model simulated at its
/// value; a finding when its interval lies outside the vehicle file's own tolerance (the
/// evidence figures are those of the measured value against `base`, nothing fitted), else an
/// estimate consistent with the file. Returns the evaluation at the measured value.
fn measured_round(
    ev: &Evaluator<'_, '_>,
    base: &Eval,
    m: &Measured,
    tolerances: &crate::model::tolerance::Tolerances,
) -> Result<(Eval, Taken), ExplainError> {
    let e = m.effect;
    let nominal = ev.problem.nominal().get(e);
    let all = vec![true; ev.models.len()];
    let best = ev.eval(base, &all, e, m.estimate.value)?;
    let w = tolerances.of_effect(e).half_width(nominal);
    let (band_low, band_high) = (nominal - w, nominal + w);
    let est = m.estimate;
    if est.ci_low <= band_high && est.ci_high >= band_low {
        let c = ConsistentEstimate {
            effect: e.id(),
            estimate: est,
            nominal,
            band_low,
            band_high,
            band_from_file: tolerances.is_given(e),
            round: 0,
            ambiguous_with: Vec::new(),
            file_tolerance: tolerances.of_effect(e),
            model_form: ModelForm::NONE,
            measured_by: Some(m.source),
        };
        return Ok((best, Taken::Consistent(c)));
    }
    let active: Vec<bool> = (0..ev.models.len())
        .map(|k| ev.changed(k, base, &best))
        .collect();
    let n_acf = ev.n_eff(&best, &active, Part::Train);
    let (n_eff, threshold) = deviance_threshold(n_acf, None);
    let dev = ev.deviance(base, &best, &active, n_eff, Part::Train);
    let RuleFigures {
        scored,
        gain,
        whiteness: (wb, wa),
    } = rule_figures(ev, e, &active, base, &best, false);
    let (explained, models) = model_scores(ev, base, &best, &active, &scored);
    let (fit, metrics) = signal_fits(ev.problem, &base.outputs, &best.outputs, None);
    let mut parameters = BTreeMap::new();
    parameters.insert(e.parameter().to_string(), est);
    let finding = Finding {
        effect: e.id(),
        ambiguous_with: Vec::new(),
        parameters,
        fit,
        metrics,
        evidence: Evidence {
            round: 0,
            domain: e.domain(),
            nominal,
            start: nominal,
            models,
            heldout_gain: gain,
            explained,
            whiteness_before: wb,
            whiteness_after: wa,
            n_eff,
            deviance_threshold: threshold,
            deviance_at_start: dev,
            deviance_heldout_at_start: None,
            ambiguity_correlation: BTreeMap::new(),
            evaluations: 1,
            measured_by: Some(m.source),
        },
    };
    Ok((best, Taken::Finding(Box::new(finding))))
}

/// The held-out mean square explained from `base` to `best`, summed over the models, and the
/// weighted RMSE before and after of each changed view (`active`), `scored` saying which rule 1
/// scored.
fn model_scores(
    ev: &Evaluator<'_, '_>,
    base: &Eval,
    best: &Eval,
    active: &[bool],
    scored: &[bool],
) -> (f64, Vec<ModelScore>) {
    let explained = (0..ev.models.len())
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
    (explained, models)
}

/// `fits` as a round keeps them: their figures without their simulations (a simulation holds
/// every model's outputs on every row; a decided round never reads them again, and on a long
/// drive the rounds' simulations would outweigh the recording).
fn without_simulations(mut fits: Vec<CandidateFit>) -> Vec<CandidateFit> {
    for f in &mut fits {
        f.eval = None;
    }
    fits
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
    // (`super::acceptance`, rule 3), and so are rules 1 and 2
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
    let (explained, models) = model_scores(ev, base, &best, active, &scored);
    let rule = AcceptanceRule::FIXED;
    let passes_heldout = gain >= rule.min_heldout_gain;
    let passes_whiteness = rule.whiteness_passes(wb.nonwhite_power, wa.nonwhite_power);
    let passes_interval = dev + dev_heldout.unwrap_or(0.0) > threshold;
    let passes = passes_heldout && passes_whiteness && passes_interval;
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
        passes_heldout,
        passes_whiteness,
        passes_interval,
        eval: passes.then_some(best),
        curvature: fr.curvature,
        active: active.to_vec(),
    }
}
