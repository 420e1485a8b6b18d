//! Logger pauses: a recording whose required signals stop for longer than the missing-value
//! limit is split into segments, each a drive of its own.
//!
//! **Where it splits.** A *hole* is a stretch longer than `max_nan_run_s` in which a required
//! column has no valid value: between two consecutive valid samples, or between the table's edge
//! and its first (last) valid sample. A logger asleep at a rest stop leaves a hole in every column
//! (no rows at all, reported as a pause of the logger); a sensor that stopped leaves one in its own
//! column (reported with the column). Holes of all required columns are merged; each segment is a
//! maximal run of rows that no merged hole crosses, and the rows inside holes are dropped.
//! Multi-rate sources are cut on their channels first (a hole of a required channel longer than the
//! limit plus 2.5 of its sample periods, [`required_holes`], the holes [`super::align::check_gaps`]
//! refuses), so a pause never becomes grid rows, and each piece is aligned and split again by the
//! same rule on its aligned rows.
//!
//! **What a segment is.** Segments are numbered 1, 2, … in time order over the whole recording.
//! When there is more than one, a segment shorter than `min_segment_s`, or in which the vehicle
//! travels less than `min_segment_m` (the speed integral; a logger that woke with the truck
//! parked), is skipped with that reason; the others become drives `<drive_id>-s<k>` that keep
//! the recording's id, their number, the count and their time span ([`Segment`]). A recording
//! that is one segment keeps its id; holes at its edges are trimmed.
//!
//! **Policy.** [`OnGap::Split`] (default) does the above; [`OnGap::Error`] rejects the
//! recording at its first hole ([`check_nan_runs`], `check_row_gaps`:
//! [`IngestError::NanRun`], [`IngestError::TimeGap`]).

use super::align::required_holes;
use super::channel::Channel;
use super::error::IngestError;
pub use crate::table::Segment;
use crate::table::Signal;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::Path;

/// What to do when a required signal stops for longer than the missing-value limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum OnGap {
    /// Split the recording there into drives of their own (default): a rest stop with the
    /// logger asleep costs the pause, not the drive.
    #[default]
    Split,
    /// Reject the recording, naming the hole.
    Error,
}

/// A segment not processed, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkippedSegment {
    /// Number of the segment, 1-based, in time order.
    pub index: usize,
    /// Id the segment would have had.
    pub drive_id: String,
    /// First sample, ns since the Unix epoch.
    pub start_ns: i64,
    /// Duration, s.
    pub duration_s: f64,
    /// Distance travelled (speed integral), m.
    pub distance_m: f64,
    /// Why it was skipped.
    pub reason: String,
}

/// A hole the recording was split at (or trimmed at, on its edges).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pause {
    /// Last valid sample before the hole (the table's first sample for a leading hole), ns.
    pub start_ns: i64,
    /// First valid sample after it (the table's last sample for a trailing hole), ns.
    pub end_ns: i64,
    /// The required column without a valid value; `None` when the recording has no sample at all
    /// there (the logger paused).
    pub column: Option<String>,
}

impl Pause {
    /// Length, s.
    pub fn seconds(&self) -> f64 {
        (self.end_ns - self.start_ns) as f64 * 1e-9
    }
}

/// Rows of a table with a hole between them: `after` is the last row before it, `before` the
/// first row after (`None`: the table's edge). Rows strictly between are dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Cut {
    after: Option<usize>,
    before: Option<usize>,
}

