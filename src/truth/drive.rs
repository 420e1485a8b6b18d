//! Drive assembly: a drawn truck, its driver and AMT, a road and wind, integrated over a whole
//! drive; the result as CAN truth, and optionally as an MCAP log ingested to a drive log.
//!
//! # Loop
//! Control steps of [`CONTROL_DT_S`] = 10 ms: the driver reads position, speed, slope, engine
//! speed and gear; the AMT turns the driver's demand into an engine torque demand, clutch travel
//! and gearbox actions; the ECU makes the combustion command ([`super::engine::command`]) and
//! the reported torque; the inputs are held over the step while the plant is integrated with
//! [`EventRk4`] at [`super::plant::STEP_S`]. The truth is sampled at every control step
//! (100 Hz), before the step.
//!
//! # Truth columns (SI; the CAN bus [`CanBus::j1939_truck`] carries them)
//! `vehicle_speed` (m/s, the wheel-based speed sensor: the body speed, or a stuck value on a
//! sensor-fault stretch), `engine_speed` (rad/s), `engine_torque` (N·m, **as the ECU reports
//! it**, map error included), `gear` (CAN gear: index + 1, 0 in neutral), `clutch_position`
//! (0 engaged … 1 open), `road_slope` (tan α as the sensor sees it, mounting angle included;
//! the bus quantises it), `brake_force` (N, the service-brake force applied), `altitude` (m, the
//! GNSS receiver's reading of the road's elevation at the travelled distance, with the
//! receiver's own errors: [`super::gnss`]; on J1939 VDS at 1 Hz). The bus's slope resolution and
//! engine-torque delay come from the concealed effect.
//!
//! # Randomness
//! One seed; independent streams per purpose, `Xoshiro256StarStar::seed_from_u64(seed ^ salt)`
//! with fixed salts (parameters, effect, wind, driver, receiver), so adding draws to one purpose leaves the
//! others unchanged. The road is generated from `seed` as [`crate::road::synth::generate`] does.

use super::amt::{Amt, AmtInput, GearAction};
use super::driver::Driver;
use super::effects::{apply, Concealed, PlantExtras, SensorSetup, TruthEffect};
use super::engine::{command, reported};
use super::gnss::{altitude_message, receiver_altitude, ReceiverParams};
use super::integrator::EventRk4;
use super::params::TruckParams;
use super::plant::{EventCounts, GearMode, Inputs, Plant, RoadGrid, STEP_S, V, W_E, W_P, X};
use super::resistance::{Wind, WindParams};
use super::TruthError;
use crate::model::vehicle::VehicleFile;
use crate::rng::Xoshiro256StarStar;
use crate::road::rules::RoadRules;
use crate::road::synth::generate;
use crate::synth::can::{write_can_drive, CanBus, SynthOptions, Truth};
use crate::table::DriveLog;
use std::path::Path;

/// Control step, s.
pub const CONTROL_DT_S: f64 = 0.01;
/// Epoch time of truth time 0 in written logs (2024-01-01T00:00:00Z), ns.
pub const START_NS: i64 = 1_704_067_200_000_000_000;

const SALT_PARAMS: u64 = 0x7472_7563_6b00_0001;
const SALT_EFFECT: u64 = 0x7472_7563_6b00_0002;
const SALT_WIND: u64 = 0x7472_7563_6b00_0003;
const SALT_DRIVER: u64 = 0x7472_7563_6b00_0004;
const SALT_RECEIVER: u64 = 0x7472_7563_6b00_0005;

