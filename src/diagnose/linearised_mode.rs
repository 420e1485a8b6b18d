//! The first torsional ("shuffle") mode of the nominal driveline linearised about a locked clutch
//! (docs/models/driveline.md; the linearised reference of [`super::modal`],
//! docs/diagnosis/method.md): the complex eigenvalue pair of lowest frequency of
//! [`crate::model::linear::linearize`], with the driven tyres taking a share of the main
//! flexibility ([`tyre_mode`]), and the relative shift of that mode the vehicle file's
//! tolerances allow ([`tolerance_shift`]; docs/diagnosis/method.md, "Model-form residual").
//!
//! Frequencies are the damped frequency `|Im λ|/2π`, Hz; decay rates `−Re λ`, 1/s; speeds m/s;
//! engine torque N·m.

use super::tyre_slip::{DRIVEN_LOAD_SHARE, TYRE_FRICTION};
use crate::model::catalogue::Tolerance;
use crate::model::driveline::DrivelineParams;
use crate::model::tolerance::Tolerances;
use serde::Serialize;

/// A mode of the linearised locked-clutch driveline ([`locked_mode`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LockedMode {
    /// Damped frequency `|Im λ|/2π`, Hz.
    pub frequency_hz: f64,
    /// Decay rate `−Re λ`, 1/s.
    pub decay_per_s: f64,
}

/// The first torsional mode of the locked-clutch driveline linearised in `gear` at `v0_mps`
/// ([`crate::model::linear::linearize`], open loop): the complex eigenvalue pair of lowest
/// frequency. `None` when the system has no oscillating mode.
pub fn locked_mode(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    v0_mps: f64,
) -> Option<LockedMode> {
    if gear == 0 || gear > ratios.len() {
        return None;
    }
    lowest_mode(&crate::model::linear::linearize(p, ratios, gear, v0_mps).open)
}

/// The lowest-frequency complex eigenvalue pair of `ss` as a mode.
fn lowest_mode(ss: &crate::model::linear::StateSpace) -> Option<LockedMode> {
    ss.eigenvalues()
        .into_iter()
        .filter(|l| l.im > 1e-6)
        .min_by(|a, b| a.im.total_cmp(&b.im))
        .map(|l| LockedMode {
            frequency_hz: l.im / (2.0 * std::f64::consts::PI),
            decay_per_s: -l.re,
        })
}

/// The driven tyres of `p` taking the share `share` of the main flexibility `k_d`
/// ([`crate::model::linear::DrivenTyres`]) under the recorded engine torque `engine_torque_nm`
/// in `gear`: traction force `F_x = M_e·i_t·i_f/r_w` against `F_x,max` =
/// [`TYRE_FRICTION`]` · `[`DRIVEN_LOAD_SHARE`]` · m g` (|ρ| at most 0.95; constants of
/// [`super::tyre_slip`]), relaxation length `r_w` (the order of magnitude Pacejka §7.2 gives:
/// of the tyre's radius), driven-wheel inertia [`DRIVEN_LOAD_SHARE`]` · J_w`.
pub fn driven_tyres(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    engine_torque_nm: f64,
    share: f64,
) -> crate::model::linear::DrivenTyres {
    let i = ratios.get(gear.wrapping_sub(1)).copied().unwrap_or(1.0) * p.final_drive_ratio;
    let f_x = engine_torque_nm * i / p.wheel_radius_m;
    let f_max = TYRE_FRICTION * DRIVEN_LOAD_SHARE * p.mass_kg * p.gravity_m_per_s2;
    crate::model::linear::DrivenTyres {
        share,
        traction_ratio: if f_max > 0.0 && f_x.is_finite() {
            (f_x / f_max).clamp(-0.95, 0.95)
        } else {
            0.0
        },
        relaxation_length_m: p.wheel_radius_m,
        wheel_inertia_kg_m2: DRIVEN_LOAD_SHARE * p.j_w_kg_m2,
    }
}

/// [`locked_mode`] with the driven tyres taking the share `share` of the main flexibility
/// under the engine torque `engine_torque_nm` ([`driven_tyres`],
/// [`crate::model::linear::linearize_with_tyres`]): the tyres' relaxation at speed, their
/// stiffness falling with the traction force and the driven wheels' inertia inside the
/// flexibility all move the shuffle mode. `share = 0` is [`locked_mode`].
pub fn tyre_mode(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    v0_mps: f64,
    engine_torque_nm: f64,
    share: f64,
) -> Option<LockedMode> {
    if gear == 0 || gear > ratios.len() {
        return None;
    }
    if share <= 0.0 {
        return locked_mode(p, ratios, gear, v0_mps);
    }
    let t = driven_tyres(p, ratios, gear, engine_torque_nm, share);
    lowest_mode(&crate::model::linear::linearize_with_tyres(
        p, ratios, gear, v0_mps, &t,
    ))
}

