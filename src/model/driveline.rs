//! Driveline parameters (docs/models/driveline.md): the typed `[driveline]` section of a vehicle
//! file, checked key by key against `schemas/vehicle.toml` (unit, range, shape).
//!
//! Symbols (the model of Myklebust & Eriksson (2012), §2, as docs/models/driveline.md restates it):
//! J_e engine + flywheel, J_c clutch disc, k_c/c_c clutch torsion spring, J_t(i) gearbox inertia
//! referred to its output shaft in gear i, b_t gearbox loss, J_p/k_p/c_p propeller shaft,
//! i_f/J_f/b_f final drive, J_d/k_d/c_d drive shafts (lumped, the main flexibility), J_w wheels,
//! r_w wheel radius, m vehicle mass. All SI.

use serde::Deserialize;
use std::sync::OnceLock;

const SCHEMA_TOML: &str = include_str!("../../schemas/vehicle.toml");

/// `sin α` of a road slope `s = tan α`, as the grade force `m g sin α` needs it:
/// `s / √(1 + s²)`: `sin(atan s)` without its two transcendental calls, which would take
/// about a tenth of a simulation step's time.
#[inline]
pub fn grade_sine(slope: f64) -> f64 {
    slope / (1.0 + slope * slope).sqrt()
}

/// Shape of a vehicle-file value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    /// One number.
    Scalar,
    /// One number per forward gear.
    PerGear,
    /// A curve: as many numbers as the other curve keys.
    Curve,
}

impl std::fmt::Display for Shape {
    /// As the schema writes it: `scalar`, `per_gear`, `curve`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Shape::Scalar => "scalar",
            Shape::PerGear => "per_gear",
            Shape::Curve => "curve",
        })
    }
}

/// One key of the vehicle-file schema.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeySpec {
    /// Key name (unit in the name).
    pub key: String,
    /// SI unit.
    pub unit: String,
    /// Smallest physical value.
    pub min: f64,
    /// Largest physical value.
    pub max: f64,
    /// Value shape.
    pub shape: Shape,
    /// For a curve: the key whose length it must match.
    #[serde(default)]
    pub pair: Option<String>,
    /// The value an absent key stands for; `None`: the key is required.
    #[serde(default)]
    pub default: Option<f64>,
    /// Symbol and meaning.
    pub meaning: String,
}

/// The vehicle-file schema.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleSchema {
    /// Version.
    pub schema_version: String,
    /// Keys of the `[driveline]` table.
    pub driveline: Vec<KeySpec>,
    /// Keys of the `[axles]` table.
    pub axles: Vec<KeySpec>,
    /// Keys of the optional `[sensors]` table (each key optional).
    #[serde(default)]
    pub sensors: Vec<KeySpec>,
}

