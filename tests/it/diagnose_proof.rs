//! The reduced proof: the first cycle of the fixed-driving proof (docs/validation/proof.md) —
//! `fleetdyn prove --seed 1 --driving fixed`, drives 0–21: every catalogue effect once at a random
//! magnitude, four drives without effect and two with rolling resistance raised on one stretch only
//! — generated, diagnosed blind (the diagnosis reads the drive file and the nominal vehicle file;
//! the answers are written apart and only the scorer reads them) and scored.
//!
//! Asserted, case by case:
//! - the effects the full proof identifies in every cycle (docs/validation/proof.md:
//!   rolling_resistance, vehicle_mass, grade_offset, engine_torque_offset,
//!   bogie_torque_reaction, load_transfer_height, air_spring_nonlinearity, cg_position,
//!   tyre_stiffness, grade_load_transfer, driveline_compliance through the shuffle
//!   frequencies after clutch engagements, driveline_backlash through the engine's speed
//!   against the wheels at torque reversals, and clutch_slip through the engine speed while
//!   the clutch is actuated) are named first;
//! - no drive confidently names a wrong effect: a catalogue drive's first finding is its
//!   hidden effect or lists it in its ambiguity set, or the drive has no finding (an effect
//!   the recorded signals cannot identify — here the slope quantisation of case 4 — ends as
//!   `none` or `unexplained`, never as another effect);
//! - drives without effect get no finding (the false-positive target);
//! - out-of-catalogue drives get no catalogue finding and a mismatch located on the stretch;
//! - correctly named drives: every fit improves the held-out RMSE of its quoted signal, the
//!   median improvement is at least a halving, and the median parameter error (relative to
//!   the hidden change) is at most 20 %;
//! - the scorer's oracle check (the hidden effect set to its truth, nothing fitted, rules 1
//!   and 2 of the acceptance rule): every identified effect is visible to the rule, and the
//!   slope quantisation (case 4: the cure cannot restore the rounding of constant grades) is
//!   not, so no diagnosis bound by the rule could name it on this drive;
//! - the written outputs: the table, the case Parquet, `proof.json` with the plan (seed,
//!   drives, lengths, driving) that regenerates any case, one contract folder per case.
//!
//! The same cycle under the drawn driving (`fleetdyn prove --seed 1`, the default: a driver
//! drawn per drive) is pinned apart, with what it measures (docs/validation/proof.md).
//! The mechanism pins below run their cases as the fixed-driving plan made them.

use crate::common::fixture;
use fleetdyn::proof::{run_proof, CaseScore, Driving, ProofConfig, ProofRun};
use fleetdyn::report::contract::Verdict;

/// Effects these reduced inversion checks must name. The rolling resistance is not among them:
/// its model-form allowance (+44 % above, measured on the independent truth's healthy trucks,
/// whose cold tyres and wind read as rolling resistance) puts an increase of the size these
/// drives hide inside the band, where it is reported as an estimate consistent with the file;
/// the proof reports this as the inversion check's cost of the allowance
/// (docs/validation/proof.md). A rolling-resistance drive must still carry no wrong name.
const IDENTIFIED: [&str; 12] = [
    "vehicle_mass",
    "grade_offset",
    "engine_torque_offset",
    "bogie_torque_reaction",
    "load_transfer_height",
    "air_spring_nonlinearity",
    "cg_position",
    "tyre_stiffness",
    "grade_load_transfer",
    "driveline_compliance",
    "driveline_backlash",
    "clutch_slip",
];

/// Effects whose truth does not pass the acceptance rule's data tests on these drives.
const NOT_VISIBLE: [&str; 1] = ["slope_quantization"];

/// Runs the proof `cfg` with the diesel variant of the axle-load thesis truck on 2 jobs into a
/// temporary folder.
fn proof(cfg: &ProofConfig) -> (tempfile::TempDir, ProofRun) {
    let dir = tempfile::tempdir().unwrap();
    let run = run_proof(
        cfg,
        &fixture("fixtures/vehicles/seed002-6x2-diesel.toml"),
        dir.path(),
        2,
        &|_, _| {},
    )
    .unwrap();
    (dir, run)
}

