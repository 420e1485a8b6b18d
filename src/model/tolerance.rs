//! Tolerances of a vehicle file's values: how far a healthy truck's true parameter may lie from the
//! file's nominal value. The diagnosis names a catalogue effect only when the fitted interval of
//! its parameter lies wholly outside the band `θ₀ ± w` widened on each side by the catalogue's
//! model-form allowance of that side ([`Tolerances::band`], docs/diagnosis/method.md); an
//! estimate inside or overlapping the band is reported as consistent with the file.
//!
//! # The `[tolerance]` table
//! Optional. One key per parameter, named as in the vehicle file (`mass_kg`, `c_w_a_f_m2`,
//! `k_d_nm_per_rad`, …) or as the catalogue names an effect's parameter (`slope_offset_rad`,
//! `engine_torque_offset_nm`, `engine_torque_delay_s`, `drive_shaft_lash_rad`, …), each an
//! inline table with exactly one of
//! - `relative`: the half-width as a fraction of the nominal value (1), `0 ≤ r < 1`;
//! - `absolute`: the half-width in the parameter's own unit (the unit in its key), `≥ 0`.
//!
//! ```toml
//! [tolerance]
//! mass_kg = { relative = 0.05 }                 # payload only known to ±5 %
//! engine_torque_offset_nm = { absolute = 40.0 } # an ECU whose torque is good to ±40 N·m
//! ```
//!
//! A parameter the table does not name has the default of its kind
//! ([`ToleranceKind::default_tolerance`]); a key outside the vehicle schema and the catalogue
//! is an error, so a misspelt key cannot silently fall back to a default.

use super::catalogue::{Effect, ModelForm, Tolerance, ToleranceKind, CATALOGUE};
use std::collections::BTreeMap;

/// The tolerances of one vehicle file: the `[tolerance]` table's entries; every other
/// parameter has its kind's default.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tolerances {
    given: BTreeMap<String, Tolerance>,
    /// Whether the vehicle file states the tyres' warm-up (`tyre_cold_excess` > 0), which
    /// selects the catalogue's allowance measured with it ([`Tolerances::model_form`]).
    tyre_warm_up: bool,
}

/// The kind of a vehicle-file key, for its default tolerance: a catalogue parameter's row
/// says it; otherwise the key's symbol does (`j_…` inertia, `k_…` stiffness, `c_…` with a
/// damping unit, `b_…` losses, `…mass_kg`, `…_inertia_kg_m2`, bellow and tyre stiffnesses,
/// `c_w_a_f_m2`, `c_r…`, clutch capacity). `None` for keys without a default (geometry,
/// curves, controller gains, constants).
pub fn kind_of_key(key: &str) -> Option<ToleranceKind> {
    if let Some(row) = CATALOGUE.iter().find(|r| r.parameter == key) {
        return Some(row.tolerance);
    }
    let damping_unit = key.ends_with("_nm_s_per_rad") || key.ends_with("_n_s_per_m");
    Some(match key {
        "c_w_a_f_m2" => ToleranceKind::DragArea,
        "c_r1" | "c_r2_s_per_m" => ToleranceKind::RollingResistance,
        "clutch_max_torque_nm" => ToleranceKind::ClutchCapacity,
        k if k.ends_with("mass_kg") => ToleranceKind::Mass,
        k if k.starts_with("j_") || k.ends_with("_inertia_kg_m2") => ToleranceKind::Inertia,
        k if k.starts_with("k_") || (k.contains("stiffness") && k.ends_with("_n_per_m")) => {
            ToleranceKind::Stiffness
        }
        k if (k.starts_with("c_") || k.starts_with("b_")) && damping_unit => ToleranceKind::Damping,
        _ => return None,
    })
}

