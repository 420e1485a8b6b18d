//! The driveline model of one recording extended by the catalogue's longitudinal effects
//! (docs/diagnosis/method.md, step 3; docs/models/driveline.md; [`super::extended`]).
//!
//! # Outputs
//! [`LongitudinalModel::simulate`]: vehicle and engine speed on the log's rows, from windows
//! re-initialised at the measured state ([`crate::sim::validate`]) every 20 s and after every
//! stretch whose inputs the recording does not determine ([`window_starts`]): open-loop drift cannot
//! accumulate over more than one window. A window starts at the recorded vehicle speed
//! interpolated at its start. (A least-squares line through the second of samples before the
//! start would average the sensor's noise out of the start state, but while the truck
//! accelerates through the gears it puts the windows 0.10–0.13 m/s off, enough to make every
//! clean drive of `fleetdyn prove --seed 1` `unexplained`.) A window starts with the
//! clutch locked when it reads closed and the truck moves, unless the measured engine speed
//! runs more than [`SLIP_START_MIN_RAD_S`] above the locked driveline's (a clutch slipping
//! under load); then, as with an open or actuated clutch, it starts slipping from the measured
//! engine speed. A locked start takes its engine side from the measured engine speed too, the
//! wheel from the vehicle speed, so that it starts in the phase of a running shuffle
//! (`LongitudinalModel::measured_twist_rate`). The driven tyres slip
//! ([`super::tyre_slip`]): the engine speed is reported as the model's times `1 + κ`, `κ` from
//! the model's drive-shaft torque and the drive's fitted slip stiffness, and a window's engine
//! side starts from the measured engine speed divided by `1 + κ`.
//!
//! Units: vehicle speed m/s, engine speed rad/s, torque N·m, times s.

use super::capacity_reach::CapacityReach;
use super::effect_parameters::Theta;
use super::extended_error::ExtendedError;
use super::kept::Kept;
use super::model_inputs::{corrected_columns, filled, INPUT_EFFECTS};
use super::simulation_windows::{fine_spans, stepped_pieces, window_starts, FINE_STEP_S};
use super::slope_grid::{cured_slope, SlopeGrid};
use crate::model::driveline::DrivelineParams;
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::signal::{interp_linear, LinearResampler};
use crate::sim::fast::{FastDriveline, Resume};
use crate::sim::hybrid::{steady_state_locked, ClutchMode};
use crate::sim::recorded::{scenario_from_view, RecordedScenario};
use crate::table::{DriveLog, LogView};
use rayon::prelude::*;
use std::sync::{Arc, OnceLock};

/// A sample of a window: time, s; vehicle speed, m/s, and engine speed, rad/s.
type Sample = (f64, [f64; 2]);

/// Windows simulated in parallel at a time ([`LongitudinalModel::simulate_windows`]): a batch's
/// samples are held until they go onto the rows (32 windows of 20 s at 1 ms: about 15 MB).
const WINDOW_BATCH: usize = 32;

/// Settings of the windowed longitudinal simulation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LongitudinalConfig {
    /// Re-initialisation window, s.
    pub window_s: f64,
    /// Integration step, s, outside the spans about the torque reversals ([`fine_spans`], at
    /// [`FINE_STEP_S`]), and outside the drive-shaft lash's gap and its approach
    /// ([`FastDriveline::with_gap_substeps`]: substeps of [`FINE_STEP_S`] there). The
    /// default is 5 ms. Why not 10 ms (the recording's row spacing): the exponential integrator
    /// ([`FastDriveline`]) holds the inputs and the road force over a step and detects clutch
    /// mode switches at step ends. At 10 ms three drives without an effect of the
    /// drawn-driving proof (`fleetdyn prove --seed 1`, `--seed 1001`) are named a 2–3 % weaker
    /// clutch or (with the lash integrated at 1 ms on the whole drive) a lash of 5·10⁻⁵ rad,
    /// which the step alone made fit better; at 5 ms none of
    /// the 84 no-effect drives of seven seeds is, and 2 ms does the same on seed 1. 1 ms
    /// everywhere costs about 110 s per drive-hour on a proof drive (9.9 s against 3.9 s at
    /// 10 ms; the budget is 60 s); 5 ms costs 4 % more than 10 ms (the seven seeds' median times
    /// per drive-hour).
    pub dt_s: f64,
    /// Samples below this measured speed do not count, m/s.
    pub min_speed_mps: f64,
    /// A locked window start takes its engine side from the measured engine speed (the
    /// module documentation, "Outputs"); `false` starts it at the locked engine
    /// speed of the recorded vehicle speed (the model before that change, kept to show what
    /// it changes).
    pub measured_engine_side: bool,
    /// The spans about the torque reversals integrate at [`FINE_STEP_S`] ([`fine_spans`]);
    /// `false` integrates them at `dt_s` too (kept to show what the fine spans change).
    pub fine_at_reversals: bool,
    /// The driven tyres' slip is part of the model, its stiffness estimated on the drive
    /// ([`super::tyre_slip`]); `false` keeps the wheels at the vehicle's speed.
    pub tyre_slip: bool,
}

