//! Scores of one diagnosed case against its answer, and the noise-free reference they are
//! read against.

use super::*;
use crate::model::catalogue::{Domain, Effect};
use crate::report::contract::{Diagnosis, Verdict};
use crate::table::DriveLog;
use serde::Serialize;
use std::collections::BTreeMap;

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
    /// The hidden effect is in the first finding's ambiguity set, or, on a drive without a
    /// finding, in the ambiguity set of an estimate within the vehicle file's tolerance.
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
    /// set, nothing fitted ([`crate::diagnose::explain::rules_at`], computed after the blind
    /// diagnosis, outside its time).
    pub oracle_heldout_gain: Option<f64>,
    /// Catalogue effects: rules 1 and 2 of the acceptance rule hold at the truth — the
    /// recorded signals show the effect to the rule on this drive.
    pub oracle_visible: Option<bool>,
    /// [`Self::heldout_ratio`] measured against the generator's noise-free signals instead of
    /// the recording ([`crate::diagnose::explain::fits_against`]): the first finding's fitted value, its
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
    /// No-effect drives: each estimated parameter against the truck's true value
    /// ([`estimate_misses`]); empty on other drives.
    pub estimate_misses: Vec<EstimateMiss>,
}

/// One parameter estimate of a no-effect drive against the truck's true value, as a fraction
/// of the file's value θ₀ for a parameter whose tolerance is relative, else in its unit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateMiss {
    /// Catalogue id.
    pub effect: &'static str,
    /// Estimate − the truck's value.
    pub error: f64,
    /// Distance from the truck's value to the estimate's 95 % interval (0 inside it).
    pub miss: f64,
    /// How the estimate was obtained (`named`, `fitted`, `linearised`).
    pub method: &'static str,
}

/// Every continuous estimate of `rows` against the truck's true values `truck` (parameter
/// name → value, the plant's; a parameter it lacks is at the file's value): the measurement
/// behind the catalogue's model-form allowance
/// ([`crate::model::catalogue::EffectSpec::model_form`]).
pub fn estimate_misses(
    rows: &[crate::diagnose::parameter_table::ParameterRow],
    truck: &BTreeMap<String, f64>,
) -> Vec<EstimateMiss> {
    use crate::model::catalogue::Tolerance;
    rows.iter()
        .filter_map(|r| {
            let e = Effect::from_id(r.effect).ok()?;
            let scale = match e.spec().tolerance.default_tolerance() {
                Tolerance::Relative(_) if r.nominal != 0.0 => r.nominal.abs(),
                Tolerance::Absolute(_) => 1.0,
                _ => return None,
            };
            let t = truck.get(r.parameter).copied().unwrap_or(r.nominal);
            let miss = (r.ci_low - t).max(t - r.ci_high).max(0.0);
            (r.value.is_finite() && miss.is_finite()).then(|| EstimateMiss {
                effect: r.effect,
                error: (r.value - t) / scale,
                miss: miss / scale,
                method: r.method.as_str(),
            })
        })
        .collect()
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
    let ambiguous_correct = !correct
        && match first {
            Some(f) => f.ambiguous_with.iter().any(|a| a == hidden),
            None => d
                .estimates
                .iter()
                .any(|e| e.ambiguous_with.iter().any(|a| a == hidden)),
        };
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
        estimate_misses: Vec::new(),
    }
}

/// `(signal, held-out RMSE after/before)` of the signals of `e`'s own model in `fits` (axle
/// effects: the bellow pressures; longitudinal: the others) with a non-zero error before —
/// what [`score`] takes its held-out ratios from; `held` reads an entry's held-out RMSE
/// `(before, after)`.
pub(crate) fn own_ratios<T>(
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
pub(crate) fn contract_held(m: &crate::report::contract::FitEntry) -> (f64, f64) {
    (m.heldout_before, m.heldout_after)
}

/// The signals a diagnosis compares that the generator knows without noise (the recorded
/// speed, engine speed and bellow pressures, and the engine speed again as the clutch view's
/// [`crate::diagnose::rows::ACTUATION_CHANNEL`]), on the rows of `log`: the truth `signals` read at
/// each row's time (linear between the truth's samples; the log's clock starts at
/// [`crate::synth::drive::DRIVE_START_NS`] = the truth's 0 s). The reference
/// [`crate::diagnose::explain::fits_against`] takes to score a fit against the noise-free signals;
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
        reference.insert(crate::diagnose::rows::ACTUATION_CHANNEL.to_string(), engine);
    }
    reference
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::parameter_table::{EstimateMethod, ParameterRow};

    fn row(
        e: Effect,
        nominal: f64,
        value: f64,
        ci: (f64, f64),
        method: EstimateMethod,
    ) -> ParameterRow {
        ParameterRow {
            effect: e.id(),
            parameter: e.parameter(),
            unit: e.unit(),
            value,
            ci_low: ci.0,
            ci_high: ci.1,
            nominal,
            tolerance_low: f64::NAN,
            tolerance_high: f64::NAN,
            method,
            n_eff: f64::NAN,
        }
    }

    #[test]
    fn misses_are_distances_to_the_interval_relative_or_absolute_by_the_tolerance_kind() {
        let truck: BTreeMap<String, f64> = [("k_d_nm_per_rad".to_string(), 380_000.0)].into();
        let rows = [
            // relative kind: the interval 320–330 kN·m/rad misses 380 by 50 = 12.5 % of 400
            row(
                Effect::DrivelineCompliance,
                400_000.0,
                325_000.0,
                (320_000.0, 330_000.0),
                EstimateMethod::Named,
            ),
            // absolute kind, the truck at the file's 0 s: the interval 0.06–0.09 s misses by 0.06
            row(
                Effect::SignalDelay,
                0.0,
                0.07,
                (0.06, 0.09),
                EstimateMethod::Fitted,
            ),
            // an interval holding the truck's value misses by 0
            row(
                Effect::VehicleMass,
                40_000.0,
                40_500.0,
                (39_000.0, 42_000.0),
                EstimateMethod::Linearised,
            ),
            // a switch has no continuous value
            row(
                Effect::SlopeQuantization,
                0.01,
                0.02,
                (0.02, 0.02),
                EstimateMethod::Named,
            ),
        ];
        let m = estimate_misses(&rows, &truck);
        assert_eq!(m.len(), 3);
        assert_eq!(m[0].effect, "driveline_compliance");
        assert!((m[0].miss - 0.125).abs() < 1e-12 && (m[0].error + 0.1375).abs() < 1e-12);
        assert_eq!(m[0].method, "named");
        assert!((m[1].miss - 0.06).abs() < 1e-12 && (m[1].error - 0.07).abs() < 1e-12);
        assert_eq!(m[2].miss, 0.0);
        assert!((m[2].error - 0.0125).abs() < 1e-12);
    }
}