/// Checks a raw vehicle-file table against its key specs: no unknown key, every key without a
/// default present, numeric, finite and inside its range; per-gear lists one value per forward
/// gear; curves at least 2 points and as long as their pair.
///
/// # Errors
/// The first problem as `(key, value, rule)`.
pub fn check_keys(
    specs: &[KeySpec],
    table: &toml::Table,
    forward_gears: usize,
) -> Result<(), KeyProblem> {
    let problem = |key: &str, value: String, rule: String| (key.to_string(), value, rule);
    for k in table.keys() {
        if !specs.iter().any(|s| &s.key == k) {
            return Err(problem(k, table[k].to_string(), "unknown key".into()));
        }
    }
    let mut lengths: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for spec in specs {
        let Some(v) = table.get(&spec.key) else {
            if spec.default.is_some() {
                continue;
            }
            return Err(problem(
                &spec.key,
                "missing".into(),
                format!("required ({}, {})", spec.meaning, spec.unit),
            ));
        };
        let numbers: Vec<f64> = match (spec.shape, v) {
            (Shape::Scalar, toml::Value::Float(x)) => vec![*x],
            (Shape::Scalar, toml::Value::Integer(i)) => vec![*i as f64],
            (Shape::PerGear | Shape::Curve, toml::Value::Array(a)) => {
                let mut out = Vec::with_capacity(a.len());
                for e in a {
                    match e {
                        toml::Value::Float(x) => out.push(*x),
                        toml::Value::Integer(i) => out.push(*i as f64),
                        other => {
                            return Err(problem(
                                &spec.key,
                                other.to_string(),
                                "must be numbers".into(),
                            ))
                        }
                    }
                }
                out
            }
            (shape, other) => {
                return Err(problem(
                    &spec.key,
                    other.to_string(),
                    format!("must be {shape} numbers"),
                ))
            }
        };
        for x in &numbers {
            if !x.is_finite() || *x < spec.min || *x > spec.max {
                return Err(problem(
                    &spec.key,
                    x.to_string(),
                    format!(
                        "must be finite and within [{}, {}] {}",
                        spec.min, spec.max, spec.unit
                    ),
                ));
            }
        }
        match spec.shape {
            Shape::PerGear if numbers.len() != forward_gears => {
                return Err(problem(
                    &spec.key,
                    format!("{} values", numbers.len()),
                    format!("needs one value per forward gear ({forward_gears})"),
                ))
            }
            Shape::Curve => {
                if numbers.len() < 2 {
                    return Err(problem(
                        &spec.key,
                        format!("{} values", numbers.len()),
                        "a curve needs at least 2 points".into(),
                    ));
                }
                if let Some(pair) = spec.pair.as_deref() {
                    if let Some(&n) = lengths.get(pair) {
                        if n != numbers.len() {
                            return Err(problem(
                                &spec.key,
                                format!("{} values", numbers.len()),
                                format!("must have as many values as {pair} ({n})"),
                            ));
                        }
                    }
                }
                lengths.insert(spec.key.as_str(), numbers.len());
            }
            _ => {}
        }
    }
    Ok(())
}

/// The embedded vehicle-file schema.
///
/// # Panics
/// Never in a released build: the embedded file is parsed by the test suite.
pub fn vehicle_schema() -> &'static VehicleSchema {
    static S: OnceLock<VehicleSchema> = OnceLock::new();
    S.get_or_init(|| toml::from_str(SCHEMA_TOML).expect("embedded schemas/vehicle.toml is valid"))
}

/// Driveline parameters, SI units (docs/models/driveline.md).
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)] // each field is documented in schemas/vehicle.toml (meaning, unit, range)
pub struct DrivelineParams {
    pub mass_kg: f64,
    pub wheel_radius_m: f64,
    pub j_w_kg_m2: f64,
    pub j_e_kg_m2: f64,
    pub j_c_kg_m2: f64,
    pub k_c_nm_per_rad: f64,
    pub c_c_nm_s_per_rad: f64,
    pub j_t_kg_m2: Vec<f64>,
    pub b_t_nm_s_per_rad: f64,
    pub j_p_kg_m2: f64,
    pub k_p_nm_per_rad: f64,
    pub c_p_nm_s_per_rad: f64,
    pub final_drive_ratio: f64,
    pub j_f_kg_m2: f64,
    pub b_f_nm_s_per_rad: f64,
    pub j_d_kg_m2: f64,
    pub k_d_nm_per_rad: f64,
    pub c_d_nm_s_per_rad: f64,
    pub rho_air_kg_per_m3: f64,
    pub c_w_a_f_m2: f64,
    pub c_r1: f64,
    pub c_r2_s_per_m: f64,
    pub c_sr_s2_per_m2: f64,
    pub gravity_m_per_s2: f64,
    pub clutch_x_max: f64,
    pub clutch_l_lower: f64,
    pub clutch_l_upper: f64,
    pub clutch_max_torque_nm: f64,
    pub clutch_static_to_kinetic: f64,
    pub engine_speed_rad_per_s: Vec<f64>,
    pub engine_max_torque_nm: Vec<f64>,
    pub engine_min_torque_nm: f64,
    pub pi_kp_nm_s_per_rad: f64,
    pub pi_ki_nm_per_rad: f64,
    #[serde(default = "default_engine_torque_lag_s")]
    pub engine_torque_lag_s: f64,
    #[serde(default)]
    pub tyre_cold_excess: f64,
    #[serde(default = "default_tyre_warm_up_distance_m")]
    pub tyre_warm_up_distance_m: f64,
}

