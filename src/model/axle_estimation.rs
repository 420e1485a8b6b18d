//! Axle-model parameter estimation from measurements (axle-load thesis, §3.3; docs/models/axle.md):
//! the centre of gravity from scale weights, the effective bellow area from the static state, the
//! bellow stiffness from a force–displacement test and damper coefficients from a datasheet table.
//!
//! Conventions: distances in m along the vehicle from the front axle, positive rearwards; masses
//! in kg as scale weights give them; forces in N; gauge pressures in Pa; damper velocities in m/s,
//! positive in extension.

use thiserror::Error;

/// Inputs that cannot give an estimate.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EstimationError {
    /// Geometry that contradicts the vehicle layout.
    #[error("inconsistent geometry: {0}")]
    Geometry(String),
    /// A measured value outside its physical range.
    #[error("{quantity} = {value}: {rule}")]
    Value {
        /// What was measured.
        quantity: &'static str,
        /// Its value.
        value: f64,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// Scale weights that leave no chassis load on an axle's bellows (axle-load thesis, eq. 3.3.8:
    /// `m_i = N_i/g − m_ai` must be positive).
    #[error("scale weight {scale_weight_kg} kg does not exceed the axle mass {axle_mass_kg} kg: no load is left on the bellows (axle-load thesis, eq. 3.3.8)")]
    NoBellowLoad {
        /// The axle's scale weight, kg.
        scale_weight_kg: f64,
        /// The axle's own (unsprung) mass, kg.
        axle_mass_kg: f64,
    },
    /// Too few or degenerate data points for a fit.
    #[error("{what}: {why}")]
    Fit {
        /// Which fit.
        what: &'static str,
        /// Why it cannot be made.
        why: String,
    },
}

/// Centre of gravity from scale weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CgEstimate {
    /// Total mass, kg.
    pub mass_kg: f64,
    /// CG distance behind the front axle, m.
    pub x_cg_m: f64,
}

fn positive(quantity: &'static str, value: f64) -> Result<f64, EstimationError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(EstimationError::Value {
            quantity,
            value,
            rule: "must be positive and finite",
        })
    }
}

/// CG from the axle scale weights of a 6x2 (front, driven rear, tag) and the rear and tag axle
/// distances behind the front axle: `x_CG = (N_r·l_r + N_t·l_t)/(m·g)` (docs/models/axle.md), with
/// N = weight·g so g cancels.
///
/// # Errors
/// Non-positive weights or distances, or the tag axle not behind the driven axle.
pub fn cg_from_scale_weights(
    front_kg: f64,
    rear_kg: f64,
    tag_kg: f64,
    l_rear_m: f64,
    l_tag_m: f64,
) -> Result<CgEstimate, EstimationError> {
    let (f, r, t) = (
        positive("front weight kg", front_kg)?,
        positive("rear weight kg", rear_kg)?,
        positive("tag weight kg", tag_kg)?,
    );
    let (lr, lt) = (
        positive("rear axle distance m", l_rear_m)?,
        positive("tag axle distance m", l_tag_m)?,
    );
    if lt <= lr {
        return Err(EstimationError::Geometry(format!(
            "tag axle at {lt} m is not behind the driven axle at {lr} m"
        )));
    }
    let m = f + r + t;
    Ok(CgEstimate {
        mass_kg: m,
        x_cg_m: (r * lr + t * lt) / m,
    })
}

/// `F = m·g·l_a/l_b` after checking the levers and gravity (`m` checked by the caller).
fn arm_bellow_force(load_kg: f64, l_a_m: f64, l_b_m: f64, g: f64) -> Result<f64, EstimationError> {
    let la = positive("l_a m", l_a_m)?;
    let lb = positive("l_b m", l_b_m)?;
    let g = positive("gravity m/s^2", g)?;
    Ok(load_kg * g * la / lb)
}

/// Static bellow force of an axle from its scale weight, N: the chassis load the axle carries,
/// `m_i = N_i/g − m_ai` (axle-load thesis, eq. 3.3.8), through the arm's moment balance about its
/// pivot, `F_s = m_i·g·l_a/l_b` (eq. 3.3.9; axle at l_a, bellow at l_b from the pivot). A bellow
/// acting directly above its axle (the front axle, eq. 3.3.5: `F_s = m_f·g`) is the case
/// `l_a = l_b`.
///
/// # Errors
/// Non-positive weight, axle mass, levers or gravity; [`EstimationError::NoBellowLoad`] when the
/// axle alone weighs at least its scale weight.
pub fn static_bellow_force(
    scale_weight_kg: f64,
    axle_mass_kg: f64,
    l_a_m: f64,
    l_b_m: f64,
    gravity_m_per_s2: f64,
) -> Result<f64, EstimationError> {
    let w = positive("scale weight kg", scale_weight_kg)?;
    let ma = positive("axle mass kg", axle_mass_kg)?;
    if w <= ma {
        return Err(EstimationError::NoBellowLoad {
            scale_weight_kg: w,
            axle_mass_kg: ma,
        });
    }
    arm_bellow_force(w - ma, l_a_m, l_b_m, gravity_m_per_s2)
}

