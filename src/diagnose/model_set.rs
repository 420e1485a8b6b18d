//! The models a recording drives and how they are compared (docs/diagnosis/method.md, steps 1
//! and 2): the longitudinal model when the log has vehicle and engine speed, engine torque and
//! gear, the axle model with the three bellow pressures and a vehicle with axles, and the rows
//! of each compared signal that count ([`ModelSet::compared`]). The noise floor
//! ([`super::noise`]) runs the same comparison on every perturbed copy.

use super::compare::{compare_at, Compared};
use super::extended::{AxleModel, LongitudinalConfig, LongitudinalModel, Theta};
use super::noise_error::NoiseError;
use crate::model::extended_vehicle::ExtendedVehicle;
use crate::schema::Interpolation;
use crate::signal::distance::fill_gaps;
use crate::table::DriveLog;

/// The models a recording drives and how they are compared (the compare step's settings).
#[derive(Debug, Clone)]
pub struct ModelSet<'a> {
    /// The nominal vehicle.
    pub truth: &'a ExtendedVehicle,
    /// Gear ratios.
    pub ratios: &'a [f64],
    /// Nominal parameters.
    pub nominal: Theta,
    /// Longitudinal model settings (`None`: not run).
    pub longitudinal: Option<LongitudinalConfig>,
    /// Run the axle model.
    pub axle: bool,
    /// Also compare the engine speed on the clutch-actuated rows
    /// ([`super::rows::actuation_channel_rows`], as [`super::rows::ACTUATION_CHANNEL`]):
    /// its floor weights the explain step's clutch-actuation view; it is not located.
    pub actuation: bool,
}

const PRESSURES: [&str; 3] = [
    "bellow_pressure_front",
    "bellow_pressure_rear",
    "bellow_pressure_tag",
];

fn has(log: &DriveLog, c: &str) -> bool {
    log.signal(c)
        .is_some_and(|v| v.iter().any(|x| x.is_finite()))
}

impl<'a> ModelSet<'a> {
    /// Every column [`ModelSet::compared`] reads off a recording, whichever models run: the
    /// models' inputs ([`super::rows::MODEL_INPUTS`]), the engine speed, the axle model's
    /// acceleration and the bellow pressures. A noise copy holds these alone
    /// ([`super::noise::noise_floors`]).
    pub fn read_columns() -> Vec<&'static str> {
        super::rows::MODEL_INPUTS
            .into_iter()
            .chain(["engine_speed", "longitudinal_acceleration"])
            .chain(PRESSURES)
            .collect()
    }

    /// The models `log` can drive: longitudinal with vehicle and engine speed, engine torque
    /// and gear; axle with the three bellow pressures and a vehicle with axles.
    pub fn for_log(
        log: &DriveLog,
        truth: &'a ExtendedVehicle,
        ratios: &'a [f64],
        nominal: Theta,
    ) -> ModelSet<'a> {
        let long = ["vehicle_speed", "engine_speed", "engine_torque", "gear"]
            .iter()
            .all(|c| has(log, c));
        let axle = truth.axles.is_some() && PRESSURES.iter().all(|c| has(log, c));
        ModelSet {
            truth,
            ratios,
            nominal,
            longitudinal: long.then(LongitudinalConfig::default),
            axle,
            actuation: false,
        }
    }

    /// The compared signals of `log` at `theta` ([`compare_at`]). Rows that count: the
    /// recorded value is a real sample (not a filled gap); for the longitudinal signals also
    /// vehicle speed at least [`LongitudinalConfig::min_speed_mps`], engine speed recorded and
    /// no clutch transition near ([`super::rows::longitudinal_rows`]); for the pressures no
    /// shift near ([`super::rows::axle_rows`]).
    ///
    /// # Errors
    /// [`NoiseError::Model`] when a model cannot be built or run.
    pub fn compared(&self, log: &DriveLog, theta: &Theta) -> Result<Vec<Compared>, NoiseError> {
        let n = log.len();
        let long = match self.longitudinal {
            Some(cfg) => Some(LongitudinalModel::new(
                log,
                self.truth,
                self.ratios,
                self.nominal,
                cfg,
            )?),
            None => None,
        };
        let long_valid: Vec<bool> = match (&self.longitudinal, log.signal("vehicle_speed")) {
            (Some(cfg), Some(v)) => {
                let w = log.signal("engine_speed");
                let steady = super::rows::longitudinal_rows(log);
                (0..n)
                    .map(|i| {
                        v[i].is_finite()
                            && v[i] >= cfg.min_speed_mps
                            && w.is_some_and(|w| w[i].is_finite())
                            && steady[i]
                    })
                    .collect()
            }
            _ => vec![false; n],
        };
        let axle = if self.axle {
            Some(AxleModel::new(log, self.truth, self.ratios, self.nominal)?)
        } else {
            None
        };
        let (mut meas, mut valid): (Vec<Vec<f64>>, Vec<Vec<bool>>) = (Vec::new(), Vec::new());
        if self.axle {
            let steady = super::rows::axle_rows(log);
            for c in PRESSURES {
                let raw = log.signal(c).unwrap_or(&[]);
                valid.push(
                    raw.iter()
                        .zip(&steady)
                        .map(|(x, s)| x.is_finite() && *s)
                        .collect(),
                );
                meas.push(fill_gaps(raw, Interpolation::Linear).unwrap_or_else(|| raw.to_vec()));
            }
        }
        let am: Option<[Vec<f64>; 3]> = meas.try_into().ok();
        let av: Option<[Vec<bool>; 3]> = valid.try_into().ok();
        let engine_valid = super::rows::engine_speed_rows(log);
        let mut out = compare_at(
            long.as_ref(),
            axle.as_ref(),
            theta,
            &long_valid,
            &engine_valid,
            am.as_ref(),
            av.as_ref(),
        )?;
        if let (true, Some(cfg)) = (self.actuation, &self.longitudinal) {
            if let Some(es) = out.iter().find(|c| c.name == "engine_speed") {
                let c = Compared {
                    name: super::rows::ACTUATION_CHANNEL.into(),
                    unit: es.unit.clone(),
                    measured: es.measured.clone(),
                    simulated: es.simulated.clone(),
                    valid: super::rows::actuation_channel_rows(log, cfg.min_speed_mps),
                };
                out.push(c);
            }
        }
        Ok(out)
    }
}
