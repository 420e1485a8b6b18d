//! The diagnosis output contract (docs/diagnosis/contract.md): `diagnosis.json` and the same
//! content as two Parquet tables for fleet-wide queries (`mismatch.parquet`, `findings.parquet`,
//! schemas/outputs/{mismatch,findings}.toml), assembled from a diagnosis's structured result
//! ([`assemble`]) with the plain sentences of [`super::sentences`]. Field names are part of the
//! contract; units are SI and named in every parameter entry.

use super::sentences::{consistent_sentence, finding_sentence};
pub use crate::diagnose::explain::Verdict;
use crate::diagnose::explain::{ConsistentEstimate, Finding};
use crate::diagnose::locate::Mismatch;
use crate::diagnose::parameter_table::{parameter_columns, ParameterRow};
use crate::diagnose::run::Diagnosed;
use crate::diagnose::{resistance_stretch, reversal_channel};
use crate::io::{config_hash, write_table, AtomicFile, OutColumn, OutData, OutputError, TableMeta};
use crate::model::catalogue::Effect;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// One located mismatch: a stretch of one signal above its noise floor.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MismatchEntry {
    /// Canonical column.
    pub signal: String,
    /// Start, s from the drive's first row.
    pub start_s: f64,
    /// End, s.
    pub end_s: f64,
    /// Start, m travelled.
    pub start_m: f64,
    /// End, m travelled.
    pub end_m: f64,
    /// Frequency band carrying most of the residual power, Hz.
    pub band_hz: [f64; 2],
    /// Operating condition in words.
    pub condition: String,
    /// RMS of the residual in the stretch, in the signal's unit.
    pub rms_residual: f64,
    /// Significance: the family-wise corrected p-value of the stretch (smaller is stronger).
    pub significance: f64,
}

/// A fitted parameter with its confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ParameterEntry {
    /// Fitted value.
    pub value: f64,
    /// Lower end of the confidence interval.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
    /// SI unit.
    pub unit: &'static str,
}

/// Before/after error of one signal.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FitEntry {
    /// Training part, nominal model.
    pub train_before: f64,
    /// Training part, with the finding.
    pub train_after: f64,
    /// Held-out part, nominal model.
    pub heldout_before: f64,
    /// Held-out part, with the finding.
    pub heldout_after: f64,
    /// The metric (`rmse`).
    pub metric: &'static str,
}

/// One accepted finding.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FindingEntry {
    /// Catalogue id.
    pub effect: String,
    /// Catalogue ids that explain the data equally well with the available signals.
    pub ambiguous_with: Vec<String>,
    /// One plain sentence with the parameter and its unit.
    pub sentence: String,
    /// Parameters by name.
    pub parameters: BTreeMap<String, ParameterEntry>,
    /// Fit per signal.
    pub fit: BTreeMap<String, FitEntry>,
}

/// `diagnosis.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnosis {
    /// Drive id.
    pub drive_id: String,
    /// Verdict.
    pub verdict: Verdict,
    /// Noise floor per signal, in the signal's unit.
    pub noise_floor: BTreeMap<String, f64>,
    /// Located mismatches.
    pub mismatch: Vec<MismatchEntry>,
    /// Accepted findings, in the order they were accepted.
    pub findings: Vec<FindingEntry>,
    /// Parameters the drive informs that the vehicle file's tolerance holds: fitted, their
    /// interval overlapping the file's tolerance band, so not named.
    pub estimates: Vec<EstimateEntry>,
}

/// A parameter estimate set against the vehicle file's tolerance band.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimateEntry {
    /// Catalogue id of the effect whose parameter it is.
    pub effect: String,
    /// Parameter name (unit in the name where it is not 1).
    pub parameter: String,
    /// Fitted value.
    pub value: f64,
    /// Lower end of the 95 % interval.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
    /// SI unit.
    pub unit: &'static str,
    /// The vehicle file's value.
    pub nominal: f64,
    /// Tolerance band, lower end.
    pub tolerance_low: f64,
    /// Tolerance band, upper end.
    pub tolerance_high: f64,
    /// The interval overlaps the band.
    pub consistent_with_file: bool,
    /// Catalogue ids that explain the data alike, each outside its own band.
    pub ambiguous_with: Vec<String>,
    /// Plain words.
    pub sentence: String,
}

impl Diagnosis {
    /// Writes `diagnosis.json` (pretty, atomically).
    ///
    /// # Errors
    /// [`OutputError`] on I/O.
    pub fn write_json(&self, path: &Path) -> Result<(), OutputError> {
        let mut text = serde_json::to_string_pretty(self).expect("plain data serialises");
        text.push('\n');
        AtomicFile::write_all(path, text.as_bytes()).map_err(|source| OutputError::Io {
            path: path.to_path_buf(),
            source,
        })
    }

