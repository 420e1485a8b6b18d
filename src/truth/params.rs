//! Parameters of the truth plant: the vehicle file's nominal driveline values plus the
//! structure the file does not describe, and their per-drive draw within tolerances.
//!
//! # Conventions
//! SI units throughout (kg, m, s, N, N·m, rad, rad/s, K). Torsional stiffnesses in N·m/rad,
//! dampings in N·m·s/rad, inertias in kg·m² about their own shaft. "Per side" values belong to
//! one of the two driven half-shafts / wheel groups of the driven axle.
//!
//! # Draw
//! Every drive draws its truck around the vehicle file with the project PRNG
//! ([`crate::rng::Xoshiro256StarStar`]): each toleranced value is
//! `nominal·(1 + u)`, `u` uniform on `[−tol, tol]` (a tolerance band, not a standard deviation:
//! production and load spreads are bounded, so a uniform band is the honest model):
//!
//! | quantity | tol |
//! |---|---|
//! | mass | ±3 % |
//! | drag area c_w·A_f | ±5 % |
//! | rolling-resistance coefficients c_r1, c_r2 | ±5 % |
//! | torsional stiffnesses and dampings (damper stages, propeller, drive shafts), tyre slip stiffness | ±10 % |
//! | inertias (engine, disc, gearbox, propeller, final drive, shafts, wheels) | ±5 % |
//! | clutch friction capacity | ±5 % |
//!
//! Per truck the engine's torque map error is drawn too: gain error uniform ±2 %, offset
//! uniform ±15 N·m (production ECU torque estimates are specified to a few per cent of the
//! reference torque). Ratios, wheel radius, gravity and air density are taken as nominal.

use super::TruthError;
use crate::model::driveline::DrivelineParams;
use crate::rng::Xoshiro256StarStar;

/// Tolerance bands of the per-drive draw (fractions of nominal; module doc).
pub mod tol {
    /// Vehicle mass.
    pub const MASS: f64 = 0.03;
    /// Drag area.
    pub const DRAG_AREA: f64 = 0.05;
    /// Rolling resistance coefficients.
    pub const ROLLING: f64 = 0.05;
    /// Stiffnesses and dampings.
    pub const STIFFNESS: f64 = 0.10;
    /// Inertias.
    pub const INERTIA: f64 = 0.05;
    /// Clutch friction capacity.
    pub const CLUTCH: f64 = 0.05;
    /// ECU torque-map gain error (absolute fraction).
    pub const MAP_GAIN: f64 = 0.02;
    /// ECU torque-map offset error, N·m.
    pub const MAP_OFFSET_NM: f64 = 15.0;
}

/// Clutch damper (torsional vibration damper in the clutch disc hub).
#[derive(Debug, Clone, PartialEq)]
pub struct DamperParams {
    /// First-stage stiffness k1, N·m/rad (the vehicle file's k_c).
    pub k1_nm_per_rad: f64,
    /// Second-stage stiffness k2 > k1, N·m/rad: 3·k1 (two-stage truck dampers have a stage-2
    /// rate 2–4 times stage 1).
    pub k2_nm_per_rad: f64,
    /// Angle where stage 2 starts, θ1, rad: 0.10 rad (5.7°; truck damper travel is ±8–10°,
    /// the first stage covers the part-load range, k1·θ1 = 1200 N·m for the 40 t truck).
    pub theta1_rad: f64,
    /// Viscous damping c_c, N·m·s/rad (the vehicle file's c_c).
    pub c_nm_s_per_rad: f64,
    /// Coulomb hysteresis (friction washers) torque T_h, N·m: 60 N·m (≈ 2 % of the clutch
    /// capacity, the usual hysteresis of a heavy-duty damper).
    pub hysteresis_nm: f64,
    /// Width of the tanh that regularises the hysteresis, ω_h, rad/s: 0.5 rad/s. The friction
    /// torque is `T_h·tanh(φ̇/ω_h)`: at 1.5 rad/s twist rate it is 99.5 % of T_h.
    pub hysteresis_width_rad_s: f64,
}

