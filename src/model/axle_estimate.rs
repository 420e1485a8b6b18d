//! Axle-model parameters from checked measurements ([`Measurements`], docs/models/axle.md):
//! the estimation functions of [`axle_estimation`](super::axle_estimation) run with the geometry
//! and axle masses of a vehicle file's `[axles]` section into an [`AxleEstimate`] (SI units, the
//! unit in each name).
//!
//! # Estimation (axle-load thesis, §3.3)
//!
//! With the scale weights `w_i` (N_i = w_i·g), the axle positions `x_r`, `x_t` behind the front
//! axle, the axle masses `m_ai` and the arm levers `l_a`, `l_b` of the vehicle file:
//! - total mass `m = Σ w_i` and vehicle CG `x_CG = (N_r x_r + N_t x_t)/(m g)` (eq. 3.3.2);
//! - chassis load on each axle `m_i = w_i − m_ai` (eq. 3.3.8), chassis mass `m_c = Σ m_i`, and
//!   chassis CG `x_c = Σ m_i x_i / m_c` (eq. 3.3.2 applied to the chassis loads: the axle masses
//!   sit at their axles);
//! - static bellow force `F_s = m_i g l_a/l_b` from each arm's moment balance (eq. 3.3.9); the
//!   front bellow acts directly above its axle, `F_s = m_f g` (eq. 3.3.5);
//! - effective bellow area `A_eff = F_s/p_s` where a static pressure is given (eq. 3.3.10);
//! - bellow stiffness: slope of the least-squares force–displacement line of each test (eq.
//!   3.3.6, thesis fig. 3.10), pressures converted to forces with `F = p·A_eff` (eq. 3.3.7) and
//!   the area estimated from the static state, as the thesis does; several tests of one axle are
//!   reported each, and the snippet takes the mean of their slopes;
//! - damper coefficients per branch, least squares through the origin (§3.3.3), and the
//!   datasheet points as the vehicle file's damper tables: extension (`v > 0`) and compression
//!   (`v < 0`) branches, both with positive speeds and forces, sorted by speed.

use super::axle::{Axle, AxleParams, DamperTable};
use super::axle_estimation::{
    bellow_stiffness, cg_from_scale_weights, damper_coefficients, effective_bellow_area,
    static_bellow_force, DamperFit, EstimationError, LineFit,
};
use super::axle_measurement::{BellowLoad, DamperDatasheet, MeasurementError, Measurements};

/// Bellow stiffness from one test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StiffnessEstimate {
    /// Axle.
    pub axle: Axle,
    /// Index of the test in the file's `[[bellow_test]]` entries.
    pub test: usize,
    /// Force–displacement line: slope N/m (the stiffness), intercept N, R².
    pub fit: LineFit,
    /// Whether the forces came from pressures (`F = p·A_eff`).
    pub from_pressure: bool,
}

/// Damper estimates from one datasheet.
#[derive(Debug, Clone, PartialEq)]
pub struct DamperEstimate {
    /// Axle.
    pub axle: Axle,
    /// Index of the datasheet in the file's `[[damper_datasheet]]` entries.
    pub datasheet: usize,
    /// Linear coefficients per branch, N·s/m.
    pub fit: DamperFit,
    /// The datasheet points as the vehicle file's tables (positive speeds and forces).
    pub table: DamperTable,
}

/// Every estimate of the axle-load thesis, §3.3, SI units (the unit is in each name); per-axle
/// arrays in [`Axle::ALL`] order.
#[derive(Debug, Clone, PartialEq)]
pub struct AxleEstimate {
    /// The measurement file.
    pub measurement_file: String,
    /// The vehicle file that gave the geometry and axle masses.
    pub vehicle_file: String,
    /// Scale weights as measured, kg.
    pub scale_weight_kg: [f64; 3],
    /// Total mass `Σ w_i`, kg.
    pub mass_kg: f64,
    /// Vehicle CG behind the front axle (eq. 3.3.2), m.
    pub x_cg_m: f64,
    /// Chassis (sprung) mass `Σ w_i − Σ m_ai`, kg.
    pub chassis_mass_kg: f64,
    /// Chassis CG behind the front axle, m.
    pub chassis_x_cg_m: f64,
    /// Static bellow forces (eq. 3.3.9; front eq. 3.3.5), N.
    pub bellow_force_n: [f64; 3],
    /// Effective bellow areas `F_s/p_s` (eq. 3.3.10) where a static pressure was given, m².
    pub bellow_area_m2: [Option<f64>; 3],
    /// Bellow stiffness per test (eq. 3.3.6).
    pub stiffness: Vec<StiffnessEstimate>,
    /// Damper coefficients and tables per datasheet.
    pub dampers: Vec<DamperEstimate>,
}

/// Arm levers `(l_a, l_b)` of an axle; the front bellow acts directly above its axle, which is
/// the lever ratio 1 (axle-load thesis, eq. 3.3.5).
fn levers(v: &AxleParams, a: Axle) -> (f64, f64) {
    v.arm(a).map_or((1.0, 1.0), |(_, la, lb, _, _)| (la, lb))
}

