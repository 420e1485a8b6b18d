//! What an [`AxleEstimate`] gives back (docs/models/axle.md): every estimate beside the vehicle
//! file's value ([`AxleEstimate::comparison`], printed as a table), the estimated `[axles]` keys
//! as a TOML snippet with their sources ([`AxleEstimate::snippet`]), and the vehicle file with
//! those keys merged in and checked ([`AxleEstimate::merged_vehicle`]). Estimates carry 6
//! significant digits.

use super::axle::{Axle, AxleParams, DamperTable};
use super::axle_estimate::AxleEstimate;
use super::axle_estimation::{damper_coefficients, DamperFit};
use super::axle_measurement::MeasurementError;
use super::vehicle::{VehicleError, VehicleFile};
use std::fmt;

/// Damper coefficients of a vehicle file's tables, fitted as a datasheet would be.
fn table_coefficients(t: &DamperTable) -> Option<DamperFit> {
    let v: Vec<f64> = t
        .ext_v
        .iter()
        .copied()
        .chain(t.comp_v.iter().map(|x| -x))
        .collect();
    let f: Vec<f64> = t
        .ext_f
        .iter()
        .copied()
        .chain(t.comp_f.iter().map(|x| -x))
        .collect();
    damper_coefficients(&v, &f).ok()
}

/// One row of the comparison with the vehicle file.
#[derive(Debug, Clone, PartialEq)]
pub struct ComparisonRow {
    /// What was estimated, with its source.
    pub quantity: String,
    /// The estimate.
    pub estimate: f64,
    /// Its unit.
    pub unit: &'static str,
    /// The vehicle file's value (given or derived by its static state), if it has one.
    pub vehicle: Option<f64>,
}

/// The estimates beside the vehicle file's values; `Display` prints the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparison {
    /// Rows in print order.
    pub rows: Vec<ComparisonRow>,
}