/// Splits a table (times `t_ns`, columns `signals`) at the holes of its `required` columns
/// longer than `limit_s` (module documentation). Returns the row ranges of the segments in time
/// order and the holes, merged, in time order.
pub fn split_rows(
    t_ns: &[i64],
    signals: &[Signal],
    required: &[&str],
    limit_s: f64,
) -> (Vec<Range<usize>>, Vec<Pause>) {
    let n = t_ns.len();
    if n == 0 {
        return (Vec::new(), Vec::new());
    }
    let longer = |a: i64, b: i64| (b.saturating_sub(a)) as f64 * 1e-9 > limit_s;
    let mut cuts: Vec<(Cut, &str)> = Vec::new();
    for s in signals
        .iter()
        .filter(|s| required.contains(&s.name.as_str()))
    {
        let mut prev: Option<usize> = None;
        for (i, v) in s.values.iter().enumerate() {
            if v.is_nan() {
                continue;
            }
            let from = prev.map_or(t_ns[0], |p| t_ns[p]);
            if longer(from, t_ns[i]) {
                cuts.push((
                    Cut {
                        after: prev,
                        before: Some(i),
                    },
                    &s.name,
                ));
            }
            prev = Some(i);
        }
        match prev {
            Some(p) if longer(t_ns[p], t_ns[n - 1]) => cuts.push((
                Cut {
                    after: Some(p),
                    before: None,
                },
                &s.name,
            )),
            Some(_) => {}
            // no valid value at all: nothing of the table is usable
            None => cuts.push((
                Cut {
                    after: None,
                    before: None,
                },
                &s.name,
            )),
        }
    }
    // order by where the hole starts (a leading hole first), then merge the holes that overlap
    // (one starts before the row where the other ends: the same pause seen by several columns)
    let start_of = |c: &Cut| c.after.map_or(-1, |a| a as isize);
    let end_of = |c: &Cut| c.before.map_or(n as isize, |b| b as isize);
    cuts.sort_by_key(|(c, _)| (start_of(c), end_of(c)));
    let mut merged: Vec<(Cut, &str)> = Vec::new();
    for (c, col) in cuts {
        if let Some((last, _)) = merged.last_mut() {
            if start_of(&c) < end_of(last) {
                if end_of(&c) > end_of(last) {
                    last.before = c.before;
                }
                continue;
            }
        }
        merged.push((c, col));
    }
    let mut ranges = Vec::new();
    let mut pauses = Vec::new();
    let mut start = 0usize;
    for (c, col) in &merged {
        if let Some(a) = c.after {
            if a + 1 > start {
                ranges.push(start..a + 1);
            }
        }
        let from = c.after.unwrap_or(0);
        let to = c.before.unwrap_or(n - 1);
        // no row at all strictly inside the hole and the rows on both sides exist: the logger
        // paused; otherwise the column had no valid value
        let logger = matches!((c.after, c.before), (Some(a), Some(b)) if b == a + 1);
        pauses.push(Pause {
            start_ns: t_ns[from],
            end_ns: t_ns[to],
            column: (!logger).then(|| (*col).to_string()),
        });
        start = c.before.unwrap_or(n);
    }
    if start < n {
        ranges.push(start..n);
    }
    (ranges, pauses)
}

/// Time windows `[start, end]` (ns, inclusive, `end > start`) of multi-rate `channels` between
/// the [`required_holes`] of their `required` channels, within the interval all required
/// channels cover (`span`), and the holes, merged, in time order.
pub fn channel_windows(
    channels: &[Channel],
    required: &[&str],
    limit_s: f64,
    span: (i64, i64),
) -> (Vec<(i64, i64)>, Vec<Pause>) {
    let mut holes: Vec<(i64, i64, &str)> = required_holes(channels, required, limit_s, span)
        .map(|(c, k)| (c.t_ns[k], c.t_ns[k + 1], c.column.as_str()))
        .collect();
    holes.sort();
    let mut merged: Vec<(i64, i64, &str)> = Vec::new();
    for h in holes {
        match merged.last_mut() {
            Some(last) if h.0 < last.1 => last.1 = last.1.max(h.1),
            _ => merged.push(h),
        }
    }
    let mut windows = Vec::new();
    let mut pauses = Vec::new();
    let mut start = span.0;
    for &(a, b, col) in &merged {
        if a > start {
            windows.push((start, a));
        }
        // a sample of any channel well inside (beyond 2.5 of its periods from either edge): a
        // signal stopped, not the logger
        let logger = !channels.iter().any(|c| {
            let m = (c.median_period_ns() as f64 * 2.5) as i64;
            let i = c.t_ns.partition_point(|&t| t <= a + m);
            i < c.t_ns.len() && c.t_ns[i] < b - m
        });
        pauses.push(Pause {
            start_ns: a,
            end_ns: b,
            column: (!logger).then(|| col.to_string()),
        });
        start = b;
    }
    if start < span.1 {
        windows.push((start, span.1));
    }
    (windows, pauses)
}

