//! Parameters that change from trip to trip with the payload ([`PER_TRIP`]: the vehicle's mass
//! and its centre of gravity's position): each drive's estimate is kept as the estimate of that
//! trip ([`trips`]), with its interval, and summarised per vehicle over its trips
//! ([`TripSummary`]), never pooled into one value or tested for a change.

use super::evidence::{sig, VehicleEvidence, PER_TRIP};
use crate::model::catalogue::Effect;
use crate::signal::stats::median;

/// One trip's estimate of a per-trip parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Trip<'a> {
    /// Drive id.
    pub drive_id: &'a str,
    /// Time of the drive's first sample, ns since the Unix epoch.
    pub start_ns: i64,
    /// The drive's `parameter_estimates` file.
    pub source: &'a str,
    /// Estimate, in the parameter's SI unit.
    pub value: f64,
    /// 95 % interval, lower end.
    pub ci_low: f64,
    /// 95 % interval, upper end.
    pub ci_high: f64,
    /// The vehicle file's value.
    pub nominal: f64,
    /// SI unit.
    pub unit: &'a str,
    /// `named`, `fitted` or `linearised`.
    pub method: &'a str,
}

/// The trips of `v` with a finite estimate of `e`'s parameter, in time order.
pub fn trips(v: &VehicleEvidence, e: Effect) -> Vec<Trip<'_>> {
    v.drives
        .iter()
        .filter_map(|d| {
            let r = d.rows.iter().find(|r| r.effect == e.id())?;
            (r.value.is_finite() && r.ci_low.is_finite() && r.ci_high.is_finite()).then_some(Trip {
                drive_id: &d.drive_id,
                start_ns: d.start_ns,
                source: &d.source,
                value: r.value,
                ci_low: r.ci_low,
                ci_high: r.ci_high,
                nominal: r.nominal,
                unit: &r.unit,
                method: &r.method,
            })
        })
        .collect()
}

/// A vehicle's trips of one per-trip parameter at a glance.
#[derive(Debug, Clone, PartialEq)]
pub struct TripSummary {
    /// The effect whose parameter it is.
    pub effect: Effect,
    /// Trips with an estimate.
    pub trips: usize,
    /// Smallest estimate.
    pub min: f64,
    /// Median estimate (the mean of the middle two for an even count).
    pub median: f64,
    /// Largest estimate.
    pub max: f64,
    /// The vehicle file's value (as of the last trip).
    pub nominal: f64,
    /// SI unit.
    pub unit: String,
}

impl TripSummary {
    /// The summary of `e`'s trips on `v`; `None` without any.
    pub fn of(v: &VehicleEvidence, e: Effect) -> Option<Self> {
        let t = trips(v, e);
        let last = t.last()?;
        let mut xs: Vec<f64> = t.iter().map(|x| x.value).collect();
        let median = median(&mut xs); // sorts
        let n = xs.len();
        Some(Self {
            effect: e,
            trips: n,
            min: xs[0],
            median,
            max: xs[n - 1],
            nominal: last.nominal,
            unit: last.unit.to_string(),
        })
    }

    /// Every per-trip parameter of `v` with at least one trip, in [`PER_TRIP`] order.
    pub fn all(v: &VehicleEvidence) -> Vec<Self> {
        PER_TRIP.iter().filter_map(|&e| Self::of(v, e)).collect()
    }

    /// In one sentence: "vehicle_mass: 31200 to 40100 kg over 30 trips, median 36500 kg; the
    /// file has 40000 kg" ("vehicle_mass: 39800 kg on 1 trip; …" for one).
    pub fn sentence(&self) -> String {
        let unit = if self.unit == "1" {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        if self.trips == 1 {
            return format!(
                "{}: {}{unit} on 1 trip; the file has {}{unit}",
                self.effect.id(),
                sig(self.median),
                sig(self.nominal)
            );
        }
        format!(
            "{}: {} to {}{unit} over {} trip{}, median {}{unit}; the file has {}{unit}",
            self.effect.id(),
            sig(self.min),
            sig(self.max),
            self.trips,
            if self.trips == 1 { "" } else { "s" },
            sig(self.median),
            sig(self.nominal)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fleet::evidence::vehicle_evidence;
    use crate::fleet::series::{DriveEstimates, EstimateRow};

    fn drive(i: usize, mass: Option<f64>) -> DriveEstimates {
        let row = |effect: &str, unit: &str, value: f64, nominal: f64| EstimateRow {
            effect: effect.into(),
            unit: unit.into(),
            value,
            ci_low: value * 0.98,
            ci_high: value * 1.02,
            nominal,
            tolerance_low: nominal * 0.97,
            tolerance_high: nominal * 1.03,
            method: "linearised".into(),
        };
        let mut rows = vec![row("aero_drag", "m^2", 5.6, 5.6)];
        if let Some(m) = mass {
            rows.push(row("vehicle_mass", "kg", m, 40_000.0));
        }
        DriveEstimates {
            vehicle_id: "TRK-1".into(),
            drive_id: format!("d{i:02}"),
            start_ns: 1_700_000_000_000_000_000 + i as i64 * 86_400_000_000_000,
            verdict: "no_significant_mismatch".into(),
            source: format!("d{i:02}.parquet"),
            rows,
        }
    }

    #[test]
    fn each_trip_keeps_its_own_mass_and_the_vehicle_is_summarised() {
        // payload from trip to trip; one drive does not inform the mass
        let masses = [
            Some(31_000.0),
            Some(40_100.0),
            None,
            Some(36_000.0),
            Some(38_000.0),
        ];
        let drives: Vec<DriveEstimates> = masses
            .iter()
            .enumerate()
            .map(|(i, m)| drive(i, *m))
            .rev()
            .collect();
        let v = vehicle_evidence("TRK-1", drives);
        let t = trips(&v, Effect::VehicleMass);
        assert_eq!(
            t.iter().map(|x| x.drive_id).collect::<Vec<_>>(),
            ["d00", "d01", "d03", "d04"]
        );
        assert_eq!(t[1].value, 40_100.0);
        assert!((t[1].ci_low - 39_298.0).abs() < 1e-6);
        // the mass is never pooled into the persistent parameters
        assert!(v.parameters.iter().all(|p| p.effect != Effect::VehicleMass));
        let s = TripSummary::of(&v, Effect::VehicleMass).unwrap();
        assert_eq!(
            (s.trips, s.min, s.median, s.max),
            (4, 31_000.0, 37_000.0, 40_100.0)
        );
        assert_eq!(
            s.sentence(),
            "vehicle_mass: 31000 to 40100 kg over 4 trips, median 37000 kg; the file has 40000 kg"
        );
        assert!(TripSummary::of(&v, Effect::CgPosition).is_none());
        let one = vehicle_evidence("TRK-1", vec![drive(0, Some(39_774.5))]);
        assert_eq!(
            TripSummary::of(&one, Effect::VehicleMass)
                .unwrap()
                .sentence(),
            "vehicle_mass: 39774 kg on 1 trip; the file has 40000 kg"
        );
        assert_eq!(TripSummary::all(&v).len(), 1);
    }
}
