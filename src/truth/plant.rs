//! The truth plant: a longitudinal heavy truck as a hybrid ODE, integrated by
//! [`super::integrator::EventRk4`].
//!
//! # Bodies and states (SI; speeds forward-positive, twists positive when the driving side
//! leads, torques positive when driving)
//!
//! | index | state | unit |
//! |---|---|---|
//! | `W_E` | engine + flywheel speed ω_e | rad/s |
//! | `W_C` | clutch-disc speed ω_c (equal to ω_e while locked) | rad/s |
//! | `PHI_C` | damper twist φ_c = θ_c − θ_in | rad |
//! | `W_I` | gearbox input-shaft speed ω_i (equal to i_t·ω_p while in gear) | rad/s |
//! | `W_P` | gearbox output / propeller front speed ω_p | rad/s |
//! | `PHI_P` | propeller-shaft twist φ_p = θ_p − i_f·θ_cage | rad |
//! | `W_SL`, `W_SR` | left/right side-gear (half-shaft inner end) speed | rad/s |
//! | `PHI_DL`, `PHI_DR` | left/right drive-shaft twist θ_s − θ_w | rad |
//! | `W_WL`, `W_WR` | left/right driven wheel-group speed | rad/s |
//! | `U_L`, `U_R` | left/right tyre longitudinal deflection | m |
//! | `V` | vehicle speed v | m/s |
//! | `X` | travelled distance | m |
//! | `M_C` | produced combustion torque (lags the ECU command) | N·m |
//! | `DT` | tyre temperature rise over ambient | K |
//!
//! # Equations (mode by mode; see [`super::clutch`], [`super::tyre`], [`super::resistance`],
//! [`super::engine`])
//! - Engine: `M_e = M_c − M_fr(ω_e)`, `Ṁ_c = (M_cmd − M_c)/τ_e`.
//! - Damper torque `M_d(φ_c, ω_c − ω_i)` (two-stage spring + hysteresis).
//! - Clutch locked: `(J_e + J_c)·ω̇_e = M_e − M_d`, `ω̇_c = ω̇_e`. Slipping (direction s):
//!   `J_e·ω̇_e = M_e − s·M_k(x)`, `J_c·ω̇_c = s·M_k(x) − M_d`.
//! - In gear i (ratio r): `(J_in·r² + J_out + J_p)·ω̇_p = r·M_d − b_t·ω_p − M_p − M_ret`,
//!   `ω̇_i = r·ω̇_p`. In neutral: `J_in·ω̇_i = M_d − σ·T_syn − b_in·ω_i`,
//!   `(J_out + J_p)·ω̇_p = r_t·σ·T_syn − b_t·ω_p − M_p − M_ret` with the synchroniser (capacity
//!   T_syn, direction σ = sign(ω_i − r_t·ω_p), off during the select phase) toward target ratio
//!   r_t; it engages when the speeds meet (event).
//! - Propeller: `M_p = k_p·φ_p + c_p·(ω_p − i_f·ω_cage)`, `ω_cage = (ω_sL + ω_sR)/2`.
//! - Open differential with carrier inertia J_f and massless spider gears (equal split):
//!   `[J_f/4 + J_s, J_f/4; J_f/4, J_f/4 + J_s]·[ω̇_sL; ω̇_sR] = [T/2 − M_dL; T/2 − M_dR]`,
//!   `T = i_f·M_p − b_f·ω_cage`.
//! - Drive shafts: `M_dj = k_s·dz(φ_dj) + c_s·φ̄̇ + c_a·(φ̇_dj − φ̄̇)` in contact, 0 inside the
//!   lash (dead zone `dz(φ) = φ ∓ b/2`; contact/free are modes located by events; no lash:
//!   always in contact), `φ̄̇ = (φ̇_dL + φ̇_dR)/2`. The vehicle file's large lumped damping c_d
//!   (= 2·c_s) damps the common wind-up of the axle, which is what it was identified from (the
//!   shuffle); the differential (left-against-right) motion of a side gear against its wheel
//!   gets the steel shaft's structural damping, 2 % of critical, `c_a = 0.04·√(k_s·J_s)`. The
//!   split dissipates: the damper power is `2c_s·φ̄̇² + c_a·Σ(φ̇_dj − φ̄̇)² ≥ 0`. (Putting c_s on
//!   each side's own rate would make the side-gear mode's decay rate c_s/J_s ≈ 35 000 1/s,
//!   which no explicit step of useful size integrates.)
//! - Wheels: `J_wd·ω̇_wj = M_dj − r_w·F_xj`; tyres per [`super::tyre`].
//! - Body: `(m + J_wn/r_w²)·v̇ = F_xL + F_xR − F_a − F_r − F_g − F_b`, `ẋ = v`, with the service
//!   brake force F_b ≥ 0 against motion (acting on the body). Retarder torque on the gearbox
//!   output `M_ret = T_r·clamp(ω_p/20 rad/s, 0, 1)` (a hydrodynamic retarder loses its torque
//!   at low propeller speed).
//! - Standstill is a mode: when v reaches 0 (event) the brakes hold the wheels and the body
//!   (wheel speeds set to 0 — a jump of the order of the tyre slip velocity; tyre deflections
//!   frozen), the driveline up to the drive shafts stays free and winds up against the held
//!   wheels; the truck leaves standstill when the driver has released the brake, a gear is
//!   engaged and the drive shafts' torque at the ground exceeds grade and rolling resistance
//!   (hill-start aid; at that moment each tyre's deflection is set to carry its shaft's
//!   torque, the force the brake handed over),
//!   checked by [`Plant::settle_modes`].
//!
//! # Step size
//! The fastest modes: the left-against-right motion of a side gear on its drive shaft (J_s on
//! k_s, ≈ 570 Hz: the shafts are stiff because the file's lumped k_d also holds the tyres'
//! compliance, see [`super::params::TruckParams::lumped_stiffness`]), the propeller shaft against
//! the final drive (≈ 300 Hz) and the axle wind-up, overdamped by the lumped c_d (real
//! eigenvalues, the fastest ≈ −8.4e3 1/s). RK4's stability limit is |λ|·h ≤ 2.8 on the imaginary
//! axis and 2.78 on the real one; [`STEP_S`] = 0.25 ms gives |λ|·h ≈ 2.2 at most (the axle
//! wind-up; measured by `truth_plant_shuffle_frequency_matches_the_nominal_model_at_low_speed`),
//! the propeller mode ≈ 0.5 (resolved: RK4 amplitude error per step (λh)⁶/144 ≈ 1e-4) and the
//! side-gear mode ≈ 0.9 (stable; its numerical damping, (λh)⁶/144 ≈ 0.4 % per step, is a fifth
//! of its 2 % structural damping; symmetric loads leave it unexcited).

