//! The proof (issue 7 point 6, diagnosis.md "Proof"): synthetic drives with one concealed effect
//! each — every catalogue effect, random magnitudes within the generator's realistic ranges,
//! different roads and driving — plus drives with no effect and drives with an effect outside
//! the catalogue; the diagnosis runs blind on each (it sees the drive and the nominal vehicle
//! file, never the answer) and is scored against the answers kept apart.
//!
//! # Plan
//! Case `i` of a proof with seed `S` has the drive seed `S + i`. Effects cycle through the
//! catalogue with extra slots per cycle: [`ProofConfig::clean_per_cycle`] drives without effect
//! (4 by default, so that the false-positive rate is measured on more than a handful) and
//! [`ProofConfig::out_of_catalogue_per_cycle`] with the out-of-catalogue stretch of extra
//! rolling resistance (2), so `22 k` drives hold every effect `k` times. The road rule set is drawn per case (highway-se, freeway-us, city-se, urban-us
//! with weights 3:3:2:2 — fleet trucks drive mostly on highways), the length uniformly in
//! [`ProofConfig::length_km`]. The driving is drawn per case too ([`Driving::Drawn`],
//! [`drive_config`]): how briskly the driver accelerates and brakes, how tightly they hold the
//! speed, how much their foot varies the torque, how often they lift off while driving on, and
//! how long they stand at a stop. Every drive has the real-log conditions of issue 7 point 7:
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
//! - held-out: the first finding's held-out RMSE after/before per signal of the effect's
//!   domain, the most improved (the quoted signal) and the least;
//! - noise-free held-out: the quoted signal's ratio again, scored against the generator's
//!   noise-free signal instead of the recording, with the fitted value and with the hidden
//!   truth ([`CaseScore::noise_free_heldout_ratio`], [`CaseScore::noise_free_truth_ratio`]):
//!   it tells a drive whose ratio the recording's noise holds up from one no fit of the effect
//!   could halve on the recorded inputs;
//! - out-of-catalogue drives pass when the verdict is `unexplained` or a mismatch overlaps the
//!   stretch without any catalogue effect being named.

use super::catalogue::{Domain, Effect};
use super::contract::{Diagnosis, Verdict};
use crate::model::vehicle::VehicleFile;
use crate::road::rng::Xoshiro256StarStar;
use crate::synth::can::Dropouts;
use crate::synth::drive::{synth_drive, DriveConfig, DriveError, HiddenEffect};
use crate::synth::driver::{DriverConfig, LiftOffs};
use crate::synth::effects::{EffectChoice, Injection, ResistanceStretch};
use crate::table::DriveLog;
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
    /// Drives without an effect in each cycle of the plan.
    pub clean_per_cycle: usize,
    /// Drives with the out-of-catalogue effect in each cycle of the plan.
    pub out_of_catalogue_per_cycle: usize,
    /// How the drives' driving is chosen.
    pub driving: Driving,
    /// Plan indices to run (each drive exactly as in the whole plan); empty: all `drives`.
    /// An index at or past `drives` matches no case and runs nothing (`fleetdyn prove --cases`
    /// rejects it with exit 2).
    pub only: Vec<usize>,
}

impl Default for ProofConfig {
    /// 66 drives: three cycles of every effect once, four clean drives and two with the
    /// out-of-catalogue effect (48 + 12 + 6), seed 1, 3–6 km, dropouts starting with
    /// probability 0.001 per message, 0.3 s long on average.
    fn default() -> Self {
        Self {
            drives: 66,
            seed: 1,
            length_km: (3.0, 6.0),
            dropouts: Dropouts {
                start_probability: 0.001,
                mean_length_s: 0.3,
            },
            clean_per_cycle: 4,
            out_of_catalogue_per_cycle: 2,
            driving: Driving::Drawn,
            only: Vec::new(),
        }
    }
}

/// How a proof's drives are driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Driving {
    /// One driver for every drive: the generator's default [`DriverConfig`] (0.8 m/s² up,
    /// 1.2 m/s² down, k_v = 0.5 1/s, ±5 % tips, 8 s at a stop, no lift-offs) — the proofs of
    /// the README's tables dated before the drawn driving (`fleetdyn prove --driving fixed`).
    Fixed,
    /// A driver drawn per case from its drive seed ([`drawn_driver`]).
    Drawn,
}

impl Driving {
    /// The `--driving` value.
    pub fn label(self) -> &'static str {
        match self {
            Driving::Fixed => "fixed",
            Driving::Drawn => "drawn",
        }
    }
}