impl Default for LongitudinalConfig {
    /// 20 s windows (long enough for drag and mass to show as speed drift, short enough that
    /// the slope sensor's quantisation bias cannot build up), 5 ms steps, 1 m/s, the engine
    /// side of a locked start from the measured engine speed, the tyres' slip modelled.
    fn default() -> Self {
        Self {
            window_s: 20.0,
            dt_s: 0.005,
            min_speed_mps: 1.0,
            measured_engine_side: true,
            fine_at_reversals: true,
            tyre_slip: true,
        }
    }
}

/// Simulated longitudinal outputs on the log's rows.
#[derive(Debug, Clone, PartialEq)]
pub struct LongitudinalOutputs {
    /// Vehicle speed, m/s.
    pub vehicle_speed: Vec<f64>,
    /// Engine speed, rad/s.
    pub engine_speed: Vec<f64>,
}

/// The columns a simulation reads off the (corrected) recording as its inputs
/// ([`scenario_from_view`] and the tyres' slip, [`super::tyre_slip::slip_of_rows`]).
pub const INPUT_COLUMNS: [&str; 6] = [
    "road_slope",
    "engine_torque",
    "gear",
    "clutch_position",
    "brake_force",
    "retarder_torque",
];

/// The driveline model of one recording, extended by the catalogue's longitudinal effects.
#[derive(Debug, Clone)]
pub struct LongitudinalModel<'a> {
    log: &'a DriveLog,
    nominal_truth: &'a ExtendedVehicle,
    ratios: &'a [f64],
    nominal: Theta,
    /// The recorded slope's grid, built when a cure first asks for it ([`cured_slope`]).
    slope_grid: OnceLock<Option<SlopeGrid>>,
    t: Vec<f64>,
    starts: Vec<f64>,
    /// Spans integrated at [`FINE_STEP_S`] (the torque reversals'), s, sorted and disjoint.
    fine: Vec<(f64, f64)>,
    v_meas: Vec<f64>,
    w_meas: Vec<f64>,
    slip: super::tyre_slip::SlipEstimate,
    cfg: LongitudinalConfig,
    /// The inputs as read at the nominal sensor parameters, built by the first simulation
    /// that reads them ([`ReadInputs`]); `None` when building them failed (each
    /// simulation then builds its own and reports the error).
    nominal_inputs: OnceLock<Option<Arc<ReadInputs>>>,
    /// Inputs read at other sensor parameters, with those parameters' bits ([`Kept`]): the
    /// explain step's base departs from the nominal ones by the fitted sensor effects, and its
    /// probes of the other effects read what it reads.
    sensor_inputs: Kept<([u64; INPUT_EFFECTS.len()], Arc<ReadInputs>)>,
    /// Simulations at other clutch capacities, whose locked windows later ones reuse
    /// ([`CapacityReach`]).
    reach: CapacityReach,
}

/// What a simulation reads off the recording besides the plant: the inputs as a scenario and
/// the driven tyres' slip on every row. Both depend on the parameters only through the sensor
/// effects ([`INPUT_EFFECTS`], which correct the recorded inputs,
/// [`super::model_inputs::corrected_log`]), the final drive and wheel radius, the engine's
/// torque lag (`engine_torque_lag_s`), which no catalogue effect changes, and, when the vehicle
/// states a tyre warm-up, the cold tyres' extra rolling resistance, which follows the mass and
/// the rolling-resistance coefficients ([`crate::sim::recorded`]); so every simulation at the
/// nominal sensor parameters and that plant — most of a diagnosis's — reads the same ones, built
/// once, and every simulation at the explain step's base sensor parameters reads the base's, kept
/// ([`LongitudinalModel::read_inputs`], [`super::kept::Kept`]).
#[derive(Debug)]
struct ReadInputs {
    rec: RecordedScenario,
    kappa: Vec<f64>,
    /// The plant's parameters they were built with ([`inputs_key`]).
    key: [u64; 8],
}

