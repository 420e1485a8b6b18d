//! The fleet-level proof (`fleetdyn prove --fleet`, docs/fleet.md): a fleet synthesised from the
//! independent truth ([`crate::truth`]) — each truck drawn once within the vehicle file's
//! tolerances and kept for all its drives, its payload drawn per trip, some trucks developing a
//! fault part-way through the period — every drive diagnosed blind, the fleet evidence
//! ([`crate::fleet`]) computed after each drive as a nightly job would, and scored against the
//! truth: detection delay, false alarms per vehicle-month, pooled estimate errors.
//!
//! # Plan
//! Truck `t` of a proof with seed `S` has the truck seed `S · 7919 + t` (its tolerance draw);
//! drive `j` of truck `t` is driven on day `j` with the drive seed `S · 1 000 003 + 10 007 t + j`,
//! a road drawn per drive (highway-se, freeway-us, city-se, urban-us, weights 3:3:2:2), a length
//! uniform in the configured range and a payload giving 75–100 % of the vehicle file's mass.
//! The first [`FleetProofConfig::faulty`] trucks develop a fault, in turn one of
//! [`FleetFault::ALL`], from a drive drawn uniformly in the middle third of the period on; the
//! others stay as drawn.
//!
//! # Scores
//! - *detected*: the fault's parameter flagged (`changed`) by the evidence of the drives up to
//!   some drive from the onset on; the delay counts the drives from the onset (the first faulty
//!   drive is 1);
//! - *false alarms*: a parameter turning flagged on a clean truck, or on a faulty one before its
//!   onset, counted once per turn; per vehicle-month with
//!   [`FleetProofConfig::drives_per_month`] drives a month; flags of other parameters of a
//!   faulty truck after its onset are reported apart (a lost fairing also moves the rolling
//!   resistance estimate);
//! - *mass per trip*: each drive's mass estimate against that trip's true mass (the payload
//!   changes from trip to trip, so the mass is never pooled);
//! - *estimate error*: the final pooled estimate (since the last change) of drag area, rolling
//!   resistance and clutch capacity against the truck's truth at its last drive.

use crate::diagnose::run::{diagnose, DiagnoseConfig};
use crate::fleet::evidence::{vehicle_evidence, Status, VehicleEvidence};
use crate::fleet::series::{DriveEstimates, EstimateRow};
use crate::model::vehicle::VehicleFile;
use crate::rng::Xoshiro256StarStar;
use crate::truth::{
    simulate_independent_drive, write_independent_drive, IndependentDriveConfig, TruthEffect,
};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A fault a truck develops.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FleetFault {
    /// A roof fairing lost: drag area × 1.25.
    LostFairing,
    /// A worn clutch: kinetic capacity × 0.6 (slips at full load in low gears).
    WornClutch,
    /// The slope sensor's mounting slipped by 0.8°.
    SlopeSensorSlipped,
}

impl FleetFault {
    /// Every fault, in the order trucks get them.
    pub const ALL: [FleetFault; 3] = [
        FleetFault::LostFairing,
        FleetFault::WornClutch,
        FleetFault::SlopeSensorSlipped,
    ];

    /// The catalogue effect whose parameter it moves.
    pub fn effect(self) -> &'static str {
        match self {
            FleetFault::LostFairing => "aero_drag",
            FleetFault::WornClutch => "clutch_slip",
            FleetFault::SlopeSensorSlipped => "grade_offset",
        }
    }

    /// The truth effect for a truck of the vehicle file's `drag_m2` and `clutch_nm`.
    fn truth(self, drag_m2: f64, clutch_nm: f64) -> TruthEffect {
        let v = match self {
            FleetFault::LostFairing => 1.25 * drag_m2,
            FleetFault::WornClutch => 0.6 * clutch_nm,
            FleetFault::SlopeSensorSlipped => 0.8f64.to_radians(),
        };
        TruthEffect::Catalogue(self.effect().to_string(), Some(v))
    }
}