/// The engine-torque lag a `[driveline]` table without `engine_torque_lag_s` stands for, s: none,
/// the model driven by the reported torque, as vehicle files written before the key read. A
/// turbocharged heavy-duty diesel's produced torque follows its ECU's figure with a time
/// constant of about 0.1 s, which a file states (schemas/vehicle.toml).
pub const DEFAULT_ENGINE_TORQUE_LAG_S: f64 = 0.0;

fn default_engine_torque_lag_s() -> f64 {
    DEFAULT_ENGINE_TORQUE_LAG_S
}

/// The distance over which cold tyres' extra rolling resistance falls by e, when a
/// `[driveline]` table states a cold excess without it, m: 20 km
/// ([`super::tyre_warm_up`]; schemas/vehicle.toml).
pub const DEFAULT_TYRE_WARM_UP_DISTANCE_M: f64 = 20_000.0;

fn default_tyre_warm_up_distance_m() -> f64 {
    DEFAULT_TYRE_WARM_UP_DISTANCE_M
}

/// A `[driveline]` table that breaks a rule: `(key, value as written, rule)`.
pub type KeyProblem = (String, String, String);

impl DrivelineParams {
    /// Checks a raw `[driveline]` table against the schema (every key present, numeric, finite,
    /// inside its range, per-gear lists one value per forward gear, curves of equal length and
    /// increasing speed, L_l < L_u) and converts it.
    ///
    /// # Errors
    /// The first problem as `(key, value, rule)`.
    pub fn from_table(table: &toml::Table, forward_gears: usize) -> Result<Self, KeyProblem> {
        let problem = |key: &str, value: String, rule: String| (key.to_string(), value, rule);
        check_keys(&vehicle_schema().driveline, table, forward_gears)?;
        let p: DrivelineParams = table
            .clone()
            .try_into()
            .map_err(|e: toml::de::Error| problem("driveline", String::new(), e.to_string()))?;
        if p.clutch_l_lower >= p.clutch_l_upper {
            return Err(problem(
                "clutch_l_upper",
                p.clutch_l_upper.to_string(),
                "must exceed clutch_l_lower".into(),
            ));
        }
        if p.engine_speed_rad_per_s.windows(2).any(|w| w[1] <= w[0]) {
            return Err(problem(
                "engine_speed_rad_per_s",
                crate::number_fmt::list(&p.engine_speed_rad_per_s),
                "must increase".into(),
            ));
        }
        Ok(p)
    }

    /// Engine full-load torque at speed `w_rad_s` (linear interpolation, held beyond the ends), N·m.
    pub fn engine_max_torque(&self, w_rad_s: f64) -> f64 {
        let (s, t) = (&self.engine_speed_rad_per_s, &self.engine_max_torque_nm);
        let k = s.partition_point(|&x| x <= w_rad_s);
        if k == 0 {
            return t[0];
        }
        if k == s.len() {
            return t[s.len() - 1];
        }
        let f = (w_rad_s - s[k - 1]) / (s[k] - s[k - 1]);
        t[k - 1] + f * (t[k] - t[k - 1])
    }