use super::clutch::{
    damper_torque, kinetic_capacity, locked_transmitted, stage_of, ClutchMode, DamperStage,
};
use super::engine::friction;
use super::integrator::{HybridSystem, MAX_GUARDS};
use super::params::TruckParams;
use super::resistance::{aero, rolling};
use super::tyre::{deflection_rate, force, rolling_factor, temperature_rate};

/// State dimension.
pub const N: usize = 18;
/// Integration step of the plant, s (module doc).
pub const STEP_S: f64 = 0.25e-3;

/// Engine speed.
pub const W_E: usize = 0;
/// Clutch disc speed.
pub const W_C: usize = 1;
/// Damper twist.
pub const PHI_C: usize = 2;
/// Input shaft speed.
pub const W_I: usize = 3;
/// Gearbox output speed.
pub const W_P: usize = 4;
/// Propeller twist.
pub const PHI_P: usize = 5;
/// Left side gear speed.
pub const W_SL: usize = 6;
/// Right side gear speed.
pub const W_SR: usize = 7;
/// Left drive-shaft twist.
pub const PHI_DL: usize = 8;
/// Right drive-shaft twist.
pub const PHI_DR: usize = 9;
/// Left wheel speed.
pub const W_WL: usize = 10;
/// Right wheel speed.
pub const W_WR: usize = 11;
/// Left tyre deflection.
pub const U_L: usize = 12;
/// Right tyre deflection.
pub const U_R: usize = 13;
/// Vehicle speed.
pub const V: usize = 14;
/// Distance.
pub const X: usize = 15;
/// Produced combustion torque.
pub const M_C: usize = 16;
/// Tyre temperature rise.
pub const DT: usize = 17;

