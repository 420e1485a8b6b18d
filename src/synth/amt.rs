//! An automated manual transmission (AMT) controller for synthetic drives.
//!
//! Works on control steps of `dt` (inputs held per step). States:
//! - **standstill**: 1st gear, clutch open (`x = x_max`), engine governed to idle; rolling
//!   faster than 0.3 m/s (e.g. downhill with the brake released) it is **coasting** instead;
//! - **launch**: 1st gear; the clutch capacity rises linearly over
//!   [`AmtConfig::launch_engage_s`] to the driver's torque demand (at least
//!   [`AmtConfig::launch_min_torque_nm`]) and on at the same rate until the clutch locks; the
//!   engine torque is the clutch capacity plus a governor to [`AmtConfig::launch_rpm`]
//!   (a clutch-slip engagement); it is abandoned for coasting if 1st gear would put the engine
//!   above the upshift speed;
//! - **driving**: clutch engaged (`x = 0`), engine torque = demand fraction × full-load torque
//!   for a demand ≥ 0, and demand fraction × |minimum torque| (engine brake, negative torque)
//!   for a demand < 0; upshift above [`AmtConfig::upshift_rpm`], downshift below [`AmtConfig::downshift_rpm`] while
//!   the driver asks for torque; below it without torque demand, or in 1st gear near idle, the
//!   clutch opens (**coasting**, engine at idle) and re-engages in the highest gear whose engine
//!   speed is at least `downshift_rpm + 100 rpm` once the driver asks for torque again (a launch
//!   when even 1st gear is below that; below 0.3 m/s it is standstill again);
//! - **shift** `a → b`: torque ramp-down ([`AmtConfig::ramp_down_s`]), clutch open
//!   ([`AmtConfig::clutch_open_s`]), gear change ([`AmtConfig::gear_change_s`]; the gear input
//!   switches at its start, the synchroniser brings the clutch disc to the new input-shaft speed
//!   and the engine is governed to the new gear's speed), clutch close
//!   ([`AmtConfig::clutch_close_s`], engine still governed), torque ramp-up
//!   ([`AmtConfig::ramp_up_s`]). Every duration is rounded to whole control steps (at least one).
//!
//! The governor is proportional, `M = K (ω_target − ω_e)` with `K = 0.5 J_e / dt` (half a
//! dead-beat step on the engine inertia alone, so stable for the explicit per-step update);
//! every engine torque is clamped to the engine's `[M_min, M_max(ω_e)]`.

use crate::model::driveline::DrivelineParams;
use std::f64::consts::PI;

/// rpm → rad/s.
const RPM: f64 = PI / 30.0;

/// AMT settings; speeds in rpm (as shift maps are written), times in s.
#[derive(Debug, Clone, PartialEq)]
pub struct AmtConfig {
    /// Upshift when the engine speed exceeds this, rpm.
    pub upshift_rpm: f64,
    /// Downshift (or open the clutch) when the engine speed falls below this, rpm.
    pub downshift_rpm: f64,
    /// Engine idle speed, rpm.
    pub idle_rpm: f64,
    /// Engine speed held during a launch, rpm.
    pub launch_rpm: f64,
    /// Clutch capacity ramp time of a launch, s.
    pub launch_engage_s: f64,
    /// Smallest clutch capacity a launch ramps to, N·m.
    pub launch_min_torque_nm: f64,
    /// Torque ramp-down before a shift, s.
    pub ramp_down_s: f64,
    /// Clutch opening, s.
    pub clutch_open_s: f64,
    /// Gear change with the clutch open, s.
    pub gear_change_s: f64,
    /// Clutch closing, s.
    pub clutch_close_s: f64,
    /// Torque ramp-up after a shift, s.
    pub ramp_up_s: f64,
}

impl Default for AmtConfig {
    /// Up at 1500 rpm, down at 1000 rpm, idle 600 rpm, launch at 900 rpm over 1 s with at least
    /// 300 N·m; shift 0.2 + 0.1 + 0.2 + 0.2 + 0.2 = 0.9 s.
    fn default() -> Self {
        Self {
            upshift_rpm: 1500.0,
            downshift_rpm: 1000.0,
            idle_rpm: 600.0,
            launch_rpm: 900.0,
            launch_engage_s: 1.0,
            launch_min_torque_nm: 300.0,
            ramp_down_s: 0.2,
            clutch_open_s: 0.1,
            gear_change_s: 0.2,
            clutch_close_s: 0.2,
            ramp_up_s: 0.2,
        }
    }
}