/// A fleet proof.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FleetProofConfig {
    /// Seed of the plan.
    pub seed: u64,
    /// Trucks.
    pub trucks: usize,
    /// Drives per truck (one a day).
    pub drives_per_truck: usize,
    /// Trucks that develop a fault (the first ones).
    pub faulty: usize,
    /// Shortest and longest drive, km.
    pub length_km: (f64, f64),
    /// Drives a vehicle makes in a month (working days), for the false-alarm rate.
    pub drives_per_month: f64,
}

impl Default for FleetProofConfig {
    /// 20 trucks × 30 drives of 10–20 km, 6 faulty, 22 drives a month.
    fn default() -> Self {
        Self {
            seed: 1,
            trucks: 20,
            drives_per_truck: 30,
            faulty: 6,
            length_km: (10.0, 20.0),
            drives_per_month: 22.0,
        }
    }
}

impl FleetProofConfig {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`crate::settings::InvalidSetting`] naming the first bad one.
    pub fn validate(&self) -> Result<(), crate::settings::InvalidSetting> {
        use crate::settings::require;
        require(
            self.trucks >= 1,
            "trucks",
            self.trucks as f64,
            "must be at least 1",
        )?;
        require(
            self.drives_per_truck >= 6,
            "drives_per_truck",
            self.drives_per_truck as f64,
            "must be at least 6 (a change needs 3 drives on either side)",
        )?;
        require(
            self.faulty <= self.trucks,
            "faulty",
            self.faulty as f64,
            "must not exceed trucks",
        )?;
        let (lo, hi) = self.length_km;
        require(lo > 0.0 && lo.is_finite(), "min_km", lo, "must be positive")?;
        require(
            hi >= lo && hi.is_finite(),
            "max_km",
            hi,
            "must be at least min_km",
        )?;
        require(
            self.drives_per_month > 0.0,
            "drives_per_month",
            self.drives_per_month,
            "must be positive",
        )
    }
}

/// One planned drive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FleetDrive {
    /// Truck index.
    pub truck: usize,
    /// Day (drive index of the truck).
    pub day: usize,
    /// Drive seed.
    pub seed: u64,
    /// Road rules.
    pub rules: String,
    /// Length, km.
    pub length_km: f64,
    /// Mass against the vehicle file's.
    pub mass_scale: f64,
    /// The fault, active on this drive.
    pub fault: Option<FleetFault>,
}

/// One planned truck.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FleetTruck {
    /// Vehicle id.
    pub vehicle_id: String,
    /// Seed of its tolerance draw.
    pub truck_seed: u64,
    /// Its fault and the first drive (day) it acts on.
    pub fault: Option<(FleetFault, usize)>,
}

/// The plan (module documentation).
pub fn fleet_plan(cfg: &FleetProofConfig) -> (Vec<FleetTruck>, Vec<FleetDrive>) {
    const ROADS: [(&str, u32); 4] = [
        ("highway-se", 3),
        ("freeway-us", 3),
        ("city-se", 2),
        ("urban-us", 2),
    ];
    let n = cfg.drives_per_truck;
    let mut trucks = Vec::new();
    let mut drives = Vec::new();
    for t in 0..cfg.trucks {
        let mut rng =
            Xoshiro256StarStar::seed_from_u64(cfg.seed.wrapping_mul(7919) ^ (t as u64 + 1));
        let fault = (t < cfg.faulty).then(|| {
            let onset = n / 3 + (rng.next_f64() * (n / 3).max(1) as f64).floor() as usize;
            (FleetFault::ALL[t % FleetFault::ALL.len()], onset.min(n - 1))
        });
        trucks.push(FleetTruck {
            vehicle_id: format!("FLEET-{t:03}"),
            truck_seed: cfg.seed.wrapping_mul(7919).wrapping_add(t as u64),
            fault,
        });
        for day in 0..n {
            let seed = cfg
                .seed
                .wrapping_mul(1_000_003)
                .wrapping_add(10_007 * t as u64 + day as u64);
            let mut r = Xoshiro256StarStar::seed_from_u64(seed ^ 0x666c_6565_7400_0001);
            let mut k = (r.next_f64() * 10.0).floor() as u32;
            let rules = ROADS
                .iter()
                .find(|(_, w)| {
                    if k < *w {
                        true
                    } else {
                        k -= w;
                        false
                    }
                })
                .map_or("highway-se", |(name, _)| name);
            let (lo, hi) = cfg.length_km;
            drives.push(FleetDrive {
                truck: t,
                day,
                seed,
                rules: rules.to_string(),
                length_km: lo + (hi - lo) * r.next_f64(),
                mass_scale: 0.75 + 0.25 * r.next_f64(),
                fault: fault.filter(|(_, onset)| day >= *onset).map(|(f, _)| f),
            });
        }
    }
    (trucks, drives)
}

