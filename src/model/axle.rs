//! Axle-load parameters (docs/models/axle.md; the model follows the axle-load thesis, a Master's
//! thesis written with Scania on the dynamic axle loads of a 6x2 electrified truck): the typed
//! `[axles]` section of a vehicle file, checked key by key against `schemas/vehicle.toml`, then for
//! consistency (geometry, masses against the scale weights, bellows able to carry the static load),
//! and its static state.
//!
//! Conventions (docs/models/axle.md): positions `x` rearwards from the front axle, heights above
//! the ground, lever lengths horizontal from the arm pivot; SI units; gauge pressures.

use super::driveline::{check_keys, vehicle_schema, KeyProblem};
use serde::Deserialize;

/// Axle-load parameters, SI units (docs/models/axle.md).
#[derive(Debug, Clone, PartialEq, Deserialize, serde::Serialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)] // each field is documented in schemas/vehicle.toml (meaning, unit, range)
pub struct AxleParams {
    pub gravity_m_per_s2: f64,
    pub chassis_mass_kg: f64,
    pub axle_mass_front_kg: f64,
    pub axle_mass_rear_kg: f64,
    pub axle_mass_tag_kg: f64,
    pub scale_weight_front_kg: f64,
    pub scale_weight_rear_kg: f64,
    pub scale_weight_tag_kg: f64,
    pub chassis_pitch_inertia_kg_m2: f64,
    pub arm_inertia_rear_kg_m2: f64,
    pub arm_inertia_tag_kg_m2: f64,
    pub rear_axle_x_m: f64,
    pub tag_axle_x_m: f64,
    pub chassis_cg_height_m: f64,
    pub wheel_radius_m: f64,
    pub rear_pivot_height_m: f64,
    pub rear_arm_l_a_m: f64,
    pub rear_arm_l_b_m: f64,
    pub rear_arm_l_d_m: f64,
    pub tag_pivot_height_m: f64,
    pub tag_arm_l_a_m: f64,
    pub tag_arm_l_b_m: f64,
    pub tag_arm_l_d_m: f64,
    pub bellow_stiffness_front_n_per_m: f64,
    pub bellow_stiffness_rear_n_per_m: f64,
    pub bellow_stiffness_tag_n_per_m: f64,
    pub bellow_area_front_m2: f64,
    pub bellow_area_rear_m2: f64,
    pub bellow_area_tag_m2: f64,
    pub bellow_max_pressure_pa: f64,
    pub tyre_stiffness_front_n_per_m: f64,
    pub tyre_stiffness_rear_n_per_m: f64,
    pub tyre_stiffness_tag_n_per_m: f64,
    pub damper_front_extension_velocity_m_per_s: Vec<f64>,
    pub damper_front_extension_force_n: Vec<f64>,
    pub damper_front_compression_velocity_m_per_s: Vec<f64>,
    pub damper_front_compression_force_n: Vec<f64>,
    pub damper_rear_extension_velocity_m_per_s: Vec<f64>,
    pub damper_rear_extension_force_n: Vec<f64>,
    pub damper_rear_compression_velocity_m_per_s: Vec<f64>,
    pub damper_rear_compression_force_n: Vec<f64>,
    pub damper_tag_extension_velocity_m_per_s: Vec<f64>,
    pub damper_tag_extension_force_n: Vec<f64>,
    pub damper_tag_compression_velocity_m_per_s: Vec<f64>,
    pub damper_tag_compression_force_n: Vec<f64>,
    pub service_brake_share_front: f64,
    pub service_brake_share_rear: f64,
    pub service_brake_share_tag: f64,
    pub resistance_height_m: f64,
    pub slip_stiffness_normalised: f64,
    pub slip_ratio_limit: f64,
    pub road_friction_coefficient: f64,
}

/// The three axles, in vehicle order; in files by their lower-case name (`"front"`, …).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axle {
    /// Front (steered) axle.
    Front,
    /// Driven rear axle.
    Rear,
    /// Tag axle behind the driven axle.
    Tag,
}

impl Axle {
    /// All axles, front to back.
    pub const ALL: [Axle; 3] = [Axle::Front, Axle::Rear, Axle::Tag];

