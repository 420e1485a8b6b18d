//! The proof's drives: one synthetic drive per case, from the truth the proof is run on
//! ([`TruthSource`]), its answer kept apart from the files the diagnosis reads.

use super::*;
use crate::model::catalogue::Effect;
use crate::model::vehicle::VehicleFile;
use crate::synth::drive::{synth_drive, DriveConfig, DriveError, HiddenEffect};
use crate::synth::driver::DriverConfig;
use crate::synth::effects::{EffectChoice, Injection};
use crate::truth::{Concealed, IndependentDriveConfig, OutOfCatalogue, TruthEffect, TruthError};
use serde::Serialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a proof drive could not be generated.
#[derive(Debug, Error)]
pub enum GenerateError {
    /// The model-based generator failed.
    #[error(transparent)]
    Model(Box<DriveError>),
    /// The independent truth failed.
    #[error(transparent)]
    Independent(#[from] TruthError),
    /// The vehicle file could not be read.
    #[error(transparent)]
    Vehicle(#[from] crate::model::vehicle::VehicleError),
    /// The answer could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

impl GenerateError {
    /// The drive's own CAN log was rejected by ingest (a dropout longer than ingest's limit on
    /// a required channel): the case may be drawn again with another seed.
    pub fn is_ingest_rejection(&self) -> bool {
        use crate::synth::can::SynthError;
        matches!(
            self,
            GenerateError::Independent(TruthError::Can(SynthError::Ingest(_)))
        ) || matches!(
            self,
            GenerateError::Model(e) if matches!(
                **e,
                DriveError::Can(SynthError::Ingest(_))
                    | DriveError::Export(crate::synth::export::ExportError::Ingest { .. })
            )
        )
    }
}

/// A stretch of road an out-of-catalogue effect acts on, m of travelled distance.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Stretch {
    /// Start, m.
    pub start_m: f64,
    /// End, m.
    pub end_m: f64,
}

/// The answer of a generated proof drive.
#[derive(Debug, Clone, PartialEq)]
pub struct ProofTruth {
    /// What was hidden.
    pub hidden: Hidden,
    /// The injection, for a catalogue effect.
    pub injection: Option<Injection>,
    /// The stretch, for an out-of-catalogue effect.
    pub stretch: Option<Stretch>,
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

/// Generates `case` with the vehicle of `vehicle` from `cfg`'s truth: the drive into
/// `drives_dir/<index>/`, the answer into `answers_dir/<index>.json`.
///
/// # Errors
/// [`GenerateError`] from the generator.
pub fn generate(
    case: &ProofCase,
    vehicle: &Path,
    cfg: &ProofConfig,
    drives_dir: &Path,
    answers_dir: &Path,
) -> Result<GeneratedCase, GenerateError> {
    let name = format!("case-{:04}", case.index);
    let dir = drives_dir.join(&name);
    let answer = answers_dir.join(format!("{name}.json"));
    match cfg.truth {
        TruthSource::Model => generate_model(case, vehicle, cfg, &dir, &answer)
            .map_err(|e| GenerateError::Model(Box::new(e))),
        TruthSource::Independent => generate_independent(case, vehicle, cfg, &dir, &answer),
    }
}

/// [`generate`] on the independent truth (the drive into `dir`, the answer into `answer`): the truck drawn around the vehicle file within
/// its tolerances, the case's concealed effect, `cfg`'s CAN dropouts; logged, ingested and
/// written as the model-based drives are.
fn generate_independent(
    case: &ProofCase,
    vehicle: &Path,
    cfg: &ProofConfig,
    dir: &Path,
    answer: &Path,
) -> Result<GeneratedCase, GenerateError> {
    let vf = VehicleFile::load(vehicle)?;
    let effect = match case.hidden {
        Hidden::Nothing => TruthEffect::None,
        Hidden::Effect(e) => TruthEffect::Catalogue(e.id().to_string(), None),
        Hidden::OutOfCatalogue(kind) => TruthEffect::OutOfCatalogue(match kind {
            Outside::WetSurface | Outside::LocalRollingResistance => OutOfCatalogue::WetSurface,
            Outside::StuckSpeedSensor => OutOfCatalogue::StuckSpeedSensor,
            Outside::HiddenRetarder => OutOfCatalogue::HiddenRetarder,
        }),
    };
    let mut drive = crate::truth::simulate_independent_drive(
        &vf,
        &IndependentDriveConfig {
            effect,
            wind: cfg.wind,
            warm_tyres: cfg.warm_tyres,
            ..IndependentDriveConfig::new(case.rules, case.length_km, case.seed)
        },
    )?;
    drive.bus = drive.bus.clone().with_dropouts(cfg.dropouts);
    crate::truth::write_independent_drive(&drive, vehicle, dir, case.seed)?;
    // the answer goes apart from the drive's folder, which the diagnosis reads
    let beside = dir.join("answer.json");
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| GenerateError::Io { path, source }
    };
    if let Some(answers_dir) = answer.parent() {
        std::fs::create_dir_all(answers_dir).map_err(io(answers_dir))?;
    }
    std::fs::rename(&beside, answer).map_err(io(answer))?;
    let (injection, stretch) = match &drive.concealed {
        Concealed::None => (None, None),
        Concealed::Catalogue {
            id, nominal, truth, ..
        } => (
            Effect::from_id(id).ok().map(|effect| Injection {
                effect,
                nominal: *nominal,
                truth: *truth,
            }),
            None,
        ),
        Concealed::OutOfCatalogue { start_m, end_m, .. } => (
            None,
            Some(Stretch {
                start_m: *start_m,
                end_m: *end_m,
            }),
        ),
    };
    Ok(GeneratedCase {
        case: case.clone(),
        drive: dir.join("drive.parquet"),
        vehicle: dir.join("vehicle.toml"),
        answer: answer.to_path_buf(),
        truth: ProofTruth {
            hidden: case.hidden,
            injection,
            stretch,
        },
        signals: drive.truth,
    })
}

/// [`generate`] on the model truth: the drive into `dir`, the answer into `answer`.
fn generate_model(
    case: &ProofCase,
    vehicle: &Path,
    cfg: &ProofConfig,
    dir: &Path,
    answer: &Path,
) -> Result<GeneratedCase, DriveError> {
    let choice = match case.hidden {
        Hidden::Nothing => EffectChoice::None,
        Hidden::Effect(e) => EffectChoice::Given(e, None),
        Hidden::OutOfCatalogue(_) => EffectChoice::LocalRollingResistance,
    };
    let r = synth_drive(
        vehicle,
        case.rules,
        case.length_km,
        case.seed,
        dir,
        &drive_config(case, cfg),
        Some(&HiddenEffect {
            choice,
            answer_path: answer.to_path_buf(),
        }),
    )?;
    Ok(GeneratedCase {
        case: case.clone(),
        drive: r.parquet,
        vehicle: r.vehicle,
        answer: answer.to_path_buf(),
        truth: ProofTruth {
            hidden: case.hidden,
            injection: r.injection,
            stretch: r.truth.stretch.map(|st| Stretch {
                start_m: st.start_m,
                end_m: st.end_m,
            }),
        },
        signals: crate::synth::drive::drive_truth(&r.drive, r.axles.as_ref()),
    })
}