impl Tolerances {
    /// Parses a `[tolerance]` table; `known` says whether a key names a vehicle-file value
    /// (a catalogue parameter is always known).
    ///
    /// # Errors
    /// `(key, value, rule)` for an unknown key, a value that is not an inline table with
    /// exactly one of `relative` / `absolute`, or a negative, non-finite or (relative) ≥ 1
    /// half-width.
    pub fn from_table(
        table: &toml::Table,
        known: impl Fn(&str) -> bool,
    ) -> Result<Self, (String, String, String)> {
        let mut given = BTreeMap::new();
        for (key, value) in table {
            let problem = |rule: &str| Err((key.clone(), value.to_string(), rule.to_string()));
            let is_catalogue = CATALOGUE.iter().any(|r| r.parameter == key);
            if !is_catalogue && !known(key) {
                return problem("unknown parameter: a vehicle-file key or a catalogue parameter");
            }
            let Some(t) = value.as_table() else {
                return problem("must be { relative = r } or { absolute = a }");
            };
            if t.len() != 1 {
                return problem("must hold exactly one of `relative` and `absolute`");
            }
            let (kind, v) = t.iter().next().expect("one entry");
            let Some(x) = v.as_float().or_else(|| v.as_integer().map(|i| i as f64)) else {
                return problem("the half-width must be a number");
            };
            if !x.is_finite() || x < 0.0 {
                return problem("the half-width must be finite and >= 0");
            }
            let tol = match kind.as_str() {
                "relative" if x < 1.0 => Tolerance::Relative(x),
                "relative" => return problem("a relative half-width must be below 1"),
                "absolute" => Tolerance::Absolute(x),
                _ => return problem("must be { relative = r } or { absolute = a }"),
            };
            given.insert(key.clone(), tol);
        }
        Ok(Self {
            given,
            tyre_warm_up: false,
        })
    }

    /// The same tolerances for a vehicle file that does (`true`) or does not state the tyres'
    /// warm-up ([`Tolerances::model_form`]).
    pub fn with_tyre_warm_up(mut self, stated: bool) -> Self {
        self.tyre_warm_up = stated;
        self
    }

    /// The catalogue's model-form allowance of `e` for this vehicle file: the one measured with
    /// the tyres' warm-up stated ([`crate::model::catalogue::EffectSpec::model_form_warm_up`])
    /// when the file states it, else the one measured without
    /// ([`crate::model::catalogue::EffectSpec::model_form`]). Each was measured with the
    /// models as such a file makes them, and the rolling resistance and drag area they fit on
    /// cold tyres differ.
    pub fn model_form(&self, e: Effect) -> ModelForm {
        if self.tyre_warm_up {
            e.spec().model_form_warm_up
        } else {
            e.spec().model_form
        }
    }

    /// The tolerance of a vehicle-file key or catalogue parameter: the table's entry, else
    /// its kind's default; `None` for a key without either.
    pub fn of_key(&self, key: &str) -> Option<Tolerance> {
        self.given
            .get(key)
            .copied()
            .or_else(|| kind_of_key(key).map(ToleranceKind::default_tolerance))
    }

    /// The tolerance of `e`'s parameter (the table's entry, else the catalogue row's kind's
    /// default).
    pub fn of_effect(&self, e: Effect) -> Tolerance {
        self.given
            .get(e.parameter())
            .copied()
            .unwrap_or_else(|| e.spec().tolerance.default_tolerance())
    }

    /// Whether the table gave `e`'s tolerance (rather than the default).
    pub fn is_given(&self, e: Effect) -> bool {
        self.given.contains_key(e.parameter())
    }

    /// The band `(θ₀ − w − m₋, θ₀ + w + m₊)` of `e`'s parameter around `nominal` that an
    /// estimate must leave to be named: `w` is the file's tolerance ([`Tolerances::of_effect`]),
    /// `m₋` and `m₊` the catalogue's model-form allowance below and above for this file
    /// ([`Tolerances::model_form`]), added because a healthy truck may sit at the edge of the
    /// one and its estimate miss it by the other.
    pub fn band(&self, e: Effect, nominal: f64) -> (f64, f64) {
        let w = self.of_effect(e).half_width(nominal);
        let (below, above) = self.model_form(e).widths(nominal);
        (nominal - w - below, nominal + w + above)
    }

