//! The proof's figures over all cases: confusion, false positives, parameter error,
//! held-out error, time; the case table.

use super::*;
use crate::report::contract::Verdict;
use serde::Serialize;
use std::collections::BTreeMap;

/// A case the proof could not diagnose (counted as not named in every share).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FailedCase {
    /// Plan index.
    pub index: usize,
    /// Hidden (label).
    pub hidden: &'static str,
    /// `generate` or `diagnose`.
    pub stage: &'static str,
    /// The error.
    pub error: String,
}

/// The proof's summary figures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProofSummary {
    /// Drives planned.
    pub drives: usize,
    /// Drives that failed to generate or diagnose.
    pub failed: usize,
    /// (hidden, named) → count.
    pub confusion: BTreeMap<String, BTreeMap<String, usize>>,
    /// Catalogue drives named correctly, share.
    pub named_correct: f64,
    /// Catalogue drives whose truth was only in the ambiguity set, share.
    pub ambiguous_correct: f64,
    /// Catalogue drives with a finding that names neither the hidden effect nor lists it in
    /// its ambiguity set — a confidently wrong name — share.
    pub named_wrong: f64,
    /// Catalogue drives whose hidden effect, set to its truth with nothing fitted, passes
    /// rules 1 and 2 of the acceptance rule ([`CaseScore::oracle_visible`]).
    pub visible: usize,
    /// Catalogue drives in all (the denominator of `visible`).
    pub catalogue: usize,
    /// Share of the visible ones named correctly.
    pub named_correct_visible: f64,
    /// Share of the not visible ones named correctly.
    pub named_correct_invisible: f64,
    /// No-effect drives with a finding, share.
    pub false_positive_rate: f64,
    /// No-effect drives with the verdict `unexplained`, share.
    pub clean_unexplained_rate: f64,
    /// No-effect drives with any finding or the verdict `unexplained` (a false alarm either
    /// way), share.
    pub false_alarm_rate: f64,
    /// Median parameter error of correctly named drives.
    pub median_parameter_error: Option<f64>,
    /// Correctly named drives whose quoted signal's held-out RMSE at least halved, share.
    pub heldout_halved: f64,
    /// Median held-out RMSE ratio after/before of the quoted signal, correctly named drives.
    pub median_heldout_ratio: Option<f64>,
    /// Correctly named drives whose quoted signal's held-out RMSE did not halve.
    pub not_halved: usize,
    /// Of those, the ones whose error against the noise-free signal did halve
    /// ([`CaseScore::noise_free_heldout_ratio`] ≤ 0.5): the recording's noise held the
    /// recorded ratio up.
    pub not_halved_noise_free_halved: usize,
    /// Of those, the others whose error against the noise-free signal would not halve with
    /// the hidden truth set either ([`CaseScore::noise_free_truth_ratio`] > 0.5): no fit of
    /// the effect could halve it on the recorded inputs.
    pub not_halved_truth_cannot: usize,
    /// Out-of-catalogue drives passing, share.
    pub out_of_catalogue_ok: f64,
    /// Out-of-catalogue drives with a mismatch located on the stretch, share.
    pub out_of_catalogue_located: f64,
    /// Median diagnosis wall time per drive, s.
    pub median_seconds: f64,
    /// Median diagnosis wall time per hour of drive, s.
    pub median_seconds_per_drive_hour: f64,
    /// Total drive time, s.
    pub drive_s: f64,
    /// No-effect drives: each parameter's estimates against the truck's true values.
    pub no_effect_estimates: Vec<EstimateSpread>,
}

/// One parameter's estimates on the no-effect drives against the truck's true values
/// ([`CaseScore::estimate_misses`]), as a fraction of θ₀ for a parameter whose tolerance is
/// relative, else in its unit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateSpread {
    /// Catalogue id.
    pub effect: &'static str,
    /// Drives with a full fit of the parameter (named, or an estimate within the band).
    pub drives: usize,
    /// Median |estimate − truck|.
    pub median_abs_error: f64,
    /// Drives whose interval misses the truck's value.
    pub missed: usize,
    /// The misses with the estimate below the truck's value.
    pub below: MissSide,
    /// The misses with the estimate above the truck's value.
    pub above: MissSide,
}

/// The misses of one side of the truck's value: the model-form allowance this run measures on
/// that side ([`crate::model::catalogue::EffectSpec::model_form`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MissSide {
    /// Drives whose interval misses the truck's value on this side.
    pub missed: usize,
    /// Largest distance from the truck's value to the interval (0 when none missed).
    pub max_miss: f64,
    /// The case of the largest miss (`None` when none missed).
    pub max_miss_case: Option<usize>,
}