/// The relative shift of the first torsional mode (the driven tyres taking `share` of the main
/// flexibility, no traction, [`tyre_mode`]) that the vehicle file's tolerances allow in `gear`
/// at `v0_mps`: each stiffness (`k_c`, `k_p`, `k_d`) and each inertia (`J_e`,
/// `J_c`, `J_t`, `J_p`, `J_f`, `J_d`, `J_w`) and the mass moved alone to the edge of its band
/// ([`Tolerances::of_key`]), the relative change of the linearised frequency taken in
/// magnitude, and the magnitudes summed: the largest shift a driveline whose every value lies
/// in its band can show to first order (the worst corner, not a spread). 0 without a mode.
///
/// A measured shuffle frequency this close to the nominal model's is consistent with the
/// vehicle file; [`ModalConfig::min_relative_shift`] is raised to it (docs/diagnosis/method.md,
/// "Model-form residual").
///
/// [`ModalConfig::min_relative_shift`]: super::modal_config::ModalConfig::min_relative_shift
pub fn tolerance_shift(
    p: &DrivelineParams,
    ratios: &[f64],
    gear: usize,
    v0_mps: f64,
    share: f64,
    tolerances: &Tolerances,
) -> f64 {
    let mode = |q: &DrivelineParams| tyre_mode(q, ratios, gear, v0_mps, 0.0, share);
    let Some(f0) = mode(p).map(|m| m.frequency_hz) else {
        return 0.0;
    };
    type Set = fn(&mut DrivelineParams, f64);
    let keys: [(&str, Set); 11] = [
        ("k_c_nm_per_rad", |q, f| q.k_c_nm_per_rad *= f),
        ("k_p_nm_per_rad", |q, f| q.k_p_nm_per_rad *= f),
        ("k_d_nm_per_rad", |q, f| q.k_d_nm_per_rad *= f),
        ("j_e_kg_m2", |q, f| q.j_e_kg_m2 *= f),
        ("j_c_kg_m2", |q, f| q.j_c_kg_m2 *= f),
        ("j_t_kg_m2", |q, f| {
            q.j_t_kg_m2.iter_mut().for_each(|j| *j *= f)
        }),
        ("j_p_kg_m2", |q, f| q.j_p_kg_m2 *= f),
        ("j_f_kg_m2", |q, f| q.j_f_kg_m2 *= f),
        ("j_d_kg_m2", |q, f| q.j_d_kg_m2 *= f),
        ("j_w_kg_m2", |q, f| q.j_w_kg_m2 *= f),
        ("mass_kg", |q, f| q.mass_kg *= f),
    ];
    keys.iter()
        .filter_map(|(key, set)| {
            let r = match tolerances.of_key(key)? {
                Tolerance::Relative(r) => r,
                // an absolute band on a positive value, as a fraction of the nominal
                Tolerance::Absolute(a) => {
                    let mut q = p.clone();
                    set(&mut q, 1.0);
                    a / nominal_of(key, &q)?
                }
                Tolerance::None => return None,
            };
            let shift = |factor: f64| {
                let mut q = p.clone();
                set(&mut q, factor);
                mode(&q).map(|m| (m.frequency_hz / f0 - 1.0).abs())
            };
            Some(
                shift(1.0 + r)
                    .unwrap_or(0.0)
                    .max(shift(1.0 - r).unwrap_or(0.0)),
            )
        })
        .sum()
}

