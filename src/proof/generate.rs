//! The proof's drives: one synthetic drive per case, its answer kept apart.

use super::*;
use crate::synth::drive::{synth_drive, DriveConfig, DriveError, HiddenEffect};
use crate::synth::driver::DriverConfig;
use crate::synth::effects::{EffectChoice, Injection, ResistanceStretch};
use std::path::{Path, PathBuf};

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
