//! A vehicle's evidence parameter by parameter ([`vehicle_evidence`]): the per-drive estimates in
//! time order, the changes over time, the current segment's pooled estimate against the vehicle
//! file's tolerance, and a sentence.

use super::change::{changes, segments, Change, FALSE_ALARM, MIN_SEGMENT};
use super::pool::{is_usable, Pooled};
use super::series::{DriveEstimates, EstimateRow};
use crate::model::catalogue::Effect;
use crate::time_fmt::utc_date;

/// Parameters that change from trip to trip with the payload: estimated per drive, never pooled.
pub const PER_TRIP: [Effect; 2] = [Effect::VehicleMass, Effect::CgPosition];

/// What the evidence says of a parameter now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// Fewer than [`MIN_SEGMENT`] drives since the last change (or in all): one drive is one
    /// road, one payload and one driver, too little to judge a vehicle by.
    TooFewDrives,
    /// The current segment's interval overlaps the tolerance band.
    Consistent,
    /// The drives' pooled interval lies outside the band, and did so from the first drive on
    /// (no change): not flagged. A per-drive estimate carries what else its drive's residual
    /// holds, and a truck's own departures from the file within tolerance (an engine map, its
    /// tyres) bias every drive of it alike, so pooling shrinks the interval but not the bias
    /// (docs/fleet.md).
    DiffersFromFile,
    /// The current segment follows a change and lies outside the band: flagged. A bias common
    /// to the truck's drives cancels between the segments a change compares.
    Changed,
}

impl Status {
    /// The spelling in the tables.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::TooFewDrives => "too_few_drives",
            Status::Consistent => "consistent",
            Status::DiffersFromFile => "differs_from_file",
            Status::Changed => "changed",
        }
    }
}

/// One drive's estimate of the parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Point {
    /// Drive id.
    pub drive_id: String,
    /// Time of the drive's first sample, ns.
    pub start_ns: i64,
    /// The drive's `parameter_estimates` file.
    pub source: String,
    /// Estimate and its 95 % interval.
    pub value: f64,
    /// Lower end.
    pub ci_low: f64,
    /// Upper end.
    pub ci_high: f64,
    /// Standard error the interval implies.
    pub se: f64,
    /// How the drive's estimate was obtained.
    pub method: String,
}

/// A segment between changes.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// First drive (index into the points).
    pub start: usize,
    /// One past the last drive.
    pub end: usize,
    /// The pooled estimate.
    pub pooled: Pooled,
}

/// The evidence of one parameter of one vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterEvidence {
    /// The effect whose parameter it is.
    pub effect: Effect,
    /// SI unit.
    pub unit: String,
    /// The vehicle file's value (as of the last drive).
    pub nominal: f64,
    /// Tolerance band.
    pub band: (f64, f64),
    /// Per-drive estimates in time order.
    pub points: Vec<Point>,
    /// Changes found.
    pub changes: Vec<Change>,
    /// Segments between them (the last is the current one).
    pub segments: Vec<Segment>,
    /// What the current segment says.
    pub status: Status,
}

impl ParameterEvidence {
    /// The current segment.
    pub fn current(&self) -> &Segment {
        self.segments.last().expect("at least one segment")
    }

    /// Start of the current segment, ns.
    pub fn since_ns(&self) -> i64 {
        self.points[self.current().start].start_ns
    }