/// PRNG stream of the drawn driving (xored into the drive seed).
const DRIVING_STREAM: u64 = 0x6472_6976_696E_6721;

/// The driver of a proof drive with seed `seed` under [`Driving::Drawn`]: the generator's
/// default driver with, drawn uniformly from the drive seed's own stream,
/// - comfortable acceleration 0.5–1.2 m/s² (a loaded truck's gentle start to a brisk one;
///   at 1.2 m/s² the 18.7 t seed 002 truck reaches cruise in its top gear at full torque,
///   `fleetdyn prove --seed 1` case 38) and deceleration 0.9–1.5 m/s²;
/// - speed-error gain 0.3–0.8 1/s;
/// - tip amplitude ±3 % to ±20 % of the torque demand;
/// - lift-offs ([`LiftOffs`]) every 20–120 s on average (each interval 0.5–1.5 times the
///   drive's mean), 1–4 s long, above 5 m/s;
/// - 5–20 s standing at each stop.
///
/// Only the driver changes: roads, stops, effects and their magnitudes, the sensors and their
/// noise draw from their own streams and are the same under either [`Driving`].
pub fn drawn_driver(seed: u64) -> DriverConfig {
    let mut rng = Xoshiro256StarStar::seed_from_u64(seed ^ DRIVING_STREAM);
    let mean_lift_s = rng.uniform(20.0, 120.0);
    DriverConfig {
        accel_mps2: rng.uniform(0.5, 1.2),
        decel_mps2: rng.uniform(0.9, 1.5),
        speed_gain_per_s: rng.uniform(0.3, 0.8),
        tip_fraction: rng.uniform(0.03, 0.2),
        stop_dwell_s: rng.uniform(5.0, 20.0),
        lift_offs: Some(LiftOffs {
            interval_s: (0.5 * mean_lift_s, 1.5 * mean_lift_s),
            duration_s: (1.0, 4.0),
            min_speed_mps: 5.0,
        }),
        ..DriverConfig::default()
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
            let cycle = Effect::ALL.len() + cfg.clean_per_cycle + cfg.out_of_catalogue_per_cycle;
            let slot = i % cycle.max(1);
            let hidden = match Effect::ALL.get(slot) {
                Some(e) => Hidden::Effect(*e),
                None if slot < Effect::ALL.len() + cfg.clean_per_cycle => Hidden::Nothing,
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
    /// The generator's noise-free signals (kept apart like the answer; the scorer's
    /// [`CaseScore::noise_free_heldout_ratio`] reads them).
    pub signals: crate::synth::can::Truth,
}

/// The generator settings of `case`'s drive: a fine (0.1 %) slope sensor, `cfg`'s dropouts, the
/// driver of [`ProofConfig::driving`] and a stop every 1–3 km (by the drive seed), so every
/// drive has standstills and launches.
pub fn drive_config(case: &ProofCase, cfg: &ProofConfig) -> DriveConfig {
    let driver = match cfg.driving {
        Driving::Fixed => DriverConfig::default(),
        Driving::Drawn => drawn_driver(case.seed),
    };
    let mut dc = DriveConfig {
        slope_resolution: 0.001,
        dropouts: Some(cfg.dropouts),
        driver,
        ..DriveConfig::default()
    };
    dc.driver.stop_every_m = Some(1000.0 + (case.seed % 3) as f64 * 1000.0);
    dc
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
    let r = synth_drive(
        vehicle,
        case.rules,
        case.length_km,
        case.seed,
        &dir,
        &drive_config(case, cfg),
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
        signals: crate::synth::drive::drive_truth(&r.drive, r.axles.as_ref()),
    })
}

/// The score of one diagnosed drive.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaseScore {
    /// Plan index.
    pub index: usize,
    /// Drive seed.
    pub seed: u64,
    /// Road rule set.
    pub rules: &'static str,
    /// Road length, m.
    pub length_m: f64,
    /// Drive duration, s.
    pub drive_s: f64,
    /// Hidden (label).
    pub hidden: &'static str,
    /// Named (label).
    pub named: String,
    /// All accepted findings' effects, in order.
    pub findings: Vec<String>,
    /// Verdict.
    pub verdict: Verdict,
    /// The hidden effect is named first.
    pub correct: bool,
    /// The hidden effect is in the first finding's ambiguity set.
    pub ambiguous_correct: bool,
    /// The hidden parameter's nominal value (catalogue effects).
    pub nominal_value: Option<f64>,
    /// Its truth.
    pub truth_value: Option<f64>,
    /// The fitted value (correctly named drives).
    pub fitted_value: Option<f64>,
    /// Parameter error relative to the hidden change (catalogue effects named correctly).
    pub parameter_error: Option<f64>,
    /// Held-out RMSE after/before of the first finding on the signal of the effect's own model
    /// that improved most (the signal its sentence quotes).
    pub heldout_ratio: Option<f64>,
    /// The same on the signal of the effect's own model that improved least.
    pub heldout_ratio_worst: Option<f64>,
    /// Out-of-catalogue: unexplained or located on the stretch without a catalogue name.
    pub out_of_catalogue_ok: Option<bool>,
    /// Out-of-catalogue: a located mismatch overlaps the stretch.
    pub out_of_catalogue_located: Option<bool>,
    /// Diagnosis wall time, s.
    pub seconds: f64,
    /// Catalogue effects: the held-out gain of the effect's own model with the hidden truth
    /// set, nothing fitted ([`super::explain::oracle_check`], computed after the blind
    /// diagnosis, outside its time).
    pub oracle_heldout_gain: Option<f64>,
    /// Catalogue effects: rules 1 and 2 of the acceptance rule hold at the truth — the
    /// recorded signals show the effect to the rule on this drive.
    pub oracle_visible: Option<bool>,
    /// [`Self::heldout_ratio`] measured against the generator's noise-free signals instead of
    /// the recording ([`super::explain::fits_against`]): the first finding's fitted value, its
    /// own model, the same rows and held-out blocks, the same (quoted) signal — when that
    /// signal is recorded directly (speed, engine speed also on the clutch-actuated rows,
    /// bellow pressures); `None` when it is an event view's (shuffle frequency, reversal
    /// speed), which has no noise-free twin. Only the outputs' noise is taken away:
    /// the models still run on the recorded, noisy inputs. The recording's ratio cannot fall
    /// below about `σ/RMSE_before` for an output sensor's noise `σ`; this one is bounded only
    /// by what the recorded inputs leave unknown. Computed after the blind diagnosis, outside
    /// its time; `None` without a finding.
    pub noise_free_heldout_ratio: Option<f64>,
    /// Catalogue effects: the same ratio with the hidden effect set to its truth instead of a
    /// fitted value (what a perfect fit would show against the noise-free signals, on the
    /// recorded inputs): on the quoted signal when the first finding names the hidden effect,
    /// else on the most improved directly recorded signal of its own model.
    pub noise_free_truth_ratio: Option<f64>,
    /// Generator attempts (more than 1 when the drive was drawn again, see [`run_proof`]).
    pub attempts: u32,
}