    /// Position in [`Axle::ALL`] and in per-axle arrays (front 0, rear 1, tag 2).
    pub fn index(self) -> usize {
        match self {
            Axle::Front => 0,
            Axle::Rear => 1,
            Axle::Tag => 2,
        }
    }

    /// Lower-case name used in column and key names.
    pub fn name(self) -> &'static str {
        match self {
            Axle::Front => "front",
            Axle::Rear => "rear",
            Axle::Tag => "tag",
        }
    }
}

/// A damper characteristic as datasheets give it: extension and compression branches, each a
/// table of (velocity > 0, force > 0), linear between points and continued at the end slopes.
#[derive(Debug, Clone, PartialEq)]
pub struct DamperTable {
    /// Extension branch velocities, m/s, increasing.
    pub ext_v: Vec<f64>,
    /// Extension branch forces, N.
    pub ext_f: Vec<f64>,
    /// Compression branch velocities, m/s, increasing.
    pub comp_v: Vec<f64>,
    /// Compression branch forces, N.
    pub comp_f: Vec<f64>,
}

/// The segment of a branch table that holds `speed`: its index (0 from the origin to the first
/// point, `k` from point `k − 1` to point `k`, the last one continued beyond the table) and its
/// end points `(v0, f0, v1, f1)`.
#[inline]
fn segment(v: &[f64], f: &[f64], speed: f64) -> (usize, (f64, f64, f64, f64)) {
    // force through (0, 0) and the table; linear continuation beyond the last point
    let n = v.len();
    // the number of velocities at or below `speed` (tables hold a handful of strictly
    // increasing points, checked on loading: a forward scan finds it sooner than a
    // bisection); a NaN speed counts none, and its force is NaN
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    let k = v.iter().position(|&x| !(x <= speed)).unwrap_or(n);
    if k == 0 || n == 1 {
        // below the first point, or a one-point table: the line through (0, 0) and it
        (0, (0.0, 0.0, v[0], f[0]))
    } else if k >= n {
        (n - 1, (v[n - 2], f[n - 2], v[n - 1], f[n - 1]))
    } else {
        (k, (v[k - 1], f[k - 1], v[k], f[k]))
    }
}

fn branch(v: &[f64], f: &[f64], speed: f64) -> f64 {
    let (_, (v0, f0, v1, f1)) = segment(v, f, speed);
    if v1 == v0 {
        return f1;
    }
    f0 + (f1 - f0) * (speed - v0) / (v1 - v0)
}

/// The line `F = intercept + slope · rate` of one segment of a damper table (N, N·s/m), with
/// the segment's identity: `+1 + k` for compression segment `k`, `−1 − k` for extension
/// segment `k` (segments numbered from the origin outwards).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DamperSegment {
    /// Which segment.
    pub id: i8,
    /// Force at zero rate of the segment's line, N.
    pub intercept_n: f64,
    /// Slope, N·s/m.
    pub slope_n_s_per_m: f64,
}

impl DamperTable {
    /// Damper force pushing the ends apart, N, at compression rate `rate` (m/s, + = shortening):
    /// `F_comp(rate)` in compression, `−F_ext(−rate)` in extension (docs/models/axle.md).
    #[inline]
    pub fn force(&self, rate: f64) -> f64 {
        if rate >= 0.0 {
            branch(&self.comp_v, &self.comp_f, rate)
        } else {
            -branch(&self.ext_v, &self.ext_f, -rate)
        }
    }

    /// The identity of [`DamperTable::segment`] alone: `+1 + k` for compression segment `k`,
    /// `−1 − k` for extension segment `k`.
    #[inline]
    pub fn segment_id(&self, rate: f64) -> i8 {
        let (sign, (k, _)) = if rate >= 0.0 {
            (1, segment(&self.comp_v, &self.comp_f, rate))
        } else {
            (-1, segment(&self.ext_v, &self.ext_f, -rate))
        };
        sign * (1 + i8::try_from(k.min(126)).unwrap_or(126))
    }