/// The torque-delay reading of case `i`'s diagnosis in `dir`: `(value, ci_low, ci_high, named)`,
/// from its finding when named, else from its estimates within the band.
fn delay_reading(dir: &std::path::Path, i: usize) -> (f64, f64, f64, bool) {
    let path = dir
        .join("diagnoses")
        .join(format!("case-{i:04}"))
        .join("diagnosis.json");
    let d: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let pick = |v: &serde_json::Value| {
        (
            v["value"].as_f64().unwrap(),
            v["ci_low"].as_f64().unwrap(),
            v["ci_high"].as_f64().unwrap(),
        )
    };
    for f in d["findings"].as_array().unwrap() {
        if f["effect"] == "signal_delay" {
            let (v, lo, hi) = pick(&f["parameters"]["engine_torque_delay_s"]);
            return (v, lo, hi, true);
        }
    }
    for e in d["estimates"].as_array().unwrap() {
        if e["effect"] == "signal_delay" {
            let (v, lo, hi) = pick(e);
            return (v, lo, hi, false);
        }
    }
    panic!("case {i}: no signal_delay reading in {}", path.display());
}

/// A hidden torque delay is read within 20 % of its truth, and named exactly when its interval
/// lies above the band of acceptance rule 4 (the file's ±0.02 s widened by the catalogue's
/// model-form allowance, which the engine's own torque lag on a real truck fills): below it
/// the diagnosis reports the delay as an estimate consistent with the file.
fn assert_delay_read(dir: &std::path::Path, s: &CaseScore) {
    use fleetdyn::model::catalogue::Effect;
    use fleetdyn::model::tolerance::Tolerances;
    assert_eq!(s.hidden, "signal_delay");
    let truth = s.truth_value.unwrap();
    let (value, lo, hi, named) = delay_reading(dir, s.index);
    assert!(
        (value - truth).abs() <= 0.2 * truth,
        "{}: {value} s for {truth} s",
        s.index
    );
    assert!(lo <= value && value <= hi, "{}", s.index);
    let (_, band_high) = Tolerances::default().band(Effect::SignalDelay, 0.0);
    assert_eq!(
        named,
        lo > band_high,
        "{}: [{lo}, {hi}] against {band_high}",
        s.index
    );
    assert_eq!(named, s.correct, "{s:?}");
    assert_eq!(
        s.verdict,
        if named {
            Verdict::Explained
        } else {
            Verdict::NoSignificantMismatch
        },
        "{s:?}"
    );
    assert!(s.findings.is_empty() || named, "{s:?}");
}

