//! The windows a clutch capacity cannot reach: what lets the fits of `clutch_slip` simulate only
//! the windows where the capacity acts ([`super::longitudinal_model::LongitudinalModel`]).
//!
//! # Why a window can be reused
//! The longitudinal model simulates a recording in windows, each started from the measured
//! state ([`super::simulation_windows`]), and the start state and clutch mode do not depend on
//! the clutch capacity `M_k,max` (`clutch_max_torque_nm`). A window whose clutch stays locked
//! from its first sample to its last reads the capacity only in the test that would unlock it,
//! `|M_trans| > (M_s/M_k)·M_k(x)` with `M_k(x) = M_k,max·f(x)`, `f ≥ 0`
//! ([`crate::sim::fast::SpanEnd::locked_throughout`]). With a larger capacity that test fails at
//! every step too, so the window's samples are the same, bit for bit. A window's rows (from its
//! start to the next window's) are interpolated from its own samples and the next window's first
//! sample, the start state, so they are the same too.
//!
//! So a simulation at capacity `c` with every other parameter the same as a recorded
//! simulation at `c_ref ≤ c` ([`Reach`]) need not integrate the windows the record found locked
//! throughout: their rows are the record's. A window where the clutch unlocked at `c_ref` is the
//! same up to the whole step in which it first unlocked, for the same reason: the simulation
//! takes it up at that step's start from the state the record kept
//! ([`crate::sim::fast::FastDriveline::resume_span_states`]), and the rows up to that step's
//! start are the record's (those after it are interpolated from samples the resumed simulation
//! gives, the step's start the first of them). A fit of the capacity (the start grid of 50–100 %
//! of the file's in 1.5 % steps, then the secant steps and the interval's) asks for the same
//! drive at dozens of capacities, and only the windows where the clutch slips at some of them —
//! launches, shifts, full-torque climbs — change between them.
//!
//! # What is kept
//! Simulations whose capacity departs from the vehicle file's are recorded (those of the
//! capacity's fits; one with no window locked throughout and none to take up is not), whatever
//! their other parameters, within [`REACH_BUDGET_BYTES`] of rows per model (plus one state per
//! window to take up), the oldest dropped first when the budget is full; none on a long drive
//! ([`super::long_drive::is_long`]), whose memory is budgeted without them. A simulation reads
//! the record with its other parameters that serves the most windows, the highest capacity
//! among equals. Whether a record exists changes the time a simulation takes, never
//! its outputs: the rows of a window are the same whether it was integrated or read from a
//! record, so the diagnosis's results do not depend on the order its parallel fits ran in.

use super::effect_parameters::{index, Theta};
use crate::model::catalogue::Effect;
use crate::sim::fast::Resume;
use std::sync::{Arc, Mutex};

/// Bytes of recorded rows a model keeps at most (two series of `f64` per record): 32 MiB, about
/// 17 records of a 20-minute drive at 100 Hz.
pub const REACH_BUDGET_BYTES: usize = 32 << 20;

/// One recorded simulation: its parameters, which windows stayed locked, and its rows.
#[derive(Debug)]
pub struct Reach {
    /// The parameters' bits, the clutch capacity's zeroed ([`reach_key`]).
    key: [u64; 16],
    /// Clutch capacity `M_k,max`, N·m.
    pub capacity_nm: f64,
    /// Per window: integrated with the clutch locked at every sample (or read from a record
    /// of a lower capacity that was). A window the simulation left out is `false`.
    pub locked: Vec<bool>,
    /// Per window that began locked and unlocked: its piece ([`super::simulation_windows`])
    /// and the whole step of that piece where a larger capacity takes it up.
    pub resume: Vec<Option<(usize, Resume)>>,
    /// Vehicle speed on the log's rows, m/s.
    pub vehicle_speed: Vec<f64>,
    /// Engine speed on the log's rows, rad/s.
    pub engine_speed: Vec<f64>,
}

impl Reach {
    /// Windows this record lets a simulation at `capacity_nm` skip or take up part-way.
    fn reaches(&self, key: &[u64; 16], capacity_nm: f64) -> usize {
        if &self.key == key && self.capacity_nm <= capacity_nm {
            self.locked.iter().filter(|&&l| l).count()
                + self.resume.iter().filter(|r| r.is_some()).count()
        } else {
            0
        }
    }
}

/// The bits of `theta` with the clutch capacity's zeroed: what must be equal for a record to
/// serve another simulation.
pub fn reach_key(theta: &Theta) -> [u64; 16] {
    let mut k = theta.0.map(f64::to_bits);
    k[index(Effect::ClutchSlip)] = 0;
    k
}

/// The records of one model (see the module documentation).
#[derive(Debug, Default)]
pub struct CapacityReach {
    /// Most records kept (0: none).
    max_records: usize,
    records: Mutex<Vec<Arc<Reach>>>,
}

impl Clone for CapacityReach {
    /// A clone starts without records.
    fn clone(&self) -> Self {
        CapacityReach {
            max_records: self.max_records,
            records: Mutex::default(),
        }
    }
}