/// The bits of the plant's parameters the read inputs depend on: the final drive ratio and
/// wheel radius, and with a tyre warm-up its cold excess, distance, mass, gravity and
/// rolling-resistance coefficients (zeros without one).
fn inputs_key(p: &DrivelineParams) -> [u64; 8] {
    let warm = crate::model::tyre_warm_up::TyreWarmUp::of(p).is_some();
    let w = |x: f64| if warm { x.to_bits() } else { 0 };
    [
        p.final_drive_ratio.to_bits(),
        p.wheel_radius_m.to_bits(),
        w(p.tyre_cold_excess),
        w(p.tyre_warm_up_distance_m),
        w(p.mass_kg),
        w(p.gravity_m_per_s2),
        w(p.c_r1),
        w(p.c_r2_s_per_m),
    ]
}

/// Engine speed above the locked driveline's at which a window with the clutch closed starts
/// slipping instead of locked ([`LongitudinalModel::simulate`]), rad/s (150 rpm). Why that margin:
/// right after a clutch closes the first-gear shuffle swings the engine against the wheels by up to
/// ~100 rpm (docs/diagnosis/events.md), and a window that starts slipping on such a swing locks
/// again within milliseconds under the clutch's full capacity, whereas a clutch that cannot carry
/// the engine torque (`clutch_slip` at full load: measured 100–390 rpm for tens of seconds on the
/// proof) keeps slipping — which a locked start never reproduces.
pub const SLIP_START_MIN_RAD_S: f64 = 150.0 * std::f64::consts::PI / 30.0;

impl<'a> LongitudinalModel<'a> {
    /// Binds a recording (vehicle speed, engine speed, engine torque and gear needed), the
    /// nominal vehicle and its gear ratios. `nominal` are the nominal parameters
    /// ([`Theta::nominal`]).
    ///
    /// # Errors
    /// [`ExtendedError::Missing`] for a missing speed column.
    pub fn new(
        log: &'a DriveLog,
        nominal_truth: &'a ExtendedVehicle,
        ratios: &'a [f64],
        nominal: Theta,
        cfg: LongitudinalConfig,
    ) -> Result<Self, ExtendedError> {
        let v_meas = filled(log, "vehicle_speed")?;
        let w_meas = filled(log, "engine_speed")?;
        let t: Vec<f64> = log.seconds_from_start();
        let slip = if cfg.tyre_slip {
            super::tyre_slip::estimate(log, &nominal_truth.driveline, ratios)
        } else {
            super::tyre_slip::SlipEstimate::RIGID
        };
        Ok(Self {
            log,
            nominal_truth,
            ratios,
            nominal,
            slope_grid: OnceLock::new(),
            starts: window_starts(log, cfg.window_s),
            fine: fine_spans(log),
            t,
            v_meas,
            w_meas,
            slip,
            cfg,
            nominal_inputs: OnceLock::new(),
            sensor_inputs: Kept::for_rows(log.len()),
            reach: CapacityReach::new(log.len()),
        })
    }

    /// The scenario and tyre slip `theta` reads ([`ReadInputs`]), with the plant's
    /// driveline `p`: the nominal ones, built once, at the nominal sensor parameters; at others
    /// the ones kept for the same sensor parameters and driveline key ([`inputs_key`]), else
    /// built for `theta` (and kept).
    fn read_inputs(
        &self,
        theta: &Theta,
        p: &DrivelineParams,
    ) -> Result<Arc<ReadInputs>, ExtendedError> {
        let sensors = INPUT_EFFECTS.map(|e| theta.get(e).to_bits());
        let nominal_sensors = sensors == INPUT_EFFECTS.map(|e| self.nominal.get(e).to_bits());
        let key = inputs_key(p);
        if nominal_sensors {
            let cached = self
                .nominal_inputs
                .get_or_init(|| self.build_inputs(&self.nominal, p).ok().map(Arc::new));
            if let Some(c) = cached.as_ref().filter(|c| c.key == key) {
                return Ok(Arc::clone(c));
            }
        } else if let Some(c) = self
            .sensor_inputs
            .find(|(bits, c)| (*bits == sensors && c.key == key).then(|| Arc::clone(c)))
        {
            return Ok(c);
        }
        let built = Arc::new(self.build_inputs(theta, p)?);
        if !nominal_sensors {
            self.sensor_inputs.keep((sensors, Arc::clone(&built)));
        }
        Ok(built)
    }