/// What one drive gave; in JSON a non-finite number is `null`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FleetDriveResult {
    /// The plan.
    pub drive: FleetDrive,
    /// The verdict (empty when the drive failed).
    pub verdict: String,
    /// Why the drive failed, if it did.
    pub error: Option<String>,
    /// Truth at this drive: drag area (m²), c_r1, clutch kinetic capacity (N·m), mass (kg).
    #[serde(with = "crate::io::json_f64::array")]
    pub truth: [f64; 4],
    /// Diagnosis time, s.
    pub seconds: f64,
    /// Simulated duration, s.
    pub duration_s: f64,
    /// The estimates (the drive's `parameter_estimates` rows).
    pub rows: Vec<EstimateRow>,
}

/// Simulates and diagnoses one drive in `scratch` (removed afterwards).
pub fn run_drive(
    d: &FleetDrive,
    truck: &FleetTruck,
    vehicle: &Path,
    vf: &VehicleFile,
    scratch: &Path,
) -> FleetDriveResult {
    let mut out = FleetDriveResult {
        drive: d.clone(),
        verdict: String::new(),
        error: None,
        truth: [f64::NAN; 4],
        seconds: 0.0,
        duration_s: 0.0,
        rows: Vec::new(),
    };
    let Some(dl) = vf.driveline.as_ref() else {
        out.error = Some("the vehicle file has no [driveline]".into());
        return out;
    };
    let effect = d.fault.map_or(TruthEffect::None, |f| {
        f.truth(dl.c_w_a_f_m2, dl.clutch_max_torque_nm)
    });
    let cfg = IndependentDriveConfig {
        effect,
        truck_seed: Some(truck.truck_seed),
        mass_scale: d.mass_scale,
        ..IndependentDriveConfig::new(&d.rules, d.length_km, d.seed)
    };
    let result = (|| -> Result<(), String> {
        let mut sim = simulate_independent_drive(vf, &cfg).map_err(|e| e.to_string())?;
        sim.vehicle_id = truck.vehicle_id.clone();
        let p = &sim.params;
        out.truth = [p.c_w_a_f_m2, p.c_r1, p.clutch_kinetic_nm, p.mass_kg];
        let log =
            write_independent_drive(&sim, vehicle, scratch, d.seed).map_err(|e| e.to_string())?;
        out.duration_s = log.duration_s();
        let t0 = std::time::Instant::now();
        let dg = diagnose(&log, vf, &DiagnoseConfig::default()).map_err(|e| e.to_string())?;
        out.seconds = t0.elapsed().as_secs_f64();
        out.verdict = dg.verdict.as_str().to_string();
        out.rows = dg
            .parameters
            .iter()
            .map(|r| EstimateRow {
                effect: r.effect.to_string(),
                unit: r.unit.to_string(),
                value: r.value,
                ci_low: r.ci_low,
                ci_high: r.ci_high,
                nominal: r.nominal,
                tolerance_low: r.tolerance_low,
                tolerance_high: r.tolerance_high,
                method: r.method.as_str().to_string(),
            })
            .collect();
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(scratch);
    out.error = result.err();
    out
}

/// The estimates of a truck's drives up to (not including) day `upto`, as the fleet stage reads
/// them (failed drives left out).
pub fn truck_drives(
    truck: &FleetTruck,
    results: &[&FleetDriveResult],
    upto: usize,
) -> Vec<DriveEstimates> {
    results
        .iter()
        .filter(|r| r.drive.day < upto && r.error.is_none())
        .map(|r| DriveEstimates {
            vehicle_id: truck.vehicle_id.clone(),
            drive_id: format!("{}-day{:03}", truck.vehicle_id, r.drive.day),
            start_ns: crate::truth::drive::START_NS + r.drive.day as i64 * 86_400_000_000_000,
            verdict: r.verdict.clone(),
            source: String::new(),
            rows: r.rows.clone(),
        })
        .collect()
}

/// One truck's score.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruckScore {
    /// Vehicle id.
    pub vehicle_id: String,
    /// Its fault and onset day.
    pub fault: Option<(FleetFault, usize)>,
    /// Drives from the onset until the fault's parameter was flagged (1: on the first faulty
    /// drive); `None`: not flagged by the last drive.
    pub delay: Option<usize>,
    /// False alarms: (parameter, day of the drive that raised it).
    pub false_alarms: Vec<(String, usize)>,
    /// Other parameters flagged after the onset of a fault: (parameter, day).
    pub side_flags: Vec<(String, usize)>,
    /// Final pooled estimate against the truth: (parameter, estimate, truth, relative error).
    pub estimates: Vec<(String, f64, f64, f64)>,
    /// Per trip: the drive's mass estimate against that trip's true mass, (estimate, truth,
    /// relative error), for the drives that inform the mass.
    pub trip_mass: Vec<(f64, f64, f64)>,
    /// Drives that failed.
    pub failed: usize,
}

/// Scores one truck from its drives' results (module documentation): the evidence after every
/// drive, as a nightly job would compute it.
pub fn score_truck(
    truck: &FleetTruck,
    results: &[&FleetDriveResult],
) -> (TruckScore, VehicleEvidence) {
    let n = results.iter().map(|r| r.drive.day + 1).max().unwrap_or(0);
    let flagged = |v: &VehicleEvidence| -> Vec<String> {
        v.parameters
            .iter()
            .filter(|p| p.status == Status::Changed)
            .map(|p| p.effect.id().to_string())
            .collect()
    };
    let mut before: Vec<String> = Vec::new();
    let (mut delay, mut false_alarms, mut side_flags) = (None, Vec::new(), Vec::new());
    for upto in 1..=n {
        let v = vehicle_evidence(&truck.vehicle_id, truck_drives(truck, results, upto));
        let now = flagged(&v);
        let day = upto - 1;
        if let Some((f, onset)) = truck.fault {
            if day >= onset && delay.is_none() && now.iter().any(|p| p == f.effect()) {
                delay = Some(day - onset + 1);
            }
        }
        for p in now.iter().filter(|p| !before.contains(p)) {
            match truck.fault {
                Some((f, onset)) if day >= onset && p == f.effect() => {}
                Some((_, onset)) if day >= onset => side_flags.push((p.clone(), day)),
                _ => false_alarms.push((p.clone(), day)),
            }
        }
        before = now;
    }
    let last = vehicle_evidence(&truck.vehicle_id, truck_drives(truck, results, n));
    let truth = results
        .iter()
        .filter(|r| r.error.is_none())
        .max_by_key(|r| r.drive.day)
        .map_or([f64::NAN; 4], |r| r.truth);
    let estimates = [
        ("aero_drag", 0),
        ("rolling_resistance", 1),
        ("clutch_slip", 2),
    ]
    .iter()
    .filter_map(|&(id, k)| {
        let p = last.parameters.iter().find(|p| p.effect.id() == id)?;
        let est = p.current().pooled.value;
        Some((id.to_string(), est, truth[k], (est - truth[k]) / truth[k]))
    })
    .collect();
    let trip_mass = results
        .iter()
        .filter(|r| r.error.is_none())
        .filter_map(|r| {
            let row = r.rows.iter().find(|x| x.effect == "vehicle_mass")?;
            let truth = r.truth[3];
            row.value
                .is_finite()
                .then(|| (row.value, truth, (row.value - truth) / truth))
        })
        .collect();
    (
        TruckScore {
            vehicle_id: truck.vehicle_id.clone(),
            fault: truck.fault,
            delay,
            false_alarms,
            side_flags,
            estimates,
            trip_mass,
            failed: results.iter().filter(|r| r.error.is_some()).count(),
        },
        last,
    )
}
