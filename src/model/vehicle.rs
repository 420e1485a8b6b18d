//! Vehicle files (`fixtures/vehicles/*.toml`): the parameters models need, with units in the
//! key names.
//!
//! A file carries identification, the gearbox (ingest uses it to reject gears outside the
//! gearbox) and, optionally, the driveline (docs/models/driveline.md) and axle-load
//! (docs/models/axle.md) sections, each checked key by key against `schemas/vehicle.toml`.

use super::axle::AxleParams;
use super::driveline::{check_keys, vehicle_schema, DrivelineParams};
use super::tolerance::Tolerances;
use serde::Deserialize;
use std::path::Path;
use thiserror::Error;

/// Gearbox description.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Gearbox {
    /// Number of forward gears (gear 1 … n).
    pub forward_gears: u8,
    /// Number of reverse gears (gear −1 … −n).
    #[serde(default)]
    pub reverse_gears: u8,
    /// Ratio of each forward gear, lowest first (i_t, dimensionless), if known.
    #[serde(default)]
    pub ratios: Vec<f64>,
    /// Final-drive ratio i_f, for vehicles without a `[driveline]` section (which has its own
    /// `final_drive_ratio`; when both are given they must agree).
    #[serde(default)]
    pub final_drive_ratio: Option<f64>,
}

/// A parsed vehicle file.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct VehicleFile {
    /// Vehicle id as it appears in drive metadata and manifests.
    pub vehicle_id: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Gearbox.
    pub gearbox: Gearbox,
    /// Driveline parameters (docs/models/driveline.md), checked against `schemas/vehicle.toml`.
    #[serde(skip)]
    pub driveline: Option<DrivelineParams>,
    /// The raw `[driveline]` table as written (checked and converted by [`VehicleFile::parse`]).
    #[serde(default, rename = "driveline")]
    driveline_raw: Option<toml::Table>,
    /// Axle-load parameters (docs/models/axle.md), checked against `schemas/vehicle.toml`.
    #[serde(skip)]
    pub axles: Option<AxleParams>,
    /// The raw `[axles]` table as written (checked and converted by [`VehicleFile::parse`]).
    #[serde(default, rename = "axles")]
    axles_raw: Option<toml::Table>,
    /// How the vehicle's bus sends its signals (the optional `[sensors]` table).
    #[serde(skip)]
    pub sensors: Sensors,
    /// The raw `[sensors]` table as written.
    #[serde(default, rename = "sensors")]
    sensors_raw: Option<toml::Table>,
    /// Tolerances of the file's values ([`super::tolerance`]): the `[tolerance]` table's
    /// entries, every other parameter its kind's default.
    #[serde(skip)]
    pub tolerance: Tolerances,
    /// The raw `[tolerance]` table as written.
    #[serde(default, rename = "tolerance")]
    tolerance_raw: Option<toml::Table>,
}

/// The optional `[sensors]` table: how the vehicle's bus sends its signals (from its DBC or
/// J1939 scaling), each key checked against `schemas/vehicle.toml`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sensors {
    /// Resolution of the `road_slope` channel, tan α per step (a grade sent in whole percent:
    /// 0.01), when the file gives it.
    pub road_slope_resolution: Option<f64>,
}

impl Sensors {
    /// The slope resolution a vehicle file without `road_slope_resolution` stands for: 0.001
    /// tan α per step (a grade sent in tenths of a percent).
    pub const DEFAULT_ROAD_SLOPE_RESOLUTION: f64 = 0.001;

    /// The `road_slope` channel's resolution, tan α per step: the file's, else
    /// [`Sensors::DEFAULT_ROAD_SLOPE_RESOLUTION`].
    pub fn road_slope_resolution(&self) -> f64 {
        self.road_slope_resolution
            .unwrap_or(Self::DEFAULT_ROAD_SLOPE_RESOLUTION)
    }
}

