//! The proof (issue 7 point 6, diagnosis.md "Proof"): synthetic drives with one concealed effect
//! each — every catalogue effect, random magnitudes within the generator's realistic ranges,
//! different roads and driving — plus drives with no effect and drives with an effect outside
//! the catalogue; the diagnosis runs blind on each (it sees the drive and the nominal vehicle
//! file, never the answer) and is scored against the answers kept apart.
//!
//! # Plan
//! Case `i` of a proof with seed `S` has the drive seed `S + i`. Effects cycle through the
//! catalogue with two extra slots per cycle, one drive without effect and one with the
//! out-of-catalogue stretch of extra rolling resistance, so `18 k` drives hold every effect
//! `k` times. The road rule set is drawn per case (highway-se, freeway-us, city-se, urban-us
//! with weights 3:3:2:2 — fleet trucks drive mostly on highways), the length uniformly in
//! [`ProofConfig::length_km`]. Every drive has the real-log conditions of issue 7 point 7:
//! multi-rate quantised CAN with noise, launches, stops and AMT shifts, standstills, CAN
//! dropouts ([`ProofConfig::dropouts`]), and starts from an unknown state for the diagnosis.
//! The slope sensor is fine (0.1 %) unless the case hides `slope_quantization`, which is then
//! the sensor's coarser step.
//!
//! # Scores
//! - *named*: the first finding's effect (`none` for a drive without finding; `unexplained`
//!   for that verdict); *correct* when it is the hidden effect; *ambiguous-correct* when the
//!   hidden effect is in the first finding's `ambiguous_with` (reported separately);
//! - false-positive rate: no-effect drives with any finding;
//! - parameter error: `|fitted − truth| / |truth − nominal|`, relative to the hidden change
//!   (stricter than relative to the value: a 30 % drag change fitted at 25 % is a 17 % error);
//! - held-out: the first finding's held-out RMSE after/before per signal, the worst signal of
//!   the effect's domain;
//! - out-of-catalogue drives pass when the verdict is `unexplained` or a mismatch overlaps the
//!   stretch without any catalogue effect being named.

use super::catalogue::Effect;
use super::contract::{Diagnosis, Verdict};
use crate::road::rng::Xoshiro256StarStar;
use crate::synth::can::Dropouts;
use crate::synth::drive::{synth_drive, DriveConfig, DriveError, HiddenEffect};
use crate::synth::effects::{EffectChoice, Injection, ResistanceStretch};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Settings of a proof run.
#[derive(Debug, Clone, PartialEq)]
pub struct ProofConfig {
    /// Number of drives.
    pub drives: usize,
    /// Seed of the plan (drive `i` uses `seed + i`).
    pub seed: u64,
    /// Drive length range, km.
    pub length_km: (f64, f64),
    /// CAN dropouts of every message.
    pub dropouts: Dropouts,
}

impl Default for ProofConfig {
    /// 36 drives (every effect twice, two clean, two out-of-catalogue), seed 1, 3–6 km,
    /// dropouts starting with probability 0.001 per message, 0.3 s long on average.
    fn default() -> Self {
        Self {
            drives: 36,
            seed: 1,
            length_km: (3.0, 6.0),
            dropouts: Dropouts {
                start_probability: 0.001,
                mean_length_s: 0.3,
            },
        }
    }
}

/// What a proof drive hides.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Hidden {
    /// Nothing.
    Nothing,
    /// A catalogue effect.
    Effect(Effect),
    /// The out-of-catalogue stretch of extra rolling resistance.
    OutOfCatalogue,
}

impl Hidden {
    /// Label in the confusion table.
    pub fn label(&self) -> &'static str {
        match self {
            Hidden::Nothing => "none",
            Hidden::Effect(e) => e.id(),
            Hidden::OutOfCatalogue => "out_of_catalogue",
        }
    }
}