/// A drive to simulate.
#[derive(Debug, Clone, PartialEq)]
pub struct IndependentDriveConfig {
    /// Road rules: a bundled name (`highway-se`, `city-se`, …) or a rules file.
    pub rules: String,
    /// Road length, km.
    pub length_km: f64,
    /// Seed of everything (road, truck draw, effect, wind, driver, CAN noise).
    pub seed: u64,
    /// Concealed effect.
    pub effect: TruthEffect,
    /// Draw the truck within tolerances (true) or use the nominal truck (false).
    pub draw_tolerances: bool,
    /// Seed of the truck's tolerance draw when it is not the drive's: drives of one truck share
    /// it (a fleet), so the truck is the same and only the road, driver and wind change.
    pub truck_seed: Option<u64>,
    /// The drawn mass times this (the trip's payload against the vehicle file's mass), with the
    /// tyre load alike.
    pub mass_scale: f64,
    /// Wind on (true) or calm (false).
    pub wind: bool,
    /// Tyres start cold, at ambient temperature (false: every drive, as a truck leaves the
    /// depot), or warm, at the rise where the file's rolling resistance holds (true: a study).
    pub warm_tyres: bool,
    /// Give up after this simulated time, s.
    pub max_duration_s: f64,
}

impl IndependentDriveConfig {
    /// A drive on `rules` of `length_km` with `seed`, no concealed effect, tolerances and wind
    /// on; time limit `length / (2 m/s) + 600 s` (a mean speed far below any drive's).
    pub fn new(rules: &str, length_km: f64, seed: u64) -> Self {
        Self {
            rules: rules.into(),
            length_km,
            seed,
            effect: TruthEffect::None,
            draw_tolerances: true,
            truck_seed: None,
            mass_scale: 1.0,
            wind: true,
            warm_tyres: false,
            max_duration_s: length_km * 1000.0 / 2.0 + 600.0,
        }
    }
}

/// A simulated drive.
#[derive(Debug, Clone)]
pub struct IndependentDrive {
    /// CAN truth (module doc).
    pub truth: Truth,
    /// The CAN bus the truth is logged with (slope resolution and torque delay set).
    pub bus: CanBus,
    /// The drawn truck (the truth), effect applied.
    pub params: TruckParams,
    /// The nominal truck of the vehicle file.
    pub nominal: TruckParams,
    /// What the drive conceals.
    pub concealed: Concealed,
    /// Sensor settings.
    pub sensors: SensorSetup,
    /// Plant extras.
    pub extras: PlantExtras,
    /// Wind of this drive.
    pub wind: WindParams,
    /// Travelled distance at each truth sample, m.
    pub distance_m: Vec<f64>,
    /// Produced net engine torque at each truth sample, N·m (what the reported torque estimates).
    pub produced_torque_nm: Vec<f64>,
    /// True body speed at each sample, m/s.
    pub true_speed_mps: Vec<f64>,
    /// True slope tan α at each sample.
    pub true_slope: Vec<f64>,
    /// Stop positions of the driver, m.
    pub stops: Vec<f64>,
    /// Road label (rules name).
    pub road_label: String,
    /// Road length, m.
    pub road_length_m: f64,
    /// Vehicle id.
    pub vehicle_id: String,
    /// Plant events over the drive.
    pub events: EventCounts,
    /// Seed.
    pub seed: u64,
}

fn stream(seed: u64, salt: u64) -> Xoshiro256StarStar {
    Xoshiro256StarStar::seed_from_u64(seed ^ salt)
}