    fn meta(&self, table: &str, vehicle_id: Option<&str>, source: &str, fp: &str) -> TableMeta {
        TableMeta {
            table: table.into(),
            drive_id: self.drive_id.clone(),
            vehicle_id: vehicle_id.map(str::to_string),
            source_file: source.into(),
            config_hash: config_hash(&[fp.as_bytes()]),
            extra: vec![("verdict".into(), self.verdict.as_str().into())],
        }
    }

    /// Writes `mismatch.parquet`: one row per located mismatch.
    ///
    /// # Errors
    /// [`OutputError`].
    pub fn write_mismatch(
        &self,
        path: &Path,
        vehicle_id: Option<&str>,
        source: &str,
        fp: &str,
    ) -> Result<(), OutputError> {
        let cols = self.mismatch_columns();
        write_table(path, &self.meta("mismatch", vehicle_id, source, fp), &cols)
    }

    /// The columns of `mismatch.parquet` (schema `mismatch`).
    pub fn mismatch_columns(&self) -> Vec<OutColumn> {
        let m = &self.mismatch;
        let f = |g: &dyn Fn(&MismatchEntry) -> f64| m.iter().map(g).collect::<Vec<f64>>();
        vec![
            OutColumn {
                name: "signal".into(),
                unit: "1".into(),
                data: OutData::Str(m.iter().map(|x| x.signal.clone()).collect()),
            },
            OutColumn::f64("start_s", "s", f(&|x| x.start_s)),
            OutColumn::f64("end_s", "s", f(&|x| x.end_s)),
            OutColumn::f64("start_m", "m", f(&|x| x.start_m)),
            OutColumn::f64("end_m", "m", f(&|x| x.end_m)),
            OutColumn::f64("band_low_hz", "Hz", f(&|x| x.band_hz[0])),
            OutColumn::f64("band_high_hz", "Hz", f(&|x| x.band_hz[1])),
            OutColumn {
                name: "condition".into(),
                unit: "1".into(),
                data: OutData::Str(m.iter().map(|x| x.condition.clone()).collect()),
            },
            OutColumn {
                name: "unit".into(),
                unit: "1".into(),
                data: OutData::Str(m.iter().map(|x| signal_unit(&x.signal).into()).collect()),
            },
            OutColumn::f64("rms_residual", "per row: see unit", f(&|x| x.rms_residual)),
            OutColumn::f64("significance", "1", f(&|x| x.significance)),
        ]
    }

    /// Writes `findings.parquet`: one row per finding, parameter and signal (a finding with
    /// one parameter and three compared signals gives three rows), so fleet queries can filter
    /// by effect, parameter or signal without unnesting.
    ///
    /// # Errors
    /// [`OutputError`].
    pub fn write_findings(
        &self,
        path: &Path,
        vehicle_id: Option<&str>,
        source: &str,
        fp: &str,
    ) -> Result<(), OutputError> {
        let cols = self.findings_columns();
        write_table(path, &self.meta("findings", vehicle_id, source, fp), &cols)
    }

    /// Writes `parameter_estimates.parquet` from `rows` ([`crate::diagnose::parameter_table`]).
    ///
    /// # Errors
    /// [`OutputError`].
    pub fn write_parameter_estimates(
        &self,
        path: &Path,
        rows: &[ParameterRow],
        vehicle_id: Option<&str>,
        source: &str,
        fp: &str,
    ) -> Result<(), OutputError> {
        let cols = parameter_columns(rows);
        let meta = self.meta("parameter_estimates", vehicle_id, source, fp);
        write_table(path, &meta, &cols)
    }