/// Tyres of the driven axle (one side = a twin-tyre group), brush/linear-slip model with
/// relaxation length (Pacejka, "Tire and Vehicle Dynamics", Elsevier, ch. 7–8).
#[derive(Debug, Clone, PartialEq)]
pub struct TyreParams {
    /// Normal load per side, N: 29 % of the weight on the driven axle (11.5 t of a 40 t
    /// combination, the EU drive-axle limit), halved.
    pub fz_n: f64,
    /// Longitudinal slip stiffness per side C_κ, N (per unit slip): 10·F_z (truck drive tyres
    /// show normalised slip stiffness 8–12).
    pub slip_stiffness_n: f64,
    /// Relaxation length σ, m: 0.6 m (truck tyres 0.4–0.8 m longitudinally).
    pub relaxation_m: f64,
    /// Friction coefficient µ: 0.8 (dry asphalt).
    pub mu: f64,
    /// Low-speed damping of the tyre deflection d_0, N·s/m (ζ ≈ 0.5 of the tyre spring against
    /// the driven wheel inertia at standstill), faded out linearly to 0 at `low_speed_mps`.
    pub low_speed_damping_n_s_per_m: f64,
    /// Speed above which the low-speed damping is zero, m/s: 3 m/s.
    pub low_speed_mps: f64,
}

/// First-order tyre thermal model for the rolling resistance.
#[derive(Debug, Clone, PartialEq)]
pub struct ThermalParams {
    /// Lumped heat capacity of all tyres, J/K: 12 tyres × 70 kg × 1500 J/(kg·K).
    pub heat_capacity_j_per_k: f64,
    /// Heat transfer to ambient at standstill, W/K.
    pub h0_w_per_k: f64,
    /// Speed-proportional heat transfer, W/K per m/s (forced convection). With h0 = 300 W/K and
    /// h1 = 45 W/(K·m/s) the time constant at 80 km/h is C/h ≈ 970 s (warm-up 15–30 min, as
    /// truck tyres show) and the steady rise ≈ 40 K.
    pub h1_w_per_k_m_s: f64,
    /// Temperature rise over ambient at which the vehicle file's c_r1 holds (warm tyres; tyre
    /// labels are measured warm, ISO 28580), K: 40 K.
    pub warm_rise_k: f64,
    /// Extra rolling resistance of cold tyres (at ambient) over warm: 0.20 (cold truck tyres
    /// roll 15–25 % harder). `c_r1(T) = c_r1·(1 + β·(ΔT_w − ΔT)/ΔT_w)`, ΔT = T − T_amb, floored
    /// at `c_r1·(1 − β)`.
    pub cold_excess: f64,
}

/// Engine and its control unit.
#[derive(Debug, Clone, PartialEq)]
pub struct EngineParams {
    /// Lag of the produced combustion torque behind the ECU's command, s: 0.10 s (fuel-path and
    /// combustion delay of a turbo diesel at constant speed, 0.05–0.15 s).
    pub lag_s: f64,
    /// Engine friction at zero speed, N·m: 60 N·m.
    pub friction0_nm: f64,
    /// Speed-proportional friction, N·m·s/rad: 0.9 (with friction0 the motoring torque is
    /// 240 N·m at 1900 rpm, the file's drag limit of about −250 N·m).
    pub friction1_nm_s_per_rad: f64,
    /// Net full-load torque curve: speeds, rad/s.
    pub full_load_speed_rad_s: Vec<f64>,
    /// Net full-load torque curve: torques, N·m.
    pub full_load_nm: Vec<f64>,
    /// Idle speed, rad/s: 600 rpm.
    pub idle_rad_s: f64,
    /// Governor proportional gain, N·m·s/rad (the vehicle file's K_P).
    pub gov_kp: f64,
    /// Governor integral gain, N·m/rad (the vehicle file's K_I).
    pub gov_ki: f64,
    /// Map error: reported = produced·(1 + gain) + offset. Gain, fraction.
    pub map_gain: f64,
    /// Map error offset, N·m.
    pub map_offset_nm: f64,
}

