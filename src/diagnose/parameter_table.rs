//! The `parameter_estimates` table of a diagnosis (docs/diagnosis/contract.md; its rows are built
//! by [`super::run::parameter_rows`]): one row per
//! catalogue parameter the drive informs, whether or not anything was named — the full fit's
//! estimate where the explain step fitted the parameter (a finding, or an estimate within the
//! vehicle file's tolerance), else the first round's linearised estimate
//! ([`super::linearised`]). Each row sets the interval against the vehicle file's tolerance
//! band, so a fleet can pool a vehicle's drives parameter by parameter.
//!
//! Values in the parameter's SI unit (column `parameter_unit`).

use crate::io::{OutColumn, OutData};

/// How a row's estimate was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EstimateMethod {
    /// Fitted and named: its interval lies outside the tolerance band.
    Named,
    /// Fitted, its interval overlapping the tolerance band.
    Fitted,
    /// Linearised from the first round's screen only.
    Linearised,
    /// Measured outside the models (the slope sensor's offset against the altitude), its
    /// interval overlapping the vehicle file's tolerance.
    Measured,
}

impl EstimateMethod {
    /// The spelling in the table.
    pub fn as_str(self) -> &'static str {
        match self {
            EstimateMethod::Named => "named",
            EstimateMethod::Fitted => "fitted",
            EstimateMethod::Linearised => "linearised",
            EstimateMethod::Measured => "measured",
        }
    }
}

/// One row of `parameter_estimates`.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterRow {
    /// Catalogue id.
    pub effect: &'static str,
    /// Parameter name.
    pub parameter: &'static str,
    /// SI unit of the parameter.
    pub unit: &'static str,
    /// Estimate.
    pub value: f64,
    /// 95 % interval, lower end.
    pub ci_low: f64,
    /// 95 % interval, upper end.
    pub ci_high: f64,
    /// The vehicle file's value.
    pub nominal: f64,
    /// Tolerance band, lower end.
    pub tolerance_low: f64,
    /// Tolerance band, upper end.
    pub tolerance_high: f64,
    /// How the estimate was obtained.
    pub method: EstimateMethod,
    /// Effective samples behind a linearised interval (NaN for a fitted one).
    pub n_eff: f64,
}

impl ParameterRow {
    /// Whether the interval overlaps the tolerance band.
    pub fn consistent_with_file(&self) -> bool {
        self.ci_low <= self.tolerance_high && self.ci_high >= self.tolerance_low
    }
}

/// The table's columns (schema `parameter_estimates`).
pub fn parameter_columns(rows: &[ParameterRow]) -> Vec<OutColumn> {
    let s = |g: &dyn Fn(&ParameterRow) -> String| OutData::Str(rows.iter().map(g).collect());
    let f = |g: &dyn Fn(&ParameterRow) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    let text = |name: &str, data: OutData| OutColumn {
        name: name.into(),
        unit: "1".into(),
        data,
    };
    let per_row = "per row: see parameter_unit";
    vec![
        text("effect", s(&|r| r.effect.to_string())),
        text("parameter", s(&|r| r.parameter.to_string())),
        text("parameter_unit", s(&|r| r.unit.to_string())),
        OutColumn::f64("value", per_row, f(&|r| r.value)),
        OutColumn::f64("ci_low", per_row, f(&|r| r.ci_low)),
        OutColumn::f64("ci_high", per_row, f(&|r| r.ci_high)),
        OutColumn::f64("nominal", per_row, f(&|r| r.nominal)),
        OutColumn::f64("tolerance_low", per_row, f(&|r| r.tolerance_low)),
        OutColumn::f64("tolerance_high", per_row, f(&|r| r.tolerance_high)),
        OutColumn {
            name: "consistent_with_file".into(),
            unit: "1".into(),
            data: OutData::Bool(
                rows.iter()
                    .map(ParameterRow::consistent_with_file)
                    .collect(),
            ),
        },
        text("method", s(&|r| r.method.as_str().to_string())),
        OutColumn::f64("n_eff", "1", f(&|r| r.n_eff)),
    ]
}
