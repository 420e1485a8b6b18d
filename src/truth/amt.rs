//! Automated manual transmission (AMT) and engine-speed control of the truth plant.
//!
//! # Conventions
//! Gear indices are 0-based internally (index 0 = 1st gear); the CAN gear is index + 1, and 0 in
//! neutral. Torques are net engine torques in N·m (the ECU adds friction, [`super::engine`]);
//! clutch travel 0 = engaged, 1 = open. Control runs every [`super::drive::CONTROL_DT_S`].
//!
//! # Behaviour
//! - **Shift schedule by input-shaft speed** `ω_in = i_t·ω_p` (the output-shaft sensor; equal to
//!   the engine speed while the clutch holds, and with the wheels while a worn clutch slips):
//!   upshift when `ω_in > 1250 rpm + 400 rpm·pedal` and the next gear keeps `ω_in ≥ 950 rpm`;
//!   downshift when `ω_in < 900 rpm + 250 rpm·pedal` (one gear, two if one is not enough to
//!   reach 1100 rpm); at least 3 s between shifts (no hunting). `pedal` is the driver's demand
//!   as a fraction of full load.
//! - **Shift sequence**: torque ramp-down to 0 in 0.25 s → clutch open in 0.15 s → **neutral**
//!   (gear out; CAN gear 0): selector travel 0.3 s, then the synchroniser brings the input
//!   shaft to the new gear's speed (the plant engages at the speed match, a located event) while
//!   the engine is rev-matched to it; neutral so lasts 0.3 s plus the synchronisation (≤ 0.3 s
//!   for the largest speed step) → clutch close in 0.3 s → torque ramp-up in 0.3 s.
//! - **Launch** from standstill in the start gear (1st on grades above 3 %, else 2nd): the
//!   engine is governed to 1000 rpm; the clutch travel is set for a clutch torque that rises at
//!   2000 N·m/s up to the driver's demand, computed with the capacity the AMT believes (the
//!   vehicle file's at first); when the slip speed is below 10 rad/s the clutch closes fully in
//!   0.3 s.
//! - **Clutch-capacity adaptation** (as AMT clutch controllers learn their clutch's torque
//!   characteristic): during a launch, once the requested clutch torque has stood at the demand
//!   for 0.3 s while the clutch slips (> 5 rad/s), the torque the clutch really carries is the
//!   engine's net torque less its inertia torque; the believed capacity moves toward
//!   `believed·carried/requested` with a 0.5 s time constant (bounds 0.3–1.2 × the file's) and
//!   is kept for later launches. A worn clutch is so closed further until it carries the launch
//!   torque (a truck on a steep grade then gets away); fully engaged (pedal released, travel 0)
//!   it still slips at full load, since its capacity is below the engine's torque.
//! - **Stopping**: when the input shaft falls below 720 rpm in the start gear (or below 3 m/s
//!   while braking) the clutch opens; at standstill the start gear is selected through neutral.
//!   A launch never runs in a gear above the start gear from below 1 m/s: the clutch opens and
//!   the start gear is selected.
//! - **Traction limit**: the net torque demand is limited per gear to
//!   `0.7·µ·F_z,axle·r_w/(i_t·i_f)` with the nominal axle load and µ = 0.8 (a gear-dependent
//!   torque limit as AMT ECUs apply against wheel spin and driveline overload).
//! - **Idle governor**: the ECU never demands less than `K_P·(ω_idle − ω_e)`.

use super::clutch::travel_for;
use super::params::TruckParams;
use super::plant::GearMode;

const RPM: f64 = std::f64::consts::PI / 30.0;

/// AMT phase.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    /// Clutch open, vehicle rolling or standing; waits for the driver.
    Open,
    /// Launching (clutch slip control).
    Launch,
    /// Driving in gear, clutch closed.
    Driving,
    /// Torque ramp-down before a shift to the target gear.
    TorqueDown(usize),
    /// Clutch opening before a shift.
    ClutchOpen(usize),
    /// Neutral toward the target gear.
    Neutral(usize),
    /// Clutch closing after a shift.
    ClutchClose,
    /// Torque ramp-up after a shift.
    TorqueUp,
}