/// Simulates a drive of `vehicle` as `cfg` says (module doc).
///
/// # Errors
/// [`TruthError`]: a vehicle without `[driveline]` or gear ratios, bad parameters, unknown
/// rules or effect, a bad length, an integration failure, or a drive that does not finish in
/// `max_duration_s`.
pub fn simulate_independent_drive(
    vehicle: &VehicleFile,
    cfg: &IndependentDriveConfig,
) -> Result<IndependentDrive, TruthError> {
    if !(cfg.length_km.is_finite() && cfg.length_km > 0.0) {
        return Err(TruthError::BadConfig {
            parameter: "length_km",
            value: cfg.length_km,
            requirement: "finite and > 0",
        });
    }
    if !(cfg.max_duration_s.is_finite() && cfg.max_duration_s > 0.0) {
        return Err(TruthError::BadConfig {
            parameter: "max_duration_s",
            value: cfg.max_duration_s,
            requirement: "finite and > 0",
        });
    }
    let d = vehicle
        .driveline
        .as_ref()
        .ok_or_else(|| TruthError::NoDriveline {
            vehicle_id: vehicle.vehicle_id.clone(),
        })?;
    let nominal = TruckParams::nominal(d, &vehicle.gearbox.ratios)?;
    let rules = RoadRules::resolve(&cfg.rules)?;
    let length_m = cfg.length_km * 1000.0;
    let road = generate(&rules, length_m, 1.0, cfg.seed)?;
    if !(cfg.mass_scale.is_finite() && cfg.mass_scale > 0.0) {
        return Err(TruthError::BadConfig {
            parameter: "mass_scale",
            value: cfg.mass_scale,
            requirement: "finite and > 0",
        });
    }
    let mut params = if cfg.draw_tolerances {
        nominal.draw(&mut stream(cfg.truck_seed.unwrap_or(cfg.seed), SALT_PARAMS))
    } else {
        nominal.clone()
    };
    if cfg.mass_scale != 1.0 {
        params.mass_kg *= cfg.mass_scale;
        params.tyre.fz_n *= cfg.mass_scale;
    }
    let (concealed, sensors, extras) = apply(
        &cfg.effect,
        &nominal,
        &mut params,
        length_m,
        &mut stream(cfg.seed, SALT_EFFECT),
    )?;
    let mut wind_rng = stream(cfg.seed, SALT_WIND);
    let wind_p = if cfg.wind {
        WindParams::draw(&mut wind_rng)
    } else {
        WindParams::calm()
    };
    let mut wind = Wind::new(wind_p, CONTROL_DT_S, wind_rng);
    let design = rules.design_speed_km_per_h.unwrap_or(80.0) / 3.6;
    let city = design <= 60.0 / 3.6;
    let mut driver = Driver::new(
        &nominal,
        length_m,
        design,
        city,
        &mut stream(cfg.seed, SALT_DRIVER),
    );
    let grid = RoadGrid {
        step_m: road.profile.step_m,
        slope: road.profile.slope.clone(),
        surface: extras.surface,
    };
    let (mut plant, mut x) = Plant::at_rest(params.clone(), grid);
    if cfg.warm_tyres {
        x[super::plant::DT] = params.thermal.warm_rise_k;
    }
    let mut amt = Amt::new(&nominal);
    let integ = EventRk4::new(STEP_S);
    let n_est = (cfg.max_duration_s / CONTROL_DT_S) as usize / 4;
    let mut rec = Recorder::with_capacity(n_est);
    let mut t = 0.0;
    let mut k: u64 = 0;
    while !driver.finished {
        if t > cfg.max_duration_s {
            return Err(TruthError::Timeout {
                max_s: cfg.max_duration_s,
                x_m: x[X],
                length_m,
            });
        }
        let slope = plant.road.slope_at(x[X]);
        let engaged = match plant.gear {
            GearMode::Engaged(g) => Some(g),
            GearMode::Neutral { .. } => None,
        };
        let start = amt.start_gear(slope);
        let cmd = driver.step(
            t,
            x[X],
            x[V],
            slope,
            x[W_E],
            engaged,
            start,
            plant.stopped,
            CONTROL_DT_S,
        );
        let out = amt.step(
            &AmtInput {
                t_s: t,
                demand_nm: cmd.demand_nm,
                pedal: cmd.pedal,
                braking: cmd.brake_n > 0.0,
                w_e: x[W_E],
                w_p: x[W_P],
                v: x[V],
                slope,
                gear: plant.gear,
                stopped: plant.stopped,
            },
            CONTROL_DT_S,
        );
        match out.action {
            GearAction::None => {}
            GearAction::ToNeutral(g) => plant.to_neutral(&mut x, Some(g)),
            GearAction::StartSync => plant.start_sync(&mut x),
        }
        let m_cmd = command(&plant.p.engine, out.engine_nm, x[W_E]);
        let retarder = match extras.retarder {
            Some((a, b, m)) if x[X] >= a && x[X] < b => m,
            _ => 0.0,
        };
        plant.u = Inputs {
            m_cmd,
            clutch_x: out.clutch_x,
            brake_n: cmd.brake_n,
            retarder_nm: retarder,
            wind_mps: wind.now(),
        };
        plant.settle_modes(&mut x);
        let e = plant.eval(&x);
        let gear = match plant.gear {
            GearMode::Engaged(g) => (g + 1) as f64,
            GearMode::Neutral { .. } => 0.0,
        };
        let sensed = (slope.atan() + sensors.slope_offset_rad).tan();
        rec.push(
            t,
            &x,
            reported(&plant.p.engine, m_cmd, x[W_E]),
            e.m_e,
            gear,
            out.clutch_x,
            slope,
            sensed,
            cmd.brake_n,
        );
        integ.advance(&mut plant, &mut t, &mut x, (k + 1) as f64 * CONTROL_DT_S)?;
        wind.step();
        k += 1;
    }
    let reference = d.engine_max_torque_nm.iter().fold(0.0f64, |m, &v| m.max(v));
    let mut bus = CanBus::j1939_truck(reference);
    for c in bus.messages.iter_mut().flat_map(|m| m.channels.iter_mut()) {
        if c.column == "road_slope" {
            c.resolution = 100.0 * sensors.slope_resolution;
        }
        if c.column == "engine_torque" {
            c.delay_s = sensors.torque_delay_s;
        }
    }
    bus.messages.push(altitude_message());
    let altitude = receiver_altitude(
        &ReceiverParams::default(),
        road.profile.step_m,
        &road.profile.elevation_m,
        &rec.t,
        &rec.x,
        &mut stream(cfg.seed, SALT_RECEIVER),
    );
    let mut speed = rec.v.clone();
    if let Some((a, b)) = sensors.speed_stuck {
        let mut held: Option<f64> = None;
        for (s, &xd) in speed.iter_mut().zip(&rec.x) {
            if xd >= a && xd < b {
                *s = *held.get_or_insert(*s);
            }
        }
    }
    let truth = Truth {
        t_s: rec.t.clone(),
        columns: vec![
            ("vehicle_speed".into(), speed),
            ("engine_speed".into(), rec.w_e.clone()),
            ("engine_torque".into(), rec.m_rep.clone()),
            ("gear".into(), rec.gear.clone()),
            ("clutch_position".into(), rec.clutch.clone()),
            ("road_slope".into(), rec.sensed.clone()),
            ("brake_force".into(), rec.brake.clone()),
            ("altitude".into(), altitude),
        ],
    };
    Ok(IndependentDrive {
        truth,
        bus,
        params,
        nominal,
        concealed,
        sensors,
        extras,
        wind: wind_p,
        distance_m: rec.x,
        produced_torque_nm: rec.m_e,
        true_speed_mps: rec.v,
        true_slope: rec.slope,
        stops: driver.stops.clone(),
        road_label: rules.name.clone(),
        road_length_m: length_m,
        vehicle_id: vehicle.vehicle_id.clone(),
        events: plant.events,
        seed: cfg.seed,
    })
}