    /// The segment of the table that [`DamperTable::force`] reads at compression rate `rate`
    /// (m/s, + = shortening), as a line in the rate: on it,
    /// `force(r) = intercept + slope · r` up to rounding. A NaN rate gives a NaN line.
    pub fn segment(&self, rate: f64) -> DamperSegment {
        let (sign, (k, (v0, f0, v1, f1))) = if rate >= 0.0 {
            (1.0, segment(&self.comp_v, &self.comp_f, rate))
        } else {
            (-1.0, segment(&self.ext_v, &self.ext_f, -rate))
        };
        let slope = if v1 == v0 { 0.0 } else { (f1 - f0) / (v1 - v0) };
        // compression: F = f0 + s (r − v0); extension: F = −(f0 + s (−r − v0))
        let base = if v1 == v0 { f1 } else { f0 - slope * v0 };
        let k = i8::try_from(k.min(126)).unwrap_or(126);
        DamperSegment {
            id: if sign > 0.0 { 1 + k } else { -1 - k },
            intercept_n: sign * base,
            slope_n_s_per_m: if rate.is_nan() { f64::NAN } else { slope },
        }
    }
}

/// The static state the scale weights define (docs/models/axle.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StaticState {
    /// Total mass m = m_c + Σ m_a, kg.
    pub mass_kg: f64,
    /// Vehicle CG behind the front axle (axle-load thesis, eq. 3.3.2), m.
    pub x_cg_m: f64,
    /// Chassis (sprung) CG behind the front axle, m.
    pub chassis_x_cg_m: f64,
    /// Vehicle CG height, m.
    pub h_cg_m: f64,
    /// Static normal forces front, rear, tag, N (scale weights scaled to m).
    pub normal_n: [f64; 3],
    /// Static bellow forces, N (axle-load thesis, eq. 3.3.9 on the arms).
    pub bellow_n: [f64; 3],
    /// Static bellow gauge pressures, Pa.
    pub pressure_pa: [f64; 3],
}