/// Distance travelled over a table, m: the trapezoidal integral of `vehicle_speed` (m/s) over
/// consecutive valid samples; 0 without the column.
pub fn distance_m(t_ns: &[i64], signals: &[Signal]) -> f64 {
    let Some(v) = signals.iter().find(|s| s.name == "vehicle_speed") else {
        return 0.0;
    };
    t_ns.windows(2)
        .zip(v.values.windows(2))
        .filter(|(_, w)| w[0].is_finite() && w[1].is_finite())
        .map(|(t, w)| 0.5 * (w[0] + w[1]).abs() * (t[1] - t[0]) as f64 * 1e-9)
        .sum()
}

/// Rejects a wide table whose consecutive rows are more than `limit_s` apart: every column is
/// missing over such a hole, as in a NaN run, and distance resampling must not integrate speed
/// across it (a year between two rows would make a year of distance grid).
pub(crate) fn check_row_gaps(
    path: &Path,
    t_ns: &[i64],
    rows: &[u64],
    limit_s: f64,
) -> Result<(), IngestError> {
    for (k, w) in t_ns.windows(2).enumerate() {
        let seconds = w[1].saturating_sub(w[0]) as f64 * 1e-9;
        if seconds > limit_s {
            return Err(IngestError::TimeGap {
                file: path.into(),
                column: "timestamp".into(),
                row: rows[k + 1],
                time_ns: w[1],
                previous_ns: w[0],
                seconds,
                limit_s,
            });
        }
    }
    Ok(())
}