#[test]
fn reduced_proof_names_the_identifiable_effects_and_nothing_else() {
    let (dir, run) = proof(&ProofConfig {
        drives: 22,
        driving: Driving::Fixed,
        ..ProofConfig::model()
    });
    println!("{}", run.summary.to_markdown());
    assert!(run.failed.is_empty(), "{:#?}", run.failed);
    assert_eq!(run.scores.len(), 22);
    let mut ratios = Vec::new();
    let mut errors = Vec::new();
    for s in &run.scores {
        let case = format!(
            "case {} ({}, {}): {:?}",
            s.index, s.hidden, s.rules, s.findings
        );
        if let Some(gain) = s.oracle_heldout_gain {
            if IDENTIFIED.contains(&s.hidden) {
                assert_eq!(s.oracle_visible, Some(true), "{case}: oracle gain {gain}");
            }
            if NOT_VISIBLE.contains(&s.hidden) {
                assert!(gain < 0.25, "{case}: oracle gain {gain}");
                assert_eq!(s.oracle_visible, Some(false), "{case}");
            }
        } else {
            assert!(matches!(s.hidden, "none" | "out_of_catalogue"), "{case}");
        }
        match s.hidden {
            "none" => assert!(s.findings.is_empty(), "false positive: {case}"),
            "out_of_catalogue" => {
                assert!(s.findings.is_empty(), "{case}");
                assert_eq!(s.out_of_catalogue_located, Some(true), "{case}");
            }
            h => {
                if IDENTIFIED.contains(&h) {
                    assert!(s.correct, "not identified: {case}");
                }
                assert!(
                    s.correct || s.ambiguous_correct || s.findings.is_empty(),
                    "a wrong effect named: {case}"
                );
                if s.correct {
                    assert_eq!(s.verdict, Verdict::Explained, "{case}");
                    let r = s.heldout_ratio.unwrap();
                    assert!(r < 1.0, "{case}: held-out ratio {r}");
                    ratios.push(r);
                    errors.push(s.parameter_error.unwrap());
                }
            }
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    assert!(median(ratios.clone()) <= 0.5, "{ratios:?}");
    assert!(median(errors.clone()) <= 0.2, "{errors:?}");
    // the written outputs: the table, the case Parquet, one contract folder per case
    assert!(std::fs::read_to_string(dir.path().join("proof.md"))
        .unwrap()
        .contains("| hidden \\ named |"));
    assert!(dir.path().join("proof_cases.parquet").exists());
    // proof.json records the plan (seed, drives, lengths): enough to regenerate any case
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("proof.json")).unwrap())
            .unwrap();
    assert_eq!(written["seed"], 1);
    assert_eq!(written["drives"], 22);
    assert_eq!(written["length_km"], serde_json::json!([3.0, 6.0]));
    assert_eq!(written["driving"], "fixed");
    for s in &run.scores {
        assert!(dir
            .path()
            .join(format!("diagnoses/case-{:04}/diagnosis.json", s.index))
            .exists());
    }
    // the effects named through an events view (a few engagements or reversals, whose
    // deviance uses their known variances, fit::Evaluator::deviance): the 95 % interval of the
    // written finding holds the hidden value (in the first cycle: case 6's lash, 3 reversals;
    // case 7's shaft stiffness)
    let mut checked = 0;
    for s in run
        .scores
        .iter()
        .filter(|s| s.correct && matches!(s.hidden, "driveline_backlash" | "driveline_compliance"))
    {
        let path = dir
            .path()
            .join(format!("diagnoses/case-{:04}/diagnosis.json", s.index));
        let d: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        let params = d["findings"][0]["parameters"].as_object().unwrap();
        let (name, p) = params.iter().next().unwrap();
        let (lo, hi) = (
            p["ci_low"].as_f64().unwrap(),
            p["ci_high"].as_f64().unwrap(),
        );
        let truth = s.truth_value.unwrap();
        assert!(
            lo <= truth && truth <= hi,
            "case {} {}: {name} 95 % CI {lo}…{hi} misses the hidden {truth}",
            s.index,
            s.hidden
        );
        checked += 1;
    }
    assert_eq!(checked, 2, "case 6 (lash) and case 7 (stiffness) are named");
}

/// Effects the drawn-driving cycle (`fleetdyn prove --seed 1`, drives 0–21) names first:
/// [`IDENTIFIED`] but for the three whose drawn drives leave them unnamed (below), and the
/// torque delay.
fn identified_drawn(hidden: &str) -> bool {
    const UNNAMED: [&str; 3] = ["driveline_compliance", "driveline_backlash", "clutch_slip"];
    hidden == "signal_delay" || (IDENTIFIED.contains(&hidden) && !UNNAMED.contains(&hidden))
}