/// Scores the diagnosis `d` of a drive whose answer is `truth`; `drive_s` is the drive's
/// duration.
pub fn score(
    case: &ProofCase,
    truth: &ProofTruth,
    d: &Diagnosis,
    drive_s: f64,
    seconds: f64,
) -> CaseScore {
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
    let fitted_value = match (correct, truth.injection, first) {
        (true, Some(inj), Some(f)) => f.parameters.get(inj.effect.parameter()).map(|p| p.value),
        _ => None,
    };
    let parameter_error = match (fitted_value, truth.injection) {
        (Some(v), Some(inj)) => {
            let change = (inj.truth - inj.nominal).abs();
            Some((v - inj.truth).abs() / change.max(f64::MIN_POSITIVE))
        }
        _ => None,
    };
    // the first finding's own model: axle effects change the bellow pressures
    let ratios: Vec<f64> = first
        .and_then(|f| {
            let e = Effect::from_id(&f.effect).ok()?;
            Some(own_ratios(e, &f.fit, contract_held).map(|r| r.1).collect())
        })
        .unwrap_or_default();
    let heldout_ratio = ratios.iter().copied().reduce(f64::min);
    let heldout_ratio_worst = ratios.iter().copied().reduce(f64::max);
    let out_of_catalogue_located = truth.stretch.map(|st| {
        d.mismatch
            .iter()
            .any(|m| m.start_m < st.end_m && m.end_m > st.start_m)
    });
    let out_of_catalogue_ok = out_of_catalogue_located
        .map(|located| d.verdict == Verdict::Unexplained || (located && d.findings.is_empty()));
    CaseScore {
        index: case.index,
        seed: case.seed,
        rules: case.rules,
        length_m: case.length_km * 1000.0,
        drive_s,
        hidden,
        named,
        findings: d.findings.iter().map(|f| f.effect.clone()).collect(),
        verdict: d.verdict,
        correct,
        ambiguous_correct,
        nominal_value: truth.injection.map(|i| i.nominal),
        truth_value: truth.injection.map(|i| i.truth),
        fitted_value,
        parameter_error,
        heldout_ratio,
        heldout_ratio_worst,
        out_of_catalogue_ok,
        out_of_catalogue_located,
        seconds,
        oracle_heldout_gain: None,
        oracle_visible: None,
        noise_free_heldout_ratio: None,
        noise_free_truth_ratio: None,
        attempts: 1,
    }
}

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