    /// The scenario and tyre slip of the recording with `theta`'s sensor effects undone.
    fn build_inputs(
        &self,
        theta: &Theta,
        p: &DrivelineParams,
    ) -> Result<ReadInputs, ExtendedError> {
        let cured = cured_slope(self.log, &self.slope_grid, theta, &self.nominal);
        // the corrected columns alone, read over the recording
        let replaced = corrected_columns(self.log, theta, cured.as_deref(), Some(&INPUT_COLUMNS));
        let log = LogView {
            log: self.log,
            replaced: &replaced,
        };
        let rec = scenario_from_view(
            log,
            self.ratios.len(),
            None,
            Some(p.final_drive_ratio / p.wheel_radius_m),
            p.engine_torque_lag_s,
            Some(p),
        )?;
        // the driven tyres' slip on every row from the corrected torque (super::tyre_slip):
        // a window's engine side starts from the recorded engine speed without it
        let kappa = super::tyre_slip::slip_of_rows(log, p, self.ratios, self.slip.slip_per_newton);
        Ok(ReadInputs {
            rec,
            kappa,
            key: inputs_key(p),
        })
    }

    /// The drive's tyre-slip estimate ([`super::tyre_slip::estimate`]).
    pub fn slip(&self) -> super::tyre_slip::SlipEstimate {
        self.slip
    }

    /// The nominal parameters.
    pub fn nominal(&self) -> &Theta {
        &self.nominal
    }

    /// Measured vehicle speed (gaps filled), m/s.
    pub fn measured_speed(&self) -> &[f64] {
        &self.v_meas
    }

    /// Measured engine speed (gaps filled), rad/s.
    pub fn measured_engine_speed(&self) -> &[f64] {
        &self.w_meas
    }

    /// Times of the rows, s from the first.
    pub fn times(&self) -> &[f64] {
        &self.t
    }

    /// Start times of the windows ([`window_starts`]), s from the first row.
    pub fn window_starts(&self) -> &[f64] {
        &self.starts
    }

    /// The records of simulations at other clutch capacities that later simulations read their
    /// locked windows off ([`CapacityReach`]).
    pub fn capacity_reach(&self) -> &CapacityReach {
        &self.reach
    }

    /// Gear ratios of the nominal vehicle (1st gear first).
    pub fn ratios(&self) -> &[f64] {
        self.ratios
    }

    /// The plant of `theta`: the nominal vehicle with `theta`'s longitudinal model effects
    /// injected (the sensor effects are corrected on the inputs instead,
    /// [`super::model_inputs::corrected_log`]).
    ///
    /// # Errors
    /// [`ExtendedError`] for a parameter outside its domain.
    pub fn plant(&self, theta: &Theta) -> Result<ExtendedVehicle, ExtendedError> {
        let mut tm = self.nominal_truth.clone();
        for e in theta.changed(&self.nominal) {
            if INPUT_EFFECTS.contains(&e) {
                continue; // corrected on the inputs
            }
            if e.domain() == crate::model::catalogue::Domain::Longitudinal {
                tm.set(e, theta.get(e))?;
            }
        }
        Ok(tm)
    }