/// One planned drive.
#[derive(Debug, Clone, PartialEq)]
pub struct ProofCase {
    /// Index in the plan.
    pub index: usize,
    /// Drive seed.
    pub seed: u64,
    /// Road rule set.
    pub rules: &'static str,
    /// Road length, km (whole hundreds of metres).
    pub length_km: f64,
    /// What it hides.
    pub hidden: Hidden,
}

/// The deterministic plan of a proof (see the module documentation).
pub fn plan(cfg: &ProofConfig) -> Vec<ProofCase> {
    let mut rng = Xoshiro256StarStar::seed_from_u64(cfg.seed ^ 0x9E00_F00D);
    (0..cfg.drives)
        .map(|i| {
            let slot = i % (Effect::ALL.len() + 2);
            let hidden = match Effect::ALL.get(slot) {
                Some(e) => Hidden::Effect(*e),
                None if slot == Effect::ALL.len() => Hidden::Nothing,
                None => Hidden::OutOfCatalogue,
            };
            let r = rng.next_u64() % 10;
            let rules = match r {
                0..=2 => "highway-se",
                3..=5 => "freeway-us",
                6..=7 => "city-se",
                _ => "urban-us",
            };
            let km = rng.uniform(cfg.length_km.0, cfg.length_km.1);
            ProofCase {
                index: i,
                seed: cfg.seed + i as u64,
                rules,
                length_km: (km * 10.0).round() / 10.0,
                hidden,
            }
        })
        .collect()
}

/// The answer of a generated proof drive.
#[derive(Debug, Clone, PartialEq)]
pub struct ProofTruth {
    /// What was hidden.
    pub hidden: Hidden,
    /// The injection, for a catalogue effect.
    pub injection: Option<Injection>,
    /// The stretch, for the out-of-catalogue effect.
    pub stretch: Option<ResistanceStretch>,
}

/// A generated proof drive.
#[derive(Debug, Clone)]
pub struct GeneratedCase {
    /// The plan entry.
    pub case: ProofCase,
    /// Canonical drive log (Parquet) the diagnosis reads.
    pub drive: PathBuf,
    /// The nominal vehicle file written beside it.
    pub vehicle: PathBuf,
    /// The answer file (apart from the drive).
    pub answer: PathBuf,
    /// The answer's content.
    pub truth: ProofTruth,
}

/// Generates `case` with the vehicle of `vehicle`: the drive into `drives_dir/<index>/`, the
/// answer into `answers_dir/<index>.json`.
///
/// # Errors
/// [`DriveError`] from the generator.
pub fn generate(
    case: &ProofCase,
    vehicle: &Path,
    cfg: &ProofConfig,
    drives_dir: &Path,
    answers_dir: &Path,
) -> Result<GeneratedCase, DriveError> {
    let name = format!("case-{:04}", case.index);
    let dir = drives_dir.join(&name);
    let answer = answers_dir.join(format!("{name}.json"));
    let choice = match case.hidden {
        Hidden::Nothing => EffectChoice::None,
        Hidden::Effect(e) => EffectChoice::Given(e, None),
        Hidden::OutOfCatalogue => EffectChoice::LocalRollingResistance,
    };
    let mut dc = DriveConfig {
        slope_resolution: 0.001,
        dropouts: Some(cfg.dropouts),
        ..DriveConfig::default()
    };
    // a stop every 1–3 km: standstills and launches in every drive
    dc.driver.stop_every_m = Some(1000.0 + (case.seed % 3) as f64 * 1000.0);
    let r = synth_drive(
        vehicle,
        case.rules,
        case.length_km,
        case.seed,
        &dir,
        &dc,
        Some(&HiddenEffect {
            choice,
            answer_path: answer.clone(),
        }),
    )?;
    Ok(GeneratedCase {
        case: case.clone(),
        drive: r.parquet,
        vehicle: r.vehicle,
        answer,
        truth: ProofTruth {
            hidden: case.hidden,
            injection: r.injection,
            stretch: r.truth.stretch,
        },
    })
}