/// Why a proof could not run at all (a failing case only fails that case).
#[derive(Debug, thiserror::Error)]
pub enum ProveError {
    /// The vehicle file.
    #[error(transparent)]
    Vehicle(#[from] crate::model::vehicle::VehicleError),
    /// The thread pool.
    #[error("thread pool: {0}")]
    Pool(String),
    /// Writing the proof's own outputs.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Writing the case table.
    #[error(transparent)]
    Output(#[from] crate::io::OutputError),
}

/// Seed stride between the attempts of one case.
pub const RESEED_STRIDE: u64 = 1_000_003;
/// Attempts to generate a case whose log ingest rejects.
pub const MAX_ATTEMPTS: u32 = 3;

/// A whole proof run.
#[derive(Debug, Clone, Serialize)]
pub struct ProofRun {
    /// Seed.
    pub seed: u64,
    /// Drives of the plan (`--drives`).
    pub drives: usize,
    /// Shortest and longest drive of the plan, km (`--min-km`, `--max-km`): with the seed
    /// they regenerate any case's drive.
    pub length_km: (f64, f64),
    /// How the drives were driven (`--driving`): with the seed and the lengths it regenerates
    /// any case's drive.
    pub driving: Driving,
    /// Worker threads.
    pub jobs: usize,
    /// Scored cases, in plan order.
    pub scores: Vec<CaseScore>,
    /// Cases that failed.
    pub failed: Vec<FailedCase>,
    /// Figures.
    pub summary: ProofSummary,
}

enum CaseOutcome {
    Scored(Box<CaseScore>),
    Failed(FailedCase),
}

/// Generates, diagnoses blind and scores one case; the diagnosis is written to
/// `out/diagnoses/case-NNNN/`.
fn run_case(case: &ProofCase, vehicle: &Path, cfg: &ProofConfig, out: &Path) -> CaseOutcome {
    use super::run::{diagnose, write_outputs, DiagnoseConfig};
    let fail = |stage, error: String| {
        CaseOutcome::Failed(FailedCase {
            index: case.index,
            hidden: case.hidden.label(),
            stage,
            error,
        })
    };
    // a drive whose own CAN log ingest rejects (a dropout longer than ingest's 2 s limit on a
    // required channel — it would fail a nightly run the same way) is drawn again with the
    // next seed of its own sequence, so the plan keeps its mix of effects
    let mut attempt: u32 = 0;
    let g = loop {
        let mut c = case.clone();
        c.seed = case.seed + u64::from(attempt) * RESEED_STRIDE;
        match generate(&c, vehicle, cfg, &out.join("drives"), &out.join("answers")) {
            Ok(g) => break g,
            Err(
                DriveError::Can(crate::synth::can::SynthError::Ingest(_))
                | DriveError::Export(crate::synth::export::ExportError::Ingest { .. }),
            ) if attempt + 1 < MAX_ATTEMPTS => {
                attempt += 1;
            }
            Err(e) => return fail("generate", e.to_string()),
        }
    };
    // blind from here: the drive file and the nominal vehicle file beside it
    let t0 = std::time::Instant::now();
    // the contract, the actuated rows' null variance (the oracle's view weights), the log and
    // the vehicle
    type BlindResult = (Diagnosis, Option<Vec<f64>>, DriveLog, VehicleFile);
    let diagnosed = (|| -> Result<BlindResult, String> {
        let vf = VehicleFile::load(&g.vehicle).map_err(|e| e.to_string())?;
        let opts = crate::pipeline::ingest_stage::IngestConfig::default()
            .options(&[], Some(&vf))
            .map_err(|e| e.to_string())?;
        let log = crate::ingest::ingest_file(&g.drive, &opts)
            .map_err(|e| e.to_string())?
            .log;
        let d = diagnose(&log, &vf, &DiagnoseConfig::default()).map_err(|e| e.to_string())?;
        let dir = out
            .join("diagnoses")
            .join(format!("case-{:04}", case.index));
        write_outputs(&dir, &d, &log, "fleetdyn prove").map_err(|e| e.to_string())?;
        Ok((d.diagnosis, d.actuation_variance, log, vf))
    })();
    let seconds = t0.elapsed().as_secs_f64();
    match diagnosed {
        Ok((d, act, log, vf)) => {
            // the scorer's own look, with the answer: could the rule see the hidden effect,
            // and what did the finding do against the noise-free signals?
            match scorer_look(&log, &vf, &d, act.as_deref(), &g) {
                Ok(look) => CaseOutcome::Scored(Box::new(CaseScore {
                    attempts: attempt + 1,
                    oracle_heldout_gain: look.oracle.as_ref().map(|o| o.heldout_gain),
                    oracle_visible: look.oracle.as_ref().map(|o| o.visible()),
                    noise_free_heldout_ratio: look.noise_free_fitted,
                    noise_free_truth_ratio: look.noise_free_truth,
                    ..score(&g.case, &g.truth, &d, log.duration_s(), seconds)
                })),
                Err(e) => fail("oracle", e),
            }
        }
        Err(e) => fail("diagnose", e),
    }
}

/// What the scorer finds with the answer, after the blind diagnosis ([`scorer_look`]).
struct ScorerLook {
    /// [`super::explain::oracle_check`] of the hidden effect at its truth.
    oracle: Option<super::explain::OracleCheck>,
    /// [`CaseScore::noise_free_heldout_ratio`].
    noise_free_fitted: Option<f64>,
    /// [`CaseScore::noise_free_truth_ratio`].
    noise_free_truth: Option<f64>,
}

/// The scorer's look at a diagnosed drive, with the problem the diagnosis built (same setup,
/// split and views): [`super::explain::oracle_check`] of the hidden effect at its truth,
/// weighted by the diagnosis' noise floor, and its noise-free ratio (catalogue effects); the
/// first finding's noise-free ratio (drives with a finding).
fn scorer_look(
    log: &DriveLog,
    vf: &VehicleFile,
    d: &Diagnosis,
    actuation_variance: Option<&[f64]>,
    g: &GeneratedCase,
) -> Result<ScorerLook, String> {
    let setup = super::setup::Setup::new(log, vf).map_err(|e| e.to_string())?;
    let problem = setup
        .problem(log, actuation_variance)
        .map_err(|e| e.to_string())?;
    // slope_quantization's parameter is the sensor resolution the cure reconstructs with
    // (extended.rs), its nominal the model's assumed 0.1 % (setup.rs): the truth is a value
    let oracle = match g.truth.injection {
        Some(inj) => Some(
            super::explain::oracle_check(&problem, Some(&d.noise_floor), inj.effect, inj.truth)
                .map_err(|e| e.to_string())?
                .ok_or_else(|| {
                    format!("{}: its model is not in use on this drive", inj.effect.id())
                })?,
        ),
        None => None,
    };
    let reference = noise_free_reference(log, &g.signals);
    // against the noise-free reference: the ratio of `signal`, or without one the most
    // improved own-model signal
    let ratio = |e: Effect, value: f64, signal: Option<&str>| -> Result<Option<f64>, String> {
        let fits = super::explain::fits_against(&problem, e, value, &reference)
            .map_err(|err| err.to_string())?;
        Ok(
            own_ratios(e, &fits, |m| (m.heldout_before, m.heldout_after))
                .filter(|(sig, _)| signal.is_none_or(|q| q == *sig))
                .map(|(_, r)| r)
                .reduce(f64::min),
        )
    };
    // the first finding, its value and the signal the proof scores it on (the quoted one)
    let first = d.findings.first().and_then(|f| {
        let e = Effect::from_id(&f.effect).ok()?;
        let value = f.parameters.get(e.parameter())?.value;
        let quoted = own_ratios(e, &f.fit, contract_held)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(sig, _)| sig.to_string())?;
        Some((e, value, quoted))
    });
    let noise_free_fitted = match &first {
        Some((e, value, quoted)) => ratio(*e, *value, Some(quoted))?,
        None => None,
    };
    let noise_free_truth = match (g.truth.injection, &first) {
        (Some(inj), Some((e, _, quoted))) if *e == inj.effect => {
            ratio(inj.effect, inj.truth, Some(quoted))?
        }
        (Some(inj), _) => ratio(inj.effect, inj.truth, None)?,
        (None, _) => None,
    };
    Ok(ScorerLook {
        oracle,
        noise_free_fitted,
        noise_free_truth,
    })
}

/// `(signal, held-out RMSE after/before)` of the signals of `e`'s own model in `fits` (axle
/// effects: the bellow pressures; longitudinal: the others) with a non-zero error before —
/// what [`score`] takes its held-out ratios from; `held` reads an entry's held-out RMSE
/// `(before, after)`.
fn own_ratios<T>(
    e: Effect,
    fits: &BTreeMap<String, T>,
    held: fn(&T) -> (f64, f64),
) -> impl Iterator<Item = (&str, f64)> {
    let axle = e.domain() == Domain::Axle;
    fits.iter()
        .filter(move |(sig, _)| sig.starts_with("bellow_pressure") == axle)
        .map(move |(sig, m)| (sig.as_str(), held(m)))
        .filter(|(_, (before, _))| *before > 0.0)
        .map(|(sig, (before, after))| (sig, after / before))
}

/// The held-out RMSE `(before, after)` of a contract fit entry.
fn contract_held(m: &super::contract::FitEntry) -> (f64, f64) {
    (m.heldout_before, m.heldout_after)
}

/// The signals a diagnosis compares that the generator knows without noise (the recorded
/// speed, engine speed and bellow pressures, and the engine speed again as the clutch view's
/// [`super::compare::ACTUATION_CHANNEL`]), on the rows of `log`: the truth `signals` read at
/// each row's time (linear between the truth's samples; the log's clock starts at
/// [`crate::synth::drive::DRIVE_START_NS`] = the truth's 0 s). The reference
/// [`super::explain::fits_against`] takes to score a fit against the noise-free signals;
/// `signals` from [`crate::synth::drive::drive_truth`].
pub fn noise_free_reference(
    log: &DriveLog,
    signals: &crate::synth::can::Truth,
) -> BTreeMap<String, Vec<f64>> {
    const COMPARED: [&str; 5] = [
        "vehicle_speed",
        "engine_speed",
        "bellow_pressure_front",
        "bellow_pressure_rear",
        "bellow_pressure_tag",
    ];
    let mut reference: BTreeMap<String, Vec<f64>> = signals
        .columns
        .iter()
        .filter(|(name, _)| COMPARED.contains(&name.as_str()))
        .map(|(name, y)| {
            let values = log
                .timestamp_ns
                .iter()
                .map(|&ns| {
                    let t = (ns - crate::synth::drive::DRIVE_START_NS) as f64 * 1e-9;
                    crate::signal::interp_linear(&signals.t_s, y, t)
                })
                .collect();
            (name.clone(), values)
        })
        .collect();
    if let Some(engine) = reference.get("engine_speed").cloned() {
        reference.insert(super::compare::ACTUATION_CHANNEL.to_string(), engine);
    }
    reference
}

/// Runs the proof of `cfg` with the vehicle file `vehicle` into `out` on `jobs` threads:
/// `out/drives/` (generated drives), `out/answers/` (kept apart), `out/diagnoses/` (one
/// contract folder per case), `out/proof.md`, `out/proof.json` and `out/proof_cases.parquet`.
/// `progress` is called after each case (from a worker thread). A case whose generated log
/// ingest rejects is drawn again with seed `seed + k·`[`RESEED_STRIDE`], up to
/// [`MAX_ATTEMPTS`] in all; the case table shows the seed used.
///
/// # Errors
/// [`ProveError`] when the run cannot start or its summary cannot be written; a case that fails
/// is recorded in [`ProofRun::failed`].
pub fn run_proof(
    cfg: &ProofConfig,
    vehicle: &Path,
    out: &Path,
    jobs: usize,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<ProofRun, ProveError> {
    use rayon::prelude::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    crate::model::vehicle::VehicleFile::load(vehicle)?;
    let cases: Vec<ProofCase> = plan(cfg)
        .into_iter()
        .filter(|c| cfg.only.is_empty() || cfg.only.contains(&c.index))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.max(1))
        .build()
        .map_err(|e| ProveError::Pool(e.to_string()))?;
    let done = AtomicUsize::new(0);
    let outcomes: Vec<CaseOutcome> = pool.install(|| {
        cases
            .par_iter()
            .with_max_len(1)
            .map(|c| {
                let o = run_case(c, vehicle, cfg, out);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, cases.len());
                o
            })
            .collect()
    });
    let mut scores = Vec::new();
    let mut failed = Vec::new();
    for o in outcomes {
        match o {
            CaseOutcome::Scored(s) => scores.push(*s),
            CaseOutcome::Failed(f) => failed.push(f),
        }
    }
    let summary = summarize(&scores, &failed);
    let run = ProofRun {
        seed: cfg.seed,
        drives: cfg.drives,
        length_km: cfg.length_km,
        driving: cfg.driving,
        jobs,
        scores,
        failed,
        summary,
    };
    write_proof(out, cfg, &run)?;
    Ok(run)
}