/// What the AMT asks of the plant's gearbox at this control step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GearAction {
    /// Nothing.
    None,
    /// Take the gear out toward a target gear index.
    ToNeutral(usize),
    /// Start the synchroniser.
    StartSync,
}

/// What the AMT reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AmtInput {
    /// Time, s.
    pub t_s: f64,
    /// Driver's net engine torque demand, N·m (may be negative: no fuel).
    pub demand_nm: f64,
    /// Driver's demand as a fraction of full load at the current speed, 0..1.
    pub pedal: f64,
    /// Driver is braking.
    pub braking: bool,
    /// Engine speed, rad/s.
    pub w_e: f64,
    /// Gearbox output speed, rad/s.
    pub w_p: f64,
    /// Vehicle speed, m/s.
    pub v: f64,
    /// Road slope at the truck, tan α.
    pub slope: f64,
    /// The plant's gearbox mode.
    pub gear: GearMode,
    /// The vehicle stands, held by the brakes.
    pub stopped: bool,
}

/// What the AMT commands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AmtOutput {
    /// Net engine torque demand to the ECU, N·m.
    pub engine_nm: f64,
    /// Clutch actuator travel, 0..1.
    pub clutch_x: f64,
    /// Gearbox action.
    pub action: GearAction,
}

/// The AMT controller.
#[derive(Debug, Clone)]
pub struct Amt {
    nominal: TruckParams,
    ratios: Vec<f64>,
    i_f: f64,
    r_w: f64,
    clutch_believed_nm: f64,
    traction_nm: f64,
    kp: f64,
    ki: f64,
    idle: f64,
    /// Current phase.
    pub phase: Phase,
    t_phase: f64,
    last_shift_t: f64,
    integ: f64,
    x: f64,
    m_hold: f64,
    sync_started: bool,
    launch_t: f64,
    last_engine: f64,
    last_w_e: f64,
}

impl Amt {
    /// An AMT for the nominal truck `nominal` (the controller knows nominal values only).
    pub fn new(nominal: &TruckParams) -> Self {
        Self {
            nominal: nominal.clone(),
            ratios: nominal.ratios.clone(),
            i_f: nominal.i_f,
            r_w: nominal.wheel_radius_m,
            clutch_believed_nm: nominal.clutch_nominal_nm,
            traction_nm: 0.7 * nominal.tyre.mu * 2.0 * nominal.tyre.fz_n * nominal.wheel_radius_m,
            kp: nominal.engine.gov_kp,
            ki: nominal.engine.gov_ki,
            idle: nominal.engine.idle_rad_s,
            phase: Phase::Open,
            t_phase: 0.0,
            last_shift_t: -10.0,
            integ: 0.0,
            x: 1.0,
            m_hold: 0.0,
            sync_started: false,
            launch_t: 0.0,
            last_engine: 0.0,
            last_w_e: nominal.engine.idle_rad_s,
        }
    }

    /// Start gear index for slope `s`.
    pub fn start_gear(&self, s: f64) -> usize {
        if s > 0.03 || self.ratios.len() < 2 {
            0
        } else {
            1
        }
    }

    fn torque_limit(&self, g: usize) -> f64 {
        self.traction_nm / (self.ratios[g] * self.i_f)
    }

    fn enter(&mut self, p: Phase, t: f64) {
        self.phase = p;
        self.t_phase = t;
        self.integ = 0.0;
        self.sync_started = false;
    }

    /// Engine speed governor toward `target`, with feed-forward `ff`, N·m.
    fn govern(&mut self, target: f64, w_e: f64, ff: f64, dt: f64) -> f64 {
        let e = target - w_e;
        self.integ = (self.integ + e * dt).clamp(-5.0, 5.0);
        ff + self.kp * e + self.ki * self.integ
    }