/// The first cycle under the drawn driving (`fleetdyn prove --seed 1`, drives 0–21: the same roads,
/// effects and magnitudes as the fixed-driving cycle above, each drive with its own driver —
/// acceleration, braking, speed holding, torque tips, lift-offs, stop time). Measured
/// (docs/validation/proof.md, drawn driving): ten effects named first (case 1's
/// rolling-resistance change lies inside its band: [`IDENTIFIED`]), aero drag named as
/// `grade_offset` with itself in the ambiguity set, no clean or out-of-catalogue drive with a
/// finding. What the drawn driving costs is pinned as a ratchet (these assertions hold while it
/// stays, and still hold when it is mended): the slope quantisation of case 4 (invisible to the
/// rule at its truth: oracle gain 0.23) is read as a `grade_offset` — the one wrong name of the
/// cycle; case 9's worn clutch (−37 %) is visible at its truth (oracle gain 0.93) but no rung of
/// the screen's ladder removes 10 % of the train error, so it ends without a finding; the lash of
/// case 6 and the stiffness of case 7 do not pass the rule even at their truth on these drives'
/// driving.
#[test]
fn reduced_proof_with_drawn_driving_names_ten_effects_and_nothing_on_clean_drives() {
    let (dir, run) = proof(&ProofConfig {
        drives: 22,
        ..ProofConfig::model()
    });
    println!("{}", run.summary.to_markdown());
    assert!(run.failed.is_empty(), "{:#?}", run.failed);
    assert_eq!(run.scores.len(), 22);
    let (mut ratios, mut errors, mut wrong) = (Vec::new(), Vec::new(), Vec::new());
    let mut identified = 0;
    for s in &run.scores {
        let case = format!(
            "case {} ({}, {}): {:?}",
            s.index, s.hidden, s.rules, s.findings
        );
        match s.hidden {
            "none" => {
                assert!(s.findings.is_empty(), "false positive: {case}");
                assert_eq!(s.verdict, Verdict::NoSignificantMismatch, "{case}");
            }
            "out_of_catalogue" => {
                assert!(s.findings.is_empty(), "{case}");
                assert_eq!(s.out_of_catalogue_located, Some(true), "{case}");
            }
            h => {
                if identified_drawn(h) {
                    assert!(s.correct, "not identified: {case}");
                    assert_eq!(s.oracle_visible, Some(true), "{case}");
                    identified += 1;
                }
                if !(s.correct || s.ambiguous_correct || s.findings.is_empty()) {
                    wrong.push(s.index);
                }
                if s.correct {
                    let r = s.heldout_ratio.unwrap();
                    assert!(r < 1.0, "{case}: held-out ratio {r}");
                    ratios.push(r);
                    errors.push(s.parameter_error.unwrap());
                }
            }
        }
    }
    assert_eq!(identified, 10);
    // aero drag: named as the grade offset it cannot be told from on this drive, itself in
    // the ambiguity set
    assert!(run.scores[0].correct || run.scores[0].ambiguous_correct);
    // at most case 4's slope quantisation is named as another effect
    assert!(wrong.iter().all(|&i| i == 4), "wrong names: {wrong:?}");
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    assert!(median(ratios.clone()) <= 0.5, "{ratios:?}");
    assert!(median(errors.clone()) <= 0.2, "{errors:?}");
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("proof.json")).unwrap())
            .unwrap();
    assert_eq!(written["driving"], "drawn");
    assert!(std::fs::read_to_string(dir.path().join("proof.md"))
        .unwrap()
        .contains("--driving drawn"));
    let cases = std::fs::File::open(dir.path().join("proof_cases.parquet")).unwrap();
    let meta = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(cases)
        .unwrap()
        .schema()
        .metadata()
        .clone();
    assert_eq!(meta.get("driving").map(String::as_str), Some("drawn"));
}

/// Four drives of the proof's later cycles, run exactly as in the whole plan
/// (`--cases 27,48,49,60`): case 27 hides a torque-signal delay whose four torque reversals all
/// fall in training blocks, so that only the engine speed while the clutch is actuated shows
/// it on held-out data (`diagnose::problem::Problem::with_actuation`); case 49 a delay whose
/// fit removes a fast error and leaves the sensors' slow drift, which a normalised whiteness
/// measure reads as worse even at the truth (`diagnose::explain`, rule 2); case 60 is a clean
/// city drive whose slope noise a plain median of the sensor's lattice steps puts 10 % low,
/// enough for a window of ordinary noise to test as a mismatch (`diagnose::noise` reads the
/// steps as grouped data); case 48 hides a 1.47 % slope sensor on a city road, named because
/// the cure keeps what the sensor's noise says about where in its cell the grade lies
/// (`signal::dequantise`: no median, cells widened by the noise; a cure that takes a median
/// first leaves the slope further from the road than the recording and the held-out error
/// worse). Both delays are read within 20 % and named only when their interval leaves the
/// band of acceptance rule 4 ([`assert_delay_read`]).
#[test]
fn delays_are_read_a_coarse_slope_sensor_is_named_and_a_clean_city_drive_has_no_mismatch() {
    let (dir, run) = proof(&ProofConfig {
        only: vec![27, 48, 49, 60],
        driving: Driving::Fixed,
        ..ProofConfig::model()
    });
    assert!(run.failed.is_empty(), "{:#?}", run.failed);
    let by = |i: usize| run.scores.iter().find(|s| s.index == i).unwrap();
    for i in [27, 49] {
        let delay = by(i);
        assert_delay_read(dir.path(), delay);
        assert_eq!(delay.oracle_visible, Some(true), "{delay:?}");
        if delay.correct {
            assert!(delay.heldout_ratio.unwrap() < 1.0, "{delay:?}");
        }
    }
    let clean = by(60);
    assert_eq!(clean.hidden, "none");
    assert!(clean.findings.is_empty(), "{clean:?}");
    assert_eq!(clean.verdict, Verdict::NoSignificantMismatch, "{clean:?}");
    // the slope sensor: named first, its held-out error lower by at least the acceptance
    // rule's 25 % (bound 0.75: what acceptance itself requires; measured: ratio 0.53, the
    // truth's rule-1 gain 0.29)
    let slope = by(48);
    assert_eq!(slope.hidden, "slope_quantization");
    assert!(slope.correct, "{:?}", slope.findings);
    assert_eq!(slope.verdict, Verdict::Explained, "{slope:?}");
    assert!(slope.heldout_ratio.unwrap() < 0.75, "{slope:?}");
    assert_eq!(slope.oracle_visible, Some(true), "{slope:?}");
    // scored against the noise-free speed instead of the recording: the sensor's step is read
    // off the recording, so the fitted value is the truth and both noise-free ratios are the
    // same simulation (equal to rounding; measured 0.53 and 0.53, the recording's 0.53)
    let (fitted, truth) = (
        slope
            .noise_free_heldout_ratio
            .expect("the quoted speed has a noise-free twin"),
        slope.noise_free_truth_ratio.expect("a catalogue drive"),
    );
    assert!((fitted - truth).abs() < 1e-9, "{slope:?}");
    assert!(fitted < 1.0, "{slope:?}");
    // no finding, no fitted ratio
    assert_eq!(clean.noise_free_heldout_ratio, None, "{clean:?}");
    assert_eq!(clean.noise_free_truth_ratio, None, "{clean:?}");
    assert_eq!(run.scores.len(), 4);
}