/// The plant state.
pub type State = [f64; N];

/// Gearbox mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GearMode {
    /// Gear index (0-based) engaged.
    Engaged(usize),
    /// Neutral: target gear index (if any) and synchroniser direction σ when it is working.
    Neutral {
        /// Gear being selected.
        target: Option<usize>,
        /// `Some(σ)` while the synchroniser works.
        sync: Option<f64>,
    },
}

/// Drive-shaft lash mode of one side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LashMode {
    /// Inside the free play: no torque.
    Free,
    /// In contact on side `sign` (±1).
    Contact(f64),
}

/// Inputs held over one control step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Inputs {
    /// ECU combustion-torque command, N·m.
    pub m_cmd: f64,
    /// Clutch actuator travel, 0 engaged … 1 open.
    pub clutch_x: f64,
    /// Service-brake force, N (≥ 0).
    pub brake_n: f64,
    /// Retarder torque on the gearbox output, N·m (≥ 0).
    pub retarder_nm: f64,
    /// Headwind, m/s.
    pub wind_mps: f64,
}

/// The road as the plant feels it: slope tan α on a uniform grid from 0 m, and an optional
/// stretch of extra rolling resistance.
#[derive(Debug, Clone, PartialEq)]
pub struct RoadGrid {
    /// Grid step, m.
    pub step_m: f64,
    /// tan α at `k·step_m`.
    pub slope: Vec<f64>,
    /// Extra rolling resistance: `(start_m, end_m, factor)` multiplies c_r1 inside.
    pub surface: Option<(f64, f64, f64)>,
}

impl RoadGrid {
    /// A road of constant slope.
    pub fn constant(slope: f64) -> Self {
        Self {
            step_m: 1.0,
            slope: vec![slope, slope],
            surface: None,
        }
    }

    /// tan α at `x` (linear, held beyond the ends; a grid without samples or without a
    /// positive finite step is flat, or its first value).
    pub fn slope_at(&self, x: f64) -> f64 {
        let n = self.slope.len();
        if n == 0 {
            return 0.0;
        }
        if !(self.step_m.is_finite() && self.step_m > 0.0 && x.is_finite()) {
            return self.slope[0];
        }
        let s = (x / self.step_m).max(0.0);
        let k = s.floor() as usize;
        if k + 1 >= n {
            return self.slope[n - 1];
        }
        let u = s - k as f64;
        self.slope[k] + u * (self.slope[k + 1] - self.slope[k])
    }

    /// Surface factor on c_r1 at `x`.
    pub fn surface_at(&self, x: f64) -> f64 {
        match self.surface {
            Some((a, b, f)) if x >= a && x < b => f,
            _ => 1.0,
        }
    }
}

/// Events counted per kind (for reports and tests).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EventCounts {
    /// Clutch stick → slip.
    pub clutch_break: usize,
    /// Clutch slip speed zero (lock or reversal).
    pub clutch_zero: usize,
    /// Damper stage changes.
    pub damper_stage: usize,
    /// Synchroniser speed match (gear engaged).
    pub sync: usize,
    /// Lash contact changes.
    pub lash: usize,
    /// Stops.
    pub stop: usize,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Guard {
    ClutchBreak(f64),
    SlipZero,
    StageUp(f64),
    StageDown,
    Sync,
    LashContact(usize, f64),
    LashFree(usize),
    Stop,
}