    /// Sets the shaft twists of a locked-clutch start state `y0` (rigid speeds already set) to
    /// carry the recorded engine torque at `ta` with the measured acceleration: with
    /// `ω̇_w = a/r_w`, `M_c = M_e − (J_e + J_c) i_t i_f ω̇_w`,
    /// `M_p = i_t M_c − b_t ω_p − (J_t + J_p) i_f ω̇_w`, `M_d = i_f M_p − b_f ω_d − (J_f + J_d) ω̇_w`
    /// (docs/models/driveline.md with every shaft rigid), twist = torque / stiffness. The
    /// road-load steady state assumes zero acceleration; under full drive torque its twist is far
    /// from the recording's, and a window started from it rings at the shuffle frequency
    /// (±8 rad/s of engine speed for 0.2 s after a re-initialisation at 0.7 m/s² in 11th gear).
    fn load_twists(
        &self,
        p: &DrivelineParams,
        sc: &crate::sim::hybrid::Scenario,
        gear: usize,
        ta: f64,
        y0: &mut [f64; crate::sim::hybrid::N_STATES],
    ) {
        let crate::sim::hybrid::EngineInput::Torque(m) = &sc.engine else {
            return;
        };
        let Some(it) = gear.checked_sub(1).and_then(|g| self.ratios.get(g)) else {
            return;
        };
        let h = 0.25;
        let (t0, t1) = ((ta - h).max(0.0), ta + h);
        let a = (interp_linear(&self.t, &self.v_meas, t1)
            - interp_linear(&self.t, &self.v_meas, t0))
            / (t1 - t0);
        let fi = p.final_drive_ratio;
        let wdot_w = a / p.wheel_radius_m;
        let m_e = m.eval(ta + 1e-9);
        let m_c = m_e - (p.j_e_kg_m2 + p.j_c_kg_m2) * it * fi * wdot_w;
        let j2 = p.j_t_kg_m2[gear - 1] + p.j_p_kg_m2;
        let m_p = it * m_c - p.b_t_nm_s_per_rad * y0[3] - j2 * fi * wdot_w;
        let m_d = fi * m_p - p.b_f_nm_s_per_rad * y0[5] - (p.j_f_kg_m2 + p.j_d_kg_m2) * wdot_w;
        y0[2] = m_c / p.k_c_nm_per_rad;
        y0[4] = m_p / p.k_p_nm_per_rad;
        y0[6] = m_d / p.k_d_nm_per_rad;
    }

    /// Sets the engine side of a locked-clutch start state `y0` (every speed from the recorded
    /// vehicle speed, [`steady_state_locked`]) to the measured engine speed `we`, rad/s: the engine
    /// and clutch disc at `we`, the gearbox output at `we / i_t` and the final drive's at
    /// `we / (i_t i_f)`, the wheel left at the recorded vehicle speed. The difference between the
    /// two sides is then the drive shafts' twist rate (the most compliant shaft,
    /// docs/models/driveline.md), so a window started during the shuffle starts in its phase. `we`
    /// is clamped to within [`SLIP_START_MIN_RAD_S`] of the locked engine speed (a faster engine
    /// starts the window slipping instead); not finite, the state is left as it is.
    ///
    /// Why: right after a launch the first gear's shuffle swings the wheel speed by ±0.1 m/s at 2–3
    /// Hz; started at the locked engine speed of one such sample, a window keeps the sample's
    /// offset to its end (after a clean launch of `fleetdyn prove --seed 1001`: engine speed 8–11
    /// rad/s and vehicle speed 0.1 m/s below the recording for the 4.7 s to the next window, the
    /// same with every input at its truth). From the measured engine speed the same window stays
    /// within ±3 rad/s.
    fn measured_twist_rate(
        &self,
        p: &DrivelineParams,
        gear: usize,
        we: f64,
        y0: &mut [f64; crate::sim::hybrid::N_STATES],
    ) {
        let Some(&it) = gear.checked_sub(1).and_then(|g| self.ratios.get(g)) else {
            return;
        };
        if !we.is_finite() {
            return;
        }
        let we = we.clamp(y0[0] - SLIP_START_MIN_RAD_S, y0[0] + SLIP_START_MIN_RAD_S);
        y0[0] = we;
        y0[1] = we;
        y0[3] = we / it;
        y0[5] = y0[3] / p.final_drive_ratio;
    }

    /// Simulates the recording with parameters `theta`, window by window from the measured
    /// state (see the module documentation).
    ///
    /// # Errors
    /// [`ExtendedError`] for parameters outside their domain or a failed simulation.
    pub fn simulate(&self, theta: &Theta) -> Result<LongitudinalOutputs, ExtendedError> {
        self.simulate_windows(theta, None)
    }

    /// Index of the window ([`LongitudinalModel::window_starts`]) that time `t` (s from the
    /// first row) falls in: the last start at or before it.
    pub fn window_of(&self, t: f64) -> usize {
        self.starts.partition_point(|&s| s <= t).saturating_sub(1)
    }

