//! The run report's `summary.md` (docs/pipelines.md, "The run report"): the run's counts and
//! throughput, failures, stages skipped, bad samples masked at ingest, the slowest drives, the
//! error metrics across the fleet and the plots beside it.

use super::record::{DriveOutcome, DriveStatus, RunReport};
use super::spec::Plan;
use crate::sim::slope_shuffle::GearShuffle;
use std::fmt::Write as _;

/// A metric's distribution: name, unit, and `drives, mean, min, p05, p50, p95, max`.
pub(super) type Distribution = (&'static str, &'static str, [f64; 7]);

fn fmt_val(x: f64) -> String {
    if !x.is_finite() {
        "–".into()
    } else if x != 0.0 && (x.abs() < 1e-2 || x.abs() >= 1e5) {
        format!("{x:.3e}")
    } else {
        format!("{x:.3}")
    }
}

/// Markdown-safe cell text.
fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// Per gear, the shuffle the slope filter removes, all drives pooled (the `shuffle` stage with
/// `compare_raw_slope`; [`crate::sim::slope_shuffle::pool`]).
fn slope_shuffle_section(s: &mut String, pooled: &[GearShuffle]) {
    if pooled.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "## Shuffle the slope filter removes, per gear\n\nMean square of the 1–5 Hz shuffle indicator of the simulated speed: the raw-slope run minus the filtered-slope run (the shuffle the slope content removed by the filter excites), beside all shuffle with the raw slope; all drives pooled, weighted by samples.\n"
    );
    let _ = writeln!(
        s,
        "| gear | samples | removed by the filter [m²/s²] | all shuffle, raw slope [m²/s²] | removed / all |\n| --- | --- | --- | --- | --- |"
    );
    for g in pooled {
        let share = if g.ms_total_m2_per_s2 > 0.0 {
            format!(
                "{:.1} %",
                100.0 * g.ms_slope_m2_per_s2 / g.ms_total_m2_per_s2
            )
        } else {
            "–".into()
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {share} |",
            g.gear,
            g.samples,
            fmt_val(g.ms_slope_m2_per_s2),
            fmt_val(g.ms_total_m2_per_s2)
        );
    }
    let _ = writeln!(s);
}

/// Recordings split at logger pauses: each drive's segment and the segments skipped.
fn split_section(s: &mut String, report: &RunReport) {
    // (input, segment, drive id, start, duration, outcome), in input and segment order
    let mut rows: Vec<(&str, usize, &str, i64, f64, String)> = report
        .drives
        .iter()
        .filter_map(|d| d.record.as_ref())
        .filter_map(|r| {
            r.segment.as_ref().map(|g| {
                (
                    r.input.as_str(),
                    g.index,
                    r.drive_id.as_str(),
                    g.start_ns,
                    (g.end_ns - g.start_ns) as f64 * 1e-9,
                    format!("drive ({} segments)", g.count),
                )
            })
        })
        .collect();
    rows.extend(report.skipped_segments.iter().map(|k| {
        let g = &k.segment;
        (
            k.input.as_str(),
            g.index,
            g.drive_id.as_str(),
            g.start_ns,
            g.duration_s,
            format!("skipped: {}", g.reason),
        )
    }));
    rows.sort_by(|a, b| (a.0, a.1).cmp(&(b.0, b.1)));
    let _ = writeln!(
        s,
        "## Recordings split at pauses ({} segments)\n",
        rows.len()
    );
    if rows.is_empty() {
        let _ = writeln!(s, "None.\n");
        return;
    }
    let _ = writeln!(
        s,
        "| input | segment | drive | start | duration | outcome |\n| --- | --- | --- | --- | --- | --- |"
    );
    for (input, index, id, start, duration, outcome) in rows {
        let _ = writeln!(
            s,
            "| `{}` | {index} | {} | {} | {duration:.0} s | {} |",
            cell(input),
            cell(id),
            crate::time_fmt::rfc3339_ns(start),
            cell(&outcome)
        );
    }
    let _ = writeln!(s);
}