/// The truck as simulated (the truth).
#[derive(Debug, Clone, PartialEq)]
pub struct TruckParams {
    /// Vehicle mass m (including the translational mass of all wheels), kg.
    pub mass_kg: f64,
    /// Dynamic wheel radius r_w, m.
    pub wheel_radius_m: f64,
    /// Engine + flywheel inertia J_e.
    pub j_e: f64,
    /// Clutch disc inertia J_c.
    pub j_c: f64,
    /// Gearbox input-shaft side inertia J_in (about the input shaft), derived from the file's
    /// per-gear J_t(i) = J_in·i² + J_out.
    pub j_in: f64,
    /// Gearbox output-side inertia J_out (about the output shaft).
    pub j_out: f64,
    /// Propeller shaft inertia J_p (lumped at the gearbox output).
    pub j_p: f64,
    /// Differential carrier + crown wheel J_f.
    pub j_f: f64,
    /// Side gear + half-shaft inertia per side J_s = J_d/2.
    pub j_s: f64,
    /// Driven wheel-group inertia per side J_wd = J_w·4/12/2 (4 of 12 tyres driven).
    pub j_wd: f64,
    /// Inertia of the non-driven wheels J_wn = J_w·8/12, counted as mass J_wn/r_w².
    pub j_wn: f64,
    /// Clutch damper.
    pub damper: DamperParams,
    /// Gear ratios i_t, lowest gear first.
    pub ratios: Vec<f64>,
    /// Gearbox output loss b_t, N·m·s/rad.
    pub b_t: f64,
    /// Input-shaft drag in neutral, N·m·s/rad: 0.05 (oil churning of the idle countershaft).
    pub b_in: f64,
    /// Synchroniser capacity, N·m (about the input shaft): 150 N·m (a 6→7 shift synchronises
    /// ~100 rad/s of 0.3 kg·m² in ~0.2 s).
    pub sync_nm: f64,
    /// Propeller shaft stiffness k_p.
    pub k_p: f64,
    /// Propeller shaft damping c_p.
    pub c_p: f64,
    /// Final drive ratio i_f.
    pub i_f: f64,
    /// Final drive loss b_f, N·m·s/rad (at the carrier).
    pub b_f: f64,
    /// Drive-shaft stiffness per side k_s. The vehicle file's k_d is the lumped main
    /// flexibility — both drive shafts in series with the tyres' torsional compliance — so the
    /// shafts take what the tyres leave: `2·k_s = 1/(1/k_d − 1/k_ty)` with the tyres'
    /// torsional stiffness `k_ty = 2·C_κ·r_w²/σ` (see [`TruckParams::tyre_torsional_stiffness`]
    /// and [`TruckParams::lumped_stiffness`]).
    pub k_s: f64,
    /// Drive-shaft damping per side c_s = c_d/2 (the file's lumped c_d on the axle wind-up; the
    /// tyres add their own, speed-dependent damping through the relaxation length).
    pub c_s: f64,
    /// Drive-shaft lash (total free play per side), rad; 0 nominally.
    pub lash_rad: f64,
    /// Clutch kinetic capacity M_k at full engagement, N·m (the plant's, independent of the
    /// actuator).
    pub clutch_kinetic_nm: f64,
    /// Static/kinetic friction ratio k_µ.
    pub clutch_static_ratio: f64,
    /// Actuator travel where the clutch starts to open, L_l.
    pub clutch_l_lower: f64,
    /// Actuator travel where it is fully open, L_u.
    pub clutch_l_upper: f64,
    /// The capacity the AMT believes (the vehicle file's), N·m.
    pub clutch_nominal_nm: f64,
    /// Air density, kg/m³.
    pub rho_air: f64,
    /// Drag area c_w·A_f, m².
    pub c_w_a_f_m2: f64,
    /// Rolling resistance (warm), 1.
    pub c_r1: f64,
    /// Speed-dependent rolling resistance, s/m.
    pub c_r2_s_per_m: f64,
    /// Gravity, m/s².
    pub gravity: f64,
    /// Tyres.
    pub tyre: TyreParams,
    /// Tyre thermal model.
    pub thermal: ThermalParams,
    /// Engine and ECU.
    pub engine: EngineParams,
}