impl AxleParams {
    /// Checks a raw `[axles]` table against the schema and for consistency, and converts it.
    ///
    /// # Errors
    /// The first problem as `(key, value, rule)`: unknown/missing/out-of-range keys, the tag
    /// axle not behind the driven axle, a pivot ahead of the front axle, an arm inertia below
    /// its axle's own `m l²`, masses that disagree with the scale weights, brake shares not
    /// summing to 1, damper tables not increasing, bellows that cannot carry the static load.
    pub fn from_table(table: &toml::Table) -> Result<Self, KeyProblem> {
        check_keys(&vehicle_schema().axles, table, 0)?;
        let problem = |key: &str, value: String, rule: String| (key.to_string(), value, rule);
        let p: AxleParams = table
            .clone()
            .try_into()
            .map_err(|e: toml::de::Error| problem("axles", String::new(), e.to_string()))?;
        if p.tag_axle_x_m <= p.rear_axle_x_m {
            return Err(problem(
                "tag_axle_x_m",
                p.tag_axle_x_m.to_string(),
                format!(
                    "the tag axle must be behind the driven axle (rear_axle_x_m = {})",
                    p.rear_axle_x_m
                ),
            ));
        }
        for (name, x, la, lb, ld, i, m, hp) in [
            (
                "rear",
                p.rear_axle_x_m,
                p.rear_arm_l_a_m,
                p.rear_arm_l_b_m,
                p.rear_arm_l_d_m,
                p.arm_inertia_rear_kg_m2,
                p.axle_mass_rear_kg,
                p.rear_pivot_height_m,
            ),
            (
                "tag",
                p.tag_axle_x_m,
                p.tag_arm_l_a_m,
                p.tag_arm_l_b_m,
                p.tag_arm_l_d_m,
                p.arm_inertia_tag_kg_m2,
                p.axle_mass_tag_kg,
                p.tag_pivot_height_m,
            ),
        ] {
            if x - la <= 0.0 {
                return Err(problem(
                    &format!("{name}_arm_l_a_m"),
                    la.to_string(),
                    format!("puts the {name} arm pivot at or ahead of the front axle"),
                ));
            }
            for (k, l) in [("l_b", lb), ("l_d", ld)] {
                if x - la + l > p.tag_axle_x_m + 3.0 {
                    return Err(problem(
                        &format!("{name}_arm_{k}_m"),
                        l.to_string(),
                        "reaches more than 3 m behind the tag axle".into(),
                    ));
                }
            }
            let own = m * (la * la + (p.wheel_radius_m - hp).powi(2));
            if i < own {
                return Err(problem(
                    &format!("arm_inertia_{name}_kg_m2"),
                    i.to_string(),
                    format!("is below the axle's own inertia about the pivot m (l_a² + (r_w − h_p)²) = {own:.1} kg·m²"),
                ));
            }
        }
        let m = p.chassis_mass_kg + p.axle_mass_front_kg + p.axle_mass_rear_kg + p.axle_mass_tag_kg;
        let w = p.scale_weight_front_kg + p.scale_weight_rear_kg + p.scale_weight_tag_kg;
        if (m - w).abs() > 0.01 * w {
            return Err(problem(
                "chassis_mass_kg",
                p.chassis_mass_kg.to_string(),
                format!("chassis + axle masses = {m} kg, the scale weights sum to {w} kg; they must agree within 1 %"),
            ));
        }
        let shares =
            p.service_brake_share_front + p.service_brake_share_rear + p.service_brake_share_tag;
        if (shares - 1.0).abs() > 1e-6 {
            return Err(problem(
                "service_brake_share_front",
                shares.to_string(),
                "the three service-brake shares must sum to 1".into(),
            ));
        }
        for a in Axle::ALL {
            for br in ["extension", "compression"] {
                let vk = format!("damper_{}_{br}_velocity_m_per_s", a.name());
                let fk = format!("damper_{}_{br}_force_n", a.name());
                let t = p.damper(a);
                let (v, f) = if br == "extension" {
                    (&t.ext_v, &t.ext_f)
                } else {
                    (&t.comp_v, &t.comp_f)
                };
                if v[0] <= 0.0 || v.windows(2).any(|w| w[1] <= w[0]) {
                    return Err(problem(
                        &vk,
                        crate::number_fmt::list(v),
                        "must be > 0 and increasing".into(),
                    ));
                }
                if f.windows(2).any(|w| w[1] < w[0]) {
                    return Err(problem(
                        &fk,
                        crate::number_fmt::list(f),
                        "must not decrease".into(),
                    ));
                }
            }
        }
        let s = p.static_state();
        for (k, a) in Axle::ALL.iter().enumerate() {
            let b = s.bellow_n[k];
            let key = format!("scale_weight_{}_kg", a.name());
            if b <= 0.0 {
                return Err(problem(
                    &key,
                    format!(
                        "{}",
                        [
                            p.scale_weight_front_kg,
                            p.scale_weight_rear_kg,
                            p.scale_weight_tag_kg
                        ][k]
                    ),
                    format!(
                        "leaves no load on the {} bellows (the axle alone weighs more)",
                        a.name()
                    ),
                ));
            }
            if s.pressure_pa[k] > p.bellow_max_pressure_pa {
                return Err(problem(
                    &format!("bellow_area_{}_m2", a.name()),
                    p.bellow_area(*a).to_string(),
                    format!(
                        "cannot carry the static load: {:.0} N needs {:.0} Pa, above bellow_max_pressure_pa = {}",
                        b, s.pressure_pa[k], p.bellow_max_pressure_pa
                    ),
                ));
            }
        }
        if s.chassis_x_cg_m <= 0.0 || s.chassis_x_cg_m >= p.tag_axle_x_m {
            return Err(problem(
                "scale_weight_front_kg",
                p.scale_weight_front_kg.to_string(),
                format!(
                    "the scale weights put the chassis CG at {:.3} m, outside the axles",
                    s.chassis_x_cg_m
                ),
            ));
        }
        Ok(p)
    }

    /// Total mass, kg.
    pub fn mass_kg(&self) -> f64 {
        self.chassis_mass_kg
            + self.axle_mass_front_kg
            + self.axle_mass_rear_kg
            + self.axle_mass_tag_kg
    }

    /// Axle position behind the front axle, m.
    pub fn axle_x(&self, a: Axle) -> f64 {
        match a {
            Axle::Front => 0.0,
            Axle::Rear => self.rear_axle_x_m,
            Axle::Tag => self.tag_axle_x_m,
        }
    }

    /// Axle (unsprung) mass, kg.
    pub fn axle_mass(&self, a: Axle) -> f64 {
        match a {
            Axle::Front => self.axle_mass_front_kg,
            Axle::Rear => self.axle_mass_rear_kg,
            Axle::Tag => self.axle_mass_tag_kg,
        }
    }