/// A large torque-signal delay (`fleetdyn prove --seed 1001 --cases 27`: 0.356 s hidden) is
/// fitted in its own basin: the cost in the delay has side basins about 0.05 s wide, and a fit
/// started from no delay stops in one at 0.27 s (23 % of the delay off); the fit starts from
/// the best point of a 25 ms grid (`model::catalogue::DELAY_GRID_S`).
#[test]
fn a_large_delay_is_fitted_in_its_own_basin() {
    let (_dir, run) = proof(&ProofConfig {
        seed: 1001,
        only: vec![27],
        driving: Driving::Fixed,
        ..ProofConfig::model()
    });
    assert!(run.failed.is_empty(), "{:#?}", run.failed);
    let delay = &run.scores[0];
    assert_eq!(delay.hidden, "signal_delay");
    assert!(delay.correct, "{:?}", delay.findings);
    // 1.0 % measured; the side basin gives 23 %, the truth's own is about ±7 % wide
    assert!(delay.parameter_error.unwrap() <= 0.05, "{delay:?}");
    assert!(delay.heldout_ratio.unwrap() < 0.5, "{delay:?}");
}

/// A worn clutch and a delayed torque signal whose responses the screen's one middle step
/// misreads (`fleetdyn prove --seed 5001 --cases 53,49`: clutch capacity 2165 N·m for 3500,
/// 0.147 s of delay): at −30 % the clutch barely slips where the truth's −38 % slips at
/// every launch (the probe's sensitivity removes 8 % of the train SSE, under the screen's
/// 10 %), and 0.2 s of delay explains 9.5 %. The screen also probes ½ and 1½ times the
/// step of these threshold and shift effects and judges them by the best rung
/// (`model::catalogue::SCREEN_LADDER`: 66 % and 22 % at −45 % and 0.3 s); both are fitted
/// within 20 %; the clutch is named and `explained`, the delay reported as an estimate within
/// the band of acceptance rule 4 (its model-form allowance, docs/diagnosis/method.md).
#[test]
fn the_screen_probes_threshold_effects_across_their_range() {
    let (dir, run) = proof(&ProofConfig {
        seed: 5001,
        only: vec![49, 53],
        driving: Driving::Fixed,
        ..ProofConfig::model()
    });
    assert!(run.failed.is_empty(), "{:#?}", run.failed);
    // the delay (0.147 s) is read within 20 %; its interval lies inside the band of rule 4,
    // so it is reported as an estimate, not named
    assert_delay_read(dir.path(), &run.scores[0]);
    let s = &run.scores[1];
    assert_eq!(s.hidden, "clutch_slip");
    assert!(s.correct, "{:?}", s.findings);
    assert_eq!(s.verdict, Verdict::Explained, "{s:?}");
    // measured 0.03 %
    assert!(s.parameter_error.unwrap() <= 0.2, "{s:?}");
    // the acceptance rule's own bound; measured 0.16
    assert!(s.heldout_ratio.unwrap() < 0.75, "{s:?}");
    assert_eq!(run.scores.len(), 2);
}

