//! Road-design rule sets for synthetic roads (Myklebust & Eriksson (2012), §4;
//! docs/models/road.md): the data that [`crate::road::synth`] draws a road from.
//!
//! A rule set is a TOML file with units in its key names (`schemas/roads/*.toml` are bundled
//! and embedded in the binary; a user file of the same shape works too):
//!
//! | key | unit | meaning |
//! | --- | --- | --- |
//! | `name` | – | rule-set name (written to the output metadata) |
//! | `source` | – | where the numbers come from (the regulation and its table) |
//! | `design_speed_km_per_h` | km/h | optional, informative only |
//! | `max_grade` | 1 (tan α) | grades are drawn uniformly from [−max_grade, max_grade] |
//! | `min_radius_m` | m | minimum vertical-curve radius R of eq. (34) `z = x²/(2R)`; crests, and sags unless `min_sag_radius_m` is given |
//! | `min_sag_radius_m` | m | optional separate minimum for sag curves (AASHTO's headlight control) |
//! | `radius_band_m` | m | radii are drawn uniformly from [R_min, R_min + band] ("a narrow range above the minimum value") |
//! | `min_length_m` | m | lower bound of the grade-segment length (PVI to PVI) |
//! | `max_length_flat_m` | m | upper bound of that length at zero grade (the widest range) |
//! | `length_e_folding_grade` | 1 (tan α) | the length range shrinks by a factor e per this much \|grade\| |
//!
//! Segment lengths are uniform on `[L_min, L_min + (L_flat − L_min)·exp(−|g|/g_e)]` — Myklebust &
//! Eriksson (2012), §4: "range of the slope-length distributions set exponentially with respect to
//! the inclination, with flat ground giving the widest range". Unknown keys are errors, so a
//! misspelt key never silently falls back to nothing.

use serde::{Deserialize, Serialize};
use std::path::Path;
use thiserror::Error;

/// The bundled rule sets: name and embedded file.
const BUNDLED: &[(&str, &str)] = &[
    (
        "highway-se",
        include_str!("../../schemas/roads/highway-se.toml"),
    ),
    (
        "highway-se-fitted",
        include_str!("../../schemas/roads/highway-se-fitted.toml"),
    ),
    ("city-se", include_str!("../../schemas/roads/city-se.toml")),
    (
        "city-se-fitted",
        include_str!("../../schemas/roads/city-se-fitted.toml"),
    ),
    (
        "freeway-us",
        include_str!("../../schemas/roads/freeway-us.toml"),
    ),
    (
        "freeway-us-fitted",
        include_str!("../../schemas/roads/freeway-us-fitted.toml"),
    ),
    (
        "urban-us",
        include_str!("../../schemas/roads/urban-us.toml"),
    ),
    (
        "urban-us-fitted",
        include_str!("../../schemas/roads/urban-us-fitted.toml"),
    ),
];

/// Steepest `max_grade` accepted: the drive-log schema's bound on |road_slope| (beyond it the
/// small-angle simplification sin α ≈ tan α stops being "very sound", Myklebust & Eriksson
/// (2012), §3).
pub const GRADE_LIMIT: f64 = 0.3;

/// Names of the bundled rule sets, in the order they are documented.
pub fn bundled_names() -> Vec<&'static str> {
    BUNDLED.iter().map(|(n, _)| *n).collect()
}

/// Why a rule set could not be used.
#[derive(Debug, Error)]
pub enum RulesError {
    /// Neither a bundled name nor an existing file.
    #[error("unknown rule set `{given}`: not a bundled one ({known}) nor a file")]
    UnknownRuleSet {
        /// What was asked for.
        given: String,
        /// The bundled names, comma separated.
        known: String,
    },
    /// The file could not be read.
    #[error("rule file {file}: {source}")]
    Io {
        /// File.
        file: String,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// TOML syntax, a missing key, a wrong type or an unknown key.
    #[error("rule file {file}: {source}")]
    Parse {
        /// File.
        file: String,
        /// Parser message (names the key).
        #[source]
        source: toml::de::Error,
    },
    /// A value outside its allowed range.
    #[error("rule file {file}: {key} = {value} {requirement}")]
    Invalid {
        /// File.
        file: String,
        /// Key.
        key: &'static str,
        /// Value given.
        value: f64,
        /// What it must satisfy.
        requirement: String,
    },
    /// A text key left empty.
    #[error("rule file {file}: {key} must not be empty")]
    Empty {
        /// File.
        file: String,
        /// Key.
        key: &'static str,
    },
}

/// One rule set (see the module doc for the keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoadRules {
    /// Rule-set name.
    pub name: String,
    /// Citation of the numbers.
    pub source: String,
    /// Design speed, km/h (informative).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub design_speed_km_per_h: Option<f64>,
    /// Largest |grade|, tan α.
    pub max_grade: f64,
    /// Minimum crest (and, without `min_sag_radius_m`, sag) radius, m.
    pub min_radius_m: f64,
    /// Minimum sag radius, m, when it differs from the crest one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_sag_radius_m: Option<f64>,
    /// Width of the uniform radius band above the minimum, m.
    pub radius_band_m: f64,
    /// Shortest grade segment, m.
    pub min_length_m: f64,
    /// Upper bound of the segment length at zero grade, m.
    pub max_length_flat_m: f64,
    /// |grade| over which the length range shrinks by a factor e, tan α.
    pub length_e_folding_grade: f64,
}

