//! The generator's truth of a proof case, for the studies that trace a residual to its
//! inputs: the drive is generated again from the proof's plan (`proof::plan`) with
//! the case's answer, so every recorded column's truth is known (the diagnosis never sees it).

use fleetdyn::proof::{drive_config, plan, Driving, ProofConfig};
use fleetdyn::signal::interp_linear;
use fleetdyn::synth::can::Truth;
use fleetdyn::synth::drive::{drive_truth, synth_drive, HiddenEffect, DRIVE_START_NS};
use fleetdyn::synth::effects::EffectChoice;
use fleetdyn::table::DriveLog;
use std::error::Error;
use std::path::Path;

/// A case's truth and where the log's rows fall on its time axis.
pub struct CaseTruth {
    /// The generator's truth.
    pub truth: Truth,
    /// Truth time of the log's first row, s.
    pub offset_s: f64,
    /// The road rules, length (km) and generator seed of the case, for a heading.
    pub heading: String,
}

impl CaseTruth {
    /// Regenerates `case` of the proof folder `dir`, whose ingested log is `log`, with its
    /// answer (`label`: the answer's label for the heading; `effect`: its catalogue effect).
    pub fn regenerate(
        dir: &Path,
        case: &str,
        log: &DriveLog,
        label: &str,
        effect: Option<(fleetdyn::model::catalogue::Effect, f64)>,
    ) -> Result<CaseTruth, Box<dyn Error>> {
        let ans: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(
            dir.join("answers").join(format!("{case}.json")),
        )?)?;
        let index: usize = case.trim_start_matches("case-").parse()?;
        let drive_seed = ans["seed"].as_u64().ok_or("answer without seed")?;
        // the plan's length range as the run recorded it (runs before it was recorded used
        // the default)
        let run: Option<serde_json::Value> = std::fs::read_to_string(dir.join("proof.json"))
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
        let length_km = run
            .as_ref()
            .and_then(|run| Some((run["length_km"][0].as_f64()?, run["length_km"][1].as_f64()?)))
            .unwrap_or(ProofConfig::model().length_km);
        // the driving as the run recorded it (runs before it was recorded drove fixed)
        let driving = match run.as_ref().and_then(|run| run["driving"].as_str()) {
            Some("drawn") => Driving::Drawn,
            _ => Driving::Fixed,
        };
        let cfg = ProofConfig {
            seed: drive_seed - index as u64,
            drives: index + 1,
            length_km,
            driving,
            ..ProofConfig::model()
        };
        let pc = plan(&cfg).pop().ok_or("empty plan")?;
        let heading = format!(
            "{case} [{label}] {} {} km seed {}",
            pc.rules, pc.length_km, pc.seed
        );
        let choice = match effect {
            Some((e, v)) => EffectChoice::Given(e, Some(v)),
            None if ans["out_of_catalogue"].is_null() => EffectChoice::None,
            None => EffectChoice::LocalRollingResistance,
        };
        let tmp = std::env::temp_dir().join(format!("proof_truth-{case}-{}", std::process::id()));
        let r = synth_drive(
            &dir.join("drives").join(case).join("vehicle.toml"),
            pc.rules,
            pc.length_km,
            pc.seed,
            &tmp,
            &drive_config(&pc, &cfg),
            Some(&HiddenEffect {
                choice,
                answer_path: tmp.join("answer.json"),
            }),
        )?;
        let truth = drive_truth(&r.drive, r.axles.as_ref());
        let _ = std::fs::remove_dir_all(&tmp);
        Ok(CaseTruth {
            truth,
            offset_s: (log.timestamp_ns[0] - DRIVE_START_NS) as f64 * 1e-9,
            heading,
        })
    }

    /// The truth of column `name` on the rows `t` (s from the log's start), read `shift_s`
    /// later (linear between the truth's samples).
    pub fn column_on(&self, name: &str, t: &[f64], shift_s: f64) -> Option<Vec<f64>> {
        let (_, y) = self.truth.columns.iter().find(|(n, _)| n == name)?;
        let off = self.offset_s + shift_s;
        Some(
            t.iter()
                .map(|&x| interp_linear(&self.truth.t_s, y, x + off))
                .collect(),
        )
    }
}