    /// One control step of length `dt`.
    pub fn step(&mut self, i: &AmtInput, dt: f64) -> AmtOutput {
        let t = i.t_s;
        let tp = t - self.t_phase;
        let mut action = GearAction::None;
        let engaged = match i.gear {
            GearMode::Engaged(g) => Some(g),
            GearMode::Neutral { .. } => None,
        };
        let engine: f64;
        match self.phase {
            Phase::Open => {
                self.x = (self.x + dt / 0.1).min(1.0);
                engine = self.govern(self.idle, i.w_e, 0.0, dt);
                let want = self.start_gear(i.slope);
                let go = i.demand_nm > 0.0 && !i.braking;
                if i.stopped || i.v < 1.0 {
                    if engaged != Some(want) {
                        if !matches!(i.gear, GearMode::Neutral { target: Some(w), .. } if w == want)
                        {
                            action = GearAction::ToNeutral(want);
                            self.enter(Phase::Neutral(want), t);
                        }
                    } else if go {
                        self.enter(Phase::Launch, t);
                        self.launch_t = t;
                    }
                } else if go {
                    let g = self.gear_for_speed(i.w_p, want);
                    if engaged == Some(g) {
                        self.enter(Phase::Launch, t);
                        self.launch_t = t;
                    } else {
                        action = GearAction::ToNeutral(g);
                        self.enter(Phase::Neutral(g), t);
                    }
                }
            }
            Phase::Launch => {
                let Some(g) = engaged else {
                    self.enter(Phase::Open, t);
                    return self.out(0.0, action);
                };
                if g > self.start_gear(i.slope) && (i.stopped || i.v < 1.0) {
                    // no launch in a gear above the start gear from (near) standstill: open, and
                    // the start gear is selected through neutral
                    self.enter(Phase::Open, t);
                    let idle = self.govern(self.idle, i.w_e, 0.0, dt);
                    return self.out(idle, action);
                }
                let dem = i.demand_nm.min(self.torque_limit(g)).max(0.0);
                let m_cl = dem.min(2000.0 * (t - self.launch_t));
                let slip = i.w_e - self.ratios[g] * i.w_p;
                self.adapt_capacity(m_cl, dem, slip, i.w_e, t, dt);
                let target_x = travel_for(&self.nominal, self.clutch_believed_nm, m_cl);
                self.x = target_x;
                engine = self.govern(1000.0 * RPM, i.w_e, m_cl, dt);
                if slip.abs() < 10.0 && i.v > 0.3 {
                    self.enter(Phase::ClutchClose, t);
                    self.m_hold = engine;
                }
                if i.braking || i.demand_nm <= 0.0 {
                    self.enter(Phase::Open, t);
                }
            }
            Phase::Driving => {
                self.x = 0.0;
                let Some(g) = engaged else {
                    self.enter(Phase::Open, t);
                    return self.out(0.0, action);
                };
                engine = i.demand_nm.min(self.torque_limit(g));
                let start = self.start_gear(i.slope);
                // the schedule reads the input-shaft speed (from the output-shaft sensor), which
                // equals the engine speed while the clutch holds and stays with the wheels when
                // a worn clutch slips
                let w_in = self.ratios[g] * i.w_p;
                if w_in < 720.0 * RPM && (g <= start || i.v < 3.0) || (i.braking && i.v < 3.0) {
                    self.enter(Phase::Open, t);
                } else if t - self.last_shift_t > 3.0 {
                    let up = (1250.0 + 400.0 * i.pedal) * RPM;
                    let dn = (900.0 + 250.0 * i.pedal) * RPM;
                    if w_in > up
                        && g + 1 < self.ratios.len()
                        && w_in * self.ratios[g + 1] / self.ratios[g] >= 950.0 * RPM
                    {
                        self.begin_shift(g + 1, t, engine);
                    } else if w_in < dn && g > 0 {
                        let mut ng = g - 1;
                        if ng > 0 && w_in * self.ratios[ng] / self.ratios[g] < 1100.0 * RPM {
                            ng -= 1;
                        }
                        self.begin_shift(ng, t, engine);
                    }
                }
            }
            Phase::TorqueDown(ng) => {
                engine = self.m_hold * (1.0 - tp / 0.25).max(0.0);
                if tp >= 0.25 {
                    self.enter(Phase::ClutchOpen(ng), t);
                }
            }
            Phase::ClutchOpen(ng) => {
                self.x = (tp / 0.15).min(1.0);
                engine = 0.0;
                if tp >= 0.15 {
                    action = GearAction::ToNeutral(ng);
                    self.enter(Phase::Neutral(ng), t);
                }
            }
            Phase::Neutral(ng) => {
                self.x = 1.0;
                let target_w = self.ratios[ng] * i.w_p;
                engine = if i.stopped || i.v < 1.0 {
                    self.govern(self.idle, i.w_e, 0.0, dt)
                } else {
                    self.govern(target_w.max(self.idle), i.w_e, 0.0, dt)
                };
                if tp >= 0.3 && !self.sync_started {
                    action = GearAction::StartSync;
                    self.sync_started = true;
                }
                if engaged == Some(ng) {
                    self.last_shift_t = t;
                    if i.stopped || i.v < 1.0 {
                        self.enter(Phase::Open, t);
                    } else if target_w < 900.0 * RPM {
                        self.enter(Phase::Launch, t);
                        self.launch_t = t;
                    } else {
                        self.enter(Phase::ClutchClose, t);
                        self.m_hold = 0.0;
                    }
                }
            }
            Phase::ClutchClose => {
                self.x = (1.0 - tp / 0.3).max(0.0);
                let g = engaged.unwrap_or(0);
                let target_w = self.ratios[g] * i.w_p;
                engine = if self.x > 0.0 {
                    self.govern(target_w, i.w_e, self.m_hold, dt)
                } else {
                    self.m_hold
                };
                if tp >= 0.3 {
                    self.m_hold = engine.max(0.0);
                    self.enter(Phase::TorqueUp, t);
                }
            }
            Phase::TorqueUp => {
                self.x = 0.0;
                let g = engaged.unwrap_or(0);
                let dem = i.demand_nm.min(self.torque_limit(g));
                let u = (tp / 0.3).min(1.0);
                engine = self.m_hold + u * (dem - self.m_hold);
                if tp >= 0.3 {
                    self.enter(Phase::Driving, t);
                }
            }
        }
        let idle = self.kp * (self.idle - i.w_e);
        let engine = engine.max(idle);
        self.last_engine = engine;
        self.last_w_e = i.w_e;
        self.out(engine, action)
    }