    /// Scale weight, kg.
    pub fn scale_weight(&self, a: Axle) -> f64 {
        match a {
            Axle::Front => self.scale_weight_front_kg,
            Axle::Rear => self.scale_weight_rear_kg,
            Axle::Tag => self.scale_weight_tag_kg,
        }
    }

    /// Total effective bellow area of an axle, m².
    pub fn bellow_area(&self, a: Axle) -> f64 {
        match a {
            Axle::Front => self.bellow_area_front_m2,
            Axle::Rear => self.bellow_area_rear_m2,
            Axle::Tag => self.bellow_area_tag_m2,
        }
    }

    /// Bellow stiffness of an axle, N/m.
    pub fn bellow_stiffness(&self, a: Axle) -> f64 {
        match a {
            Axle::Front => self.bellow_stiffness_front_n_per_m,
            Axle::Rear => self.bellow_stiffness_rear_n_per_m,
            Axle::Tag => self.bellow_stiffness_tag_n_per_m,
        }
    }

    /// Tyre vertical stiffness of an axle, N/m.
    pub fn tyre_stiffness(&self, a: Axle) -> f64 {
        match a {
            Axle::Front => self.tyre_stiffness_front_n_per_m,
            Axle::Rear => self.tyre_stiffness_rear_n_per_m,
            Axle::Tag => self.tyre_stiffness_tag_n_per_m,
        }
    }

    /// Service-brake share of an axle.
    pub fn brake_share(&self, a: Axle) -> f64 {
        match a {
            Axle::Front => self.service_brake_share_front,
            Axle::Rear => self.service_brake_share_rear,
            Axle::Tag => self.service_brake_share_tag,
        }
    }

    /// Arm geometry `(pivot height, l_a, l_b, l_d, inertia about the pivot)` of the rear or tag
    /// arm; `None` for the front axle.
    pub fn arm(&self, a: Axle) -> Option<(f64, f64, f64, f64, f64)> {
        match a {
            Axle::Front => None,
            Axle::Rear => Some((
                self.rear_pivot_height_m,
                self.rear_arm_l_a_m,
                self.rear_arm_l_b_m,
                self.rear_arm_l_d_m,
                self.arm_inertia_rear_kg_m2,
            )),
            Axle::Tag => Some((
                self.tag_pivot_height_m,
                self.tag_arm_l_a_m,
                self.tag_arm_l_b_m,
                self.tag_arm_l_d_m,
                self.arm_inertia_tag_kg_m2,
            )),
        }
    }

    /// The damper characteristic of an axle.
    pub fn damper(&self, a: Axle) -> DamperTable {
        let (ev, ef, cv, cf) = match a {
            Axle::Front => (
                &self.damper_front_extension_velocity_m_per_s,
                &self.damper_front_extension_force_n,
                &self.damper_front_compression_velocity_m_per_s,
                &self.damper_front_compression_force_n,
            ),
            Axle::Rear => (
                &self.damper_rear_extension_velocity_m_per_s,
                &self.damper_rear_extension_force_n,
                &self.damper_rear_compression_velocity_m_per_s,
                &self.damper_rear_compression_force_n,
            ),
            Axle::Tag => (
                &self.damper_tag_extension_velocity_m_per_s,
                &self.damper_tag_extension_force_n,
                &self.damper_tag_compression_velocity_m_per_s,
                &self.damper_tag_compression_force_n,
            ),
        };
        DamperTable {
            ext_v: ev.clone(),
            ext_f: ef.clone(),
            comp_v: cv.clone(),
            comp_f: cf.clone(),
        }
    }