pub(super) fn summary_md(
    plan: &Plan,
    report: &RunReport,
    dist: &[Distribution],
    by_gear: &[GearShuffle],
    plots: &[(&str, &str)],
    spectrum_line: Option<&str>,
) -> String {
    let mut s = String::new();
    let drive_h: f64 = report
        .drives
        .iter()
        .filter(|d| d.status == DriveStatus::Ok)
        .filter_map(|d| d.record.as_ref())
        .map(|r| r.metrics.duration_s)
        .sum::<f64>()
        / 3600.0;
    let _ = writeln!(
        s,
        "# Run report: {} (model {})\n",
        report.pipeline, report.model_version
    );
    let _ = writeln!(
        s,
        "Pipeline file `{}`, fleetdyn {}, stages {}.{}\n",
        report.pipeline_file,
        report.fleetdyn_version,
        plan.stages
            .iter()
            .map(|s| s.name())
            .collect::<Vec<_>>()
            .join(" → "),
        report.shard.map_or(String::new(), |s| format!(
            " Shard {}/{}.",
            s.index, s.count
        ))
    );
    let _ = writeln!(
        s,
        "| drives in this run | processed | reused (up to date) | failed | wall time | jobs | drives in flight | drive-hours processed | drive-hours per core-hour |"
    );
    let _ = writeln!(s, "| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    let core_h = report.elapsed_s * report.jobs as f64 / 3600.0;
    let _ = writeln!(
        s,
        "| {} | {} | {} | {} | {:.2} s | {} | {} | {:.3} | {} |\n",
        report.drives.len(),
        report.ok,
        report.reused,
        report.failed,
        report.elapsed_s,
        report.jobs,
        report.max_drives_in_flight,
        drive_h,
        if core_h > 0.0 && report.ok > 0 {
            format!("{:.0}", drive_h / core_h)
        } else {
            "–".into()
        }
    );
    let failed: Vec<&DriveOutcome> = report
        .drives
        .iter()
        .filter(|d| d.status == DriveStatus::Failed)
        .collect();
    let _ = writeln!(s, "## Failures ({})\n", failed.len());
    if failed.is_empty() {
        let _ = writeln!(s, "None.\n");
    } else {
        let _ = writeln!(
            s,
            "| drive | input | stage | error |\n| --- | --- | --- | --- |"
        );
        for d in failed {
            let _ = writeln!(
                s,
                "| {} | `{}` | {} | {} |",
                cell(&d.drive_id),
                cell(&d.input),
                d.failed_stage.unwrap_or("?"),
                cell(d.error.as_deref().unwrap_or(""))
            );
        }
        let _ = writeln!(s);
    }
    split_section(&mut s, report);
    let skipped: Vec<(&str, &str, &str)> = report
        .drives
        .iter()
        .filter_map(|d| d.record.as_ref())
        .flat_map(|r| {
            r.stages.iter().filter_map(move |n| {
                n.reason
                    .as_deref()
                    .map(|why| (r.drive_id.as_str(), n.stage.as_str(), why))
            })
        })
        .collect();
    let _ = writeln!(s, "## Stages skipped for a drive ({})\n", skipped.len());
    if skipped.is_empty() {
        let _ = writeln!(s, "None.\n");
    } else {
        let _ = writeln!(s, "| drive | stage | reason |\n| --- | --- | --- |");
        for (d, st, why) in skipped {
            let _ = writeln!(s, "| {} | {st} | {} |", cell(d), cell(why));
        }
        let _ = writeln!(s);
    }
    let glitches: Vec<(&str, String, u64)> = report
        .drives
        .iter()
        .filter_map(|d| d.record.as_ref())
        .filter(|r| !r.metrics.masked_samples.is_empty() || r.metrics.conflicts_resolved > 0)
        .map(|r| {
            let m = &r.metrics;
            let cols: Vec<String> = m
                .masked_samples
                .iter()
                .map(|(c, n)| format!("{c} {n}"))
                .collect();
            (r.drive_id.as_str(), cols.join(", "), m.conflicts_resolved)
        })
        .collect();
    let _ = writeln!(
        s,
        "## Bad samples masked at ingest ({} drives)\n",
        glitches.len()
    );
    if glitches.is_empty() {
        let _ = writeln!(s, "None.\n");
    } else {
        let _ = writeln!(
            s,
            "| drive | masked samples | repeated timestamps, later kept |\n| --- | --- | --- |"
        );
        for (d, cols, conflicts) in glitches {
            let _ = writeln!(s, "| {} | {} | {conflicts} |", cell(d), cell(&cols));
        }
        let _ = writeln!(s);
    }
    slope_shuffle_section(&mut s, by_gear);
    let mut slow: Vec<&DriveOutcome> = report
        .drives
        .iter()
        .filter(|d| d.status != DriveStatus::Reused)
        .collect();
    slow.sort_by(|a, b| b.elapsed_s.total_cmp(&a.elapsed_s));
    slow.truncate(plan.spec.report.slowest_drives);
    let _ = writeln!(s, "## Slowest drives (processed in this run)\n");
    if slow.is_empty() {
        let _ = writeln!(s, "None: every drive was up to date.\n");
    } else {
        let _ = writeln!(
            s,
            "| drive | status | wall time [s] | rows | rows/s | drive duration [s] |\n| --- | --- | --- | --- | --- | --- |"
        );
        for d in slow {
            let (rows, dur) = d
                .record
                .as_ref()
                .map_or((0, f64::NAN), |r| (r.metrics.rows, r.metrics.duration_s));
            let _ = writeln!(
                s,
                "| {} | {} | {:.3} | {} | {} | {} |",
                cell(&d.drive_id),
                d.status.name(),
                d.elapsed_s,
                rows,
                if d.elapsed_s > 0.0 && rows > 0 {
                    format!("{:.0}", rows as f64 / d.elapsed_s)
                } else {
                    "–".into()
                },
                fmt_val(dur)
            );
        }
        let _ = writeln!(s);
    }
    let _ = writeln!(
        s,
        "## Error metrics across the fleet (`fleet_validation.parquet`)\n\n| metric | unit | drives | mean | min | p05 | p50 | p95 | max |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    );
    for (name, unit, d) in dist {
        if d[0] > 0.0 {
            let _ = writeln!(
                s,
                "| {name} | {unit} | {} | {} | {} | {} | {} | {} | {} |",
                d[0],
                fmt_val(d[1]),
                fmt_val(d[2]),
                fmt_val(d[3]),
                fmt_val(d[4]),
                fmt_val(d[5]),
                fmt_val(d[6])
            );
        }
    }
    let _ = writeln!(s);
    if let Some(l) = spectrum_line {
        let _ = writeln!(s, "{l}\n");
    }
    for (file, title) in plots {
        let _ = writeln!(s, "## {title}\n\n![{title}]({file})\n");
    }
    let _ = writeln!(
        s,
        "Per-drive rows: `drive_validation.parquet`; every table of the dataset reads as one hive-partitioned table under `{}`.",
        report.output_dir
    );
    s
}