/// Shift phase.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShiftPhase {
    /// Torque ramp-down.
    RampDown,
    /// Clutch opening.
    Open,
    /// Gear change, clutch open.
    Change,
    /// Clutch closing.
    Close,
    /// Torque ramp-up.
    RampUp,
}

/// AMT state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AmtState {
    /// Standing in 1st gear with the clutch open.
    Standstill,
    /// Slipping-clutch launch in 1st gear; `step` counts control steps since its start.
    Launch {
        /// Control steps since the launch started.
        step: usize,
    },
    /// Clutch engaged in `gear`.
    Driving {
        /// Engaged gear (1 = lowest).
        gear: usize,
    },
    /// Rolling with the clutch open, `gear` selected.
    Coasting {
        /// Selected gear.
        gear: usize,
    },
    /// Shifting from `from` to `to`.
    Shift {
        /// Gear before.
        from: usize,
        /// Gear after.
        to: usize,
        /// Current phase.
        phase: ShiftPhase,
        /// Control steps spent in the phase.
        step: usize,
    },
}

/// The AMT's outputs for one control step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AmtOutput {
    /// Gear input (1 = lowest).
    pub gear: usize,
    /// Clutch position, 0 = engaged … `x_max` = open.
    pub clutch_x: f64,
    /// Engine torque, N·m.
    pub engine_torque_nm: f64,
    /// The gear changed at the start of this step: the disc must be synchronised.
    pub synchronise: bool,
}

/// The AMT controller.
#[derive(Debug, Clone)]
pub struct Amt {
    cfg: AmtConfig,
    dt: f64,
    /// Current state.
    pub state: AmtState,
}

fn steps(d: f64, dt: f64) -> usize {
    ((d / dt).round() as usize).max(1)
}

impl Amt {
    /// An AMT at standstill with control step `dt_s`.
    pub fn new(cfg: AmtConfig, dt_s: f64) -> Self {
        Self {
            cfg,
            dt: dt_s,
            state: AmtState::Standstill,
        }
    }

    /// The selected gear.
    pub fn gear(&self) -> usize {
        match self.state {
            AmtState::Standstill | AmtState::Launch { .. } => 1,
            AmtState::Driving { gear } | AmtState::Coasting { gear } => gear,
            AmtState::Shift {
                from, to, phase, ..
            } => match phase {
                ShiftPhase::RampDown | ShiftPhase::Open => from,
                _ => to,
            },
        }
    }

    fn phase_steps(&self, ph: ShiftPhase) -> usize {
        let c = &self.cfg;
        steps(
            match ph {
                ShiftPhase::RampDown => c.ramp_down_s,
                ShiftPhase::Open => c.clutch_open_s,
                ShiftPhase::Change => c.gear_change_s,
                ShiftPhase::Close => c.clutch_close_s,
                ShiftPhase::RampUp => c.ramp_up_s,
            },
            self.dt,
        )
    }