/// `x` with 6 significant digits, trailing zeros dropped; scientific outside 1e-3 … 1e7.
fn sig6(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let mag = x.abs().log10().floor();
    if !(-3.0..7.0).contains(&mag) {
        return format!("{x:.5e}");
    }
    let s = format!("{:.*}", (5.0 - mag).max(0.0) as usize, x);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// `x` rounded to 6 significant digits, as a TOML float.
fn toml6(x: f64) -> String {
    let r: f64 = format!("{x:.5e}").parse().unwrap_or(x);
    format!("{r:?}")
}

fn toml_list(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
    format!("[{}]", items.join(", "))
}

impl AxleEstimate {
    /// Every estimate beside the vehicle file's value: its keys, or what its static state derives
    /// from them (CGs, bellow forces), or a fit of its damper tables.
    pub fn comparison(&self, v: &AxleParams) -> Comparison {
        let st = v.static_state();
        let mut rows = Vec::new();
        let mut row =
            |quantity: String, estimate: f64, unit: &'static str, vehicle: Option<f64>| {
                rows.push(ComparisonRow {
                    quantity,
                    estimate,
                    unit,
                    vehicle,
                })
            };
        for (k, a) in Axle::ALL.iter().enumerate() {
            row(
                format!("scale weight {}", a.name()),
                self.scale_weight_kg[k],
                "kg",
                Some(v.scale_weight(*a)),
            );
        }
        row(
            "total mass (sum of scale weights)".into(),
            self.mass_kg,
            "kg",
            Some(v.mass_kg()),
        );
        row(
            "vehicle CG x behind front axle (eq. 3.3.2)".into(),
            self.x_cg_m,
            "m",
            Some(st.x_cg_m),
        );
        row(
            "chassis mass (scale weights - axle masses)".into(),
            self.chassis_mass_kg,
            "kg",
            Some(v.chassis_mass_kg),
        );
        row(
            "chassis CG x behind front axle".into(),
            self.chassis_x_cg_m,
            "m",
            Some(st.chassis_x_cg_m),
        );
        for (k, a) in Axle::ALL.iter().enumerate() {
            let eq = if *a == Axle::Front { "3.3.5" } else { "3.3.9" };
            row(
                format!("static bellow force {} (eq. {eq})", a.name()),
                self.bellow_force_n[k],
                "N",
                Some(st.bellow_n[k]),
            );
        }
        for (k, a) in Axle::ALL.iter().enumerate() {
            if let Some(area) = self.bellow_area_m2[k] {
                row(
                    format!("bellow area {} (eq. 3.3.10)", a.name()),
                    area,
                    "m^2",
                    Some(v.bellow_area(*a)),
                );
            }
        }
        for s in &self.stiffness {
            row(
                format!(
                    "bellow stiffness {}, bellow_test[{}] (R^2 {:.6})",
                    s.axle.name(),
                    s.test,
                    s.fit.r2
                ),
                s.fit.slope,
                "N/m",
                Some(v.bellow_stiffness(s.axle)),
            );
        }
        for d in &self.dampers {
            let current = table_coefficients(&v.damper(d.axle));
            for (branch, c, cur) in [
                (
                    "extension",
                    d.fit.extension_ns_per_m,
                    current.map(|f| f.extension_ns_per_m),
                ),
                (
                    "compression",
                    d.fit.compression_ns_per_m,
                    current.map(|f| f.compression_ns_per_m),
                ),
            ] {
                row(
                    format!(
                        "damper {} {branch}, damper_datasheet[{}]",
                        d.axle.name(),
                        d.datasheet
                    ),
                    c,
                    "N*s/m",
                    cur,
                );
            }
        }
        Comparison { rows }
    }

    /// The estimates as a TOML snippet of `[axles]` keys, with a header comment that says where
    /// each came from: `scale_weight_*_kg` and `chassis_mass_kg` always, `bellow_area_*_m2`
    /// where static pressures were given, `bellow_stiffness_*_n_per_m` where tests were,
    /// `damper_*` tables where datasheets were. Estimated values carry 6 significant digits,
    /// measured values are copied as written.
    pub fn snippet(&self) -> String {
        let mut s = String::new();
        let mut line = |l: &str| {
            s.push_str(l);
            s.push('\n');
        };
        line("# [axles] keys estimated by `fleetdyn estimate axle` (axle-load thesis §3.3; docs/models/axle.md)");
        line(&format!("#   measurements: {}", self.measurement_file));
        line(&format!(
            "#   vehicle file: {} (axle positions, arm levers, axle masses, gravity)",
            self.vehicle_file
        ));
        line("# Replace these keys in the vehicle file's [axles] section.");
        line("#   scale_weight_*_kg: [scale] as weighed");
        line("#   chassis_mass_kg: sum of the scale weights minus the axle masses (eq. 3.3.8)");
        if self.bellow_area_m2.iter().any(Option::is_some) {
            line("#   bellow_area_*_m2: A_eff = F_s/p_s (eq. 3.3.10), F_s from the arm's moment balance");
            line("#     (eq. 3.3.9; front eq. 3.3.5) and p_s from [static_pressure]");
        }
        if !self.stiffness.is_empty() {
            line("#   bellow_stiffness_*_n_per_m: slope of the force-displacement line (eq. 3.3.6) of");
            line("#     [[bellow_test]] (mean over an axle's tests), pressures as F = p·A_eff (eq. 3.3.7)");
        }
        if !self.dampers.is_empty() {
            line("#   damper_*: [[damper_datasheet]] points split into extension (v > 0) and");
            line("#     compression (v < 0) branches, positive speeds and forces");
        }
        line(&format!(
            "# Derived, for reference (not keys): vehicle CG {} m and chassis CG {} m behind the front axle.",
            sig6(self.x_cg_m),
            sig6(self.chassis_x_cg_m)
        ));
        line("[axles]");
        for (k, a) in Axle::ALL.iter().enumerate() {
            line(&format!(
                "scale_weight_{}_kg = {:?}",
                a.name(),
                self.scale_weight_kg[k]
            ));
        }
        line(&format!(
            "chassis_mass_kg = {}",
            toml6(self.chassis_mass_kg)
        ));
        for (k, a) in Axle::ALL.iter().enumerate() {
            if let Some(area) = self.bellow_area_m2[k] {
                line(&format!(
                    "bellow_area_{}_m2 = {}   # static_pressure.{}_pa",
                    a.name(),
                    toml6(area),
                    a.name()
                ));
            }
        }
        for a in Axle::ALL {
            if let Some(c) = self.bellow_stiffness_n_per_m(a) {
                let tests: Vec<String> = self
                    .stiffness
                    .iter()
                    .filter(|s| s.axle == a)
                    .map(|s| format!("bellow_test[{}] R^2 {:.6}", s.test, s.fit.r2))
                    .collect();
                line(&format!(
                    "bellow_stiffness_{}_n_per_m = {}   # {}",
                    a.name(),
                    toml6(c),
                    tests.join(", ")
                ));
            }
        }
        for d in &self.dampers {
            let n = d.axle.name();
            line(&format!("# damper_datasheet[{}]", d.datasheet));
            for (key, vals) in [
                ("extension_velocity_m_per_s", &d.table.ext_v),
                ("extension_force_n", &d.table.ext_f),
                ("compression_velocity_m_per_s", &d.table.comp_v),
                ("compression_force_n", &d.table.comp_f),
            ] {
                line(&format!("damper_{n}_{key} = {}", toml_list(vals)));
            }
        }
        s
    }

    /// The vehicle file with the snippet's keys replacing those in its `[axles]` section, checked
    /// as a vehicle file (comments are not kept: this is for checking, not for writing back).
    ///
    /// # Errors
    /// [`MeasurementError::Vehicle`] when the text is not a vehicle file with an `[axles]` table,
    /// or when the merged file breaks a rule of `schemas/vehicle.toml` or of the axle model
    /// (naming the key).
    pub fn merged_vehicle(
        &self,
        vehicle_text: &str,
        vehicle_file: &str,
    ) -> Result<VehicleFile, MeasurementError> {
        let label = format!("{vehicle_file} with the estimated [axles] keys");
        let parse = |source| MeasurementError::Vehicle {
            source: VehicleError::Parse {
                file: label.clone(),
                source,
            },
        };
        let mut doc: toml::Table = toml::from_str(vehicle_text).map_err(parse)?;
        let snippet: toml::Table = toml::from_str(&self.snippet()).map_err(parse)?;
        let missing = || MeasurementError::Vehicle {
            source: VehicleError::Range {
                file: vehicle_file.into(),
                key: "axles".into(),
                value: "missing".into(),
                rule: "the estimates go into an [axles] section".into(),
            },
        };
        let axles = doc
            .get_mut("axles")
            .and_then(toml::Value::as_table_mut)
            .ok_or_else(missing)?;
        if let Some(new) = snippet.get("axles").and_then(toml::Value::as_table) {
            for (k, val) in new {
                axles.insert(k.clone(), val.clone());
            }
        }
        let text = toml::to_string(&doc).map_err(|e| MeasurementError::Vehicle {
            source: VehicleError::Range {
                file: label.clone(),
                key: "axles".into(),
                value: String::new(),
                rule: e.to_string(),
            },
        })?;
        VehicleFile::parse(&text, &label).map_err(|source| MeasurementError::Vehicle { source })
    }
}