#[derive(Debug, Default)]
struct Recorder {
    t: Vec<f64>,
    x: Vec<f64>,
    v: Vec<f64>,
    w_e: Vec<f64>,
    m_rep: Vec<f64>,
    m_e: Vec<f64>,
    gear: Vec<f64>,
    clutch: Vec<f64>,
    slope: Vec<f64>,
    sensed: Vec<f64>,
    brake: Vec<f64>,
}

impl Recorder {
    fn with_capacity(n: usize) -> Self {
        let v = || Vec::with_capacity(n);
        Self {
            t: v(),
            x: v(),
            v: v(),
            w_e: v(),
            m_rep: v(),
            m_e: v(),
            gear: v(),
            clutch: v(),
            slope: v(),
            sensed: v(),
            brake: v(),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn push(
        &mut self,
        t: f64,
        x: &super::plant::State,
        m_rep: f64,
        m_e: f64,
        gear: f64,
        clutch: f64,
        slope: f64,
        sensed: f64,
        brake: f64,
    ) {
        self.t.push(t);
        self.x.push(x[X]);
        self.v.push(x[V]);
        self.w_e.push(x[W_E]);
        self.m_rep.push(m_rep);
        self.m_e.push(m_e);
        self.gear.push(gear);
        self.clutch.push(clutch);
        self.slope.push(slope);
        self.sensed.push(sensed);
        self.brake.push(brake);
    }
}

/// Writes `drive` as a CAN log: `drive.mcap` (the bus sampled with CAN noise from `seed`),
/// `drive.parquet` (what ingest makes of it), `vehicle.toml` (a copy of `vehicle_path`) and
/// `answer.json` (the concealed effect and the drawn parameters) in `out_dir`; returns the
/// ingested drive log.
///
/// # Errors
/// [`TruthError::Io`] for directory or copy failures, [`TruthError::Can`] for sampling, MCAP or
/// ingest failures.
pub fn write_independent_drive(
    drive: &IndependentDrive,
    vehicle_path: &Path,
    out_dir: &Path,
    seed: u64,
) -> Result<DriveLog, TruthError> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| TruthError::Io { path, source }
    };
    std::fs::create_dir_all(out_dir).map_err(io(out_dir))?;
    let opts = SynthOptions {
        start_ns: START_NS,
        seed,
        drive_id: format!(
            "truth-{}-{:.1}km-seed{}",
            drive.road_label,
            drive.road_length_m / 1000.0,
            drive.seed
        ),
        vehicle_id: Some(drive.vehicle_id.clone()),
    };
    let log = write_can_drive(
        &out_dir.join("drive.mcap"),
        &out_dir.join("drive.parquet"),
        &drive.bus,
        &drive.truth,
        &opts,
    )?;
    let vehicle = out_dir.join("vehicle.toml");
    std::fs::copy(vehicle_path, &vehicle).map_err(io(&vehicle))?;
    let answer = out_dir.join("answer.json");
    let text = serde_json::to_string_pretty(&answer_json(drive)).unwrap_or_default();
    std::fs::write(&answer, text).map_err(io(&answer))?;
    Ok(log)
}