    /// The static state on a level road (docs/models/axle.md): normal forces from the scale
    /// weights scaled to the model's mass, bellow forces from each arm's moment balance
    /// (axle-load thesis, eq. 3.3.9) and the front axle's force balance, pressures `p = F/A_eff`,
    /// and the chassis CG that makes the chassis balance (thesis eq. 3.3.2 less the axle masses).
    pub fn static_state(&self) -> StaticState {
        let g = self.gravity_m_per_s2;
        let m = self.mass_kg();
        let w: f64 = Axle::ALL.iter().map(|a| self.scale_weight(*a)).sum();
        let normal_n = Axle::ALL.map(|a| self.scale_weight(a) * g * m / w);
        let mut bellow_n = [0.0; 3];
        for (k, a) in Axle::ALL.iter().enumerate() {
            let net = normal_n[k] - self.axle_mass(*a) * g;
            bellow_n[k] = match self.arm(*a) {
                None => net,
                Some((_, la, lb, _, _)) => net * la / lb,
            };
        }
        let pressure_pa = [0, 1, 2].map(|k| bellow_n[k] / self.bellow_area(Axle::ALL[k]));
        let x_cg_m = (normal_n[1] * self.rear_axle_x_m + normal_n[2] * self.tag_axle_x_m) / (m * g);
        let chassis_x_cg_m = (normal_n[1] * self.rear_axle_x_m + normal_n[2] * self.tag_axle_x_m
            - g * (self.axle_mass_rear_kg * self.rear_axle_x_m
                + self.axle_mass_tag_kg * self.tag_axle_x_m))
            / (self.chassis_mass_kg * g);
        let h_cg_m = (self.chassis_mass_kg * self.chassis_cg_height_m
            + (m - self.chassis_mass_kg) * self.wheel_radius_m)
            / m;
        StaticState {
            mass_kg: m,
            x_cg_m,
            chassis_x_cg_m,
            h_cg_m,
            normal_n,
            bellow_n,
            pressure_pa,
        }
    }

    /// Static axle loads (kg, as a scale would read them) from bellow gauge pressures at rest on
    /// a level road: the inverse of [`AxleParams::static_state`] — bellow force `p·A_eff`, then
    /// the front axle's force balance `N = F + m_af g` and each arm's moment balance
    /// `N = F l_b/l_a + m_a g` (axle-load thesis, eqs. 3.3.4, 3.3.9).
    pub fn axle_loads_from_pressures(&self, pressure_pa: [f64; 3]) -> [f64; 3] {
        let g = self.gravity_m_per_s2;
        [0, 1, 2].map(|k| {
            let a = Axle::ALL[k];
            let f = pressure_pa[k] * self.bellow_area(a);
            let lever = self.arm(a).map_or(1.0, |(_, la, lb, _, _)| lb / la);
            (f * lever + self.axle_mass(a) * g) / g
        })
    }

    /// The largest auxiliary brake force at the driven wheels that keeps the slip ratio under
    /// `slip_ratio_limit` at driven-axle normal force `n_rear` (axle-load thesis, eq. 1.1.1 read as
    /// `F_x/N = k(µ)·i`, the longitudinal force over the normal force linear in slip), capped by
    /// the road friction `µ N`: `F_max = min(k i_lim, µ) · max(N, 0)`, N.
    pub fn slip_limited_brake_force(&self, n_rear: f64) -> f64 {
        (self.slip_stiffness_normalised * self.slip_ratio_limit).min(self.road_friction_coefficient)
            * n_rear.max(0.0)
    }
}

/// Physics the nominal half-truck leaves out, each named by its diagnosis-catalogue id
/// (docs/diagnosis/catalogue.md). Every field's zero is the nominal model; all are SI.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AxleExtensions {
    /// `bogie_torque_reaction`: fraction κ (1) of the driven axle's wheel torque
    /// `T = F_r r_w` (drive − auxiliary brake − the driven axle's service-brake share, + driving)
    /// whose housing reaction goes into the chassis (torque rods) instead of the trailing arm.
    /// It acts between arm and chassis as the moment pair `κ T (e_φr + e_θ)` on the generalised
    /// forces (docs/models/axle.md sign convention: `φ` rear end up, `θ` nose up), so it loads
    /// the driven-axle bellow in proportion to the torque and mirrors in braking.
    pub torque_reaction: f64,
    /// `air_spring_nonlinearity`: progression γ ≥ 0 of every bellow, 1/m: the bellow force is
    /// `B = B_0 + k_b (e^{2γc} − 1)/(2γ) = B_0 + k_b (c + γ c² + …)` with `c` the bellow
    /// compression, m. Its second-order term is the polytropic gas law's (`p V^n = const` gives
    /// `γ = (n + 1) k_b / (2 n B_0)`); unlike a bare quadratic it stays monotone (stiffening in
    /// compression, softening in extension) at any travel.
    pub bellow_progression_per_m: f64,
    /// `grade_load_transfer`: height offset Δh, m, of the point where the chassis' gravity
    /// component along the road, `−m_c g sin α`, acts (above its CG for Δh > 0): an extra pitch
    /// moment `m_c g sin α Δh` that moves load rearwards uphill.
    pub grade_height_offset_m: f64,
}