/// Forces and torques of one evaluation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Eval {
    /// ẋ.
    pub dx: State,
    /// Net engine torque M_e, N·m.
    pub m_e: f64,
    /// Damper torque M_d, N·m.
    pub m_d: f64,
    /// Torque through the locked clutch interface, N·m.
    pub m_tr: f64,
    /// Static clutch capacity, N·m.
    pub m_s: f64,
    /// Propeller torque, N·m.
    pub m_p: f64,
    /// Drive-shaft torques, N·m.
    pub m_dl: f64,
    /// Right drive-shaft torque, N·m.
    pub m_dr: f64,
    /// Tyre forces, N.
    pub f_x: f64,
    /// Aerodynamic drag, N.
    pub f_a: f64,
    /// Rolling resistance, N.
    pub f_r: f64,
    /// Grade force, N.
    pub f_g: f64,
}

/// The truth plant (module doc).
#[derive(Debug, Clone)]
pub struct Plant {
    /// Parameters (the truth).
    pub p: TruckParams,
    /// Road.
    pub road: RoadGrid,
    /// Inputs of the current control step.
    pub u: Inputs,
    /// Clutch mode.
    pub clutch: ClutchMode,
    /// Damper stage.
    pub stage: DamperStage,
    /// Gearbox mode.
    pub gear: GearMode,
    /// Lash modes, left and right.
    pub lash: [LashMode; 2],
    /// Standing still, held by the brakes.
    pub stopped: bool,
    /// Event counts.
    pub events: EventCounts,
}

impl Plant {
    /// A plant at standstill in neutral, clutch open, engine at idle speed.
    pub fn at_rest(p: TruckParams, road: RoadGrid) -> (Self, State) {
        let mut x = [0.0; N];
        x[W_E] = p.engine.idle_rad_s;
        x[W_C] = 0.0;
        x[M_C] = friction(&p.engine, x[W_E]);
        let plant = Plant {
            p,
            road,
            u: Inputs {
                clutch_x: 1.0,
                ..Inputs::default()
            },
            clutch: ClutchMode::Slipping(1.0),
            stage: DamperStage::First,
            gear: GearMode::Neutral {
                target: None,
                sync: None,
            },
            lash: [LashMode::Contact(1.0); 2],
            stopped: true,
            events: EventCounts::default(),
        };
        (plant, x)
    }