impl RoadRules {
    /// Parses and checks a rule file's text; `file` names it in errors.
    ///
    /// # Errors
    /// [`RulesError::Parse`], [`RulesError::Invalid`], [`RulesError::Empty`].
    pub fn parse(text: &str, file: &str) -> Result<Self, RulesError> {
        let r: RoadRules = toml::from_str(text).map_err(|source| RulesError::Parse {
            file: file.into(),
            source,
        })?;
        r.validate(file)?;
        Ok(r)
    }

    /// Reads and checks a rule file.
    ///
    /// # Errors
    /// [`RulesError::Io`] and those of [`RoadRules::parse`].
    pub fn load(path: &Path) -> Result<Self, RulesError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|source| RulesError::Io {
            file: file.clone(),
            source,
        })?;
        Self::parse(&text, &file)
    }

    /// A bundled rule set by name.
    ///
    /// # Errors
    /// [`RulesError::UnknownRuleSet`] for any other name.
    pub fn bundled(name: &str) -> Result<Self, RulesError> {
        let (_, text) =
            BUNDLED
                .iter()
                .find(|(n, _)| *n == name)
                .ok_or_else(|| RulesError::UnknownRuleSet {
                    given: name.into(),
                    known: bundled_names().join(", "),
                })?;
        Self::parse(text, &format!("schemas/roads/{name}.toml (bundled)"))
    }

    /// A bundled name, else a file path. A bare word (no path separator, no `.toml`) that is not
    /// bundled and not an existing file is reported as an unknown rule set.
    ///
    /// # Errors
    /// As [`RoadRules::bundled`] and [`RoadRules::load`].
    pub fn resolve(name_or_path: &str) -> Result<Self, RulesError> {
        if BUNDLED.iter().any(|(n, _)| *n == name_or_path) {
            return Self::bundled(name_or_path);
        }
        let p = Path::new(name_or_path);
        let bare = !name_or_path.contains(['/', '\\']) && !name_or_path.ends_with(".toml");
        if bare && !p.exists() {
            return Err(RulesError::UnknownRuleSet {
                given: name_or_path.into(),
                known: bundled_names().join(", "),
            });
        }
        Self::load(p)
    }

    /// Minimum radius for a crest (`crest = true`, slope decreasing) or a sag curve, m.
    pub fn min_radius(&self, crest: bool) -> f64 {
        if crest {
            self.min_radius_m
        } else {
            self.min_sag_radius_m.unwrap_or(self.min_radius_m)
        }
    }

    /// The smaller of the crest and sag minima, m: the bound on |d(slope)/dx| = 1/R.
    pub fn smallest_radius(&self) -> f64 {
        self.min_radius(true).min(self.min_radius(false))
    }

    /// Upper bound of the segment-length range at grade `g`, m.
    pub fn max_length_at(&self, g: f64) -> f64 {
        self.min_length_m
            + (self.max_length_flat_m - self.min_length_m)
                * (-g.abs() / self.length_e_folding_grade).exp()
    }

    /// The canonical TOML text of these rules (written to output metadata and hashed).
    pub fn canonical_toml(&self) -> String {
        toml::to_string(self).unwrap_or_else(|e| format!("<unserialisable rules: {e}>"))
    }

    fn validate(&self, file: &str) -> Result<(), RulesError> {
        let invalid = |key: &'static str, value: f64, requirement: String| RulesError::Invalid {
            file: file.into(),
            key,
            value,
            requirement,
        };
        if self.name.trim().is_empty() {
            return Err(RulesError::Empty {
                file: file.into(),
                key: "name",
            });
        }
        if self.source.trim().is_empty() {
            return Err(RulesError::Empty {
                file: file.into(),
                key: "source",
            });
        }
        let positive = |key: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(invalid(key, v, "must be finite and > 0".into()))
            }
        };
        positive("max_grade", self.max_grade)?;
        if self.max_grade > GRADE_LIMIT {
            return Err(invalid(
                "max_grade",
                self.max_grade,
                format!("must be <= {GRADE_LIMIT} (a fraction, tan alpha; not percent)"),
            ));
        }
        positive("min_radius_m", self.min_radius_m)?;
        if let Some(r) = self.min_sag_radius_m {
            positive("min_sag_radius_m", r)?;
        }
        if let Some(v) = self.design_speed_km_per_h {
            positive("design_speed_km_per_h", v)?;
        }
        if !(self.radius_band_m.is_finite() && self.radius_band_m >= 0.0) {
            return Err(invalid(
                "radius_band_m",
                self.radius_band_m,
                "must be finite and >= 0".into(),
            ));
        }
        positive("min_length_m", self.min_length_m)?;
        if !(self.max_length_flat_m.is_finite() && self.max_length_flat_m >= self.min_length_m) {
            return Err(invalid(
                "max_length_flat_m",
                self.max_length_flat_m,
                format!("must be finite and >= min_length_m ({})", self.min_length_m),
            ));
        }
        positive("length_e_folding_grade", self.length_e_folding_grade)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bundled_rule_set_parses_under_its_name() {
        for name in bundled_names() {
            let r = RoadRules::bundled(name).unwrap();
            assert_eq!(r.name, name);
            assert!(r.max_length_at(r.max_grade) < r.max_length_at(0.0) + 1e-9);
            // the canonical text parses back to the same rules
            assert_eq!(RoadRules::parse(&r.canonical_toml(), "x").unwrap(), r);
        }
    }

    #[test]
    fn length_range_shrinks_exponentially() {
        let r = RoadRules::bundled("highway-se").unwrap();
        let span = |g: f64| r.max_length_at(g) - r.min_length_m;
        let ratio = span(r.length_e_folding_grade) / span(0.0);
        assert!((ratio - (-1.0f64).exp()).abs() < 1e-12, "{ratio}");
    }

    #[test]
    fn aashto_k_values_follow_the_green_book_equations() {
        // Cross-check of the US customary K values in freeway-us.toml / urban-us.toml against
        // the Green Book's own design equations: stopping sight distance
        // SSD = 1.47·V·t + 1.075·V²/a (ft, V in mph, t = 2.5 s, a = 11.2 ft/s²), rounded up to
        // the next 5 ft; crest K = SSD²/2158 (eye 3.5 ft, object 2.0 ft, SSD < L), sag
        // K = SSD²/(400 + 3.5·SSD) (headlight 2 ft, 1° upward spread), both rounded up.
        let ssd = |v: f64| (((1.47 * v * 2.5 + 1.075 * v * v / 11.2) / 5.0).ceil()) * 5.0;
        let crest = |v: f64| (ssd(v).powi(2) / 2158.0).ceil();
        let sag = |v: f64| (ssd(v).powi(2) / (400.0 + 3.5 * ssd(v))).ceil();
        assert_eq!((ssd(70.0), crest(70.0), sag(70.0)), (730.0, 247.0, 181.0));
        assert_eq!((ssd(30.0), crest(30.0), sag(30.0)), (200.0, 19.0, 37.0));
        // R = 100·K, K in m per percent = 0.3048·K in ft per percent.
        let fw = RoadRules::bundled("freeway-us").unwrap();
        assert!((fw.min_radius_m - 100.0 * 0.3048 * 247.0).abs() < 1e-9);
        assert!((fw.min_sag_radius_m.unwrap() - 100.0 * 0.3048 * 181.0).abs() < 1e-9);
        let ur = RoadRules::bundled("urban-us").unwrap();
        assert!((ur.min_radius_m - 100.0 * 0.3048 * 19.0).abs() < 1e-9);
        assert!((ur.min_sag_radius_m.unwrap() - 100.0 * 0.3048 * 37.0).abs() < 1e-9);
    }
}