impl MissSide {
    fn of(misses: impl Iterator<Item = (usize, f64)>) -> Self {
        let mut side = MissSide {
            missed: 0,
            max_miss: 0.0,
            max_miss_case: None,
        };
        for (case, miss) in misses.filter(|&(_, m)| m > 0.0) {
            side.missed += 1;
            // the largest, and the first case among equal ones
            if miss > side.max_miss {
                side.max_miss = miss;
                side.max_miss_case = Some(case);
            }
        }
        side
    }

    fn cell(&self) -> String {
        match self.max_miss_case {
            Some(c) => format!("{}, {:.4} (case {c})", self.missed, self.max_miss),
            None => "0".to_string(),
        }
    }
}

/// Per parameter, in catalogue order, the spread of [`CaseScore::estimate_misses`] over the
/// full fits (a finding's or an estimate within the band; not the linearised or measured
/// estimates).
fn estimate_spreads(scores: &[CaseScore]) -> Vec<EstimateSpread> {
    crate::model::catalogue::Effect::ALL
        .iter()
        .filter_map(|e| {
            let id = e.id();
            let m: Vec<(usize, &super::score::EstimateMiss)> = scores
                .iter()
                .flat_map(|s| s.estimate_misses.iter().map(move |m| (s.index, m)))
                // the full fits, which rule 4 of the acceptance rule judges; a linearised
                // estimate's interval is the first round's approximation, and a measured one
                // does not go through the models
                .filter(|(_, m)| m.effect == id && !matches!(m.method, "linearised" | "measured"))
                .collect();
            if m.is_empty() {
                return None;
            }
            // a miss lies on the side of the truck's value the estimate is on
            let side = |above: bool| {
                MissSide::of(
                    m.iter()
                        .filter(move |(_, x)| (x.error > 0.0) == above)
                        .map(|(c, x)| (*c, x.miss)),
                )
            };
            Some(EstimateSpread {
                effect: id,
                drives: m.len(),
                median_abs_error: median(m.iter().map(|(_, x)| x.error.abs()).collect())
                    .unwrap_or(f64::NAN),
                missed: m.iter().filter(|(_, x)| x.miss > 0.0).count(),
                below: side(false),
                above: side(true),
            })
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    (!v.is_empty()).then(|| crate::signal::stats::median(&mut v))
}

fn is_catalogue(hidden: &str) -> bool {
    hidden != "none" && hidden != "out_of_catalogue"
}

/// Summarises case scores; `failed` cases count in every denominator and never as a success.
pub fn summarize(scores: &[CaseScore], failed: &[FailedCase]) -> ProofSummary {
    let mut confusion: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for s in scores {
        *confusion
            .entry(s.hidden.to_string())
            .or_default()
            .entry(s.named.clone())
            .or_default() += 1;
    }
    for f in failed {
        *confusion
            .entry(f.hidden.to_string())
            .or_default()
            .entry("failed".into())
            .or_default() += 1;
    }
    let share = |num: usize, den: usize| {
        if den == 0 {
            f64::NAN
        } else {
            num as f64 / den as f64
        }
    };
    let failed_of = |pred: &dyn Fn(&str) -> bool| failed.iter().filter(|f| pred(f.hidden)).count();
    let catalogue: Vec<&CaseScore> = scores.iter().filter(|s| is_catalogue(s.hidden)).collect();
    let n_catalogue = catalogue.len() + failed_of(&is_catalogue);
    let clean: Vec<&CaseScore> = scores.iter().filter(|s| s.hidden == "none").collect();
    let n_clean = clean.len() + failed_of(&|h| h == "none");
    let ooc: Vec<&CaseScore> = scores
        .iter()
        .filter(|s| s.hidden == "out_of_catalogue")
        .collect();
    let n_ooc = ooc.len() + failed_of(&|h| h == "out_of_catalogue");
    let correct: Vec<&&CaseScore> = catalogue.iter().filter(|s| s.correct).collect();
    let not_halved: Vec<&&&CaseScore> = correct
        .iter()
        .filter(|s| s.heldout_ratio.is_some_and(|r| r > 0.5))
        .collect();
    let visible: Vec<&&CaseScore> = catalogue
        .iter()
        .filter(|s| s.oracle_visible == Some(true))
        .collect();
    let invisible: Vec<&&CaseScore> = catalogue
        .iter()
        .filter(|s| s.oracle_visible == Some(false))
        .collect();
    ProofSummary {
        drives: scores.len() + failed.len(),
        failed: failed.len(),
        confusion,
        named_correct: share(correct.len(), n_catalogue),
        ambiguous_correct: share(
            catalogue.iter().filter(|s| s.ambiguous_correct).count(),
            n_catalogue,
        ),
        named_wrong: share(
            catalogue
                .iter()
                .filter(|s| !s.correct && !s.ambiguous_correct && !s.findings.is_empty())
                .count(),
            n_catalogue,
        ),
        visible: visible.len(),
        catalogue: n_catalogue,
        named_correct_visible: share(visible.iter().filter(|s| s.correct).count(), visible.len()),
        named_correct_invisible: share(
            invisible.iter().filter(|s| s.correct).count(),
            invisible.len(),
        ),
        false_positive_rate: share(
            clean.iter().filter(|s| !s.findings.is_empty()).count(),
            n_clean,
        ),
        clean_unexplained_rate: share(
            clean
                .iter()
                .filter(|s| s.verdict == Verdict::Unexplained)
                .count(),
            n_clean,
        ),
        false_alarm_rate: share(
            clean
                .iter()
                .filter(|s| !s.findings.is_empty() || s.verdict == Verdict::Unexplained)
                .count(),
            n_clean,
        ),
        median_parameter_error: median(correct.iter().filter_map(|s| s.parameter_error).collect()),
        heldout_halved: share(
            correct
                .iter()
                .filter(|s| s.heldout_ratio.is_some_and(|r| r <= 0.5))
                .count(),
            correct.len(),
        ),
        median_heldout_ratio: median(correct.iter().filter_map(|s| s.heldout_ratio).collect()),
        not_halved: not_halved.len(),
        not_halved_noise_free_halved: not_halved
            .iter()
            .filter(|s| s.noise_free_heldout_ratio.is_some_and(|r| r <= 0.5))
            .count(),
        not_halved_truth_cannot: not_halved
            .iter()
            .filter(|s| s.noise_free_heldout_ratio.is_some_and(|r| r > 0.5))
            .filter(|s| s.noise_free_truth_ratio.is_some_and(|r| r > 0.5))
            .count(),
        out_of_catalogue_ok: share(
            ooc.iter()
                .filter(|s| s.out_of_catalogue_ok == Some(true))
                .count(),
            n_ooc,
        ),
        out_of_catalogue_located: share(
            ooc.iter()
                .filter(|s| s.out_of_catalogue_located == Some(true))
                .count(),
            n_ooc,
        ),
        median_seconds: median(scores.iter().map(|s| s.seconds).collect()).unwrap_or(f64::NAN),
        median_seconds_per_drive_hour: median(
            scores
                .iter()
                .filter(|s| s.drive_s > 0.0)
                .map(|s| s.seconds / s.drive_s * 3600.0)
                .collect(),
        )
        .unwrap_or(f64::NAN),
        drive_s: scores.iter().map(|s| s.drive_s).sum(),
        no_effect_estimates: estimate_spreads(scores),
    }
}

impl ProofSummary {
    /// The confusion table and the figures as Markdown.
    pub fn to_markdown(&self) -> String {
        use std::fmt::Write as _;
        let mut named: Vec<String> = self
            .confusion
            .values()
            .flat_map(|m| m.keys().cloned())
            .collect();
        named.sort();
        named.dedup();
        let mut s = String::new();
        let _ = writeln!(s, "| hidden \\ named | {} |", named.join(" | "));
        let _ = writeln!(s, "|---|{}", "---|".repeat(named.len()));
        for (h, row) in &self.confusion {
            let cells: Vec<String> = named
                .iter()
                .map(|n| row.get(n).map_or(String::new(), |c| c.to_string()))
                .collect();
            let _ = writeln!(s, "| {h} | {} |", cells.join(" | "));
        }
        let pct = |x: f64| {
            if x.is_nan() {
                "n/a".to_string()
            } else {
                format!("{:.1} %", 100.0 * x)
            }
        };
        let _ = writeln!(s);
        let _ = writeln!(s, "| figure | value |\n|---|---|");
        let _ = writeln!(
            s,
            "| drives (failed to run) | {} ({}) |",
            self.drives, self.failed
        );
        let _ = writeln!(s, "| drive time | {:.2} h |", self.drive_s / 3600.0);
        // with its count: a share against the ≥ 90 % target is read to the drive
        let _ = writeln!(
            s,
            "| catalogue effects named correctly | {} ({} of {}) |",
            pct(self.named_correct),
            if self.catalogue > 0 {
                (self.named_correct * self.catalogue as f64).round() as usize
            } else {
                0
            },
            self.catalogue
        );
        let _ = writeln!(
            s,
            "| hidden effect only in the ambiguity set | {} |",
            pct(self.ambiguous_correct)
        );
        let _ = writeln!(
            s,
            "| catalogue drives named a wrong effect, the hidden one not in its ambiguity set | {} |",
            pct(self.named_wrong)
        );
        let _ = writeln!(
            s,
            "| catalogue drives whose effect, at its truth, passes the rule's held-out and whiteness tests | {} of {} |",
            self.visible, self.catalogue
        );
        let _ = writeln!(
            s,
            "| named correctly among those / among the others | {} / {} |",
            pct(self.named_correct_visible),
            pct(self.named_correct_invisible)
        );
        let _ = writeln!(
            s,
            "| false positives on no-effect drives | {} |",
            pct(self.false_positive_rate)
        );
        let _ = writeln!(
            s,
            "| no-effect drives with the verdict unexplained | {} |",
            pct(self.clean_unexplained_rate)
        );
        let _ = writeln!(
            s,
            "| false alarms on no-effect drives (a finding or unexplained) | {} |",
            pct(self.false_alarm_rate)
        );
        let _ = writeln!(
            s,
            "| median parameter error (relative to the hidden change) | {} |",
            self.median_parameter_error
                .map_or("n/a".into(), |x| format!("{:.1} %", 100.0 * x))
        );
        let _ = writeln!(
            s,
            "| correctly named drives with held-out RMSE at least halved | {} |",
            pct(self.heldout_halved)
        );
        let _ = writeln!(
            s,
            "| median held-out RMSE after/before, correctly named drives | {} |",
            self.median_heldout_ratio
                .map_or("n/a".into(), |r| format!("{r:.2}"))
        );
        let _ = writeln!(
            s,
            "| of the correctly named drives not halved: halved against the noise-free signal / not halved there even at the truth | {} of {} / {} of {} |",
            self.not_halved_noise_free_halved,
            self.not_halved,
            self.not_halved_truth_cannot,
            self.not_halved
        );
        let _ = writeln!(
            s,
            "| out-of-catalogue drives unexplained or located without a name | {} |",
            pct(self.out_of_catalogue_ok)
        );
        let _ = writeln!(
            s,
            "| out-of-catalogue drives with a mismatch located on the stretch | {} |",
            pct(self.out_of_catalogue_located)
        );
        let _ = writeln!(
            s,
            "| median diagnosis time per drive | {:.2} s |",
            self.median_seconds
        );
        let _ = writeln!(
            s,
            "| median diagnosis time per drive-hour | {:.1} s |",
            self.median_seconds_per_drive_hour
        );
        if !self.no_effect_estimates.is_empty() {
            let _ = writeln!(
                s,
                "\n### Estimates on no-effect drives\n\nEach parameter's full fit (a finding, \
                 or an estimate within the band) against the truck's true value, as a fraction of the file's value (drag, rolling \
                 resistance, mass, stiffness, clutch capacity) or in its unit (offsets, delay, \
                 lash); the largest miss of the truck's value by the 95 % interval on each side \
                 is the model-form allowance this run measures.\n\n\
                 | parameter | drives with a fit | median abs. error | intervals missing the truck | \
                 below: misses, largest (its case) | above: misses, largest (its case) |\n\
                 |---|---|---|---|---|---|"
            );
            for e in &self.no_effect_estimates {
                let _ = writeln!(
                    s,
                    "| {} | {} | {:.4} | {} | {} | {} |",
                    e.effect,
                    e.drives,
                    e.median_abs_error,
                    e.missed,
                    e.below.cell(),
                    e.above.cell()
                );
            }
        }
        s
    }
}

/// The per-case table as Markdown.
pub fn cases_markdown(scores: &[CaseScore], failed: &[FailedCase]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| case | seed | road | km | min | hidden | truth (nominal) | named | findings | verdict | fitted | param. error | held-out ratio | noise-free ratio (at the truth) | oracle gain | diagnosis s |"
    );
    let _ = writeln!(s, "|{}", "---|".repeat(16));
    let num = |x: Option<f64>, d: usize| x.map_or(String::new(), |v| format!("{v:.d$}"));
    for c in scores {
        let truth = match (c.truth_value, c.nominal_value) {
            (Some(t), Some(n)) => format!("{t:.4} ({n:.4})"),
            _ => String::new(),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {:.1} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1} |",
            c.index,
            c.seed,
            c.rules,
            c.length_m / 1000.0,
            c.drive_s / 60.0,
            c.hidden,
            truth,
            c.named,
            c.findings.join(", "),
            c.verdict.as_str(),
            num(c.fitted_value, 4),
            num(c.parameter_error, 2),
            num(c.heldout_ratio, 2),
            match (c.noise_free_heldout_ratio, c.noise_free_truth_ratio) {
                (Some(f), Some(t)) => format!("{f:.2} ({t:.2})"),
                (Some(f), None) => format!("{f:.2}"),
                (None, Some(t)) => format!("({t:.2})"),
                (None, None) => String::new(),
            },
            match (c.oracle_heldout_gain, c.oracle_visible) {
                (Some(g), Some(v)) => format!("{g:.2}{}", if v { "" } else { " (not visible)" }),
                _ => String::new(),
            },
            c.seconds
        );
    }
    for f in failed {
        let _ = writeln!(
            s,
            "| {} | | | | | {} | | failed ({}) | {} | | | | | | | |",
            f.index,
            f.hidden,
            f.stage,
            f.error.replace('|', "/")
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::catalogue::Effect;
    use crate::proof::{score, Hidden, ProofCase, ProofTruth};
    use crate::report::contract::Diagnosis;
    use crate::report::contract::{FindingEntry, FitEntry, ParameterEntry};
    use crate::synth::effects::Injection;

    fn diag(effect: Option<(&str, f64)>, verdict: Verdict) -> Diagnosis {
        let findings = effect
            .map(|(id, v)| {
                let mut parameters = BTreeMap::new();
                parameters.insert(
                    "c_w_a_f_m2".to_string(),
                    ParameterEntry {
                        value: v,
                        ci_low: v - 0.1,
                        ci_high: v + 0.1,
                        unit: "m2",
                    },
                );
                let mut fit = BTreeMap::new();
                fit.insert(
                    "vehicle_speed".to_string(),
                    FitEntry {
                        train_before: 0.4,
                        train_after: 0.1,
                        heldout_before: 0.4,
                        heldout_after: 0.1,
                        metric: "rmse",
                    },
                );
                vec![FindingEntry {
                    effect: id.into(),
                    ambiguous_with: vec![],
                    sentence: String::new(),
                    parameters,
                    fit,
                }]
            })
            .unwrap_or_default();
        Diagnosis {
            drive_id: "x".into(),
            verdict,
            noise_floor: BTreeMap::new(),
            mismatch: vec![],
            findings,
            estimates: Vec::new(),
        }
    }

    #[test]
    fn scores_and_summary() {
        let case = |h: Hidden| ProofCase {
            index: 0,
            seed: 1,
            rules: "highway-se",
            length_km: 3.0,
            hidden: h,
        };
        let aero = ProofTruth {
            hidden: Hidden::Effect(Effect::AeroDrag),
            injection: Some(Injection {
                effect: Effect::AeroDrag,
                nominal: 5.0,
                truth: 6.0,
            }),
            stretch: None,
        };
        let s1 = score(
            &case(aero.hidden),
            &aero,
            &diag(Some(("aero_drag", 5.9)), Verdict::Explained),
            600.0,
            1.0,
        );
        assert!(s1.correct);
        assert!((s1.parameter_error.unwrap() - 0.1).abs() < 1e-12);
        assert_eq!(s1.heldout_ratio, Some(0.25));
        let clean = ProofTruth {
            hidden: Hidden::Nothing,
            injection: None,
            stretch: None,
        };
        let s2 = score(
            &case(Hidden::Nothing),
            &clean,
            &diag(None, Verdict::NoSignificantMismatch),
            600.0,
            2.0,
        );
        assert_eq!(s2.named, "none");
        let s3 = score(
            &case(Hidden::Nothing),
            &clean,
            &diag(Some(("aero_drag", 5.5)), Verdict::Explained),
            600.0,
            3.0,
        );
        // a catalogue drive named a wrong effect with no ambiguity set
        let s4 = score(
            &case(aero.hidden),
            &aero,
            &diag(Some(("vehicle_mass", 20_000.0)), Verdict::Explained),
            600.0,
            2.0,
        );
        assert!(!s4.correct && !s4.ambiguous_correct);
        let sum = summarize(&[s1, s2, s3, s4], &[]);
        assert_eq!(sum.named_correct, 0.5);
        assert_eq!(sum.named_wrong, 0.5);
        assert_eq!(sum.false_positive_rate, 0.5);
        assert_eq!(sum.median_seconds, 2.0);
        let md = sum.to_markdown();
        assert!(md.contains("| aero_drag | 1 |"));
        // one of the two catalogue drives, to a tenth of a percent and counted
        assert!(
            md.contains("| catalogue effects named correctly | 50.0 % (1 of 2) |"),
            "{md}"
        );
    }

    #[test]
    fn drives_not_halved_are_told_apart_by_their_noise_free_ratios() {
        let named = |ratio: f64, noise_free: Option<f64>, truth: Option<f64>| CaseScore {
            heldout_ratio: Some(ratio),
            noise_free_heldout_ratio: noise_free,
            noise_free_truth_ratio: truth,
            ..score(
                &ProofCase {
                    index: 0,
                    seed: 1,
                    rules: "highway-se",
                    length_km: 3.0,
                    hidden: Hidden::Effect(Effect::AeroDrag),
                },
                &ProofTruth {
                    hidden: Hidden::Effect(Effect::AeroDrag),
                    injection: Some(Injection {
                        effect: Effect::AeroDrag,
                        nominal: 5.0,
                        truth: 6.0,
                    }),
                    stretch: None,
                },
                &diag(Some(("aero_drag", 5.9)), Verdict::Explained),
                600.0,
                1.0,
            )
        };
        let sum = summarize(
            &[
                named(0.2, Some(0.1), Some(0.1)),   // halved: not counted
                named(0.55, Some(0.25), Some(0.2)), // the recording's noise held it up
                named(0.6, Some(0.6), Some(0.58)),  // not even the truth halves it
                named(0.6, Some(0.6), Some(0.3)),   // the fit fell short of the truth
                named(0.7, None, None),             // an event view: no noise-free twin
            ],
            &[],
        );
        assert_eq!(
            (
                sum.not_halved,
                sum.not_halved_noise_free_halved,
                sum.not_halved_truth_cannot
            ),
            (4, 1, 1)
        );
        assert!(sum.to_markdown().contains("| 1 of 4 / 1 of 4 |"));
    }

    #[test]
    fn no_effect_misses_are_measured_on_each_side_apart() {
        use super::super::score::EstimateMiss;
        let clean = |index: usize, misses: &[(f64, f64, &'static str)]| CaseScore {
            index,
            estimate_misses: misses
                .iter()
                .map(|&(error, miss, method)| EstimateMiss {
                    effect: "clutch_slip",
                    error,
                    miss,
                    method,
                })
                .collect(),
            ..score(
                &ProofCase {
                    index,
                    seed: 1,
                    rules: "highway-se",
                    length_km: 3.0,
                    hidden: Hidden::Nothing,
                },
                &ProofTruth {
                    hidden: Hidden::Nothing,
                    injection: None,
                    stretch: None,
                },
                &diag(None, Verdict::NoSignificantMismatch),
                600.0,
                1.0,
            )
        };
        let sum = summarize(
            &[
                clean(3, &[(0.3, 0.2, "fitted")]),
                clean(4, &[(0.25, 0.1, "named"), (-0.9, 0.8, "linearised")]),
                clean(5, &[(-0.02, 0.01, "fitted")]),
                clean(6, &[(0.05, 0.0, "fitted")]),
            ],
            &[],
        );
        let e = sum
            .no_effect_estimates
            .iter()
            .find(|e| e.effect == "clutch_slip")
            .unwrap();
        // the linearised estimate is not a full fit and does not count
        assert_eq!((e.drives, e.missed), (4, 3));
        assert_eq!(
            e.above,
            MissSide {
                missed: 2,
                max_miss: 0.2,
                max_miss_case: Some(3)
            }
        );
        assert_eq!(
            e.below,
            MissSide {
                missed: 1,
                max_miss: 0.01,
                max_miss_case: Some(5)
            }
        );
        assert!(sum.to_markdown().contains(
            "| clutch_slip | 4 | 0.1500 | 3 | 1, 0.0100 (case 5) | 2, 0.2000 (case 3) |"
        ));
    }
}