    /// The columns of `findings.parquet` (schema `findings`).
    pub fn findings_columns(&self) -> Vec<OutColumn> {
        let mut rows: Vec<FindingRow> = Vec::new();
        for (k, fe) in self.findings.iter().enumerate() {
            for (pn, pe) in &fe.parameters {
                for (sn, fit) in &fe.fit {
                    rows.push((k, fe, pn, pe, sn, fit));
                }
            }
        }
        let s = |g: &dyn Fn(&FindingRow) -> String| OutData::Str(rows.iter().map(g).collect());
        let f = |g: &dyn Fn(&FindingRow) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
        vec![
            OutColumn {
                name: "rank".into(),
                unit: "1".into(),
                data: OutData::U64(rows.iter().map(|r| r.0 as u64 + 1).collect()),
            },
            OutColumn {
                name: "effect".into(),
                unit: "1".into(),
                data: s(&|r| r.1.effect.clone()),
            },
            OutColumn {
                name: "ambiguous_with".into(),
                unit: "1".into(),
                data: s(&|r| r.1.ambiguous_with.join(",")),
            },
            OutColumn {
                name: "sentence".into(),
                unit: "1".into(),
                data: s(&|r| r.1.sentence.clone()),
            },
            OutColumn {
                name: "parameter".into(),
                unit: "1".into(),
                data: s(&|r| r.2.to_string()),
            },
            OutColumn::f64("value", "per row: see parameter_unit", f(&|r| r.3.value)),
            OutColumn::f64("ci_low", "per row: see parameter_unit", f(&|r| r.3.ci_low)),
            OutColumn::f64(
                "ci_high",
                "per row: see parameter_unit",
                f(&|r| r.3.ci_high),
            ),
            OutColumn {
                name: "parameter_unit".into(),
                unit: "1".into(),
                data: s(&|r| r.3.unit.to_string()),
            },
            OutColumn {
                name: "signal".into(),
                unit: "1".into(),
                data: s(&|r| r.4.to_string()),
            },
            OutColumn {
                name: "signal_unit".into(),
                unit: "1".into(),
                data: s(&|r| signal_unit(r.4).to_string()),
            },
            OutColumn {
                name: "metric".into(),
                unit: "1".into(),
                data: s(&|r| r.5.metric.to_string()),
            },
            OutColumn::f64(
                "train_before",
                "per row: see signal_unit",
                f(&|r| r.5.train_before),
            ),
            OutColumn::f64(
                "train_after",
                "per row: see signal_unit",
                f(&|r| r.5.train_after),
            ),
            OutColumn::f64(
                "heldout_before",
                "per row: see signal_unit",
                f(&|r| r.5.heldout_before),
            ),
            OutColumn::f64(
                "heldout_after",
                "per row: see signal_unit",
                f(&|r| r.5.heldout_after),
            ),
        ]
    }
}

/// One row of `findings.parquet`: (finding index, finding, parameter name, parameter, signal,
/// fit).
type FindingRow<'a> = (
    usize,
    &'a FindingEntry,
    &'a str,
    &'a ParameterEntry,
    &'a str,
    &'a FitEntry,
);

/// The content of `diagnosis.json` for the diagnosis `d`: its verdict, noise floors, located
/// mismatches, findings and estimates consistent with the vehicle file, each with its sentence.
pub fn assemble(d: &Diagnosed) -> Diagnosis {
    Diagnosis {
        drive_id: d.drive_id.clone(),
        verdict: d.verdict,
        noise_floor: d.floors.summary(),
        mismatch: d.location.mismatch.iter().map(mismatch_entry).collect(),
        findings: d.explanation.findings.iter().map(finding_entry).collect(),
        estimates: d
            .explanation
            .consistent
            .iter()
            .map(|c| {
                let e = Effect::from_id(c.effect).expect("catalogue id");
                EstimateEntry {
                    effect: c.effect.to_string(),
                    parameter: e.parameter().to_string(),
                    value: c.estimate.value,
                    ci_low: c.estimate.ci_low,
                    ci_high: c.estimate.ci_high,
                    unit: c.estimate.unit,
                    nominal: c.nominal,
                    tolerance_low: c.band_low,
                    tolerance_high: c.band_high,
                    consistent_with_file: true,
                    ambiguous_with: c.ambiguous_with.iter().map(|a| a.to_string()).collect(),
                    sentence: estimate_sentence(c),
                }
            })
            .collect(),
    }
}

/// The sentence of an estimate consistent with the vehicle file, with the effects the recorded
/// signals cannot tell it from.
fn estimate_sentence(c: &ConsistentEstimate) -> String {
    let mut s = consistent_sentence(c);
    if !c.ambiguous_with.is_empty() {
        s.push_str(&format!(
            "; the recorded signals cannot tell it from {}",
            c.ambiguous_with.join(", ")
        ));
    }
    s
}

fn mismatch_entry(m: &Mismatch) -> MismatchEntry {
    MismatchEntry {
        signal: m.signal.clone(),
        start_s: m.start_s,
        end_s: m.end_s,
        start_m: m.start_m,
        end_m: m.end_m,
        band_hz: m.band_hz,
        condition: m.condition.clone(),
        rms_residual: m.rms_residual,
        significance: m.significance,
    }
}

fn finding_entry(f: &Finding) -> FindingEntry {
    FindingEntry {
        effect: f.effect.to_string(),
        ambiguous_with: f.ambiguous_with.iter().map(|s| s.to_string()).collect(),
        sentence: finding_sentence(f),
        parameters: f
            .parameters
            .iter()
            .map(|(k, p)| {
                (
                    k.clone(),
                    ParameterEntry {
                        value: p.value,
                        ci_low: p.ci_low,
                        ci_high: p.ci_high,
                        unit: p.unit,
                    },
                )
            })
            .collect(),
        fit: f
            .fit
            .iter()
            .map(|(k, e)| {
                (
                    k.clone(),
                    FitEntry {
                        train_before: e.train_before,
                        train_after: e.train_after,
                        heldout_before: e.heldout_before,
                        heldout_after: e.heldout_after,
                        metric: e.metric,
                    },
                )
            })
            .collect(),
    }
}