    /// Kinetic clutch capacity M_k at clutch position `x` (docs/models/driveline.md actuator law:
    /// `x_eff = clamp(x/x_max, L_l, L_u)`, `M_k = k_clutch (L_u − x_eff)/(L_u − L_l)`), N·m.
    pub fn clutch_capacity(&self, x: f64) -> f64 {
        let x_eff = (x / self.clutch_x_max).clamp(self.clutch_l_lower, self.clutch_l_upper);
        self.clutch_max_torque_nm * (self.clutch_l_upper - x_eff)
            / (self.clutch_l_upper - self.clutch_l_lower)
    }

    /// The clutch position whose kinetic capacity is `torque_nm`: the inverse of
    /// [`DrivelineParams::clutch_capacity`], clamped to the effective range.
    pub fn clutch_position_for(&self, torque_nm: f64) -> f64 {
        let f = (torque_nm / self.clutch_max_torque_nm).clamp(0.0, 1.0);
        (self.clutch_l_upper - f * (self.clutch_l_upper - self.clutch_l_lower)) * self.clutch_x_max
    }

    /// Torque through a locked clutch, `M_trans = (M_e J_c + M_c J_e)/(J_e + J_c)`, N·m.
    pub fn locked_clutch_torque(&self, m_e: f64, m_c: f64) -> f64 {
        (m_e * self.j_c_kg_m2 + m_c * self.j_e_kg_m2) / (self.j_e_kg_m2 + self.j_c_kg_m2)
    }