impl CapacityReach {
    /// The records of a model of a recording of `rows` rows (none on a long drive).
    pub fn new(rows: usize) -> Self {
        let max_records = if super::long_drive::is_long(rows) {
            0
        } else {
            REACH_BUDGET_BYTES / (16 * rows.max(1))
        };
        CapacityReach {
            max_records,
            records: Mutex::default(),
        }
    }

    /// The record that lets a simulation at `theta` skip the most windows, if any.
    pub fn best_for(&self, theta: &Theta) -> Option<Arc<Reach>> {
        if self.max_records == 0 {
            return None;
        }
        let key = reach_key(theta);
        let c = theta.get(Effect::ClutchSlip);
        let records = self.records.lock().unwrap_or_else(|e| e.into_inner());
        // among those that serve as many windows, the highest capacity: its windows unlock
        // latest (capacities are positive, so their bits order as they do)
        records
            .iter()
            .map(|r| (r.reaches(&key, c), r))
            .filter(|(n, _)| *n > 0)
            .max_by_key(|(n, r)| (*n, r.capacity_nm.to_bits()))
            .map(|(_, r)| Arc::clone(r))
    }

    /// Whether a simulation at `theta` would be recorded (when it has windows to serve): records
    /// are kept and its capacity departs from `nominal`'s.
    pub fn keeps(&self, theta: &Theta, nominal: &Theta) -> bool {
        self.max_records > 0
            && theta.get(Effect::ClutchSlip).to_bits() != nominal.get(Effect::ClutchSlip).to_bits()
    }

    /// Records a simulation at `theta` whose capacity departs from `nominal`'s (others are not
    /// kept), the oldest record dropped when the budget is full.
    pub fn keep(
        &self,
        theta: &Theta,
        nominal: &Theta,
        (locked, resume): (Vec<bool>, Vec<Option<(usize, Resume)>>),
        vehicle_speed: &[f64],
        engine_speed: &[f64],
    ) {
        let c = theta.get(Effect::ClutchSlip);
        if !self.keeps(theta, nominal)
            || (!locked.contains(&true) && resume.iter().all(Option::is_none))
        {
            return;
        }
        let r = Arc::new(Reach {
            key: reach_key(theta),
            capacity_nm: c,
            locked,
            resume,
            vehicle_speed: vehicle_speed.to_vec(),
            engine_speed: engine_speed.to_vec(),
        });
        let mut records = self.records.lock().unwrap_or_else(|e| e.into_inner());
        if records.len() >= self.max_records {
            records.remove(0);
        }
        records.push(r);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn theta(capacity_nm: f64, mass_kg: f64) -> Theta {
        let mut t = Theta([1.0; 16]);
        t.set(Effect::ClutchSlip, capacity_nm);
        t.set(Effect::VehicleMass, mass_kg);
        t
    }

    #[test]
    fn a_record_serves_the_same_parameters_at_its_capacity_and_above() {
        let nominal = theta(3000.0, 40e3);
        let reach = CapacityReach::new(1000);
        let rows = vec![0.0; 1000];
        reach.keep(
            &theta(1500.0, 40e3),
            &nominal,
            (vec![true, false, true], vec![None; 3]),
            &rows,
            &rows,
        );
        reach.keep(
            &theta(2000.0, 40e3),
            &nominal,
            (vec![true, true, true], vec![None; 3]),
            &rows,
            &rows,
        );
        // the most windows among the records at or below the capacity
        assert_eq!(
            reach.best_for(&theta(2500.0, 40e3)).unwrap().capacity_nm,
            2000.0
        );
        assert_eq!(
            reach.best_for(&theta(2000.0, 40e3)).unwrap().capacity_nm,
            2000.0
        );
        assert_eq!(
            reach.best_for(&theta(1800.0, 40e3)).unwrap().capacity_nm,
            1500.0
        );
        assert!(reach.best_for(&theta(1400.0, 40e3)).is_none());
        // another mass: no record
        assert!(reach.best_for(&theta(2500.0, 41e3)).is_none());
    }

    #[test]
    fn the_files_capacity_and_windowless_records_are_not_kept_and_the_oldest_goes_first() {
        let nominal = theta(3000.0, 40e3);
        let rows = vec![0.0; 1000];
        let reach = CapacityReach::new(1000);
        reach.keep(&nominal, &nominal, (vec![true], vec![None]), &rows, &rows);
        reach.keep(
            &theta(2000.0, 40e3),
            &nominal,
            (vec![false], vec![None]),
            &rows,
            &rows,
        );
        assert!(reach.best_for(&theta(3500.0, 40e3)).is_none());
        // a budget of two records
        let reach = CapacityReach {
            max_records: 2,
            records: Mutex::default(),
        };
        for c in [1000.0, 1500.0, 2000.0] {
            reach.keep(
                &theta(c, 40e3),
                &nominal,
                (vec![true], vec![None]),
                &rows,
                &rows,
            );
        }
        assert!(reach.best_for(&theta(1200.0, 40e3)).is_none());
        assert_eq!(
            reach.best_for(&theta(1600.0, 40e3)).unwrap().capacity_nm,
            1500.0
        );
        // none on a long drive
        assert_eq!(
            CapacityReach::new(super::super::long_drive::LONG_DRIVE_MIN_ROWS).max_records,
            0
        );
    }
}