/// Effective bellow area from the static state of a trailing arm: the arm's moment balance about
/// its pivot gives the bellow force `F_s = m_i·g·l_a/l_b` (axle load m_i acting at l_a, bellow at
/// l_b; axle-load thesis, eq. 3.3.9), and `A_eff = F_s/p_s` with the static gauge pressure p_s
/// (eq. 3.3.10), m².
///
/// # Errors
/// Non-positive load, levers or pressure.
pub fn effective_bellow_area(
    axle_load_kg: f64,
    l_a_m: f64,
    l_b_m: f64,
    static_pressure_pa: f64,
    gravity_m_per_s2: f64,
) -> Result<f64, EstimationError> {
    let m = positive("axle load kg", axle_load_kg)?;
    let f = arm_bellow_force(m, l_a_m, l_b_m, gravity_m_per_s2)?;
    let p = positive("static bellow pressure Pa", static_pressure_pa)?;
    Ok(f / p)
}

/// A least-squares line `y = slope·x + intercept` with its coefficient of determination.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineFit {
    /// Slope (N/m for a bellow stiffness).
    pub slope: f64,
    /// Intercept.
    pub intercept: f64,
    /// R², 1 for a perfect line.
    pub r2: f64,
}

/// Bellow stiffness as the slope of a least-squares line through a force–displacement test
/// (axle-load thesis, §3.3), N/m.
///
/// # Errors
/// Fewer than two points, unequal lengths, non-finite values or no spread in displacement.
pub fn bellow_stiffness(
    displacement_m: &[f64],
    force_n: &[f64],
) -> Result<LineFit, EstimationError> {
    let what = "bellow force-displacement fit";
    if displacement_m.len() != force_n.len() || displacement_m.len() < 2 {
        return Err(EstimationError::Fit {
            what,
            why: format!(
                "{} displacements, {} forces; need ≥ 2 pairs",
                displacement_m.len(),
                force_n.len()
            ),
        });
    }
    if displacement_m.iter().chain(force_n).any(|x| !x.is_finite()) {
        return Err(EstimationError::Fit {
            what,
            why: "non-finite value".into(),
        });
    }
    let n = displacement_m.len() as f64;
    let mx = displacement_m.iter().sum::<f64>() / n;
    let my = force_n.iter().sum::<f64>() / n;
    let sxx: f64 = displacement_m.iter().map(|x| (x - mx) * (x - mx)).sum();
    let sxy: f64 = displacement_m
        .iter()
        .zip(force_n)
        .map(|(x, y)| (x - mx) * (y - my))
        .sum();
    let syy: f64 = force_n.iter().map(|y| (y - my) * (y - my)).sum();
    if sxx <= 0.0 {
        return Err(EstimationError::Fit {
            what,
            why: "all displacements equal".into(),
        });
    }
    let slope = sxy / sxx;
    let r2 = if syy > 0.0 {
        sxy * sxy / (sxx * syy)
    } else {
        1.0
    };
    Ok(LineFit {
        slope,
        intercept: my - slope * mx,
        r2,
    })
}

/// Linear damper coefficients from a datasheet force–velocity table, one per branch (datasheets
/// give extension and compression separately): least squares through the origin,
/// `c = Σ v·F / Σ v²` over the points of that branch, N·s/m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DamperFit {
    /// Extension (v > 0) coefficient, N·s/m.
    pub extension_ns_per_m: f64,
    /// Compression (v < 0) coefficient, N·s/m.
    pub compression_ns_per_m: f64,
}