/// SI unit of a compared canonical signal.
pub fn signal_unit(signal: &str) -> &'static str {
    match signal {
        "vehicle_speed" => "m/s",
        "engine_speed" => "rad/s",
        reversal_channel::NAME => reversal_channel::UNIT,
        resistance_stretch::NAME => resistance_stretch::UNIT,
        s if s.starts_with("bellow_pressure") => "Pa",
        s if s.starts_with("suspension_travel") => "m",
        _ => "1",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Diagnosis {
        let mut parameters = BTreeMap::new();
        parameters.insert(
            "c_w_a_f_m2".to_string(),
            ParameterEntry {
                value: 7.2,
                ci_low: 6.9,
                ci_high: 7.5,
                unit: "m2",
            },
        );
        let mut fit = BTreeMap::new();
        for s in ["vehicle_speed", "engine_speed"] {
            fit.insert(
                s.to_string(),
                FitEntry {
                    train_before: 0.4,
                    train_after: 0.1,
                    heldout_before: 0.42,
                    heldout_after: 0.06,
                    metric: "rmse",
                },
            );
        }
        Diagnosis {
            drive_id: "d1".into(),
            verdict: Verdict::Explained,
            noise_floor: [("vehicle_speed".to_string(), 0.05)].into_iter().collect(),
            mismatch: vec![MismatchEntry {
                signal: "vehicle_speed".into(),
                start_s: 10.0,
                end_s: 40.0,
                start_m: 100.0,
                end_m: 700.0,
                band_hz: [0.0, 0.5],
                condition: "gear 12, drive torque, 70-90 km/h".into(),
                rms_residual: 0.4,
                significance: 1e-6,
            }],
            findings: vec![FindingEntry {
                effect: "aero_drag".into(),
                ambiguous_with: vec![],
                sentence: "aerodynamic drag is 31 % higher than the vehicle file says".into(),
                parameters,
                fit,
            }],
            estimates: Vec::new(),
        }
    }

    #[test]
    fn json_has_the_contract_keys() {
        let v = serde_json::to_value(sample()).unwrap();
        assert_eq!(v["verdict"], "explained");
        for k in [
            "signal",
            "start_s",
            "end_s",
            "start_m",
            "end_m",
            "band_hz",
            "condition",
            "rms_residual",
            "significance",
        ] {
            assert!(!v["mismatch"][0][k].is_null(), "{k}");
        }
        let f = &v["findings"][0];
        assert_eq!(f["effect"], "aero_drag");
        assert!(f["ambiguous_with"].as_array().unwrap().is_empty());
        for k in ["value", "ci_low", "ci_high", "unit"] {
            assert!(!f["parameters"]["c_w_a_f_m2"][k].is_null(), "{k}");
        }
        for k in [
            "train_before",
            "train_after",
            "heldout_before",
            "heldout_after",
            "metric",
        ] {
            assert!(!f["fit"]["vehicle_speed"][k].is_null(), "{k}");
        }
    }

    #[test]
    fn the_event_channels_carry_their_own_units() {
        assert_eq!(signal_unit("reversal_relative_speed"), "rad/s");
        assert_eq!(signal_unit("shuffle_frequency"), "1");
        assert_eq!(signal_unit("engine_speed"), "rad/s");
        assert_eq!(signal_unit("bellow_pressure_tag"), "Pa");
    }

    #[test]
    fn parquet_tables_follow_their_schemas() {
        use parquet::file::reader::{FileReader, SerializedFileReader};
        let dir = tempfile::tempdir().unwrap();
        let d = sample();
        let (m, f, j) = (
            dir.path().join("mismatch.parquet"),
            dir.path().join("findings.parquet"),
            dir.path().join("diagnosis.json"),
        );
        d.write_mismatch(&m, Some("TRK"), "src.mcap", "fp").unwrap();
        d.write_findings(&f, Some("TRK"), "src.mcap", "fp").unwrap();
        d.write_json(&j).unwrap();
        let rows = |p: &Path| {
            SerializedFileReader::new(std::fs::File::open(p).unwrap())
                .unwrap()
                .metadata()
                .file_metadata()
                .num_rows()
        };
        assert_eq!(rows(&m), 1);
        // one finding x one parameter x two signals
        assert_eq!(rows(&f), 2);
        let back: serde_json::Value = serde_json::from_slice(&std::fs::read(&j).unwrap()).unwrap();
        assert_eq!(back["drive_id"], "d1");
    }
}