    /// Decides the step: `demand` is the driver's torque fraction (−1…1; < 0 engine brake, see
    /// [`super::driver::DriverCommand::torque_fraction`]), `w_e` the engine speed,
    /// `w_w` the wheel speed (rad/s), `locked` whether the clutch is locked at the step start.
    pub fn step(
        &mut self,
        p: &DrivelineParams,
        ratios: &[f64],
        demand: f64,
        w_e: f64,
        w_w: f64,
        locked: bool,
    ) -> AmtOutput {
        let c = self.cfg.clone();
        let n = ratios.len();
        let x_open = p.clutch_x_max;
        let k_gov = 0.5 * p.j_e_kg_m2 / self.dt;
        let clamp = |m: f64, w: f64| m.max(p.engine_min_torque_nm).min(p.engine_max_torque(w));
        let gov = |target: f64| k_gov * (target - w_e);
        let w_gear = |g: usize| ratios[g - 1] * p.final_drive_ratio * w_w;
        // the driver's demand as an engine torque: full load above zero, engine brake below
        let demanded = if demand >= 0.0 {
            demand * p.engine_max_torque(w_e)
        } else {
            -demand * p.engine_min_torque_nm.min(0.0)
        };
        let rpm = w_e / RPM;
        // state transitions decided at the step start
        self.state = match self.state {
            AmtState::Standstill if w_w * p.wheel_radius_m > 0.3 => AmtState::Coasting { gear: 1 },
            AmtState::Standstill if demand > 0.0 => AmtState::Launch { step: 0 },
            AmtState::Launch { .. } if w_gear(1) > c.upshift_rpm * RPM => {
                AmtState::Coasting { gear: 1 }
            }
            AmtState::Launch { step } if locked && step > 0 => AmtState::Driving { gear: 1 },
            AmtState::Launch { .. } if demand <= 0.0 && w_w * p.wheel_radius_m < 0.3 => {
                AmtState::Standstill
            }
            AmtState::Launch { step } => AmtState::Launch { step: step + 1 },
            AmtState::Driving { gear } => {
                if rpm > c.upshift_rpm && gear < n {
                    AmtState::Shift {
                        from: gear,
                        to: gear + 1,
                        phase: ShiftPhase::RampDown,
                        step: 0,
                    }
                } else if gear == 1 && rpm < c.idle_rpm + 150.0 && demand <= 0.0 {
                    AmtState::Coasting { gear }
                } else if rpm < c.downshift_rpm && gear > 1 {
                    if demand > 0.0 {
                        AmtState::Shift {
                            from: gear,
                            to: gear - 1,
                            phase: ShiftPhase::RampDown,
                            step: 0,
                        }
                    } else {
                        AmtState::Coasting { gear }
                    }
                } else if gear == 1 && rpm < c.idle_rpm {
                    // stalling in 1st under load: slip the clutch again
                    AmtState::Launch { step: 0 }
                } else {
                    AmtState::Driving { gear }
                }
            }
            AmtState::Coasting { gear } => {
                if w_w * p.wheel_radius_m < 0.3 {
                    AmtState::Standstill
                } else if demand > 0.0 {
                    let g = (1..=n)
                        .rev()
                        .find(|&g| w_gear(g) >= (c.downshift_rpm + 100.0) * RPM);
                    match g {
                        Some(g) => AmtState::Shift {
                            from: gear,
                            to: g,
                            phase: ShiftPhase::Change,
                            step: 0,
                        },
                        None => AmtState::Launch { step: 0 },
                    }
                } else {
                    AmtState::Coasting { gear }
                }
            }
            AmtState::Shift {
                from,
                to,
                phase,
                step,
            } => {
                if step + 1 < self.phase_steps(phase) {
                    AmtState::Shift {
                        from,
                        to,
                        phase,
                        step: step + 1,
                    }
                } else {
                    let next = match phase {
                        ShiftPhase::RampDown => Some(ShiftPhase::Open),
                        ShiftPhase::Open => Some(ShiftPhase::Change),
                        ShiftPhase::Change => Some(ShiftPhase::Close),
                        ShiftPhase::Close => Some(ShiftPhase::RampUp),
                        ShiftPhase::RampUp => None,
                    };
                    match next {
                        Some(phase) => AmtState::Shift {
                            from,
                            to,
                            phase,
                            step: 0,
                        },
                        None => AmtState::Driving { gear: to },
                    }
                }
            }
            s => s,
        };
        let gear = self.gear();
        let (clutch_x, m, sync) = match self.state {
            AmtState::Standstill | AmtState::Coasting { .. } => {
                (x_open, gov(c.idle_rpm * RPM), false)
            }
            AmtState::Launch { step } => {
                let target =
                    (demand * p.engine_max_torque(c.launch_rpm * RPM)).max(c.launch_min_torque_nm);
                let rate = target / c.launch_engage_s.max(self.dt);
                let cap = (rate * (step + 1) as f64 * self.dt).min(p.clutch_max_torque_nm);
                let x = p.clutch_position_for(cap);
                (x, p.clutch_capacity(x) + gov(c.launch_rpm * RPM), false)
            }
            AmtState::Driving { .. } => (0.0, demanded, false),
            AmtState::Shift {
                to, phase, step, ..
            } => {
                let frac = (step + 1) as f64 / self.phase_steps(phase) as f64;
                match phase {
                    ShiftPhase::RampDown => (0.0, demanded * (1.0 - frac), false),
                    ShiftPhase::Open => (x_open * frac, 0.0, false),
                    ShiftPhase::Change => (x_open, gov(w_gear(to)), step == 0),
                    ShiftPhase::Close => (x_open * (1.0 - frac), gov(w_gear(to)), false),
                    ShiftPhase::RampUp => (0.0, demanded * frac, false),
                }
            }
        };
        AmtOutput {
            gear,
            clutch_x,
            engine_torque_nm: clamp(m, w_e),
            synchronise: sync,
        }
    }
}