/// The score of one diagnosed drive.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaseScore {
    /// Plan index.
    pub index: usize,
    /// Road rule set.
    pub rules: &'static str,
    /// Hidden (label).
    pub hidden: &'static str,
    /// Named (label).
    pub named: String,
    /// Verdict.
    pub verdict: Verdict,
    /// The hidden effect is named first.
    pub correct: bool,
    /// The hidden effect is in the first finding's ambiguity set.
    pub ambiguous_correct: bool,
    /// Parameter error relative to the hidden change (catalogue effects named correctly).
    pub parameter_error: Option<f64>,
    /// Worst held-out RMSE ratio after/before of the first finding.
    pub heldout_ratio: Option<f64>,
    /// Out-of-catalogue: unexplained or located on the stretch without a catalogue name.
    pub out_of_catalogue_ok: Option<bool>,
    /// Diagnosis wall time, s.
    pub seconds: f64,
}

/// Scores the diagnosis `d` of a drive whose answer is `truth`.
pub fn score(case: &ProofCase, truth: &ProofTruth, d: &Diagnosis, seconds: f64) -> CaseScore {
    let first = d.findings.first();
    let named = match (d.verdict, first) {
        (Verdict::Unexplained, None) => "unexplained".to_string(),
        (_, Some(f)) => f.effect.clone(),
        (_, None) => "none".to_string(),
    };
    let hidden = truth.hidden.label();
    let correct = named == hidden;
    let ambiguous_correct =
        !correct && first.is_some_and(|f| f.ambiguous_with.iter().any(|a| a == hidden));
    let parameter_error = match (correct, truth.injection, first) {
        (true, Some(inj), Some(f)) => f.parameters.get(inj.effect.parameter()).map(|p| {
            let change = (inj.truth - inj.nominal).abs();
            (p.value - inj.truth).abs() / change.max(f64::MIN_POSITIVE)
        }),
        _ => None,
    };
    let heldout_ratio = first.and_then(|f| {
        f.fit
            .values()
            .filter(|e| e.heldout_before > 0.0)
            .map(|e| e.heldout_after / e.heldout_before)
            .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))))
    });
    let out_of_catalogue_ok = truth.stretch.map(|st| {
        let located = d
            .mismatch
            .iter()
            .any(|m| m.start_m < st.end_m && m.end_m > st.start_m);
        d.verdict == Verdict::Unexplained || (located && d.findings.is_empty())
    });
    CaseScore {
        index: case.index,
        rules: case.rules,
        hidden,
        named,
        verdict: d.verdict,
        correct,
        ambiguous_correct,
        parameter_error,
        heldout_ratio,
        out_of_catalogue_ok,
        seconds,
    }
}