impl fmt::Display for Comparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let cells: Vec<[String; 5]> = self
            .rows
            .iter()
            .map(|r| {
                let (cur, diff) = match r.vehicle {
                    Some(c) => {
                        let d = r.estimate - c;
                        let rel = if c != 0.0 {
                            format!(" ({:+.2} %)", 100.0 * d / c)
                        } else {
                            String::new()
                        };
                        (sig6(c), format!("{}{rel}", sig6(d)))
                    }
                    None => ("-".into(), "-".into()),
                };
                [
                    r.quantity.clone(),
                    sig6(r.estimate),
                    r.unit.to_string(),
                    cur,
                    diff,
                ]
            })
            .collect();
        let head = ["quantity", "estimate", "unit", "vehicle file", "difference"];
        let width = |i: usize| {
            cells
                .iter()
                .map(|c| c[i].chars().count())
                .chain([head[i].len()])
                .max()
                .unwrap_or(0)
        };
        let w = [width(0), width(1), width(2), width(3)];
        let mut row = |c: [&str; 5]| {
            writeln!(
                f,
                "{:<w0$}  {:>w1$}  {:<w2$}  {:>w3$}  {}",
                c[0],
                c[1],
                c[2],
                c[3],
                c[4],
                w0 = w[0],
                w1 = w[1],
                w2 = w[2],
                w3 = w[3]
            )
        };
        row(head)?;
        for c in &cells {
            row([&c[0], &c[1], &c[2], &c[3], &c[4]])?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn significant_digits() {
        assert_eq!(sig6(18700.0), "18700");
        assert_eq!(sig6(0.1087), "0.1087");
        assert_eq!(sig6(1.234567891), "1.23457");
        assert_eq!(sig6(-1.5e-9), "-1.50000e-9");
        assert_eq!(toml6(0.109_706_123), "0.109706");
        assert_eq!(toml6(15800.0), "15800.0");
    }
}