/// Two worn clutches with side basins in their cost (`fleetdyn prove --seed 1 --cases 31` and
/// `--seed 1001 --cases 31`, drawn driving: 2660 and 2629 N·m for 3500). The cost in the
/// capacity is a staircase of basins about 3 % of it wide, and the secant from the screen's
/// probe ends at 3017 and 3092 N·m, both rejected by the rule. The fit starts from the best
/// point of a grid of 50 … 100 % of the nominal capacity in 1.5 % steps
/// (`model::catalogue::CLUTCH_GRID`); both drives are named.
#[test]
fn a_worn_clutch_is_fitted_in_its_own_basin() {
    for seed in [1, 1001] {
        // measured 1.6 % (seed 1: 2673 N·m) and 1.9 % (seed 1001: 2613 N·m) of the hidden
        // change; the side basins lie 42 % and 53 % off. 10 % of these changes (85 N·m) is
        // less than one basin's width, so the bound holds only in the truth's own basin.
        named_worn_clutch(
            &ProofConfig {
                seed,
                only: vec![31],
                driving: Driving::Drawn,
                ..ProofConfig::model()
            },
            0.75,
        );
    }
}

/// Runs the one worn-clutch case `cfg` selects and asserts it is named first and explained,
/// its capacity within 10 % of the hidden change (less than one basin of the cost's
/// staircase, `a_worn_clutch_is_fitted_in_its_own_basin`) and its held-out ratio below
/// `max_heldout_ratio`; returns its score.
fn named_worn_clutch(cfg: &ProofConfig, max_heldout_ratio: f64) -> CaseScore {
    let (_dir, run) = proof(cfg);
    assert!(run.failed.is_empty(), "{:#?}", run.failed);
    let s = run.scores[0].clone();
    assert_eq!(s.hidden, "clutch_slip");
    assert!(s.correct, "seed {}: {:?}", cfg.seed, s.findings);
    assert_eq!(s.verdict, Verdict::Explained, "{s:?}");
    assert!(s.parameter_error.unwrap().abs() <= 0.1, "{s:?}");
    assert!(s.heldout_ratio.unwrap() < max_heldout_ratio, "{s:?}");
    s
}

/// The two worn clutches the 3–6 km proof sees at their truth and misses (`fleetdyn prove --seed 2`
/// and `--seed 9001`, case 9, drawn driving: fits of 2210 and 2275 N·m for 2131 and 2365 hidden,
/// each on the wrong side of a held-out event's slip threshold), on the drives the same plans give
/// at 10–20 km (`--min-km 10 --max-km 20`: 16.6 and 15.1 km). There the diagnosis names both
/// (docs/validation/proof.md: at 10–20 km every worn clutch visible at its truth is named, 20 of
/// 20).
#[test]
fn worn_clutches_missed_on_short_drives_are_named_on_longer_ones() {
    for seed in [2, 9001] {
        // measured 1.0 % (seed 2) and 0.17 % (seed 9001) of the hidden change; the held-out
        // bound is the proof's target, RMSE at least halved (measured 0.038 and 0.027)
        let s = named_worn_clutch(
            &ProofConfig {
                seed,
                only: vec![9],
                length_km: (10.0, 20.0),
                driving: Driving::Drawn,
                ..ProofConfig::model()
            },
            0.5,
        );
        assert!(s.length_m > 10_000.0, "{s:?}");
    }
}

/// One slope-quantisation drive of the proof, named: its score and its `detail.json`.
fn named_slope_case(seed: u64, case: usize, driving: Driving) -> (CaseScore, serde_json::Value) {
    let (dir, run) = proof(&ProofConfig {
        seed,
        only: vec![case],
        driving,
        ..ProofConfig::model()
    });
    assert!(run.failed.is_empty(), "{:#?}", run.failed);
    let s = run.scores[0].clone();
    assert_eq!(s.hidden, "slope_quantization");
    assert!(s.correct, "{:?}", s.findings);
    assert_eq!(s.verdict, Verdict::Explained, "{s:?}");
    let detail: serde_json::Value = serde_json::from_reader(
        std::fs::File::open(
            dir.path()
                .join(format!("diagnoses/case-{case:04}/detail.json")),
        )
        .unwrap(),
    )
    .unwrap();
    (s, detail)
}