/// The proof's summary figures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProofSummary {
    /// Drives scored.
    pub drives: usize,
    /// (hidden, named) → count.
    pub confusion: BTreeMap<String, BTreeMap<String, usize>>,
    /// Catalogue drives named correctly, share.
    pub named_correct: f64,
    /// Catalogue drives whose truth was only in the ambiguity set, share.
    pub ambiguous_correct: f64,
    /// No-effect drives with a finding, share.
    pub false_positive_rate: f64,
    /// Median parameter error of correctly named drives.
    pub median_parameter_error: Option<f64>,
    /// Correctly named drives whose worst held-out RMSE at least halved, share.
    pub heldout_halved: f64,
    /// Out-of-catalogue drives passing, share.
    pub out_of_catalogue_ok: f64,
    /// Median diagnosis wall time, s.
    pub median_seconds: f64,
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// Summarises case scores.
pub fn summarize(scores: &[CaseScore]) -> ProofSummary {
    let mut confusion: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for s in scores {
        *confusion
            .entry(s.hidden.to_string())
            .or_default()
            .entry(s.named.clone())
            .or_default() += 1;
    }
    let share = |num: usize, den: usize| {
        if den == 0 {
            f64::NAN
        } else {
            num as f64 / den as f64
        }
    };
    let catalogue: Vec<&CaseScore> = scores
        .iter()
        .filter(|s| s.hidden != "none" && s.hidden != "out_of_catalogue")
        .collect();
    let clean: Vec<&CaseScore> = scores.iter().filter(|s| s.hidden == "none").collect();
    let ooc: Vec<&CaseScore> = scores
        .iter()
        .filter(|s| s.hidden == "out_of_catalogue")
        .collect();
    let correct: Vec<&&CaseScore> = catalogue.iter().filter(|s| s.correct).collect();
    ProofSummary {
        drives: scores.len(),
        confusion,
        named_correct: share(correct.len(), catalogue.len()),
        ambiguous_correct: share(
            catalogue.iter().filter(|s| s.ambiguous_correct).count(),
            catalogue.len(),
        ),
        false_positive_rate: share(
            clean.iter().filter(|s| s.named != "none").count(),
            clean.len(),
        ),
        median_parameter_error: median(correct.iter().filter_map(|s| s.parameter_error).collect()),
        heldout_halved: share(
            correct
                .iter()
                .filter(|s| s.heldout_ratio.is_some_and(|r| r <= 0.5))
                .count(),
            correct.len(),
        ),
        out_of_catalogue_ok: share(
            ooc.iter()
                .filter(|s| s.out_of_catalogue_ok == Some(true))
                .count(),
            ooc.len(),
        ),
        median_seconds: median(scores.iter().map(|s| s.seconds).collect()).unwrap_or(f64::NAN),
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
                format!("{:.0} %", 100.0 * x)
            }
        };
        let _ = writeln!(s);
        let _ = writeln!(s, "| figure | value |\n|---|---|");
        let _ = writeln!(s, "| drives | {} |", self.drives);
        let _ = writeln!(
            s,
            "| catalogue effects named correctly | {} |",
            pct(self.named_correct)
        );
        let _ = writeln!(
            s,
            "| hidden effect only in the ambiguity set | {} |",
            pct(self.ambiguous_correct)
        );
        let _ = writeln!(
            s,
            "| false positives on no-effect drives | {} |",
            pct(self.false_positive_rate)
        );
        let _ = writeln!(
            s,
            "| median parameter error (relative to the hidden change) | {} |",
            self.median_parameter_error.map_or("n/a".into(), pct)
        );
        let _ = writeln!(
            s,
            "| correctly named drives with held-out RMSE at least halved | {} |",
            pct(self.heldout_halved)
        );
        let _ = writeln!(
            s,
            "| out-of-catalogue drives unexplained or located without a name | {} |",
            pct(self.out_of_catalogue_ok)
        );
        let _ = writeln!(
            s,
            "| median diagnosis time per drive | {:.2} s |",
            self.median_seconds
        );
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::contract::{FindingEntry, FitEntry, ParameterEntry};

    #[test]
    fn plan_cycles_the_catalogue_and_is_deterministic() {
        let cfg = ProofConfig::default();
        let p = plan(&cfg);
        assert_eq!(p, plan(&cfg));
        assert_eq!(p.len(), 36);
        for e in Effect::ALL {
            assert_eq!(
                p.iter().filter(|c| c.hidden == Hidden::Effect(e)).count(),
                2
            );
        }
        assert_eq!(p.iter().filter(|c| c.hidden == Hidden::Nothing).count(), 2);
        assert_eq!(
            p.iter()
                .filter(|c| c.hidden == Hidden::OutOfCatalogue)
                .count(),
            2
        );
        assert!(p.iter().all(|c| c.length_km >= 3.0 && c.length_km <= 6.0));
    }

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
            2.0,
        );
        assert_eq!(s2.named, "none");
        let s3 = score(
            &case(Hidden::Nothing),
            &clean,
            &diag(Some(("aero_drag", 5.5)), Verdict::Explained),
            3.0,
        );
        let sum = summarize(&[s1, s2, s3]);
        assert_eq!(sum.named_correct, 1.0);
        assert_eq!(sum.false_positive_rate, 0.5);
        assert_eq!(sum.median_seconds, 2.0);
        assert!(sum.to_markdown().contains("| aero_drag | 1 |"));
    }
}