fn check(name: &'static str, v: f64, ok: bool) -> Result<(), TruthError> {
    if v.is_finite() && ok {
        Ok(())
    } else {
        Err(TruthError::BadParameter {
            parameter: name,
            value: v,
        })
    }
}

impl TruckParams {
    /// The nominal truck of a vehicle file's driveline and gear ratios (no draw, no map error).
    ///
    /// # Errors
    /// [`TruthError::BadParameter`] for a non-finite or non-positive value the plant divides by,
    /// fewer than one gear ratio, or a lumped `k_d_nm_per_rad` not below the tyres' torsional
    /// stiffness (the shafts would need a non-positive or infinite stiffness).
    pub fn nominal(d: &DrivelineParams, ratios: &[f64]) -> Result<Self, TruthError> {
        if ratios.is_empty() || d.j_t_kg_m2.len() != ratios.len() {
            return Err(TruthError::BadParameter {
                parameter: "gearbox ratios (count must match j_t_kg_m2, ≥ 1)",
                value: ratios.len() as f64,
            });
        }
        for &r in ratios {
            check("gear ratio", r, r > 0.0)?;
        }
        // J_t(i) = J_in i² + J_out from the first and last gear (exact for the file's rule)
        let n = ratios.len();
        let (r1, rn) = (ratios[0], ratios[n - 1]);
        let (j1, jn) = (d.j_t_kg_m2[0], d.j_t_kg_m2[n - 1]);
        let j_in = if n > 1 && (r1 * r1 - rn * rn).abs() > 1e-9 {
            ((j1 - jn) / (r1 * r1 - rn * rn)).max(0.01)
        } else {
            0.2
        };
        let j_out = (jn - j_in * rn * rn).max(0.05);
        let fz = 0.29 * d.mass_kg * d.gravity_m_per_s2 / 2.0;
        let slip = 10.0 * fz;
        let sigma = 0.6;
        let j_wd = d.j_w_kg_m2 * 4.0 / 12.0 / 2.0;
        let m_eq = j_wd / (d.wheel_radius_m * d.wheel_radius_m);
        let low_damp = 2.0 * 0.5 * (slip / sigma * m_eq).sqrt();
        // the file's k_d lumps shafts and tyres in series; the tyres' share is their carcass
        // stiffness C_κ/σ at the wheel radius, both sides in parallel
        let k_ty = 2.0 * slip / sigma * d.wheel_radius_m * d.wheel_radius_m;
        let k_d = d.k_d_nm_per_rad;
        check("k_d_nm_per_rad", k_d, k_d > 0.0)?;
        check(
            "k_d_nm_per_rad (must be below the tyres' torsional stiffness 2·C_κ·r_w²/σ)",
            k_d,
            k_d < k_ty,
        )?;
        let k_shafts = 1.0 / (1.0 / k_d - 1.0 / k_ty);
        let p = TruckParams {
            mass_kg: d.mass_kg,
            wheel_radius_m: d.wheel_radius_m,
            j_e: d.j_e_kg_m2,
            j_c: d.j_c_kg_m2,
            j_in,
            j_out,
            j_p: d.j_p_kg_m2,
            j_f: d.j_f_kg_m2,
            j_s: d.j_d_kg_m2 / 2.0,
            j_wd,
            j_wn: d.j_w_kg_m2 * 8.0 / 12.0,
            damper: DamperParams {
                k1_nm_per_rad: d.k_c_nm_per_rad,
                k2_nm_per_rad: 3.0 * d.k_c_nm_per_rad,
                theta1_rad: 0.10,
                c_nm_s_per_rad: d.c_c_nm_s_per_rad,
                hysteresis_nm: 60.0,
                hysteresis_width_rad_s: 0.5,
            },
            ratios: ratios.to_vec(),
            b_t: d.b_t_nm_s_per_rad,
            b_in: 0.05,
            sync_nm: 150.0,
            k_p: d.k_p_nm_per_rad,
            c_p: d.c_p_nm_s_per_rad,
            i_f: d.final_drive_ratio,
            b_f: d.b_f_nm_s_per_rad,
            k_s: k_shafts / 2.0,
            c_s: d.c_d_nm_s_per_rad / 2.0,
            lash_rad: 0.0,
            clutch_kinetic_nm: d.clutch_max_torque_nm,
            clutch_static_ratio: d.clutch_static_to_kinetic,
            clutch_l_lower: d.clutch_l_lower,
            clutch_l_upper: d.clutch_l_upper,
            clutch_nominal_nm: d.clutch_max_torque_nm,
            rho_air: d.rho_air_kg_per_m3,
            c_w_a_f_m2: d.c_w_a_f_m2,
            c_r1: d.c_r1,
            c_r2_s_per_m: d.c_r2_s_per_m,
            gravity: d.gravity_m_per_s2,
            tyre: TyreParams {
                fz_n: fz,
                slip_stiffness_n: slip,
                relaxation_m: sigma,
                mu: 0.8,
                low_speed_damping_n_s_per_m: low_damp,
                low_speed_mps: 3.0,
            },
            thermal: ThermalParams {
                heat_capacity_j_per_k: 12.0 * 70.0 * 1500.0,
                h0_w_per_k: 300.0,
                h1_w_per_k_m_s: 45.0,
                warm_rise_k: 40.0,
                cold_excess: 0.20,
            },
            engine: EngineParams {
                lag_s: 0.10,
                friction0_nm: 60.0,
                friction1_nm_s_per_rad: 0.9,
                full_load_speed_rad_s: d.engine_speed_rad_per_s.clone(),
                full_load_nm: d.engine_max_torque_nm.clone(),
                idle_rad_s: 600.0 * std::f64::consts::PI / 30.0,
                gov_kp: d.pi_kp_nm_s_per_rad,
                gov_ki: d.pi_ki_nm_per_rad,
                map_gain: 0.0,
                map_offset_nm: 0.0,
            },
        };
        p.validate()?;
        Ok(p)
    }