/// A vehicle file that cannot be used; names the file and the key.
#[derive(Debug, Error)]
pub enum VehicleError {
    /// Read error.
    #[error("{file}: {source}")]
    Io {
        /// File.
        file: String,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Syntax, unknown key or wrong type.
    #[error("{file}: {source}")]
    Parse {
        /// File.
        file: String,
        /// Cause (names the key and line).
        #[source]
        source: toml::de::Error,
    },
    /// A value outside its range.
    #[error("{file}: {key} = {value}: {rule}")]
    Range {
        /// File.
        file: String,
        /// Key.
        key: String,
        /// Value.
        value: String,
        /// The rule it breaks.
        rule: String,
    },
}

impl VehicleFile {
    /// Reads and validates a vehicle file.
    ///
    /// # Errors
    /// [`VehicleError`] naming the file and offending key.
    pub fn load(path: &Path) -> Result<Self, VehicleError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| VehicleError::Io {
            file: file.clone(),
            source: e,
        })?;
        Self::parse(&text, &file)
    }

    /// Parses and validates vehicle-file text; `file` names it in errors.
    ///
    /// # Errors
    /// [`VehicleError::Parse`] or [`VehicleError::Range`].
    pub fn parse(text: &str, file: &str) -> Result<Self, VehicleError> {
        let mut v: VehicleFile = toml::from_str(text).map_err(|e| VehicleError::Parse {
            file: file.into(),
            source: e,
        })?;
        let range = |key: &str, value: String, rule: &str| VehicleError::Range {
            file: file.into(),
            key: key.into(),
            value,
            rule: rule.into(),
        };
        let g = v.gearbox.clone();
        let g = &g;
        if g.forward_gears == 0 || g.forward_gears > 32 {
            return Err(range(
                "gearbox.forward_gears",
                g.forward_gears.to_string(),
                "must be 1 … 32",
            ));
        }
        if !g.ratios.is_empty() {
            if g.ratios.len() != usize::from(g.forward_gears) {
                return Err(range(
                    "gearbox.ratios",
                    format!("{} entries", g.ratios.len()),
                    "needs one ratio per forward gear",
                ));
            }
            if g.ratios.iter().any(|r| !(r.is_finite() && *r > 0.0))
                || g.ratios.windows(2).any(|w| w[1] > w[0])
            {
                return Err(range(
                    "gearbox.ratios",
                    crate::number_fmt::list(&g.ratios),
                    "ratios must be positive and non-increasing from gear 1",
                ));
            }
        }
        if let Some(t) = v.driveline_raw.take() {
            let p = DrivelineParams::from_table(&t, usize::from(g.forward_gears)).map_err(
                |(key, value, rule)| VehicleError::Range {
                    file: file.into(),
                    key: format!("driveline.{key}"),
                    value,
                    rule,
                },
            )?;
            v.driveline = Some(p);
        }
        if let Some(i_f) = g.final_drive_ratio {
            if !(i_f.is_finite() && i_f > 0.0) {
                return Err(range(
                    "gearbox.final_drive_ratio",
                    i_f.to_string(),
                    "must be positive",
                ));
            }
            if let Some(d) = &v.driveline {
                if d.final_drive_ratio != i_f {
                    return Err(range(
                        "gearbox.final_drive_ratio",
                        i_f.to_string(),
                        &format!(
                            "disagrees with driveline.final_drive_ratio = {}",
                            d.final_drive_ratio
                        ),
                    ));
                }
            }
        }
        if let Some(t) = v.axles_raw.take() {
            let p =
                AxleParams::from_table(&t).map_err(|(key, value, rule)| VehicleError::Range {
                    file: file.into(),
                    key: format!("axles.{key}"),
                    value,
                    rule,
                })?;
            if let Some(d) = &v.driveline {
                let m = p.mass_kg();
                if (d.mass_kg - m).abs() > 0.01 * m {
                    return Err(VehicleError::Range {
                        file: file.into(),
                        key: "driveline.mass_kg".into(),
                        value: d.mass_kg.to_string(),
                        rule: format!(
                            "disagrees with the [axles] masses ({m} kg) by more than 1 %"
                        ),
                    });
                }
            }
            v.axles = Some(p);
        }
        if let Some(t) = v.sensors_raw.take() {
            // every key optional: the specs of the keys given, so a key outside the schema is
            // still "unknown" and none is "missing"
            let specs: Vec<_> = vehicle_schema()
                .sensors
                .iter()
                .filter(|s| t.contains_key(&s.key))
                .cloned()
                .collect();
            check_keys(&specs, &t, usize::from(g.forward_gears)).map_err(
                |(key, value, rule)| VehicleError::Range {
                    file: file.into(),
                    key: format!("sensors.{key}"),
                    value,
                    rule,
                },
            )?;
            v.sensors = Sensors {
                road_slope_resolution: t
                    .get("road_slope_resolution")
                    .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64))),
            };
        }
        if let Some(t) = v.tolerance_raw.take() {
            let schema = vehicle_schema();
            let known = |k: &str| {
                schema
                    .driveline
                    .iter()
                    .chain(&schema.axles)
                    .any(|s| s.key == k)
            };
            v.tolerance = Tolerances::from_table(&t, known).map_err(|(key, value, rule)| {
                VehicleError::Range {
                    file: file.into(),
                    key: format!("tolerance.{key}"),
                    value,
                    rule,
                }
            })?;
        }
        let warm_up = v
            .driveline
            .as_ref()
            .is_some_and(|d| d.tyre_cold_excess > 0.0);
        v.tolerance = std::mem::take(&mut v.tolerance).with_tyre_warm_up(warm_up);
        Ok(v)
    }

    /// Driveline parameters, or an error naming the file when the section is absent.
    ///
    /// # Errors
    /// [`VehicleError::Range`] for a vehicle file without `[driveline]`.
    pub fn driveline(&self, file: &str) -> Result<&DrivelineParams, VehicleError> {
        self.driveline.as_ref().ok_or_else(|| VehicleError::Range {
            file: file.into(),
            key: "driveline".into(),
            value: "missing".into(),
            rule: "the driveline model needs a [driveline] section".into(),
        })
    }

    /// Axle-load parameters, or an error naming the file when the section is absent.
    ///
    /// # Errors
    /// [`VehicleError::Range`] for a vehicle file without `[axles]`.
    pub fn axles(&self, file: &str) -> Result<&AxleParams, VehicleError> {
        self.axles.as_ref().ok_or_else(|| VehicleError::Range {
            file: file.into(),
            key: "axles".into(),
            value: "missing".into(),
            rule: "the axle-load model needs an [axles] section".into(),
        })
    }

    /// Final-drive ratio: the driveline's, else the gearbox section's.
    pub fn final_drive_ratio(&self) -> Option<f64> {
        self.driveline
            .as_ref()
            .map(|d| d.final_drive_ratio)
            .or(self.gearbox.final_drive_ratio)
    }

    /// Valid gear range for ingest checks: (−reverse_gears, forward_gears).
    pub fn gear_range(&self) -> (i16, i16) {
        (
            -i16::from(self.gearbox.reverse_gears),
            i16::from(self.gearbox.forward_gears),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixture_vehicle_parses() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/vehicles/truck-40t.toml");
        let v = VehicleFile::load(&p).unwrap();
        assert_eq!(v.gear_range(), (-2, 12));
    }

    #[test]
    fn bad_values_name_the_key() {
        let e = VehicleFile::parse(
            "vehicle_id = \"x\"\n[gearbox]\nforward_gears = 0\n",
            "v.toml",
        )
        .unwrap_err();
        assert!(e.to_string().contains("gearbox.forward_gears"), "{e}");
        let e = VehicleFile::parse(
            "vehicle_id = \"x\"\n[gearbox]\nforward_gears = 2\nratios = [1.0, 2.0]\n",
            "v.toml",
        )
        .unwrap_err();
        assert!(e.to_string().contains("gearbox.ratios"), "{e}");
        let e = VehicleFile::parse(
            "vehicle_id = \"x\"\ncolour = 1\n[gearbox]\nforward_gears = 2\n",
            "v.toml",
        )
        .unwrap_err();
        assert!(e.to_string().contains("colour"), "{e}");
    }

    const HEAD: &str = "vehicle_id = \"T\"\n[gearbox]\nforward_gears = 2\nratios = [2.0, 1.0]\n";

    #[test]
    fn the_sensors_table_is_optional_and_checked_key_by_key() {
        let v = VehicleFile::parse(HEAD, "v.toml").unwrap();
        assert_eq!(v.sensors.road_slope_resolution, None);
        assert_eq!(v.sensors.road_slope_resolution(), 0.001);
        let v = VehicleFile::parse(
            &format!("{HEAD}[sensors]\nroad_slope_resolution = 0.01\n"),
            "v.toml",
        )
        .unwrap();
        assert_eq!(v.sensors.road_slope_resolution(), 0.01);
        for (body, key, rule) in [
            (
                "road_slope_resolutoin = 0.01",
                "sensors.road_slope_resolutoin",
                "unknown key",
            ),
            (
                "road_slope_resolution = 0.5",
                "sensors.road_slope_resolution",
                "within",
            ),
            (
                "road_slope_resolution = \"1 %\"",
                "sensors.road_slope_resolution",
                "must be",
            ),
        ] {
            match VehicleFile::parse(&format!("{HEAD}[sensors]\n{body}\n"), "v.toml") {
                Err(VehicleError::Range {
                    key: k, rule: r, ..
                }) => {
                    assert_eq!(k, key, "{body}");
                    assert!(r.contains(rule), "{body}: {r}");
                }
                other => panic!("{body}: {other:?}"),
            }
        }
    }

    #[test]
    fn the_bundled_40_t_truck_sends_its_slope_in_whole_percent() {
        let p = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/vehicles/truck-40t.toml"
        );
        let v = VehicleFile::load(std::path::Path::new(p)).unwrap();
        assert_eq!(v.sensors.road_slope_resolution(), 0.01);
    }
}