    /// Everything at `x` in the current modes.
    pub fn eval(&self, x: &State) -> Eval {
        let p = &self.p;
        let mut dx = [0.0; N];
        let m_e = x[M_C] - friction(&p.engine, x[W_E]);
        dx[M_C] = (self.u.m_cmd - x[M_C]) / p.engine.lag_s;
        let locked = self.clutch == ClutchMode::Locked;
        let w_c = if locked { x[W_E] } else { x[W_C] };
        let w_i = match self.gear {
            GearMode::Engaged(g) => p.ratios[g] * x[W_P],
            GearMode::Neutral { .. } => x[W_I],
        };
        let dphi_c = w_c - w_i;
        let m_d = damper_torque(&p.damper, self.stage, x[PHI_C], dphi_c);
        dx[PHI_C] = dphi_c;
        let m_k = kinetic_capacity(p, self.u.clutch_x);
        let m_s = p.clutch_static_ratio * m_k;
        let m_tr = locked_transmitted(p, m_e, m_d);
        match self.clutch {
            ClutchMode::Locked => {
                dx[W_E] = (m_e - m_d) / (p.j_e + p.j_c);
                dx[W_C] = dx[W_E];
            }
            ClutchMode::Slipping(s) => {
                dx[W_E] = (m_e - s * m_k) / p.j_e;
                dx[W_C] = (s * m_k - m_d) / p.j_c;
            }
        }
        let w_cage = 0.5 * (x[W_SL] + x[W_SR]);
        let dphi_p = x[W_P] - p.i_f * w_cage;
        let m_p = p.k_p * x[PHI_P] + p.c_p * dphi_p;
        let m_ret = self.u.retarder_nm * (x[W_P] / 20.0).clamp(0.0, 1.0);
        let half = 0.5 * p.lash_rad;
        let dphi_dl = x[W_SL] - x[W_WL];
        let dphi_dr = x[W_SR] - x[W_WR];
        // damping: c_s on the common (axle wind-up) twist rate, c_a on each side's difference
        // from it (module doc)
        let mean = 0.5 * (dphi_dl + dphi_dr);
        let c_a = p.antisymmetric_damping();
        let shaft = |phi: f64, dphi: f64, mode: LashMode| match mode {
            LashMode::Free => 0.0,
            LashMode::Contact(s) => p.k_s * (phi - s * half) + p.c_s * mean + c_a * (dphi - mean),
        };
        let m_dl = shaft(x[PHI_DL], dphi_dl, self.lash[0]);
        let m_dr = shaft(x[PHI_DR], dphi_dr, self.lash[1]);
        let tan_a = self.road.slope_at(x[X]);
        let cos_a = 1.0 / (1.0 + tan_a * tan_a).sqrt();
        let sin_a = tan_a * cos_a;
        let v = x[V];
        let mg = p.mass_kg * p.gravity;
        let c_r1 = p.c_r1 * rolling_factor(&p.thermal, x[DT]) * self.road.surface_at(x[X]);
        let f_r = rolling(c_r1, p.c_r2_s_per_m, v, p.mass_kg, p.gravity, cos_a);
        let f_a = aero(p.rho_air, p.c_w_a_f_m2, v, self.u.wind_mps);
        let f_g = mg * sin_a;
        let r = p.wheel_radius_m;
        let vsl = x[W_WL] * r - v;
        let vsr = x[W_WR] * r - v;
        let f_l = force(&p.tyre, x[U_L], vsl, v);
        let f_rr = force(&p.tyre, x[U_R], vsr, v);
        dx[DT] = temperature_rate(&p.thermal, x[DT], f_r * v.abs(), v);
        let mut e = Eval {
            dx,
            m_e,
            m_d,
            m_tr,
            m_s,
            m_p,
            m_dl,
            m_dr,
            f_x: f_l + f_rr,
            f_a,
            f_r,
            f_g,
        };
        let dx = &mut e.dx;
        match self.gear {
            GearMode::Engaged(g) => {
                let ri = p.ratios[g];
                let j = p.j_in * ri * ri + p.j_out + p.j_p;
                dx[W_P] = (ri * m_d - p.b_t * x[W_P] - m_p - m_ret) / j;
                dx[W_I] = ri * dx[W_P];
            }
            GearMode::Neutral { target, sync } => {
                let (rt, ts) = match (target, sync) {
                    (Some(t), Some(sig)) => (p.ratios[t], sig * p.sync_nm),
                    _ => (0.0, 0.0),
                };
                dx[W_I] = (m_d - ts - p.b_in * x[W_I]) / p.j_in;
                dx[W_P] = (rt * ts - p.b_t * x[W_P] - m_p - m_ret) / (p.j_out + p.j_p);
            }
        }
        dx[PHI_P] = dphi_p;
        let t_cage = p.i_f * m_p - p.b_f * w_cage;
        let (a, b) = (0.25 * p.j_f + p.j_s, 0.25 * p.j_f);
        let (rl, rr) = (0.5 * t_cage - m_dl, 0.5 * t_cage - m_dr);
        let det = a * a - b * b;
        dx[W_SL] = (a * rl - b * rr) / det;
        dx[W_SR] = (a * rr - b * rl) / det;
        dx[PHI_DL] = dphi_dl;
        dx[PHI_DR] = dphi_dr;
        if self.stopped {
            return e;
        }
        dx[W_WL] = (m_dl - r * f_l) / p.j_wd;
        dx[W_WR] = (m_dr - r * f_rr) / p.j_wd;
        dx[U_L] = deflection_rate(&p.tyre, x[U_L], vsl, v);
        dx[U_R] = deflection_rate(&p.tyre, x[U_R], vsr, v);
        dx[V] = (f_l + f_rr - f_a - f_r - f_g - self.u.brake_n) / p.body_mass();
        dx[X] = v;
        e
    }