/// The scalar value of a vehicle-file key of [`tolerance_shift`] (`J_t` of the first gear).
fn nominal_of(key: &str, q: &DrivelineParams) -> Option<f64> {
    Some(match key {
        "k_c_nm_per_rad" => q.k_c_nm_per_rad,
        "k_p_nm_per_rad" => q.k_p_nm_per_rad,
        "k_d_nm_per_rad" => q.k_d_nm_per_rad,
        "j_e_kg_m2" => q.j_e_kg_m2,
        "j_c_kg_m2" => q.j_c_kg_m2,
        "j_t_kg_m2" => *q.j_t_kg_m2.first()?,
        "j_p_kg_m2" => q.j_p_kg_m2,
        "j_f_kg_m2" => q.j_f_kg_m2,
        "j_d_kg_m2" => q.j_d_kg_m2,
        "j_w_kg_m2" => q.j_w_kg_m2,
        "mass_kg" => q.mass_kg,
        _ => return None,
    })
    .filter(|v| *v > 0.0)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The proof's vehicle (the diesel variant of the axle-load thesis 6×2): driveline parameters
    /// and gear ratios.
    pub(crate) fn vehicle() -> (DrivelineParams, Vec<f64>) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures/vehicles/seed002-6x2-diesel.toml");
        let vf = crate::model::vehicle::VehicleFile::load(&path).expect("bundled vehicle");
        (vf.driveline.expect("has a driveline"), vf.gearbox.ratios)
    }

    #[test]
    fn the_locked_mode_follows_the_shaft_stiffness() {
        let (p, ratios) = vehicle();
        let mut stiff = p.clone();
        stiff.k_d_nm_per_rad *= 1.4;
        for gear in [1, 7, 12] {
            let a = locked_mode(&p, &ratios, gear, 10.0).expect("a shuffle mode");
            let b = locked_mode(&stiff, &ratios, gear, 10.0).expect("a shuffle mode");
            // in the shuffle band, and a stiffer shaft raises it by at most √1.4 (the shaft
            // is one of the mode's springs in series) and by more than 0.5 %: measured 1.15 in
            // gear 1, where the drive shaft dominates the mode, falling to 1.01 in gear 12,
            // where the engine-side shafts (seen through a small ratio) soften it as much
            assert!(a.frequency_hz > 0.8 && a.frequency_hz < 12.0, "{a:?}");
            let ratio = b.frequency_hz / a.frequency_hz;
            assert!(
                ratio > 1.005 && ratio <= 1.4f64.sqrt() + 1e-9,
                "gear {gear}: {ratio}"
            );
            assert!(a.decay_per_s > 0.0, "{a:?}");
        }
        assert!(locked_mode(&p, &ratios, 0, 10.0).is_none());
        assert!(locked_mode(&p, &ratios, ratios.len() + 1, 10.0).is_none());
    }

    #[test]
    fn the_tolerance_shift_follows_the_square_root_law_and_adds_the_bands() {
        let (p, ratios) = vehicle();
        let zero = |keys: &[&str]| {
            let text: String = keys
                .iter()
                .map(|k| format!("{k} = {{ relative = 0.0 }}\n"))
                .collect();
            let t: toml::Table = toml::from_str(&text).unwrap();
            Tolerances::from_table(&t, |_| true).unwrap()
        };
        let all = [
            "k_c_nm_per_rad",
            "k_p_nm_per_rad",
            "k_d_nm_per_rad",
            "j_e_kg_m2",
            "j_c_kg_m2",
            "j_t_kg_m2",
            "j_p_kg_m2",
            "j_f_kg_m2",
            "j_d_kg_m2",
            "j_w_kg_m2",
            "mass_kg",
        ];
        // every band closed: no shift allowed
        assert_eq!(tolerance_shift(&p, &ratios, 1, 3.0, 0.0, &zero(&all)), 0.0);
        // only k_d's ±10 % open: at most the square-root law's 1 − √0.9 = 5.1 %, and most of
        // it, since the drive shafts are the main flexibility
        let only_kd: Vec<&str> = all
            .iter()
            .copied()
            .filter(|k| *k != "k_d_nm_per_rad")
            .collect();
        let s = tolerance_shift(&p, &ratios, 1, 3.0, 0.0, &zero(&only_kd));
        assert!(s > 0.03 && s <= 1.0 - 0.9_f64.sqrt() + 1e-12, "{s}");
        // the default bands add the others' shifts on top
        let d = tolerance_shift(&p, &ratios, 1, 3.0, 0.0, &Tolerances::default());
        assert!(d > s && d < 0.15, "{d} vs {s}");
    }

    /// The margin docs/diagnosis/method.md quotes for the bundled truck files (gears 1–4 at
    /// 1200 rpm, default tolerances): the shaft stiffness's ±10 % gives up to 5.1 % (square-root
    /// law), the inertias' ±5 % and the mass's ±3 % the rest. Printed with
    /// `cargo test --release --lib tolerance_margin_of_the_bundled -- --nocapture`.
    #[test]
    fn tolerance_margin_of_the_bundled_trucks() {
        use crate::model::resonance::{vehicle_speed_at, OPERATING_ENGINE_SPEED_RAD_S};
        for file in ["truck-40t.toml", "seed002-6x2-diesel.toml"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("fixtures/vehicles")
                .join(file);
            let vf = crate::model::vehicle::VehicleFile::load(&path).unwrap();
            let d = vf.driveline.as_ref().unwrap();
            let r = &vf.gearbox.ratios;
            let margin = (1..=4)
                .map(|g| {
                    let v0 = vehicle_speed_at(d, r, g, OPERATING_ENGINE_SPEED_RAD_S);
                    tolerance_shift(d, r, g, v0, 0.0, &vf.tolerance)
                })
                .fold(0.0, f64::max);
            eprintln!("{file}: modal tolerance margin {:.2} %", 100.0 * margin);
            assert!(margin > 0.06 && margin < 0.09, "{file}: {margin}");
        }
    }
}
