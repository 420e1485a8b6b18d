//! Running a proof: every case generated, diagnosed blind and scored, in parallel; the
//! results written.

use super::score::{contract_held, estimate_misses, own_ratios};
use super::*;
use crate::model::catalogue::Effect;
use crate::model::vehicle::VehicleFile;
use crate::report::contract::{assemble, Diagnosis};
use crate::table::DriveLog;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
    /// A saved proof that cannot be read back.
    #[error("{path}: {message}")]
    Saved {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
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
    /// Where the drives' truth came from (`--truth`).
    pub truth: TruthSource,
    /// Wind on the independent truth's drives (false with `--calm`, a study, not the proof).
    pub wind: bool,
    /// Tyres warm at the start of the independent truth's drives (true with `--warm-tyres`, a
    /// study, not the proof).
    pub warm_tyres: bool,
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
    use crate::diagnose::run::{diagnose, DiagnoseConfig};
    use crate::report::diagnosis_files::write_outputs;
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
            Err(e) if e.is_ingest_rejection() && attempt + 1 < MAX_ATTEMPTS => {
                attempt += 1;
            }
            Err(e) => return fail("generate", e.to_string()),
        }
    };
    // blind from here: the drive file and the nominal vehicle file beside it
    let t0 = std::time::Instant::now();
    // the contract, the actuated rows' null variance (the oracle's view weights), the log and
    // the vehicle
    type BlindResult = (
        Diagnosis,
        Option<Vec<f64>>,
        DriveLog,
        VehicleFile,
        Vec<crate::diagnose::parameter_table::ParameterRow>,
    );
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
        Ok((assemble(&d), d.actuation_variance, log, vf, d.parameters))
    })();
    let seconds = t0.elapsed().as_secs_f64();
    match diagnosed {
        Ok((d, act, log, vf, rows)) => {
            // no-effect drives: every estimate against the truck's true values
            let estimate_misses = if g.truth.hidden == Hidden::Nothing {
                match truck_values(&g.answer) {
                    Ok(truck) => estimate_misses(&rows, &truck),
                    Err(e) => return fail("answer", e),
                }
            } else {
                Vec::new()
            };
            // the scorer's own look, with the answer: could the rule see the hidden effect,
            // and what did the finding do against the noise-free signals?
            match scorer_look(&log, &vf, &d, act.as_deref(), &g) {
                Ok(look) => CaseOutcome::Scored(Box::new(CaseScore {
                    attempts: attempt + 1,
                    oracle_heldout_gain: look.oracle.as_ref().map(|o| o.heldout_gain),
                    oracle_visible: look.oracle.as_ref().map(|o| o.both_hold()),
                    noise_free_heldout_ratio: look.noise_free_fitted,
                    noise_free_truth_ratio: look.noise_free_truth,
                    estimate_misses,
                    ..score(&g.case, &g.truth, &d, log.duration_s(), seconds)
                })),
                Err(e) => fail("oracle", e),
            }
        }
        Err(e) => fail("diagnose", e),
    }
}