/// A whole-percent slope sensor whose rounding shows mostly in the training blocks, where the
/// road crosses its steps (`fleetdyn prove --seed 9001 --cases 48`, drawn driving). The cure
/// is a switch (nothing fitted), so rules 1 and 2 score it on every row, and only on the
/// views it moves (`diagnose::explain`, "Which views the rule scores"): the speeds, not the
/// torque reversals, which it moves by a weighted mean square of 4·10⁻⁴. On the held-out
/// part alone its speeds fall by 17 % and with the reversals averaged in by less; on every
/// row of the speeds by 44 %, and the drive is named.
#[test]
fn a_switch_is_scored_on_every_row_of_the_views_it_moves() {
    let (_, detail) = named_slope_case(9001, 48, Driving::Drawn);
    let ev = &detail["explanation"]["findings"][0]["evidence"];
    let view = |kind: &str| {
        ev["models"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["view"] == kind)
            .unwrap_or_else(|| panic!("no {kind} view in {ev}"))
            .clone()
    };
    let (speeds, reversals) = (view("speeds"), view("reversals"));
    assert_eq!(speeds["scored"], true, "{ev}");
    assert_eq!(reversals["scored"], false, "{ev}");
    // weighted mean squares from the weighted RMSEs the evidence lists
    let ms = |m: &serde_json::Value, k: &str| m[k].as_f64().unwrap().powi(2);
    let gain = |after: f64, before: f64| 1.0 - (after / before).sqrt();
    let every_row = gain(
        ms(&speeds, "train_after") + ms(&speeds, "heldout_after"),
        ms(&speeds, "train_before") + ms(&speeds, "heldout_before"),
    );
    let heldout = gain(ms(&speeds, "heldout_after"), ms(&speeds, "heldout_before"));
    let diluted = gain(
        ms(&speeds, "heldout_after") + ms(&reversals, "heldout_after"),
        ms(&speeds, "heldout_before") + ms(&reversals, "heldout_before"),
    );
    // rule 1's figure is the speeds' on every row (the same sums, so to rounding)
    let rule1 = ev["heldout_gain"].as_f64().unwrap();
    assert!((rule1 - every_row).abs() < 1e-9, "{rule1} {every_row}");
    // measured 0.44, 0.17 and 0.03: every row passes the 25 % of rule 1, neither held-out
    // figure does
    assert!(every_row >= 0.25, "{ev}");
    assert!(heldout < 0.25, "{ev}");
    assert!(diluted < heldout, "{ev}");
}

/// A slope sensor's rounding whose reconstruction the train blocks barely see
/// (`fleetdyn prove --seed 5001 --cases 26 --driving fixed`): the cure (a switch, nothing
/// fitted) lowers the held-out weighted RMSE of the speeds by more than half and the held-out
/// whiteness. With nothing fitted, rule 3 tests the switch on both parts
/// (`diagnose::explain`, rule 3): the drive is named, and the held-out part's
/// likelihood-ratio statistic is the larger (measured 10.4 against the train part's 4.9, the
/// threshold 3.84). The screen takes a switch on every row too, with no threshold
/// (`diagnose::fit`), so a drive whose train part sees little of the cure still has it tested.
#[test]
fn a_switch_is_tested_on_every_row() {
    let (s, detail) = named_slope_case(5001, 26, Driving::Fixed);
    // the acceptance rule's own bound; measured 0.31
    assert!(s.heldout_ratio.unwrap() < 0.75, "{s:?}");
    let ev = &detail["explanation"]["findings"][0]["evidence"];
    let train = ev["deviance_at_start"].as_f64().unwrap();
    let heldout = ev["deviance_heldout_at_start"].as_f64().unwrap();
    let threshold = ev["deviance_threshold"].as_f64().unwrap();
    assert!(train + heldout > threshold, "{ev}");
    assert!(heldout > train, "{ev}");
}