    /// The evidence in one sentence, e.g. "aero_drag: 6.9 m² (6.7 to 7.1) since 2026-05-03,
    /// 23 % above the file (5.6 m²); the 12 drives before were consistent with it."
    pub fn sentence(&self) -> String {
        let c = self.current();
        let p = &c.pooled;
        let unit = if self.unit == "1" {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        let n = c.end - c.start;
        let mut s = format!(
            "{}: {}{unit} ({} to {}) over {n} drive{}",
            self.effect.id(),
            sig(p.value),
            sig(p.ci_low),
            sig(p.ci_high),
            if n == 1 { "" } else { "s" }
        );
        if c.start > 0 {
            s.push_str(&format!(" since {}", utc_date(self.since_ns())));
        }
        let rel = if self.nominal != 0.0 {
            format!(
                ", {} % {} the file ({}{unit})",
                sig(100.0 * ((p.value - self.nominal) / self.nominal).abs()),
                if p.value > self.nominal {
                    "above"
                } else {
                    "below"
                },
                sig(self.nominal)
            )
        } else {
            format!(", the file has {}{unit}", sig(self.nominal))
        };
        s.push_str(&rel);
        s.push_str(match self.status {
            Status::TooFewDrives => ", too few drives to judge",
            Status::Consistent => ", within its tolerance",
            Status::DiffersFromFile => {
                ", outside its tolerance on every drive (not flagged: no change)"
            }
            Status::Changed => ", outside its tolerance since a change",
        });
        if let Some(prev) = self.segments.iter().rev().nth(1) {
            let q = &prev.pooled;
            let held = q.ci_low <= self.band.1 && q.ci_high >= self.band.0;
            s.push_str(&format!(
                "; the {} drives before: {}{unit} ({} to {}), {}",
                prev.end - prev.start,
                sig(q.value),
                sig(q.ci_low),
                sig(q.ci_high),
                if held {
                    "consistent with it"
                } else {
                    "also outside it"
                }
            ));
        }
        s.push('.');
        s
    }
}

/// Three significant figures, no exponent between 10⁻⁴ and 10⁶ (the diagnosis's sentences').
pub use crate::number_fmt::sig3 as sig;

/// The evidence of one vehicle.
#[derive(Debug, Clone, PartialEq)]
pub struct VehicleEvidence {
    /// Vehicle id.
    pub vehicle_id: String,
    /// Its drives, in time order.
    pub drives: Vec<DriveEstimates>,
    /// Persistent parameters with at least one estimate, in catalogue order.
    pub parameters: Vec<ParameterEvidence>,
}

impl VehicleEvidence {
    /// Flagged parameters: the current segment (of at least [`MIN_SEGMENT`] drives) follows a
    /// change and lies outside the tolerance band ([`Status::Changed`]).
    pub fn flagged(&self) -> impl Iterator<Item = &ParameterEvidence> {
        self.parameters
            .iter()
            .filter(|p| p.status == Status::Changed)
    }
}

/// Whether a drive's estimate stopped at an edge of the effect's fit domain
/// ([`crate::model::catalogue::FitRule`]: `lo`, `hi`, times the nominal value for a relative
/// rule) that is only the end of the search: such a fit reads a bound — "at most 0.25 θ₀" — not
/// a value, and pooling it as a value with a Gaussian error would pull the vehicle's estimate to
/// the edge. An edge at the nominal value is a physical limit the truck can sit on (no lash, no
/// delay), and an estimate there is a value. The edge is met within 10⁻⁹ of the domain's width:
/// the fit clamps to the edge exactly, and the margin only absorbs the rounding of the edge
/// recomputed from the nominal value written to the table.
pub fn at_domain_edge(e: Effect, r: &EstimateRow) -> bool {
    let f = e.spec().fit;
    let k = f.factor(r.nominal);
    let (lo, hi) = (f.lo * k, f.hi * k);
    let eps = 1e-9 * (hi - lo).abs();
    let stopped_at = |edge: f64| (r.value - edge).abs() <= eps && (edge - r.nominal).abs() > eps;
    !f.switch && eps > 0.0 && (stopped_at(lo) || stopped_at(hi))
}

/// The band a vehicle's pooled estimate of `e` is judged against: the drives' band of `r` (the
/// file's tolerance widened by the catalogue's model-form allowance of a full fit,
/// [`crate::model::catalogue::EffectSpec::model_form`]), each side widened further to the
/// allowance of the linearised estimates where that is the larger
/// ([`crate::model::catalogue::EffectSpec::linearised_form`]): the pool holds estimates of
/// both kinds, and most are linearised.
pub fn pooled_band(e: Effect, r: &EstimateRow) -> (f64, f64) {
    let spec = e.spec();
    let (full_below, full_above) = spec.model_form.widths(r.nominal);
    let (lin_below, lin_above) = spec.linearised_form.widths(r.nominal);
    (
        r.tolerance_low - (lin_below - full_below).max(0.0),
        r.tolerance_high + (lin_above - full_above).max(0.0),
    )
}

/// The evidence of one vehicle from its drives (any order; sorted by start time, then drive id):
/// for every persistent catalogue parameter (not [`PER_TRIP`], not a switch) the drives'
/// estimates (those that stopped at the edge of the fit domain left out, [`at_domain_edge`]),
/// the changes at [`FALSE_ALARM`], the segments and the current status (judged only on at
/// least [`MIN_SEGMENT`] drives; flagged only after a change).
pub fn vehicle_evidence(vehicle_id: &str, mut drives: Vec<DriveEstimates>) -> VehicleEvidence {
    drives.sort_by(|a, b| (a.start_ns, &a.drive_id).cmp(&(b.start_ns, &b.drive_id)));
    let mut parameters = Vec::new();
    for e in Effect::ALL {
        if PER_TRIP.contains(&e) || e == Effect::SlopeQuantization {
            continue;
        }
        let mut points = Vec::new();
        let mut last = None;
        for d in &drives {
            if let Some(r) = d.rows.iter().find(|r| r.effect == e.id()) {
                let se = r.standard_error();
                if is_usable(&(r.value, se)) && !at_domain_edge(e, r) {
                    points.push(Point {
                        drive_id: d.drive_id.clone(),
                        start_ns: d.start_ns,
                        source: d.source.clone(),
                        value: r.value,
                        ci_low: r.ci_low,
                        ci_high: r.ci_high,
                        se,
                        method: r.method.clone(),
                    });
                    last = Some(r);
                }
            }
        }
        let Some(last) = last else {
            continue;
        };
        let xs: Vec<(f64, f64)> = points.iter().map(|p| (p.value, p.se)).collect();
        let found = changes(&xs, FALSE_ALARM);
        let segs: Vec<Segment> = segments(&xs, &found)
            .into_iter()
            .filter_map(|(start, end, p)| p.map(|pooled| Segment { start, end, pooled }))
            .collect();
        let Some(cur) = segs.last() else {
            continue;
        };
        let band = pooled_band(e, last);
        let status = if cur.end - cur.start < MIN_SEGMENT {
            Status::TooFewDrives
        } else if cur.pooled.ci_low > band.1 || cur.pooled.ci_high < band.0 {
            if found.is_empty() {
                Status::DiffersFromFile
            } else {
                Status::Changed
            }
        } else {
            Status::Consistent
        };
        parameters.push(ParameterEvidence {
            effect: e,
            unit: last.unit.clone(),
            nominal: last.nominal,
            band,
            points,
            changes: found,
            segments: segs,
            status,
        });
    }
    VehicleEvidence {
        vehicle_id: vehicle_id.to_string(),
        drives,
        parameters,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fleet::series::EstimateRow;

    fn drive(i: usize, drag: f64) -> DriveEstimates {
        DriveEstimates {
            vehicle_id: "TRK-1".into(),
            drive_id: format!("d{i:02}"),
            start_ns: 1_700_000_000_000_000_000 + i as i64 * 86_400_000_000_000,
            verdict: "no_significant_mismatch".into(),
            source: String::new(),
            rows: vec![EstimateRow {
                effect: "aero_drag".into(),
                unit: "m^2".into(),
                value: drag,
                ci_low: drag - 0.4,
                ci_high: drag + 0.4,
                nominal: 5.6,
                tolerance_low: 5.32,
                tolerance_high: 5.88,
                method: "linearised".into(),
            }],
        }
    }

    #[test]
    fn a_changed_drag_area_is_dated_and_set_against_the_pooled_band() {
        // the pooled band: the rows' 5.32–5.88 m², not widened below (the linearised
        // estimates' allowance, 16 % of 5.6 m², is below the full fit's 21 %) and widened above
        // by what the linearised estimates' allowance adds to the full fit's (190 % against 82 %)
        let (lo, hi) = pooled_band(Effect::AeroDrag, &drive(0, 5.6).rows[0]);
        assert!((lo - 5.32).abs() < 1e-9, "{lo}");
        assert!((hi - (5.88 + 1.08 * 5.6)).abs() < 1e-9, "{hi}");
        // 12 drives at the file's value, then 18 at a new level, alternating ±0.1 around each
        for (level, status, words) in [
            // a lost fairing: dated, but within what the models' own error allows
            (
                6.9,
                Status::Consistent,
                "23.2 % above the file (5.60 m^2), within its tolerance",
            ),
            // 123 % above: flagged
            (
                12.5,
                Status::Changed,
                "123 % above the file (5.60 m^2), outside its tolerance",
            ),
        ] {
            let drives: Vec<DriveEstimates> = (0..30)
                .map(|i| {
                    let l = if i < 12 { 5.6 } else { level };
                    drive(i, l + if i.is_multiple_of(2) { 0.1 } else { -0.1 })
                })
                .collect();
            let v = vehicle_evidence("TRK-1", drives.into_iter().rev().collect());
            let p = &v.parameters[0];
            assert_eq!(p.effect, Effect::AeroDrag);
            assert_eq!(p.band, (lo, hi));
            assert_eq!(p.changes.len(), 1);
            assert_eq!(p.changes[0].at, 12);
            assert_eq!(p.status, status, "{level}");
            let s = p.sentence();
            assert!(
                s.starts_with(&format!("aero_drag: {} m^2", sig(level))),
                "{s}"
            );
            assert!(s.contains("since 2023-11-26") && s.contains(words), "{s}");
            assert!(
                s.contains("the 12 drives before: 5.60 m^2") && s.contains("consistent with it"),
                "{s}"
            );
        }
    }

    #[test]
    fn fits_stopped_at_the_domain_edge_are_left_out() {
        // ten drives at the file's value and three whose drag fit stopped at 0.25 θ₀ (the fit
        // domain's lower edge): the three read only a bound and are not pooled
        let mut drives: Vec<DriveEstimates> = (0..10)
            .map(|i| drive(i, 5.6 + if i.is_multiple_of(2) { 0.1 } else { -0.1 }))
            .collect();
        for i in 10..13 {
            let mut d = drive(i, 0.25 * 5.6);
            d.rows[0].ci_high = 22.4;
            drives.push(d);
        }
        assert!(at_domain_edge(Effect::AeroDrag, &drives[10].rows[0]));
        assert!(!at_domain_edge(Effect::AeroDrag, &drives[0].rows[0]));
        // no lash is the lash domain's lower edge and the file's value: a value, kept
        let no_lash = EstimateRow {
            effect: "driveline_backlash".into(),
            value: 0.0,
            ci_low: 0.0,
            ci_high: 0.01,
            nominal: 0.0,
            ..drives[0].rows[0].clone()
        };
        assert!(!at_domain_edge(Effect::DrivelineBacklash, &no_lash));
        let v = vehicle_evidence("TRK-1", drives);
        let p = &v.parameters[0];
        assert_eq!(p.points.len(), 10);
        assert!(
            (p.current().pooled.value - 5.6).abs() < 1e-9,
            "{:?}",
            p.current()
        );
        assert_eq!(p.status, Status::Consistent);
    }

    #[test]
    fn a_clean_vehicle_is_consistent_without_change() {
        let drives: Vec<DriveEstimates> = (0..30)
            .map(|i| drive(i, 5.6 + if i.is_multiple_of(2) { 0.1 } else { -0.1 }))
            .collect();
        let v = vehicle_evidence("TRK-1", drives);
        let p = &v.parameters[0];
        assert!(p.changes.is_empty());
        assert_eq!(p.status, Status::Consistent);
        assert_eq!(v.flagged().count(), 0);
    }

    #[test]
    fn three_significant_digits() {
        assert_eq!(sig(6.9), "6.90");
        assert_eq!(sig(0.00612), "0.00612");
        assert_eq!(sig(400000.0), "400000");
        assert_eq!(sig(-21.46), "-21.5");
    }
}