    /// Checks every value the plant uses: finite, and positive where it is divided by or must be.
    ///
    /// # Errors
    /// [`TruthError::BadParameter`] naming the first bad value.
    pub fn validate(&self) -> Result<(), TruthError> {
        let pos = [
            ("mass_kg", self.mass_kg),
            ("wheel_radius_m", self.wheel_radius_m),
            ("j_e", self.j_e),
            ("j_c", self.j_c),
            ("j_in", self.j_in),
            ("j_out", self.j_out),
            ("j_p", self.j_p),
            ("j_f", self.j_f),
            ("j_s", self.j_s),
            ("j_wd", self.j_wd),
            ("damper.k1", self.damper.k1_nm_per_rad),
            ("damper.k2", self.damper.k2_nm_per_rad),
            ("damper.theta1", self.damper.theta1_rad),
            (
                "damper.hysteresis_width",
                self.damper.hysteresis_width_rad_s,
            ),
            ("k_p", self.k_p),
            ("i_f", self.i_f),
            ("k_s", self.k_s),
            ("clutch_static_ratio", self.clutch_static_ratio),
            ("clutch_nominal_nm", self.clutch_nominal_nm),
            ("tyre.fz", self.tyre.fz_n),
            ("tyre.slip_stiffness", self.tyre.slip_stiffness_n),
            ("tyre.relaxation", self.tyre.relaxation_m),
            ("tyre.mu", self.tyre.mu),
            ("tyre.low_speed", self.tyre.low_speed_mps),
            ("thermal.heat_capacity", self.thermal.heat_capacity_j_per_k),
            ("thermal.h0", self.thermal.h0_w_per_k),
            ("thermal.warm_rise", self.thermal.warm_rise_k),
            ("engine.lag_s", self.engine.lag_s),
            ("engine.idle", self.engine.idle_rad_s),
            ("gravity", self.gravity),
        ];
        for (n, v) in pos {
            check(n, v, v > 0.0)?;
        }
        let nonneg = [
            ("j_wn", self.j_wn),
            ("damper.c", self.damper.c_nm_s_per_rad),
            ("damper.hysteresis", self.damper.hysteresis_nm),
            ("b_t", self.b_t),
            ("b_in", self.b_in),
            ("sync_nm", self.sync_nm),
            ("c_p", self.c_p),
            ("b_f", self.b_f),
            ("c_s", self.c_s),
            ("lash_rad", self.lash_rad),
            ("clutch_kinetic_nm", self.clutch_kinetic_nm),
            ("rho_air", self.rho_air),
            ("c_w_a_f_m2", self.c_w_a_f_m2),
            ("c_r1", self.c_r1),
            ("c_r2", self.c_r2_s_per_m),
            (
                "tyre.low_speed_damping",
                self.tyre.low_speed_damping_n_s_per_m,
            ),
            ("thermal.h1", self.thermal.h1_w_per_k_m_s),
            ("thermal.cold_excess", self.thermal.cold_excess),
            ("engine.friction0", self.engine.friction0_nm),
            ("engine.friction1", self.engine.friction1_nm_s_per_rad),
            ("engine.gov_kp", self.engine.gov_kp),
            ("engine.gov_ki", self.engine.gov_ki),
        ];
        for (n, v) in nonneg {
            check(n, v, v >= 0.0)?;
        }
        check(
            "engine.map_gain",
            self.engine.map_gain,
            self.engine.map_gain > -0.5,
        )?;
        check("engine.map_offset_nm", self.engine.map_offset_nm, true)?;
        check(
            "damper.k2 (must be ≥ k1)",
            self.damper.k2_nm_per_rad,
            self.damper.k2_nm_per_rad >= self.damper.k1_nm_per_rad,
        )?;
        check(
            "clutch_l_upper (must exceed clutch_l_lower)",
            self.clutch_l_upper,
            self.clutch_l_upper > self.clutch_l_lower,
        )?;
        for &r in &self.ratios {
            check("gear ratio", r, r > 0.0)?;
        }
        let e = &self.engine;
        if e.full_load_speed_rad_s.len() < 2
            || e.full_load_speed_rad_s.len() != e.full_load_nm.len()
        {
            return Err(TruthError::BadParameter {
                parameter: "engine full-load curve (≥ 2 points, equal lengths)",
                value: e.full_load_nm.len() as f64,
            });
        }
        for (&w, &m) in e.full_load_speed_rad_s.iter().zip(&e.full_load_nm) {
            check("engine full-load speed", w, w >= 0.0)?;
            check("engine full-load torque", m, m >= 0.0)?;
        }
        Ok(())
    }