/// The truck's true parameter values from an answer file's `params` (the truth plant's drawn
/// truck; empty for a model-truth answer, whose truck is the file's).
fn truck_values(answer: &Path) -> Result<BTreeMap<String, f64>, String> {
    let text = std::fs::read_to_string(answer).map_err(|e| format!("{}: {e}", answer.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", answer.display()))?;
    Ok(v.get("params")
        .and_then(|p| p.as_object())
        .map(|m| {
            m.iter()
                .filter_map(|(k, x)| Some((k.clone(), x.as_f64()?)))
                .collect()
        })
        .unwrap_or_default())
}

/// What the scorer finds with the answer, after the blind diagnosis ([`scorer_look`]).
struct ScorerLook {
    /// [`crate::diagnose::explain::rules_at`] of the hidden effect at its truth.
    oracle: Option<crate::diagnose::explain::RulesAt>,
    /// [`CaseScore::noise_free_heldout_ratio`].
    noise_free_fitted: Option<f64>,
    /// [`CaseScore::noise_free_truth_ratio`].
    noise_free_truth: Option<f64>,
}

/// The scorer's look at a diagnosed drive, with the problem the diagnosis built (same setup,
/// split and views): [`crate::diagnose::explain::rules_at`] of the hidden effect at its truth,
/// weighted by the diagnosis' noise floor, and its noise-free ratio (catalogue effects); the
/// first finding's noise-free ratio (drives with a finding).
fn scorer_look(
    log: &DriveLog,
    vf: &VehicleFile,
    d: &Diagnosis,
    actuation_variance: Option<&[f64]>,
    g: &GeneratedCase,
) -> Result<ScorerLook, String> {
    let setup = crate::diagnose::setup::Setup::new(log, vf).map_err(|e| e.to_string())?;
    let problem = setup
        .problem(log, actuation_variance)
        .map_err(|e| e.to_string())?;
    // slope_quantization's parameter is the sensor resolution the cure reconstructs with
    // (extended.rs), its nominal the vehicle file's `[sensors]` resolution (setup.rs): the
    // truth is a value
    let oracle = match g.truth.injection {
        Some(inj) => Some(
            crate::diagnose::explain::rules_at(
                &problem,
                Some(&d.noise_floor),
                inj.effect,
                inj.truth,
            )
            .map_err(|e| e.to_string())?
            .ok_or_else(|| format!("{}: its model is not in use on this drive", inj.effect.id()))?,
        ),
        None => None,
    };
    let reference = noise_free_reference(log, &g.signals);
    // against the noise-free reference: the ratio of `signal`, or without one the most
    // improved own-model signal
    let ratio = |e: Effect, value: f64, signal: Option<&str>| -> Result<Option<f64>, String> {
        let fits = crate::diagnose::explain::fits_against(&problem, e, value, &reference)
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
    crate::model::vehicle::VehicleFile::load(vehicle)?;
    let cases: Vec<ProofCase> = plan(cfg)
        .into_iter()
        .filter(|c| cfg.only.is_empty() || cfg.only.contains(&c.index))
        .collect();
    let outcomes: Vec<CaseOutcome> =
        super::workers::on_workers(jobs, &cases, |c| run_case(c, vehicle, cfg, out), &|k| {
            progress(k, cases.len())
        })
        .map_err(ProveError::Pool)?;
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
        truth: cfg.truth,
        wind: cfg.wind,
        warm_tyres: cfg.warm_tyres,
        jobs,
        scores,
        failed,
        summary,
    };
    write_proof(out, cfg, &run)?;
    Ok(run)
}

/// The sentence that marks a study run (`--calm`, `--warm-tyres`) as not the proof; empty for
/// the proof itself.
fn study_sentence(cfg: &ProofConfig) -> String {
    let mut parts = Vec::new();
    if !cfg.wind {
        parts.push("calm (no mean wind, no gusts)");
    }
    if cfg.warm_tyres {
        parts.push("driven on tyres that start warm");
    }
    if parts.is_empty() {
        String::new()
    } else {
        format!(
            " The drives are {}: a study of what that physics costs the diagnosis, not the \
             proof.",
            parts.join(" and ")
        )
    }
}

fn write_proof(out: &Path, cfg: &ProofConfig, run: &ProofRun) -> Result<(), ProveError> {
    use crate::io::{write_table, AtomicFile, OutColumn, OutData, TableMeta};
    let io = |path: PathBuf| move |source| ProveError::Io { path, source };
    let md = format!(
        "# Diagnosis proof\n\n`fleetdyn prove --truth {} --drives {} --seed {} --min-km {} \
         --max-km {} --driving {}{}{}{}`: \
         {} synthetic drives, each hiding one catalogue effect (random magnitude), nothing, or \
         an effect outside the catalogue on one stretch; diagnosed blind. {}{}\n\n{}\n\
         ## Cases\n\n{}",
        cfg.truth.label(),
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
        if cfg.wind { "" } else { " --calm" },
        if cfg.warm_tyres { " --warm-tyres" } else { "" },
        run.summary.drives,
        match cfg.truth {
            TruthSource::Independent => {
                "The drives come from the independent truth plant, which shares no code with \
                 the models the diagnosis fits; the truck's parameters are drawn around the \
                 vehicle file within its tolerances on every drive."
            }
            TruthSource::Model => {
                "The drives come from the diagnosis's own extended model: this is an \
                 inversion check, not a proof."
            }
        },
        study_sentence(cfg),
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
        config_hash: crate::io::config_hash(&[crate::io::canonical("proof:v2", cfg).as_bytes()]),
        // with the seed and the plan's lengths (proof.json) it regenerates any case's drive
        extra: vec![("driving".into(), cfg.driving.label().into())],
    };
    write_table(&out.join("proof_cases.parquet"), &meta, &cols)?;
    Ok(())
}