    fn guard_list(
        &self,
        x: &State,
        g: &mut [f64; MAX_GUARDS],
        ids: &mut [Guard; MAX_GUARDS],
    ) -> usize {
        let e = self.eval(x);
        let mut n = 0;
        let mut push = |v: f64, id: Guard| {
            g[n] = v;
            ids[n] = id;
            n += 1;
        };
        match self.clutch {
            ClutchMode::Locked => {
                push(e.m_s - e.m_tr, Guard::ClutchBreak(1.0));
                push(e.m_s + e.m_tr, Guard::ClutchBreak(-1.0));
            }
            ClutchMode::Slipping(s) => push(s * (x[W_E] - x[W_C]), Guard::SlipZero),
        }
        let th1 = self.p.damper.theta1_rad;
        match self.stage {
            DamperStage::First => {
                push(th1 - x[PHI_C], Guard::StageUp(1.0));
                push(th1 + x[PHI_C], Guard::StageUp(-1.0));
            }
            DamperStage::Second(s) => push(s * x[PHI_C] - th1, Guard::StageDown),
        }
        if let GearMode::Neutral {
            target: Some(t),
            sync: Some(sig),
        } = self.gear
        {
            push(sig * (x[W_I] - self.p.ratios[t] * x[W_P]), Guard::Sync);
        }
        if self.p.lash_rad > 0.0 {
            let half = 0.5 * self.p.lash_rad;
            for (side, phi) in [(0, x[PHI_DL]), (1, x[PHI_DR])] {
                match self.lash[side] {
                    LashMode::Free => {
                        push(half - phi, Guard::LashContact(side, 1.0));
                        push(half + phi, Guard::LashContact(side, -1.0));
                    }
                    LashMode::Contact(s) => push(s * phi - half, Guard::LashFree(side)),
                }
            }
        }
        if !self.stopped {
            push(x[V], Guard::Stop);
        }
        n
    }

    fn stop(&mut self, x: &mut State) {
        self.stopped = true;
        self.events.stop += 1;
        for i in [W_WL, W_WR, V] {
            x[i] = 0.0;
        }
    }

    /// Brings the modes in line with the state after the inputs changed (control-step
    /// boundary): a locked clutch whose static capacity fell below its torque breaks away; a
    /// slip whose direction was overrun reverses; the damper stage and lash modes follow their
    /// angles; a truck rolling backwards stops; a stopped truck starts when the brake is off
    /// and the clutch-side force at the wheels exceeds grade and rolling resistance.
    pub fn settle_modes(&mut self, x: &mut State) {
        let e = self.eval(x);
        match self.clutch {
            ClutchMode::Locked => {
                if e.m_tr.abs() > e.m_s {
                    self.clutch = ClutchMode::Slipping(e.m_tr.signum());
                    self.events.clutch_break += 1;
                }
            }
            ClutchMode::Slipping(s) => {
                let d = x[W_E] - x[W_C];
                if s * d < 0.0 {
                    self.clutch = ClutchMode::Slipping(d.signum());
                }
            }
        }
        self.stage = stage_of(&self.p.damper, x[PHI_C]);
        if self.p.lash_rad > 0.0 {
            let half = 0.5 * self.p.lash_rad;
            for (side, i) in [(0, PHI_DL), (1, PHI_DR)] {
                self.lash[side] = if x[i].abs() <= half {
                    LashMode::Free
                } else {
                    LashMode::Contact(x[i].signum())
                };
            }
        }
        if !self.stopped && x[V] < 0.0 {
            self.stop(x);
        }
        if self.stopped && self.u.brake_n <= 0.0 && matches!(self.gear, GearMode::Engaged(_)) {
            // the held wheels release when the drive shafts' torque at the ground exceeds what
            // holds the truck back: grade and rolling resistance
            let f = (e.m_dl + e.m_dr) / self.p.wheel_radius_m;
            let tan_a = self.road.slope_at(x[X]);
            let cos_a = 1.0 / (1.0 + tan_a * tan_a).sqrt();
            let mg = self.p.mass_kg * self.p.gravity;
            let hold = mg * tan_a * cos_a + self.p.c_r1 * mg * cos_a;
            if f > hold {
                self.stopped = false;
                // as the brakes let go, each tyre takes over the torque of its shaft: its
                // deflection is set to carry M_dj/r_w (F_x(u) = µF_z·tanh(C_κ·u/σ/(µF_z))
                // inverted; no slip velocity at standstill)
                let t = &self.p.tyre;
                let fmax = t.mu * t.fz_n;
                for (i, m) in [(U_L, e.m_dl), (U_R, e.m_dr)] {
                    let q = (m / self.p.wheel_radius_m / fmax).clamp(-0.999, 0.999);
                    x[i] = t.relaxation_m * q.atanh() * fmax / t.slip_stiffness_n;
                }
            }
        }
    }

