//! The fleet evidence as tables (schemas `fleet_vehicles`, `fleet_parameters`, `fleet_changes`,
//! `fleet_trips`): one row per vehicle, per vehicle and parameter, per change, per trip and
//! per-trip parameter.

use super::evidence::{VehicleEvidence, PER_TRIP};
use super::trips::{trips, Trip};
use crate::io::{OutColumn, OutData};
use crate::model::catalogue::Effect;

fn text(name: &str, v: Vec<String>) -> OutColumn {
    OutColumn {
        name: name.into(),
        unit: "1".into(),
        data: OutData::Str(v),
    }
}

fn count(name: &str, v: Vec<u64>) -> OutColumn {
    OutColumn {
        name: name.into(),
        unit: "1".into(),
        data: OutData::U64(v),
    }
}

/// `fleet_vehicles`: drives, period, verdicts, parameters outside tolerance and changes.
pub fn vehicle_columns(vs: &[VehicleEvidence]) -> Vec<OutColumn> {
    let verdicts = |name: &str| -> Vec<u64> {
        vs.iter()
            .map(|v| v.drives.iter().filter(|d| d.verdict == name).count() as u64)
            .collect()
    };
    vec![
        text(
            "vehicle_id",
            vs.iter().map(|v| v.vehicle_id.clone()).collect(),
        ),
        count("drives", vs.iter().map(|v| v.drives.len() as u64).collect()),
        OutColumn::timestamp(vs.iter().map(|v| v.drives[0].start_ns).collect()),
        OutColumn {
            name: "last_drive".into(),
            unit: "ns".into(),
            data: OutData::Timestamp(
                vs.iter()
                    .map(|v| v.drives[v.drives.len() - 1].start_ns)
                    .collect(),
            ),
        },
        count("explained", verdicts("explained")),
        count(
            "no_significant_mismatch",
            verdicts("no_significant_mismatch"),
        ),
        count("unexplained", verdicts("unexplained")),
        count(
            "parameters_flagged",
            vs.iter().map(|v| v.flagged().count() as u64).collect(),
        ),
        count(
            "changes",
            vs.iter()
                .map(|v| v.parameters.iter().map(|p| p.changes.len() as u64).sum())
                .collect(),
        ),
    ]
}

/// `fleet_parameters`: the current segment's pooled estimate of every persistent parameter of
/// every vehicle, against the file.
pub fn parameter_columns(vs: &[VehicleEvidence]) -> Vec<OutColumn> {
    let rows: Vec<(&VehicleEvidence, &super::evidence::ParameterEvidence)> = vs
        .iter()
        .flat_map(|v| v.parameters.iter().map(move |p| (v, p)))
        .collect();
    let f = |g: &dyn Fn(&super::evidence::ParameterEvidence) -> f64| {
        rows.iter().map(|(_, p)| g(p)).collect::<Vec<f64>>()
    };
    let per_row = "per row: see parameter_unit";
    vec![
        text(
            "vehicle_id",
            rows.iter().map(|(v, _)| v.vehicle_id.clone()).collect(),
        ),
        text(
            "effect",
            rows.iter()
                .map(|(_, p)| p.effect.id().to_string())
                .collect(),
        ),
        text(
            "parameter",
            rows.iter()
                .map(|(_, p)| p.effect.parameter().to_string())
                .collect(),
        ),
        text(
            "parameter_unit",
            rows.iter().map(|(_, p)| p.unit.clone()).collect(),
        ),
        OutColumn::f64("value", per_row, f(&|p| p.current().pooled.value)),
        OutColumn::f64("ci_low", per_row, f(&|p| p.current().pooled.ci_low)),
        OutColumn::f64("ci_high", per_row, f(&|p| p.current().pooled.ci_high)),
        OutColumn::f64("nominal", per_row, f(&|p| p.nominal)),
        OutColumn::f64("tolerance_low", per_row, f(&|p| p.band.0)),
        OutColumn::f64("tolerance_high", per_row, f(&|p| p.band.1)),
        OutColumn {
            name: "since".into(),
            unit: "ns".into(),
            data: OutData::Timestamp(rows.iter().map(|(_, p)| p.since_ns()).collect()),
        },
        count(
            "drives",
            rows.iter()
                .map(|(_, p)| (p.current().end - p.current().start) as u64)
                .collect(),
        ),
        count(
            "drives_total",
            rows.iter().map(|(_, p)| p.points.len() as u64).collect(),
        ),
        OutColumn::f64(
            "between_drive_sd",
            per_row,
            f(&|p| p.current().pooled.between_drive_sd),
        ),
        OutColumn::f64("dispersion", "1", f(&|p| p.current().pooled.dispersion)),
        count(
            "changes",
            rows.iter().map(|(_, p)| p.changes.len() as u64).collect(),
        ),
        text(
            "status",
            rows.iter()
                .map(|(_, p)| p.status.as_str().to_string())
                .collect(),
        ),
        text("sentence", rows.iter().map(|(_, p)| p.sentence()).collect()),
    ]
}