/// The answer of a drive as JSON: the concealed effect and the drawn parameters a harness
/// scores recovery against.
pub fn answer_json(drive: &IndependentDrive) -> serde_json::Value {
    use serde_json::json;
    let concealed = match &drive.concealed {
        Concealed::None => json!({"kind": "none"}),
        Concealed::Catalogue {
            id,
            parameter,
            unit,
            nominal,
            truth,
        } => json!({"kind": "catalogue", "id": id, "parameter": parameter, "unit": unit,
                    "nominal": nominal, "truth": truth}),
        Concealed::OutOfCatalogue {
            kind,
            start_m,
            end_m,
            magnitude,
        } => json!({"kind": "out_of_catalogue", "id": kind.id(),
                    "description": kind.description(), "start_m": start_m, "end_m": end_m,
                    "magnitude": magnitude}),
    };
    let p = &drive.params;
    json!({
        "seed": drive.seed,
        "road": drive.road_label,
        "length_m": drive.road_length_m,
        "concealed": concealed,
        "params": {
            "mass_kg": p.mass_kg,
            "c_w_a_f_m2": p.c_w_a_f_m2,
            "c_r1": p.c_r1,
            "c_r2_s_per_m": p.c_r2_s_per_m,
            "k_d_nm_per_rad": p.lumped_stiffness(),
            "k_shafts_nm_per_rad": 2.0 * p.k_s,
            "k_tyres_nm_per_rad": p.tyre_torsional_stiffness(),
            "c_d_nm_s_per_rad": 2.0 * p.c_s,
            "k_p_nm_per_rad": p.k_p,
            "k_c_nm_per_rad": p.damper.k1_nm_per_rad,
            "clutch_max_torque_nm": p.clutch_kinetic_nm,
            "drive_shaft_lash_rad": p.lash_rad,
            "engine_map_gain": p.engine.map_gain,
            "engine_torque_offset_nm": p.engine.map_offset_nm,
            "engine_lag_s": p.engine.lag_s,
        },
        "wind": {"mean_mps": drive.wind.mean_mps, "gust_sigma_mps": drive.wind.gust_sigma_mps,
                 "gust_tau_s": drive.wind.gust_tau_s},
        "stops_m": drive.stops,
    })
}