    /// [`LongitudinalModel::simulate`] on the windows `needed` marks (one flag per window;
    /// `None`: every window). A window left out is not integrated: its rows read NaN, and
    /// only its first sample — the state it starts from, which needs no integration — is kept
    /// for the rows of the window before that interpolate towards it. Every window starts from
    /// the measured state, so the outputs on the rows of the windows simulated are those of
    /// the whole simulation, bit for bit. Outside a parallel job the windows are spread over
    /// the thread pool ([`LongitudinalModel::simulate_windows_on`]); inside one they run on the
    /// job's thread.
    ///
    /// # Errors
    /// As [`LongitudinalModel::simulate`] (a window left out fails nothing).
    pub fn simulate_windows(
        &self,
        theta: &Theta,
        needed: Option<&[bool]>,
    ) -> Result<LongitudinalOutputs, ExtendedError> {
        // inside a parallel job (a fit's grid point, a drive of the proof or the pipeline) the
        // windows run on the job's thread: a thread waiting for its windows would take up
        // another job, another simulation whose inputs and outputs it then holds too
        let threads = if rayon::current_thread_index().is_some() {
            1
        } else {
            rayon::current_num_threads().max(1)
        };
        self.simulate_windows_on(theta, needed, threads)
    }

    /// [`LongitudinalModel::simulate_windows`] with the windows spread over `threads`
    /// integrators (1: one after the other on this thread, the samples straight onto the rows;
    /// more: a batch of `WINDOW_BATCH` (32) windows at a time, each integrator a contiguous run of
    /// them in parallel, the samples pushed in window order). The outputs are the same, bit for
    /// bit, whatever `threads`: every window starts from the measured state.
    ///
    /// # Errors
    /// As [`LongitudinalModel::simulate`].
    pub fn simulate_windows_on(
        &self,
        theta: &Theta,
        needed: Option<&[bool]>,
        threads: usize,
    ) -> Result<LongitudinalOutputs, ExtendedError> {
        let threads = threads.max(1);
        let tm = self.plant(theta)?;
        let p: &DrivelineParams = &tm.driveline;
        let file = self.log.meta.source_file.clone();
        let inputs = self.read_inputs(theta, p)?;
        let sc = &inputs.rec.scenario;
        let kappa = &inputs.kappa;
        let dt = self.cfg.dt_s;
        // with a lash, the steps near and in its gap are cut to the fine step
        let gap_substeps = if tm.lash_rad > 0.0 {
            ((dt / FINE_STEP_S).round() as usize).max(1)
        } else {
            1
        };
        let fine_dt = (self.cfg.fine_at_reversals && dt > FINE_STEP_S).then_some(FINE_STEP_S);
        let fine_spans: &[(f64, f64)] = if fine_dt.is_some() { &self.fine } else { &[] };
        let starts = &self.starts;
        let n_win = starts.len();
        // the integration samples go onto the rows as they come (one integrator) or a batch of
        // windows at a time (several): a long drive's samples are never all held
        let mut rows = LinearResampler::<2>::new(&self.t);
        // the driven tyres' slip of a sample, from the model's drive-shaft torque
        // M_d = k_d·(twist beyond the lash) + c_d·(ω_d − ω_w), F_x = M_d / r_w
        let slip_of = |y: &[f64; crate::sim::hybrid::N_STATES]| {
            let half = 0.5 * tm.lash_rad;
            let twist = y[6] - y[6].clamp(-half, half);
            let m_d = p.k_d_nm_per_rad * twist + p.c_d_nm_s_per_rad * (y[5] - y[7]);
            (self.slip.slip_per_newton * m_d / p.wheel_radius_m).clamp(-0.2, 0.2)
        };
        // a record at a lower capacity, whose locked windows this simulation reads off it
        // (`reached`), and the windows the caller leaves out (`skipped`)
        let record = self.reach.best_for(theta);
        // whether this simulation will be recorded: only then are the first unlocks kept
        let recorded = self.reach.keeps(theta, &self.nominal);
        let reached = |w: usize| record.as_ref().is_some_and(|r| r.locked[w]);
        let skipped = |w: usize| needed.is_some_and(|nd| !nd.get(w).copied().unwrap_or(true));
        // where the record lets window `w` be taken up part-way (its piece and whole step)
        let resumed = |w: usize| record.as_ref().and_then(|r| r.resume[w]);
        // window `w`'s samples (time; vehicle speed, engine speed), simulated by `fast` and
        // `fine` (integrators of the window's steps: each window starts from the measured
        // state, so a window's samples do not depend on which integrator ran the one before);
        // returns whether the clutch was locked at every sample of the window (a window
        // read off the record: as the record found it; one left out: false) and where a
        // larger capacity could take it up
        let window = |w: usize,
                      fast: &mut FastDriveline<'_>,
                      fine: &mut Option<FastDriveline<'_>>,
                      out: &mut dyn FnMut(f64, [f64; 2])|
         -> Result<WindowRun, ExtendedError> {
            let ta = starts[w];
            let tb = starts
                .get(w + 1)
                .copied()
                .unwrap_or(sc.t_end_s)
                .min(sc.t_end_s);
            if tb - ta < dt {
                return Ok(WindowRun::default());
            }
            let v0 = interp_linear(&self.t, &self.v_meas, ta).max(0.0);
            let gear = sc.gear.eval(ta + 1e-9).round() as usize;
            let slope = sc.slope.eval(ta + 1e-9);
            let x = sc.clutch_x.eval(ta + 1e-9);
            let (mut y0, _) = steady_state_locked(p, self.ratios, gear, v0, slope, sc.smoothing);
            let engaged = x <= p.clutch_l_lower * p.clutch_x_max;
            // the recorded engine speed without the tyres' slip, which the model adds back on
            // its output (both clutch modes alike); a closed clutch whose engine runs well
            // above the gearbox slips (a worn clutch under full torque): the window starts
            // slipping from it
            let we = interp_linear(&self.t, &self.w_meas, ta)
                / (1.0 + interp_linear(&self.t, kappa, ta));
            let slipping = we.is_finite() && we - y0[0] > SLIP_START_MIN_RAD_S;
            let mode = if engaged && v0 >= self.cfg.min_speed_mps && !slipping {
                ClutchMode::Locked
            } else {
                let sigma = if we >= y0[1] { 1.0 } else { -1.0 };
                y0[0] = we;
                ClutchMode::Slipping(sigma)
            };
            y0[8] = 0.0;
            if mode == ClutchMode::Locked {
                self.load_twists(p, sc, gear, ta, &mut y0);
                if self.cfg.measured_engine_side {
                    self.measured_twist_rate(p, gear, we, &mut y0);
                }
            }
            if tm.lash_rad > 0.0 {
                // the steady twist carries the drive torque: in contact on its side
                y0[6] += 0.5 * tm.lash_rad * y0[6].signum();
            }
            let skip = skipped(w);
            if skip || reached(w) {
                // the sample the window's first piece would start with
                out(ta, [p.wheel_radius_m * y0[7], y0[0] * (1.0 + slip_of(&y0))]);
                return Ok(WindowRun {
                    locked: !skip,
                    ..WindowRun::default()
                });
            }
            // the window piece by piece, each from the state and mode the last ended in; a
            // window the record takes up part-way at a whole step of one of its pieces
            // (its first sample handed over for the rows before it, which the record gives)
            let pieces = stepped_pieces(ta, tb, dt, fine_spans);
            let from = resumed(w);
            if from.is_some() {
                out(ta, [p.wheel_radius_m * y0[7], y0[0] * (1.0 + slip_of(&y0))]);
            }
            let (mut y, mut mode) = (y0, mode);
            let (mut locked, mut first_unlock, mut taken_up_at) = (true, None, None);
            for (j, &(a, b, is_fine)) in pieces.iter().enumerate() {
                let take_up = match from {
                    Some((jr, _)) if j < jr => continue,
                    Some((jr, r)) if j == jr => Some(r),
                    _ => None,
                };
                // a piece's last sample is the next piece's (or window's) first
                let last = w + 1 == n_win && j + 1 == pieces.len();
                // the engine turns faster than the vehicle's speed carries it by the slip
                let mut sample = |t: f64, y: &[f64; crate::sim::hybrid::N_STATES]| {
                    out(t, [p.wheel_radius_m * y[7], y[0] * (1.0 + slip_of(y))]);
                };
                let run = match (is_fine, fine.as_mut(), take_up) {
                    (true, Some(f), Some(r)) => {
                        // the step's start time, as the integrator computes it
                        taken_up_at = Some(a + r.step() as f64 * f.step_s());
                        f.resume_span_states(sc, (a, b), &r, last, &mut sample)
                    }
                    (true, Some(f), None) => {
                        f.simulate_span_states(sc, (a, b), y, mode, last, &mut sample)
                    }
                    (_, _, Some(r)) => {
                        taken_up_at = Some(a + r.step() as f64 * fast.step_s());
                        fast.resume_span_states(sc, (a, b), &r, last, &mut sample)
                    }
                    (_, _, None) => {
                        fast.simulate_span_states(sc, (a, b), y, mode, last, &mut sample)
                    }
                };
                let end = run.map_err(|source| ExtendedError::Sim {
                    file: file.clone(),
                    source,
                })?;
                if locked && !end.locked_throughout {
                    first_unlock = end.first_unlock.map(|r| (j, r));
                }
                (y, mode) = (end.y, end.mode);
                locked &= end.locked_throughout;
            }
            Ok(WindowRun {
                locked,
                first_unlock,
                taken_up_at,
            })
        };
        // one integrator per thread (its matrix cache carries over between windows)
        let mut sims: Vec<_> = (0..threads)
            .map(|_| {
                (
                    FastDriveline::new(p, self.ratios, dt)
                        .with_lash(tm.lash_rad)
                        .with_gap_substeps(gap_substeps)
                        .tracking_first_unlock(recorded),
                    fine_dt.map(|f| {
                        FastDriveline::new(p, self.ratios, f)
                            .with_lash(tm.lash_rad)
                            .tracking_first_unlock(recorded)
                    }),
                )
            })
            .collect();
        let mut runs = Vec::with_capacity(n_win);
        if let [(fast, fine)] = sims.as_mut_slice() {
            for w in 0..n_win {
                runs.push(window(w, fast, fine, &mut |t, y| rows.push(t, y))?);
            }
        } else {
            // windows in parallel a batch at a time, each thread a contiguous run of them, the
            // samples pushed in window order (the same rows whatever the thread count; a
            // batch's samples are all a long drive holds)
            let batch = WINDOW_BATCH.max(threads);
            let all: Vec<usize> = (0..n_win).collect();
            for ws in all.chunks(batch) {
                let samples: Vec<(Vec<Sample>, Vec<WindowRun>)> = sims
                    .par_iter_mut()
                    .zip(ws.par_chunks(ws.len().div_ceil(threads)))
                    .map(|((fast, fine), run)| {
                        let mut got = Vec::new();
                        let mut run_runs = Vec::with_capacity(run.len());
                        for &w in run {
                            run_runs.push(window(w, fast, fine, &mut |t, y| got.push((t, y)))?);
                        }
                        Ok((got, run_runs))
                    })
                    .collect::<Result<_, ExtendedError>>()?;
                for (got, run_runs) in samples {
                    for (t, y) in got {
                        rows.push(t, y);
                    }
                    runs.extend(run_runs);
                }
            }
        }
        let [vehicle_speed, engine_speed] = rows.finish();
        let mut out = LongitudinalOutputs {
            vehicle_speed,
            engine_speed,
        };
        // the rows of each window left out (NaN) or read off the record (a window's rows: from
        // its start to the next one's, the first window's from the first row; a window taken
        // up part-way: to the step it was taken up at, that step's row included), found per
        // window, not per row
        let row_at = |s: f64| self.t.partition_point(|&x| x < s);
        for (w, run) in runs.iter().enumerate() {
            let (left_out, read) = (skipped(w), reached(w));
            if !left_out && !read && run.taken_up_at.is_none() {
                continue;
            }
            let lo = if w == 0 { 0 } else { row_at(starts[w]) };
            let hi = match run.taken_up_at {
                Some(t) if !left_out && !read => self.t.partition_point(|&x| x <= t),
                _ => starts.get(w + 1).map_or(self.t.len(), |&s| row_at(s)),
            };
            match (&record, left_out) {
                (Some(r), false) => {
                    out.vehicle_speed[lo..hi].copy_from_slice(&r.vehicle_speed[lo..hi]);
                    out.engine_speed[lo..hi].copy_from_slice(&r.engine_speed[lo..hi]);
                }
                _ => {
                    out.vehicle_speed[lo..hi].fill(f64::NAN);
                    out.engine_speed[lo..hi].fill(f64::NAN);
                }
            }
        }
        let kept = runs.iter().map(|r| (r.locked, r.first_unlock)).unzip();
        self.reach.keep(
            theta,
            &self.nominal,
            kept,
            &out.vehicle_speed,
            &out.engine_speed,
        );
        Ok(out)
    }
}

/// How one window of [`LongitudinalModel::simulate_windows_on`] ran.
#[derive(Debug, Default, Clone, Copy)]
struct WindowRun {
    /// The clutch was locked at every sample (a window read off a record: as the record found
    /// it; one left out or too short: `false`).
    locked: bool,
    /// Where a larger capacity can take the window up: its piece and whole step.
    first_unlock: Option<(usize, Resume)>,
    /// The time of the step this simulation took the window up at, from a record.
    taken_up_at: Option<f64>,
}