    /// Road force at the wheels `F = sign(v)(F_r + F_a + F_b) + F_g`, N (positive resists forward
    /// motion): `F_r = f(v)(c_r1 + c_r2|v|) m g` with `f(v) = 1 − exp(−c_sr v²)` when `smoothing`
    /// (else 1), `F_a = ½ρ c_wA_f v²`, `F_g = m g sin(atan s)` for slope s = tan α; sign(0) = 0.
    pub fn road_force(&self, v_mps: f64, slope: f64, brake_n: f64, smoothing: bool) -> f64 {
        let v = v_mps;
        let f = if smoothing {
            self.rolling_smoothing(v)
        } else {
            1.0
        };
        let mg = self.mass_kg * self.gravity_m_per_s2;
        let f_r = f * (self.c_r1 + self.c_r2_s_per_m * v.abs()) * mg;
        let f_a = 0.5 * self.rho_air_kg_per_m3 * self.c_w_a_f_m2 * v * v;
        let sgn = if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        };
        sgn * (f_r + f_a + brake_n) + mg * grade_sine(slope)
    }

    /// The rolling-resistance smoothing `f(v) = 1 − exp(−c_sr v²)` (docs/models/driveline.md), 1.
    ///
    /// Where `exp(−c_sr v²) < 2⁻⁵⁴` the difference rounds to exactly 1.0 in IEEE double, so for
    /// `c_sr v² > 40` (`exp(−40) ≈ 4·10⁻¹⁸`) 1.0 is returned without calling `exp` — the same
    /// bits, without libm's slow underflow path that large arguments take (measured: 15 % of
    /// the accurate integrator's time at highway speed).
    pub fn rolling_smoothing(&self, v_mps: f64) -> f64 {
        let x = self.c_sr_s2_per_m2 * v_mps * v_mps;
        if x > 40.0 {
            1.0
        } else {
            1.0 - (-x).exp()
        }
    }

    /// J4 = m·r_w² + J_w, the vehicle inertia seen at the wheel, kg·m².
    pub fn j4(&self) -> f64 {
        self.mass_kg * self.wheel_radius_m.powi(2) + self.j_w_kg_m2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bundled truck-40t vehicle file as a TOML table.
    fn truck_40t() -> toml::Table {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/fixtures/vehicles/truck-40t.toml"
        ))
        .unwrap();
        toml::from_str(&text).unwrap()
    }

    #[test]
    fn rolling_smoothing_has_the_bits_of_the_formula() {
        // the short cut above c_sr v² = 40 must give exactly 1 − exp(−c_sr v²): checked on a
        // fine sweep across the cut (x from 0 to 60) and far beyond it (exp underflows)
        let doc = truck_40t();
        let mut p: DrivelineParams = doc["driveline"].clone().try_into().unwrap();
        for c_sr in [p.c_sr_s2_per_m2, 1.0, 1e3] {
            p.c_sr_s2_per_m2 = c_sr;
            for k in 0..=60_000 {
                let x = k as f64 * 1e-3;
                let v = (x / c_sr).sqrt();
                let direct = 1.0 - (-c_sr * v * v).exp();
                assert_eq!(
                    p.rolling_smoothing(v).to_bits(),
                    direct.to_bits(),
                    "x = {x}"
                );
                assert_eq!(p.rolling_smoothing(-v).to_bits(), direct.to_bits());
            }
            for v in [30.0, 1e3, 1e10] {
                assert_eq!(p.rolling_smoothing(v), 1.0 - (-c_sr * v * v).exp());
            }
        }
    }

    #[test]
    fn schema_lists_every_field() {
        // every struct field has a schema entry and vice versa: the fixture parses through both
        let doc = truck_40t();
        let t = doc["driveline"].as_table().unwrap();
        let p = DrivelineParams::from_table(t, 12).unwrap();
        let fields: Vec<String> = toml::Table::try_from(&p).unwrap().keys().cloned().collect();
        let mut keys: Vec<String> = vehicle_schema()
            .driveline
            .iter()
            .map(|s| s.key.clone())
            .collect();
        keys.sort();
        assert_eq!(fields, keys);
        assert_eq!(p.engine_torque_lag_s, 0.1);
        // a key with a default may be left out, which the default then stands for; no other
        for spec in &vehicle_schema().driveline {
            let mut without = t.clone();
            without.remove(&spec.key);
            match (spec.default, DrivelineParams::from_table(&without, 12)) {
                (Some(d), Ok(q)) => {
                    let q = toml::Table::try_from(&q).unwrap();
                    assert_eq!(q[&spec.key].as_float(), Some(d), "{}", spec.key);
                }
                (None, Err((key, value, _))) => {
                    assert_eq!((key, value), (spec.key.clone(), "missing".to_string()))
                }
                (d, r) => panic!("{}: default {d:?}, parsed {}", spec.key, r.is_ok()),
            }
        }
        assert_eq!(DEFAULT_ENGINE_TORQUE_LAG_S, 0.0);
        assert_eq!(p.j_t_kg_m2.len(), 12);
        assert_eq!(p.engine_max_torque(120.0), 2600.0);
        assert_eq!(p.engine_max_torque(0.0), 1100.0);
    }

    #[test]
    fn problems_name_the_key() {
        let doc = truck_40t();
        let base = doc["driveline"].as_table().unwrap().clone();
        let with = |k: &str, v: toml::Value| {
            let mut t = base.clone();
            t.insert(k.into(), v);
            DrivelineParams::from_table(&t, 12).unwrap_err()
        };
        assert_eq!(
            with("k_d_nm_per_rad", toml::Value::Float(-1.0)).0,
            "k_d_nm_per_rad"
        );
        assert_eq!(with("mass_kg", toml::Value::Float(f64::NAN)).0, "mass_kg");
        assert_eq!(
            with(
                "j_t_kg_m2",
                toml::Value::Array(vec![toml::Value::Float(1.0)])
            )
            .0,
            "j_t_kg_m2"
        );
        assert_eq!(
            with("warp_factor", toml::Value::Float(1.0)).0,
            "warp_factor"
        );
        assert_eq!(
            with("clutch_l_upper", toml::Value::Float(0.01)).0,
            "clutch_l_upper"
        );
        let mut t = base.clone();
        t.remove("c_d_nm_s_per_rad");
        assert_eq!(
            DrivelineParams::from_table(&t, 12).unwrap_err().0,
            "c_d_nm_s_per_rad"
        );
    }
}