    /// Draws this drive's truck around `self` (module doc): every toleranced value scaled by
    /// `1 + u`, `u` uniform in ±tol, plus the ECU map error. The order of the draws is fixed
    /// (the field order of the tolerance table) so a seed always gives the same truck.
    pub fn draw(&self, rng: &mut Xoshiro256StarStar) -> TruckParams {
        let mut p = self.clone();
        let mut f = |tol: f64| 1.0 + rng.uniform(-tol, tol);
        p.mass_kg *= f(tol::MASS);
        p.c_w_a_f_m2 *= f(tol::DRAG_AREA);
        p.c_r1 *= f(tol::ROLLING);
        p.c_r2_s_per_m *= f(tol::ROLLING);
        p.damper.k1_nm_per_rad *= f(tol::STIFFNESS);
        p.damper.k2_nm_per_rad *= f(tol::STIFFNESS);
        p.damper.c_nm_s_per_rad *= f(tol::STIFFNESS);
        p.k_p *= f(tol::STIFFNESS);
        p.c_p *= f(tol::STIFFNESS);
        p.k_s *= f(tol::STIFFNESS);
        p.c_s *= f(tol::STIFFNESS);
        p.tyre.slip_stiffness_n *= f(tol::STIFFNESS);
        p.j_e *= f(tol::INERTIA);
        p.j_c *= f(tol::INERTIA);
        p.j_in *= f(tol::INERTIA);
        p.j_out *= f(tol::INERTIA);
        p.j_p *= f(tol::INERTIA);
        p.j_f *= f(tol::INERTIA);
        p.j_s *= f(tol::INERTIA);
        p.j_wd *= f(tol::INERTIA);
        p.j_wn *= f(tol::INERTIA);
        p.clutch_kinetic_nm *= f(tol::CLUTCH);
        // stage 2 must stay stiffer than stage 1 (the draws are ±10 % around 1:3)
        p.damper.k2_nm_per_rad = p.damper.k2_nm_per_rad.max(p.damper.k1_nm_per_rad);
        p.engine.map_gain = rng.uniform(-tol::MAP_GAIN, tol::MAP_GAIN);
        p.engine.map_offset_nm = rng.uniform(-tol::MAP_OFFSET_NM, tol::MAP_OFFSET_NM);
        // the tyre load follows the drawn mass
        p.tyre.fz_n *= p.mass_kg / self.mass_kg;
        p
    }