/// Datasheet points as the vehicle file's branch tables (module doc), checked so that the
/// vehicle file accepts them: signs, at least two points per branch, speeds strictly
/// increasing, forces not falling. A point (0, 0) carries no information and is dropped.
fn datasheet_table(
    d: &DamperDatasheet,
    k: usize,
    file: &str,
) -> Result<DamperTable, MeasurementError> {
    let value = |key: &str, value: String, rule: String| MeasurementError::Value {
        file: file.into(),
        key: format!("damper_datasheet[{k}].{key}"),
        value,
        rule,
    };
    if d.velocity_m_per_s.len() != d.force_n.len() {
        return Err(value(
            "force_n",
            format!("{} values", d.force_n.len()),
            format!(
                "needs one force per velocity ({} velocities)",
                d.velocity_m_per_s.len()
            ),
        ));
    }
    let (mut ext, mut comp) = (Vec::new(), Vec::new());
    for (&v, &f) in d.velocity_m_per_s.iter().zip(&d.force_n) {
        if !(v.is_finite() && f.is_finite()) {
            return Err(value(
                "force_n",
                format!("({v} m/s, {f} N)"),
                "must be finite".into(),
            ));
        }
        if v == 0.0 && f == 0.0 {
            continue;
        }
        if v * f <= 0.0 {
            return Err(value(
                "force_n",
                format!("{f} at {v} m/s"),
                "a damper force has the sign of its velocity (+ extension, − compression) and is not zero".into(),
            ));
        }
        if v > 0.0 {
            ext.push((v, f));
        } else {
            comp.push((-v, -f));
        }
    }
    let branch = |pts: &mut Vec<(f64, f64)>,
                  name: &str|
     -> Result<(Vec<f64>, Vec<f64>), MeasurementError> {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pts.len() < 2 {
            return Err(value(
                "velocity_m_per_s",
                format!("{} {name} points", pts.len()),
                format!("the vehicle file's damper tables need at least 2 points per branch ({name}: {})", if name == "extension" { "v > 0" } else { "v < 0" }),
            ));
        }
        if let Some(w) = pts.windows(2).find(|w| w[1].0 == w[0].0) {
            return Err(value(
                "velocity_m_per_s",
                format!("{}", w[0].0),
                format!("two {name} points at the same speed"),
            ));
        }
        if let Some(w) = pts.windows(2).find(|w| w[1].1 < w[0].1) {
            return Err(value(
                "force_n",
                format!(
                    "{} N at {} m/s, {} N at {} m/s",
                    w[0].1, w[0].0, w[1].1, w[1].0
                ),
                format!("the {name} force must not fall as the speed rises"),
            ));
        }
        Ok(pts.iter().copied().unzip())
    };
    let (ext_v, ext_f) = branch(&mut ext, "extension")?;
    let (comp_v, comp_f) = branch(&mut comp, "compression")?;
    Ok(DamperTable {
        ext_v,
        ext_f,
        comp_v,
        comp_f,
    })
}