/// `fleet_changes`: every change found, with the segments on either side.
pub fn change_columns(vs: &[VehicleEvidence]) -> Vec<OutColumn> {
    struct Row<'a> {
        v: &'a VehicleEvidence,
        p: &'a super::evidence::ParameterEvidence,
        k: usize,
    }
    let rows: Vec<Row<'_>> = vs
        .iter()
        .flat_map(|v| {
            v.parameters
                .iter()
                .flat_map(move |p| (0..p.changes.len()).map(move |k| Row { v, p, k }))
        })
        .collect();
    fn seg<'a>(r: &Row<'a>, after: bool) -> &'a crate::fleet::pool::Pooled {
        &r.p.segments[r.k + usize::from(after)].pooled
    }
    let f = |g: &dyn Fn(&Row<'_>) -> f64| rows.iter().map(g).collect::<Vec<f64>>();
    let per_row = "per row: see parameter_unit";
    let band = |r: &Row<'_>| {
        let a = seg(r, true);
        a.ci_low > r.p.band.1 || a.ci_high < r.p.band.0
    };
    vec![
        text(
            "vehicle_id",
            rows.iter().map(|r| r.v.vehicle_id.clone()).collect(),
        ),
        text(
            "effect",
            rows.iter().map(|r| r.p.effect.id().to_string()).collect(),
        ),
        text(
            "parameter_unit",
            rows.iter().map(|r| r.p.unit.clone()).collect(),
        ),
        OutColumn::timestamp(
            rows.iter()
                .map(|r| r.p.points[r.p.changes[r.k].at].start_ns)
                .collect(),
        ),
        text(
            "first_drive_after",
            rows.iter()
                .map(|r| r.p.points[r.p.changes[r.k].at].drive_id.clone())
                .collect(),
        ),
        OutColumn::f64("value_before", per_row, f(&|r| seg(r, false).value)),
        OutColumn::f64("ci_low_before", per_row, f(&|r| seg(r, false).ci_low)),
        OutColumn::f64("ci_high_before", per_row, f(&|r| seg(r, false).ci_high)),
        count(
            "drives_before",
            rows.iter().map(|r| seg(r, false).n as u64).collect(),
        ),
        OutColumn::f64("value_after", per_row, f(&|r| seg(r, true).value)),
        OutColumn::f64("ci_low_after", per_row, f(&|r| seg(r, true).ci_low)),
        OutColumn::f64("ci_high_after", per_row, f(&|r| seg(r, true).ci_high)),
        count(
            "drives_after",
            rows.iter().map(|r| seg(r, true).n as u64).collect(),
        ),
        OutColumn::f64("p_value", "1", f(&|r| r.p.changes[r.k].p_value)),
        OutColumn {
            name: "outside_tolerance_after".into(),
            unit: "1".into(),
            data: OutData::Bool(rows.iter().map(band).collect()),
        },
    ]
}

/// `fleet_trips`: every drive's estimate of each per-trip parameter
/// ([`super::evidence::PER_TRIP`]), vehicle by vehicle in time order.
pub fn trip_columns(vs: &[VehicleEvidence]) -> Vec<OutColumn> {
    let rows: Vec<(&VehicleEvidence, Effect, Trip<'_>)> = vs
        .iter()
        .flat_map(|v| {
            PER_TRIP
                .iter()
                .flat_map(move |&e| trips(v, e).into_iter().map(move |t| (v, e, t)))
        })
        .collect();
    let f = |g: &dyn Fn(&Trip<'_>) -> f64| rows.iter().map(|(_, _, t)| g(t)).collect::<Vec<f64>>();
    let s = |g: &dyn for<'a> Fn(&'a Trip<'a>) -> &'a str| {
        rows.iter()
            .map(|(_, _, t)| g(t).to_string())
            .collect::<Vec<String>>()
    };
    let per_row = "per row: see parameter_unit";
    vec![
        text(
            "vehicle_id",
            rows.iter().map(|(v, _, _)| v.vehicle_id.clone()).collect(),
        ),
        text("drive_id", s(&|t| t.drive_id)),
        OutColumn::timestamp(rows.iter().map(|(_, _, t)| t.start_ns).collect()),
        text(
            "effect",
            rows.iter().map(|(_, e, _)| e.id().to_string()).collect(),
        ),
        text(
            "parameter",
            rows.iter()
                .map(|(_, e, _)| e.parameter().to_string())
                .collect(),
        ),
        text("parameter_unit", s(&|t| t.unit)),
        OutColumn::f64("value", per_row, f(&|t| t.value)),
        OutColumn::f64("ci_low", per_row, f(&|t| t.ci_low)),
        OutColumn::f64("ci_high", per_row, f(&|t| t.ci_high)),
        OutColumn::f64("nominal", per_row, f(&|t| t.nominal)),
        text("method", s(&|t| t.method)),
        text("source", s(&|t| t.source)),
    ]
}