    /// Total ratio of gear index `g` (0-based) with the final drive, i_t·i_f.
    pub fn total_ratio(&self, g: usize) -> f64 {
        self.ratios[g] * self.i_f
    }

    /// Structural damping of one drive shaft's differential (left-against-right) motion,
    /// N·m·s/rad: 2 % of critical of a side gear on its shaft, `0.04·√(k_s·J_s)` (steel shafts
    /// damp 1–2 %; see [`super::plant`]).
    pub fn antisymmetric_damping(&self) -> f64 {
        0.04 * (self.k_s * self.j_s).sqrt()
    }

    /// Torsional stiffness of the driven tyres at the axle, both sides, N·m/rad:
    /// `k_ty = 2·C_κ·r_w²/σ`. At low speed (|v|/σ well below the frequency of interest) the
    /// relaxation-length tyre is a spring of longitudinal stiffness C_κ/σ at the contact patch
    /// (its carcass), seen at the axle through r_w².
    pub fn tyre_torsional_stiffness(&self) -> f64 {
        2.0 * self.tyre.slip_stiffness_n / self.tyre.relaxation_m
            * self.wheel_radius_m
            * self.wheel_radius_m
    }

    /// The lumped main flexibility, N·m/rad: both shafts (2·k_s) in series with the tyres
    /// (`k_ty`), `1/(1/(2·k_s) + 1/k_ty)` — what the vehicle file's k_d describes. Equal to the
    /// file's k_d for the nominal truck.
    pub fn lumped_stiffness(&self) -> f64 {
        1.0 / (1.0 / (2.0 * self.k_s) + 1.0 / self.tyre_torsional_stiffness())
    }

    /// Equivalent translational mass of the body: m + J_wn/r_w², kg.
    pub fn body_mass(&self) -> f64 {
        self.mass_kg + self.j_wn / (self.wheel_radius_m * self.wheel_radius_m)
    }
}