fn write_proof(out: &Path, cfg: &ProofConfig, run: &ProofRun) -> Result<(), ProveError> {
    use crate::io::{write_table, AtomicFile, OutColumn, OutData, TableMeta};
    let io = |path: PathBuf| move |source| ProveError::Io { path, source };
    let md = format!(
        "# Diagnosis proof\n\n`fleetdyn prove --drives {} --seed {} --min-km {} --max-km {} \
         --driving {}{}`: \
         {} synthetic drives, each hiding one catalogue effect (random magnitude), nothing, or \
         the out-of-catalogue stretch of extra rolling resistance; diagnosed blind.\n\n{}\n\
         ## Cases\n\n{}",
        cfg.drives,
        cfg.seed,
        cfg.length_km.0,
        cfg.length_km.1,
        cfg.driving.label(),
        if cfg.only.is_empty() {
            String::new()
        } else {
            format!(
                " --cases {}",
                cfg.only
                    .iter()
                    .map(|i| i.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            )
        },
        run.summary.drives,
        run.summary.to_markdown(),
        cases_markdown(&run.scores, &run.failed)
    );
    let p = out.join("proof.md");
    AtomicFile::write_all(&p, md.as_bytes()).map_err(io(p.clone()))?;
    let mut json = serde_json::to_string_pretty(run).expect("plain data serialises");
    json.push('\n');
    let p = out.join("proof.json");
    AtomicFile::write_all(&p, json.as_bytes()).map_err(io(p.clone()))?;
    let sc = &run.scores;
    let f = |g: &dyn Fn(&CaseScore) -> f64| sc.iter().map(g).collect::<Vec<f64>>();
    let o = |x: Option<f64>| x.unwrap_or(f64::NAN);
    let b = |x: bool| if x { 1.0 } else { 0.0 };
    let st = |g: &dyn Fn(&CaseScore) -> String| OutData::Str(sc.iter().map(g).collect());
    let cols = vec![
        OutColumn {
            name: "case".into(),
            unit: "1".into(),
            data: OutData::U64(sc.iter().map(|c| c.index as u64).collect()),
        },
        OutColumn {
            name: "seed".into(),
            unit: "1".into(),
            data: OutData::U64(sc.iter().map(|c| c.seed).collect()),
        },
        OutColumn {
            name: "rules".into(),
            unit: "1".into(),
            data: st(&|c| c.rules.to_string()),
        },
        OutColumn::f64("length_m", "m", f(&|c| c.length_m)),
        OutColumn::f64("drive_s", "s", f(&|c| c.drive_s)),
        OutColumn {
            name: "hidden".into(),
            unit: "1".into(),
            data: st(&|c| c.hidden.to_string()),
        },
        OutColumn {
            name: "named".into(),
            unit: "1".into(),
            data: st(&|c| c.named.clone()),
        },
        OutColumn {
            name: "findings".into(),
            unit: "1".into(),
            data: st(&|c| c.findings.join(",")),
        },
        OutColumn {
            name: "verdict".into(),
            unit: "1".into(),
            data: st(&|c| c.verdict.as_str().to_string()),
        },
        OutColumn {
            name: "correct".into(),
            unit: "1".into(),
            data: OutData::I16(f(&|c| b(c.correct))),
        },
        OutColumn {
            name: "ambiguous_correct".into(),
            unit: "1".into(),
            data: OutData::I16(f(&|c| b(c.ambiguous_correct))),
        },
        OutColumn::f64(
            "nominal_value",
            "per row: see parameter",
            f(&|c| o(c.nominal_value)),
        ),
        OutColumn::f64(
            "truth_value",
            "per row: see parameter",
            f(&|c| o(c.truth_value)),
        ),
        OutColumn::f64(
            "fitted_value",
            "per row: see parameter",
            f(&|c| o(c.fitted_value)),
        ),
        OutColumn::f64("parameter_error", "1", f(&|c| o(c.parameter_error))),
        OutColumn::f64("heldout_ratio", "1", f(&|c| o(c.heldout_ratio))),
        OutColumn::f64("heldout_ratio_worst", "1", f(&|c| o(c.heldout_ratio_worst))),
        OutColumn::f64(
            "noise_free_heldout_ratio",
            "1",
            f(&|c| o(c.noise_free_heldout_ratio)),
        ),
        OutColumn::f64(
            "noise_free_truth_ratio",
            "1",
            f(&|c| o(c.noise_free_truth_ratio)),
        ),
        OutColumn {
            name: "out_of_catalogue_ok".into(),
            unit: "1".into(),
            data: OutData::I16(f(&|c| c.out_of_catalogue_ok.map_or(f64::NAN, b))),
        },
        OutColumn {
            name: "out_of_catalogue_located".into(),
            unit: "1".into(),
            data: OutData::I16(f(&|c| c.out_of_catalogue_located.map_or(f64::NAN, b))),
        },
        OutColumn::f64("oracle_heldout_gain", "1", f(&|c| o(c.oracle_heldout_gain))),
        OutColumn {
            name: "oracle_visible".into(),
            unit: "1".into(),
            data: OutData::I16(f(&|c| c.oracle_visible.map_or(f64::NAN, b))),
        },
        OutColumn::f64("diagnosis_s", "s", f(&|c| c.seconds)),
    ];
    let meta = TableMeta {
        table: "proof_cases".into(),
        drive_id: format!("proof-seed-{}", cfg.seed),
        vehicle_id: None,
        source_file: "fleetdyn prove".into(),
        config_hash: crate::io::config_hash(&[format!("{cfg:?}").as_bytes()]),
        // with the seed and the plan's lengths (proof.json) it regenerates any case's drive
        extra: vec![("driving".into(), cfg.driving.label().into())],
    };
    write_table(&out.join("proof_cases.parquet"), &meta, &cols)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::contract::{FindingEntry, FitEntry, ParameterEntry};

    #[test]
    fn drawn_drivers_are_the_seeds_own_and_within_their_ranges() {
        let drivers: Vec<DriverConfig> = (1..200).map(drawn_driver).collect();
        assert_eq!(drivers[0], drawn_driver(1));
        for d in &drivers {
            assert!((0.5..=1.2).contains(&d.accel_mps2));
            assert!((0.9..=1.5).contains(&d.decel_mps2));
            assert!((0.3..=0.8).contains(&d.speed_gain_per_s));
            assert!((0.03..=0.2).contains(&d.tip_fraction));
            assert!((5.0..=20.0).contains(&d.stop_dwell_s));
            let l = d.lift_offs.unwrap();
            assert!(l.interval_s.0 >= 10.0 && l.interval_s.1 <= 180.0);
            assert_eq!(l.interval_s.1, 3.0 * l.interval_s.0);
            // everything else is the generator's default driver
            assert_eq!(d.stop_every_m, DriverConfig::default().stop_every_m);
            assert_eq!(d.retarder, DriverConfig::default().retarder);
        }
        // the drives differ: brisk and gentle, nervous and steady feet
        let (lo, hi) = drivers.iter().fold((f64::MAX, 0.0_f64), |(lo, hi), d| {
            (lo.min(d.accel_mps2), hi.max(d.accel_mps2))
        });
        assert!(lo < 0.6 && hi > 1.1, "{lo}…{hi}");
        // the fixed driving is the default driver, whatever the seed
        let case = plan(&ProofConfig::default())[5].clone();
        let fixed = ProofConfig {
            driving: Driving::Fixed,
            ..ProofConfig::default()
        };
        assert_eq!(drive_config(&case, &fixed).driver.accel_mps2, 0.8);
        assert_eq!(drive_config(&case, &fixed).driver.lift_offs, None);
        assert_eq!(
            drive_config(&case, &ProofConfig::default())
                .driver
                .stop_every_m,
            drive_config(&case, &fixed).driver.stop_every_m
        );
    }

    #[test]
    fn plan_cycles_the_catalogue_and_is_deterministic() {
        let cfg = ProofConfig::default();
        let p = plan(&cfg);
        assert_eq!(p, plan(&cfg));
        assert_eq!(p.len(), 66);
        for e in Effect::ALL {
            assert_eq!(
                p.iter().filter(|c| c.hidden == Hidden::Effect(e)).count(),
                3
            );
        }
        assert_eq!(p.iter().filter(|c| c.hidden == Hidden::Nothing).count(), 12);
        assert_eq!(
            p.iter()
                .filter(|c| c.hidden == Hidden::OutOfCatalogue)
                .count(),
            6
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
}