    /// Starts the synchroniser toward the neutral target (direction from the speed difference);
    /// engages at once if the speeds already match within 1e-9 rad/s.
    pub fn start_sync(&mut self, x: &mut State) {
        if let GearMode::Neutral {
            target: Some(t), ..
        } = self.gear
        {
            let d = x[W_I] - self.p.ratios[t] * x[W_P];
            if d.abs() < 1e-9 {
                self.gear = GearMode::Engaged(t);
                x[W_I] = self.p.ratios[t] * x[W_P];
                self.events.sync += 1;
            } else {
                self.gear = GearMode::Neutral {
                    target: Some(t),
                    sync: Some(d.signum()),
                };
            }
        }
    }

    /// Takes the gear out: neutral with target `target`, synchroniser off.
    pub fn to_neutral(&mut self, x: &mut State, target: Option<usize>) {
        if let GearMode::Engaged(g) = self.gear {
            x[W_I] = self.p.ratios[g] * x[W_P];
        }
        self.gear = GearMode::Neutral { target, sync: None };
    }
}

impl HybridSystem<N> for Plant {
    fn derivative(&self, _t: f64, x: &State) -> State {
        self.eval(x).dx
    }

    fn guards(&self, _t: f64, x: &State, g: &mut [f64; MAX_GUARDS]) -> usize {
        let mut ids = [Guard::Stop; MAX_GUARDS];
        self.guard_list(x, g, &mut ids)
    }

    fn on_event(&mut self, j: usize, _t: f64, x: &mut State) {
        let mut g = [0.0; MAX_GUARDS];
        let mut ids = [Guard::Stop; MAX_GUARDS];
        let n = self.guard_list(x, &mut g, &mut ids);
        if j >= n {
            return;
        }
        match ids[j] {
            Guard::ClutchBreak(s) => {
                x[W_C] = x[W_E];
                self.clutch = ClutchMode::Slipping(s);
                self.events.clutch_break += 1;
            }
            Guard::SlipZero => {
                self.events.clutch_zero += 1;
                let e = self.eval(x);
                if e.m_tr.abs() <= e.m_s && e.m_s > 0.0 {
                    let p = &self.p;
                    let w = (p.j_e * x[W_E] + p.j_c * x[W_C]) / (p.j_e + p.j_c);
                    x[W_E] = w;
                    x[W_C] = w;
                    self.clutch = ClutchMode::Locked;
                } else if let ClutchMode::Slipping(s) = self.clutch {
                    self.clutch = ClutchMode::Slipping(-s);
                }
            }
            Guard::StageUp(s) => {
                self.stage = DamperStage::Second(s);
                self.events.damper_stage += 1;
            }
            Guard::StageDown => {
                self.stage = DamperStage::First;
                self.events.damper_stage += 1;
            }
            Guard::Sync => {
                if let GearMode::Neutral {
                    target: Some(t), ..
                } = self.gear
                {
                    x[W_I] = self.p.ratios[t] * x[W_P];
                    self.gear = GearMode::Engaged(t);
                    self.events.sync += 1;
                }
            }
            Guard::LashContact(side, s) => {
                self.lash[side] = LashMode::Contact(s);
                self.events.lash += 1;
            }
            Guard::LashFree(side) => {
                self.lash[side] = LashMode::Free;
                self.events.lash += 1;
            }
            Guard::Stop => self.stop(x),
        }
    }
}