/// Fits [`DamperFit`] to a table of velocities (m/s, + = extension) and forces (N, same sign).
///
/// # Errors
/// Unequal lengths, non-finite values, or a branch without points.
pub fn damper_coefficients(
    velocity_mps: &[f64],
    force_n: &[f64],
) -> Result<DamperFit, EstimationError> {
    let what = "damper force-velocity fit";
    if velocity_mps.len() != force_n.len() {
        return Err(EstimationError::Fit {
            what,
            why: "velocity and force tables differ in length".into(),
        });
    }
    if velocity_mps.iter().chain(force_n).any(|x| !x.is_finite()) {
        return Err(EstimationError::Fit {
            what,
            why: "non-finite value".into(),
        });
    }
    let branch = |ext: bool| -> Result<f64, EstimationError> {
        let (mut svf, mut svv) = (0.0, 0.0);
        for (v, f) in velocity_mps.iter().zip(force_n) {
            if (ext && *v > 0.0) || (!ext && *v < 0.0) {
                svf += v * f;
                svv += v * v;
            }
        }
        if svv == 0.0 {
            return Err(EstimationError::Fit {
                what,
                why: format!(
                    "no {} points",
                    if ext {
                        "extension (v > 0)"
                    } else {
                        "compression (v < 0)"
                    }
                ),
            });
        }
        Ok(svf / svv)
    };
    Ok(DamperFit {
        extension_ns_per_m: branch(true)?,
        compression_ns_per_m: branch(false)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cg_balances_the_moments_of_the_scale_weights() {
        // axle-load thesis table 4.2 scale weights 7.6 / 6.8 / 4.3 t; illustrative axle positions
        // 0, 4.0, 5.35 m
        let e = cg_from_scale_weights(7600.0, 6800.0, 4300.0, 4.0, 5.35).unwrap();
        assert_eq!(e.mass_kg, 18700.0);
        // moment balance about the front axle: m x_cg = N_r l_r + N_t l_t
        assert!((e.mass_kg * e.x_cg_m - (6800.0 * 4.0 + 4300.0 * 5.35)).abs() < 1e-9);
        // all weight on the front axle puts the CG there
        assert!(
            cg_from_scale_weights(1e4, 1e-9, 1e-9, 4.0, 5.35)
                .unwrap()
                .x_cg_m
                < 1e-9
        );
    }

    #[test]
    fn inconsistent_geometry_and_values_are_errors() {
        assert!(matches!(
            cg_from_scale_weights(7600.0, 6800.0, 4300.0, 4.0, 3.0),
            Err(EstimationError::Geometry(_))
        ));
        assert!(matches!(
            cg_from_scale_weights(7600.0, -1.0, 4300.0, 4.0, 5.0),
            Err(EstimationError::Value { .. })
        ));
        assert!(matches!(
            effective_bellow_area(3000.0, 0.6, -0.8, 4e5, 9.81),
            Err(EstimationError::Value {
                quantity: "l_b m",
                ..
            })
        ));
        assert!(matches!(
            effective_bellow_area(3000.0, 0.6, 0.8, 0.0, 9.81),
            Err(EstimationError::Value { .. })
        ));
    }

    #[test]
    fn bellow_area_from_the_arm_moment_balance() {
        // 3 t on an arm with the axle at 0.6 m and the bellow at 0.8 m from the pivot, 4 bar:
        // F_s = 3000·9.81·0.6/0.8 = 22 072.5 N, A = F_s / 4e5 Pa
        let a = effective_bellow_area(3000.0, 0.6, 0.8, 4e5, 9.81).unwrap();
        assert!((a - 22_072.5 / 4e5).abs() < 1e-12);
    }

    #[test]
    fn static_bellow_force_needs_load_left_on_the_bellow() {
        // 4.3 t on the tag axle of 750 kg, arm 0.6 / 0.95 m: (4300 − 750)·9.81·0.6/0.95 N
        let f = static_bellow_force(4300.0, 750.0, 0.6, 0.95, 9.81).unwrap();
        assert!((f - 3550.0 * 9.81 * 0.6 / 0.95).abs() < 1e-9);
        // a direct-acting bellow (l_a = l_b) carries the chassis load itself
        let f = static_bellow_force(7600.0, 850.0, 1.0, 1.0, 9.81).unwrap();
        assert!((f - 6750.0 * 9.81).abs() < 1e-9);
        assert_eq!(
            static_bellow_force(700.0, 750.0, 0.6, 0.95, 9.81),
            Err(EstimationError::NoBellowLoad {
                scale_weight_kg: 700.0,
                axle_mass_kg: 750.0
            })
        );
    }

    #[test]
    fn stiffness_is_the_slope_of_the_force_line() {
        let x: Vec<f64> = (0..11).map(|k| -0.05 + 0.01 * k as f64).collect();
        let f: Vec<f64> = x.iter().map(|d| 20000.0 + 3.0e5 * d).collect();
        let fit = bellow_stiffness(&x, &f).unwrap();
        assert!((fit.slope - 3.0e5).abs() < 1e-6 && (fit.intercept - 20000.0).abs() < 1e-6);
        assert!((fit.r2 - 1.0).abs() < 1e-12);
        assert!(bellow_stiffness(&[0.1], &[1.0]).is_err());
        assert!(bellow_stiffness(&[0.1, 0.1], &[1.0, 2.0]).is_err());
    }

    #[test]
    fn damper_branches_are_fitted_separately() {
        // a datasheet with a stiffer extension than compression branch
        let v = [-0.52, -0.26, -0.13, -0.05, 0.05, 0.13, 0.26, 0.52];
        let f: Vec<f64> = v
            .iter()
            .map(|&x: &f64| if x > 0.0 { 12000.0 * x } else { 4000.0 * x })
            .collect();
        let d = damper_coefficients(&v, &f).unwrap();
        assert!((d.extension_ns_per_m - 12000.0).abs() < 1e-9);
        assert!((d.compression_ns_per_m - 4000.0).abs() < 1e-9);
        assert!(
            damper_coefficients(&[0.1, 0.2], &[1.0, 2.0]).is_err(),
            "no compression points"
        );
    }
}