impl AxleExtensions {
    /// True when every extension is absent (the nominal model).
    pub fn is_nominal(&self) -> bool {
        *self == Self::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn damper_branches_interpolate_and_extend() {
        let d = DamperTable {
            ext_v: vec![0.1, 0.5],
            ext_f: vec![2000.0, 6000.0],
            comp_v: vec![0.1, 0.5],
            comp_f: vec![500.0, 1500.0],
        };
        assert_eq!(d.force(0.0), 0.0);
        assert!((d.force(0.05) - 250.0).abs() < 1e-9, "through the origin");
        assert!((d.force(0.3) - 1000.0).abs() < 1e-9);
        assert!((d.force(-0.3) + 4000.0).abs() < 1e-9, "extension pulls");
        assert!(
            (d.force(1.0) - 2750.0).abs() < 1e-9,
            "continued at the last slope"
        );
    }

    #[test]
    fn a_one_point_damper_table_is_the_line_through_the_origin_and_a_nan_rate_gives_nan() {
        // a table of one point per branch passes the file checks; beyond the point the force
        // continues on the line through (0, 0) and it, and a NaN rate (a diverged state) gives
        // a NaN force, not a panic
        let d = DamperTable {
            ext_v: vec![0.2],
            ext_f: vec![4000.0],
            comp_v: vec![0.2],
            comp_f: vec![1000.0],
        };
        assert!((d.force(0.1) - 500.0).abs() < 1e-9);
        assert!((d.force(0.4) - 2000.0).abs() < 1e-9);
        assert!((d.force(-0.4) + 8000.0).abs() < 1e-9);
        assert!(d.force(f64::NAN).is_nan());
    }

    #[test]
    fn a_damper_segment_is_the_line_the_force_reads_and_its_identity_alone_agrees() {
        // every rate from −1 to 1 m/s in 1 mm/s steps, the table's points included: the force
        // is the segment's line to rounding (1e-9 of the force, ~1e-12 N on these tables), the
        // identity alone is the segment's, and one identity is one line
        let d = DamperTable {
            ext_v: vec![0.05, 0.13, 0.26, 0.52],
            ext_f: vec![2400.0, 5400.0, 8400.0, 12800.0],
            comp_v: vec![0.05, 0.13, 0.26, 0.52],
            comp_f: vec![800.0, 1800.0, 2800.0, 4300.0],
        };
        let mut lines = std::collections::BTreeMap::new();
        for k in -1000..=1000 {
            let r = f64::from(k) * 1e-3;
            let s = d.segment(r);
            let f = s.intercept_n + s.slope_n_s_per_m * r;
            assert!(
                (f - d.force(r)).abs() <= 1e-9 * (1.0 + d.force(r).abs()),
                "{r}: {f}"
            );
            assert_eq!(d.segment_id(r), s.id, "{r}");
            let line = lines
                .entry(s.id)
                .or_insert((s.intercept_n, s.slope_n_s_per_m));
            assert_eq!(*line, (s.intercept_n, s.slope_n_s_per_m), "{r}");
        }
        // four segments a side, compression + and extension −; the first ones through 0
        assert_eq!(
            lines.keys().copied().collect::<Vec<_>>(),
            vec![-4, -3, -2, -1, 1, 2, 3, 4]
        );
        assert!(lines[&1].0 == 0.0 && (lines[&1].1 - 16_000.0).abs() < 1e-9);
        assert!(lines[&-1].0 == 0.0 && (lines[&-1].1 - 48_000.0).abs() < 1e-9);
        assert_eq!(
            d.segment(0.0).id,
            1,
            "zero rate is compression, as the force reads it"
        );
        assert!(d.segment(f64::NAN).slope_n_s_per_m.is_nan());
    }
}