    /// Clutch-capacity adaptation during a launch (module doc): while the clutch slips at the
    /// governed engine speed and the requested clutch torque `m_cl` has stood at the demand `dem`
    /// for 0.3 s, the clutch carries what the engine gives less its inertia torque,
    /// `M_obs = M_e,prev − J_e·Δω_e/Δt`; the believed capacity follows `M_obs/m_cl` of itself
    /// with a 0.5 s time constant, bounded to 0.3–1.2 × the vehicle file's capacity.
    fn adapt_capacity(&mut self, m_cl: f64, dem: f64, slip: f64, w_e: f64, t: f64, dt: f64) {
        let settled = t - self.launch_t >= dem / 2000.0 + 0.3;
        if !(settled && slip > 5.0 && m_cl > 100.0) {
            return;
        }
        let m_obs = self.last_engine - self.nominal.j_e * (w_e - self.last_w_e) / dt;
        let ratio = (m_obs / m_cl).clamp(0.5, 1.5);
        let nom = self.nominal.clutch_nominal_nm;
        self.clutch_believed_nm = (self.clutch_believed_nm
            * (1.0 + (ratio - 1.0) * (dt / 0.5).min(1.0)))
        .clamp(0.3 * nom, 1.2 * nom);
    }

    /// The clutch capacity the AMT currently believes, N·m (the vehicle file's until a launch
    /// teaches it otherwise).
    pub fn clutch_believed_nm(&self) -> f64 {
        self.clutch_believed_nm
    }

    fn out(&self, engine_nm: f64, action: GearAction) -> AmtOutput {
        AmtOutput {
            engine_nm,
            clutch_x: self.x,
            action,
        }
    }

    fn begin_shift(&mut self, ng: usize, t: f64, engine: f64) {
        self.m_hold = engine.max(0.0);
        self.last_shift_t = t;
        self.enter(Phase::TorqueDown(ng), t);
    }

    /// The highest gear that keeps the engine at or above 1100 rpm at output speed `w_p`, not
    /// below `lowest`.
    fn gear_for_speed(&self, w_p: f64, lowest: usize) -> usize {
        let mut best = lowest;
        for (g, r) in self.ratios.iter().enumerate().skip(lowest) {
            if r * w_p >= 1100.0 * RPM {
                best = g;
            }
        }
        best
    }

    /// Wheel radius the AMT assumes, m.
    pub fn wheel_radius(&self) -> f64 {
        self.r_w
    }
}