    /// The entries the table gave, by key.
    pub fn given(&self) -> &BTreeMap<String, Tolerance> {
        &self.given
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Tolerances, (String, String, String)> {
        let t: toml::Table = toml::from_str(text).unwrap();
        Tolerances::from_table(&t, |k| k == "mass_kg" || k == "j_e_kg_m2")
    }

    #[test]
    fn defaults_by_kind_and_overrides() {
        let t = parse("mass_kg = { relative = 0.05 }\nengine_torque_offset_nm = { absolute = 40 }")
            .unwrap();
        assert_eq!(t.of_effect(Effect::VehicleMass), Tolerance::Relative(0.05));
        assert!(t.is_given(Effect::VehicleMass));
        assert_eq!(
            t.of_effect(Effect::EngineTorqueOffset),
            Tolerance::Absolute(40.0)
        );
        // not given: the kind's default
        assert_eq!(t.of_effect(Effect::AeroDrag), Tolerance::Relative(0.05));
        assert_eq!(
            t.of_effect(Effect::DrivelineCompliance),
            Tolerance::Relative(0.10)
        );
        assert_eq!(t.of_key("j_e_kg_m2"), Some(Tolerance::Relative(0.05)));
        assert_eq!(
            t.of_key("c_d_nm_s_per_rad"),
            Some(Tolerance::Relative(0.10))
        );
        assert_eq!(t.of_key("wheel_radius_m"), None);
        // the band: the file's tolerance plus the catalogue's model-form allowance
        let (lo, hi) = t.band(Effect::VehicleMass, 40_000.0);
        let (below, above) = Effect::VehicleMass.spec().model_form.widths(40_000.0);
        assert!(below > 0.0 && above > 0.0);
        assert!((lo - (40_000.0 - 2000.0 - below)).abs() < 1e-9);
        assert!((hi - (40_000.0 + 2000.0 + above)).abs() < 1e-9);
        let (lo, hi) = Tolerances::default().band(Effect::GradeOffset, 0.0);
        let (below, above) = Effect::GradeOffset.spec().model_form.widths(0.0);
        assert_eq!((lo, hi), (-0.002 - below, 0.002 + above));
        // an allowance measured on one side only widens that side: the clutch's estimates on
        // healthy trucks missed upwards only
        let (lo, hi) = Tolerances::default().band(Effect::ClutchSlip, 3000.0);
        assert!((lo - 2700.0).abs() < 1e-9 && hi > 3300.0, "{lo} {hi}");
        // a switch has neither
        assert_eq!(
            Tolerances::default().band(Effect::SlopeQuantization, 0.01),
            (0.01, 0.01)
        );
    }

    #[test]
    fn a_file_that_states_the_tyres_warm_up_is_judged_with_its_own_allowance() {
        use crate::model::vehicle::VehicleFile;
        let load = |name: &str| {
            let path = format!("{}/fixtures/vehicles/{name}", env!("CARGO_MANIFEST_DIR"));
            VehicleFile::parse(&std::fs::read_to_string(&path).unwrap(), name).unwrap()
        };
        let (plain, cold) = (load("truck-40t.toml"), load("truck-40t-cold-start.toml"));
        let c_w = 5.5;
        for (file, form) in [
            (&plain, Effect::AeroDrag.spec().model_form),
            (&cold, Effect::AeroDrag.spec().model_form_warm_up),
        ] {
            assert_eq!(file.tolerance.model_form(Effect::AeroDrag), form);
            let (below, above) = form.widths(c_w);
            let (lo, hi) = file.tolerance.band(Effect::AeroDrag, c_w);
            assert!((lo - (c_w * 0.95 - below)).abs() < 1e-9, "{lo}");
            assert!((hi - (c_w * 1.05 + above)).abs() < 1e-9, "{hi}");
        }
        // the two measurements differ where cold tyres push the resistances
        assert_ne!(
            cold.tolerance.band(Effect::AeroDrag, c_w),
            plain.tolerance.band(Effect::AeroDrag, c_w)
        );
    }

    #[test]
    fn bad_entries_name_the_key_and_the_rule() {
        for (text, key, rule) in [
            (
                "mas_kg = { relative = 0.05 }",
                "mas_kg",
                "unknown parameter",
            ),
            ("mass_kg = 0.05", "mass_kg", "must be"),
            ("mass_kg = { relative = 1.5 }", "mass_kg", "below 1"),
            ("mass_kg = { absolute = -1.0 }", "mass_kg", ">= 0"),
            (
                "mass_kg = { relative = 0.1, absolute = 1.0 }",
                "mass_kg",
                "exactly one",
            ),
            ("mass_kg = { percent = 5 }", "mass_kg", "must be"),
        ] {
            let (k, _, r) = parse(text).unwrap_err();
            assert_eq!(k, key, "{text}");
            assert!(r.contains(rule), "{text}: {r}");
        }
    }
}