/// Runs the estimation of the axle-load thesis, §3.3 (module doc) on checked measurements with
/// the geometry and axle masses of a vehicle file's `[axles]` section; `vehicle_file` names it
/// in errors.
///
/// # Errors
/// [`MeasurementError::Estimate`] naming the file and key: scale weights that leave no load on
/// an axle's bellows, the vehicle file's tag axle not behind its driven axle, a degenerate
/// bellow test or datasheet; [`MeasurementError::Value`] for a test pressure without the static
/// pressure of its axle, a falling force–displacement line, or datasheet points the vehicle
/// file's damper tables cannot take.
pub fn estimate(
    m: &Measurements,
    v: &AxleParams,
    vehicle_file: &str,
) -> Result<AxleEstimate, MeasurementError> {
    let file = m.file.as_str();
    let at = |file: &str, key: String| {
        let file = file.to_string();
        move |source| MeasurementError::Estimate { file, key, source }
    };
    let g = v.gravity_m_per_s2;
    let w = m.scale_weight_kg;
    let mut bellow_force_n = [0.0; 3];
    for (k, a) in Axle::ALL.iter().enumerate() {
        let (la, lb) = levers(v, *a);
        bellow_force_n[k] = static_bellow_force(w[k], v.axle_mass(*a), la, lb, g)
            .map_err(at(file, format!("scale.{}_kg", a.name())))?;
    }
    let geometry_key = |e: &EstimationError| match e {
        EstimationError::Value { quantity, .. } if quantity.starts_with("rear") => {
            "axles.rear_axle_x_m"
        }
        _ => "axles.tag_axle_x_m",
    };
    let (xr, xt) = (v.rear_axle_x_m, v.tag_axle_x_m);
    let vehicle = cg_from_scale_weights(w[0], w[1], w[2], xr, xt).map_err(|e| {
        MeasurementError::Estimate {
            file: vehicle_file.into(),
            key: geometry_key(&e).into(),
            source: e,
        }
    })?;
    // the chassis loads m_i = w_i − m_ai are positive (checked with the bellow forces above)
    let load = |k: usize| w[k] - v.axle_mass(Axle::ALL[k]);
    let chassis = cg_from_scale_weights(load(0), load(1), load(2), xr, xt).map_err(|e| {
        MeasurementError::Estimate {
            file: vehicle_file.into(),
            key: geometry_key(&e).into(),
            source: e,
        }
    })?;
    let mut bellow_area_m2 = [None; 3];
    for (k, a) in Axle::ALL.iter().enumerate() {
        if let Some(p) = m.static_pressure_pa[k] {
            let (la, lb) = levers(v, *a);
            bellow_area_m2[k] = Some(
                effective_bellow_area(load(k), la, lb, p, g)
                    .map_err(at(file, format!("static_pressure.{}_pa", a.name())))?,
            );
        }
    }
    let mut stiffness = Vec::with_capacity(m.bellow_tests.len());
    for (k, t) in m.bellow_tests.iter().enumerate() {
        let i = t.axle.index();
        let (force, from_pressure) = match &t.load {
            BellowLoad::ForceN(f) => (f.clone(), false),
            BellowLoad::PressurePa(p) => {
                let area = bellow_area_m2[i].ok_or_else(|| MeasurementError::Value {
                    file: file.into(),
                    key: format!("bellow_test[{k}].pressure_pa"),
                    value: format!("{} pressures", p.len()),
                    rule: format!(
                        "converting pressure to force (F = p·A_eff, axle-load thesis, eq. 3.3.7) needs A_eff from the static state: give static_pressure.{}_pa, or give force_n instead",
                        t.axle.name()
                    ),
                })?;
                (p.iter().map(|p| p * area).collect(), true)
            }
        };
        let fit = bellow_stiffness(&t.displacement_m, &force)
            .map_err(at(file, format!("bellow_test[{k}]")))?;
        if fit.slope <= 0.0 {
            return Err(MeasurementError::Value {
                file: file.into(),
                key: format!("bellow_test[{k}].displacement_m"),
                value: format!("slope {} N/m", fit.slope),
                rule: "the bellow force must rise with the displacement: displacement_m is the bellow's compression (+ = shortening)".into(),
            });
        }
        stiffness.push(StiffnessEstimate {
            axle: t.axle,
            test: k,
            fit,
            from_pressure,
        });
    }
    let mut dampers = Vec::with_capacity(m.damper_datasheets.len());
    for (k, d) in m.damper_datasheets.iter().enumerate() {
        let table = datasheet_table(d, k, file)?;
        let fit = damper_coefficients(&d.velocity_m_per_s, &d.force_n)
            .map_err(at(file, format!("damper_datasheet[{k}]")))?;
        dampers.push(DamperEstimate {
            axle: d.axle,
            datasheet: k,
            fit,
            table,
        });
    }
    Ok(AxleEstimate {
        measurement_file: m.file.clone(),
        vehicle_file: vehicle_file.into(),
        scale_weight_kg: w,
        mass_kg: vehicle.mass_kg,
        x_cg_m: vehicle.x_cg_m,
        chassis_mass_kg: chassis.mass_kg,
        chassis_x_cg_m: chassis.x_cg_m,
        bellow_force_n,
        bellow_area_m2,
        stiffness,
        dampers,
    })
}

impl AxleEstimate {
    /// The bellow stiffness the snippet takes for an axle: the mean slope of its tests, N/m.
    pub fn bellow_stiffness_n_per_m(&self, a: Axle) -> Option<f64> {
        let s: Vec<f64> = self
            .stiffness
            .iter()
            .filter(|s| s.axle == a)
            .map(|s| s.fit.slope)
            .collect();
        (!s.is_empty()).then(|| s.iter().sum::<f64>() / s.len() as f64)
    }

    /// The damper estimate of an axle, if a datasheet was given.
    pub fn damper(&self, a: Axle) -> Option<&DamperEstimate> {
        self.dampers.iter().find(|d| d.axle == a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn datasheet_branches_become_positive_tables() {
        let d = DamperDatasheet {
            axle: Axle::Rear,
            velocity_m_per_s: vec![0.52, -0.13, 0.0, 0.13, -0.52],
            force_n: vec![16000.0, -2300.0, 0.0, 6800.0, -5300.0],
        };
        let t = datasheet_table(&d, 0, "m.toml").unwrap();
        assert_eq!(t.ext_v, [0.13, 0.52]);
        assert_eq!(t.ext_f, [6800.0, 16000.0]);
        assert_eq!(t.comp_v, [0.13, 0.52]);
        assert_eq!(t.comp_f, [2300.0, 5300.0]);
        let bad = DamperDatasheet {
            force_n: vec![16000.0, 2300.0, 0.0, 6800.0, -5300.0],
            ..d
        };
        let e = datasheet_table(&bad, 3, "m.toml").unwrap_err().to_string();
        assert!(e.contains("m.toml: damper_datasheet[3].force_n"), "{e}");
    }
}