/// Rejects runs of missing values in the `required` columns (column, stage) longer than
/// `limit_s`.
///
/// # Errors
/// [`IngestError::NanRun`] naming the column, the first row of the run and its length.
pub fn check_nan_runs(
    path: &Path,
    t_ns: &[i64],
    signals: &[Signal],
    required: &[(&str, &str)],
    limit_s: f64,
) -> Result<(), IngestError> {
    for s in signals {
        if !required.iter().any(|r| r.0 == s.name) {
            continue;
        }
        let mut i = 0;
        while i < s.values.len() {
            if !s.values[i].is_nan() {
                i += 1;
                continue;
            }
            let start = i;
            while i < s.values.len() && s.values[i].is_nan() {
                i += 1;
            }
            // A run lasts from the last valid sample before it to the first valid one after
            // (from / to the table's edge when it touches one).
            let before = t_ns[start.saturating_sub(1)];
            let after = t_ns[i.min(t_ns.len() - 1)];
            let seconds = (after - before) as f64 * 1e-9;
            if seconds > limit_s {
                return Err(IngestError::NanRun {
                    file: path.into(),
                    column: s.name.clone(),
                    row: start as u64,
                    time_ns: t_ns[start],
                    samples: (i - start) as u64,
                    seconds,
                    limit_s,
                });
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schema::Interpolation;

    fn sig(name: &str, v: &[f64]) -> Signal {
        Signal {
            name: name.into(),
            unit: "1".into(),
            values: v.to_vec(),
        }
    }

    const S: i64 = 1_000_000_000;

    #[test]
    fn a_row_gap_splits_and_is_a_logger_pause() {
        // 1 Hz rows 0..5, a 100 s pause, rows 105..110
        let t: Vec<i64> = (0..5).chain(105..110).map(|k| k * S).collect();
        let v = sig("vehicle_speed", &[1.0; 10]);
        let (r, p) = split_rows(&t, &[v], &["vehicle_speed"], 2.0);
        assert_eq!(r, vec![0..5, 5..10]);
        assert_eq!(p.len(), 1);
        assert_eq!((p[0].start_ns, p[0].end_ns), (4 * S, 105 * S));
        assert_eq!(p[0].column, None);
        assert!((p[0].seconds() - 101.0).abs() < 1e-9);
    }

    #[test]
    fn a_missing_run_splits_and_names_its_column() {
        let t: Vec<i64> = (0..10).map(|k| k * S).collect();
        let nan = f64::NAN;
        let v = sig("vehicle_speed", &[1.0; 10]);
        let g = sig("gear", &[1.0, 1.0, nan, nan, nan, nan, 2.0, 2.0, 2.0, 2.0]);
        // the run lasts from row 1 (t = 1 s) to row 6 (t = 6 s): 5 s > 2 s
        let (r, p) = split_rows(&t, &[v.clone(), g.clone()], &["vehicle_speed", "gear"], 2.0);
        assert_eq!(r, vec![0..2, 6..10]);
        assert_eq!(p[0].column.as_deref(), Some("gear"));
        // a column that is not required does not split
        let (r, p) = split_rows(&t, &[v, g], &["vehicle_speed"], 2.0);
        assert_eq!((r.len(), r[0].clone(), p.len()), (1, 0..10, 0));
    }

    #[test]
    fn overlapping_holes_merge_and_edges_are_trimmed() {
        let t: Vec<i64> = (0..20).map(|k| k * S).collect();
        let nan = f64::NAN;
        let mut a = vec![1.0; 20];
        let mut b = vec![1.0; 20];
        // a: leading hole rows 0..4 (first valid at 4 s), hole rows 8..12
        for k in (0..4).chain(8..12) {
            a[k] = nan;
        }
        // b: hole rows 10..15 overlapping a's, and a trailing hole from row 17
        for k in (10..15).chain(17..20) {
            b[k] = nan;
        }
        let (r, p) = split_rows(
            &t,
            &[sig("vehicle_speed", &a), sig("engine_speed", &b)],
            &["vehicle_speed", "engine_speed"],
            2.0,
        );
        assert_eq!(r, vec![4..8, 15..17]);
        assert_eq!(p.len(), 3);
        assert_eq!((p[1].start_ns, p[1].end_ns), (7 * S, 15 * S));
        assert_eq!((p[2].start_ns, p[2].end_ns), (16 * S, 19 * S));
        // short holes do not split
        let (r, p) = split_rows(&t, &[sig("vehicle_speed", &a)], &["vehicle_speed"], 10.0);
        assert_eq!((r.len(), r[0].clone(), p.len()), (1, 0..20, 0));
    }

    #[test]
    fn a_column_without_any_value_leaves_nothing() {
        let t: Vec<i64> = (0..10).map(|k| k * S).collect();
        let (r, p) = split_rows(
            &t,
            &[sig("vehicle_speed", &[f64::NAN; 10])],
            &["vehicle_speed"],
            2.0,
        );
        assert!(r.is_empty());
        assert_eq!(p.len(), 1);
    }

    #[test]
    fn channels_are_cut_at_a_pause_of_every_signal() {
        let mut speed = Channel::new("vehicle_speed", "m/s", Interpolation::Linear);
        let mut eng = Channel::new("engine_speed", "rad/s", Interpolation::Linear);
        for k in (0..100).chain(7300..7400) {
            speed.push(k * S / 10, 10.0, k as u64);
        }
        for k in (0..200).chain(14600..14800) {
            eng.push(k * S / 20, 100.0, k as u64);
        }
        let span = (0, 7399 * S / 10);
        let (w, p) = channel_windows(&[speed, eng], &["vehicle_speed"], 2.0, span);
        assert_eq!(w, vec![(0, 99 * S / 10), (730 * S, 7399 * S / 10)]);
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].column, None, "no channel has a sample in the pause");
    }

    #[test]
    fn distance_integrates_valid_speed() {
        let t: Vec<i64> = (0..5).map(|k| k * S).collect();
        let v = sig("vehicle_speed", &[10.0, 10.0, f64::NAN, 10.0, 10.0]);
        assert!((distance_m(&t, &[v]) - 20.0).abs() < 1e-12);
        assert_eq!(distance_m(&t, &[]), 0.0);
    }
}
