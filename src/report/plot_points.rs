//! A time series thinned to what a line plot of a given width can show, without changing the
//! drawing: M4 aggregation (Jugel, Jerzak, Hackenbroich, Markl, *M4: A Visualization-Oriented
//! Time Series Data Aggregation*, Proceedings of the VLDB Endowment 7(10), 2014).
//!
//! The x range `[x0, x1]` is cut into `columns` equal columns; of the points falling in one
//! column only four are kept: the first and the last (by position, so the lines into and out of
//! the column are the same) and those with the smallest and the largest value (first occurrence
//! on ties), in their original order. A polyline through the kept points covers, in every
//! column, the same vertical extent as the polyline through all points and joins its
//! neighbours at the same points, so at a drawing width of at most `columns` pixels the two
//! draw the same pixels. The residual plots of a 10-hour drive (1.8 million rows per signal)
//! thereby hold at most `4 · columns` points per line instead of every row.
//!
//! Points with a non-finite coordinate are dropped (a line plot joins across them, as it would
//! have). The input is expected in ascending x (rows in time order); for any order the result
//! still keeps the first, last, smallest and largest point of every run of consecutive points in
//! one column.

/// The points of `points` that an M4 aggregation over `columns` equal columns of `[x0, x1]`
/// keeps (module doc), in their original order. `columns` of 0 is read as 1; an empty or
/// degenerate range (`x1 ≤ x0`) puts every point in one column.
pub fn m4_points(
    points: impl IntoIterator<Item = (f64, f64)>,
    (x0, x1): (f64, f64),
    columns: usize,
) -> Vec<(f64, f64)> {
    let columns = columns.max(1);
    let scale = if x1 > x0 {
        columns as f64 / (x1 - x0)
    } else {
        0.0
    };
    let column_of = |x: f64| (((x - x0) * scale).floor().max(0.0) as usize).min(columns - 1);
    let mut out = Vec::new();
    // the run of points in one column: its column and first, last, min and max points, each
    // with its position in the input for the order
    let mut run: Option<Run> = None;
    for (i, (x, y)) in points
        .into_iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .enumerate()
    {
        let c = column_of(x);
        match run.as_mut() {
            Some(r) if r.column == c => r.push(i, (x, y)),
            _ => {
                if let Some(r) = run.take() {
                    r.emit(&mut out);
                }
                run = Some(Run::new(c, i, (x, y)));
            }
        }
    }
    if let Some(r) = run {
        r.emit(&mut out);
    }
    out
}

/// The kept points of one run of consecutive points in one column, each with its position.
struct Run {
    column: usize,
    first: (usize, (f64, f64)),
    last: (usize, (f64, f64)),
    min: (usize, (f64, f64)),
    max: (usize, (f64, f64)),
}

impl Run {
    fn new(column: usize, i: usize, p: (f64, f64)) -> Self {
        Self {
            column,
            first: (i, p),
            last: (i, p),
            min: (i, p),
            max: (i, p),
        }
    }

    fn push(&mut self, i: usize, p: (f64, f64)) {
        self.last = (i, p);
        if p.1 < self.min.1 .1 {
            self.min = (i, p);
        }
        if p.1 > self.max.1 .1 {
            self.max = (i, p);
        }
    }

    /// Appends the distinct kept points in their input order.
    fn emit(self, out: &mut Vec<(f64, f64)>) {
        let mut kept = [self.first, self.min, self.max, self.last];
        kept.sort_by_key(|(i, _)| *i);
        let mut previous = None;
        for (i, p) in kept {
            if previous != Some(i) {
                out.push(p);
                previous = Some(i);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro256StarStar;

    /// Per column of `[x0, x1]`: (first, last, min, max) of the points in it.
    fn extremes(
        pts: &[(f64, f64)],
        range: (f64, f64),
        columns: usize,
    ) -> Vec<Option<[(f64, f64); 4]>> {
        let mut out = vec![None; columns];
        for &(x, y) in pts {
            // the column as m4_points computes it (a point on a column's edge rounds alike)
            let c = (((x - range.0) * (columns as f64 / (range.1 - range.0))).floor() as usize)
                .min(columns - 1);
            let e = out[c].get_or_insert([(x, y); 4]);
            e[1] = (x, y);
            if y < e[2].1 {
                e[2] = (x, y);
            }
            if y > e[3].1 {
                e[3] = (x, y);
            }
        }
        out
    }

    #[test]
    fn m4_keeps_every_columns_first_last_lowest_and_highest_point() {
        let mut rng = Xoshiro256StarStar::seed_from_u64(3);
        // a random walk with spikes at 50 Hz for an hour, gaps of NaN in it
        let mut y = 0.0;
        let pts: Vec<(f64, f64)> = (0..180_000)
            .map(|i| {
                y += rng.standard_normal();
                let spike = if i % 9_973 == 0 { 500.0 } else { 0.0 };
                let v = if (40_000..40_500).contains(&i) {
                    f64::NAN
                } else {
                    y + spike
                };
                (i as f64 * 0.02, v)
            })
            .collect();
        let range = (0.0, 3600.0);
        let columns = 1000;
        let kept = m4_points(pts.iter().copied(), range, columns);
        assert!(kept.len() <= 4 * columns, "{} points kept", kept.len());
        assert!(kept.windows(2).all(|w| w[0].0 < w[1].0), "time order kept");
        let finite: Vec<(f64, f64)> = pts.iter().copied().filter(|p| p.1.is_finite()).collect();
        // the same extremes in every column, exactly (the kept points are input points)
        assert_eq!(
            extremes(&kept, range, columns),
            extremes(&finite, range, columns)
        );
        // every kept point is an input point
        assert!(kept
            .iter()
            .all(|p| finite.binary_search_by(|q| q.0.total_cmp(&p.0)).is_ok()));
    }

    #[test]
    fn m4_returns_short_series_whole_and_handles_degenerate_ranges() {
        let pts = [(0.0, 1.0), (1.0, 3.0), (2.0, 2.0)];
        // one point per column: all of them
        assert_eq!(m4_points(pts, (0.0, 3.0), 3), pts.to_vec());
        // one column: a run of three, all of them extremes or ends
        assert_eq!(m4_points(pts, (0.0, 0.0), 0), pts.to_vec());
        // a flat run keeps its ends only
        let flat: Vec<(f64, f64)> = (0..100).map(|i| (i as f64, 5.0)).collect();
        assert_eq!(
            m4_points(flat.iter().copied(), (0.0, 100.0), 1),
            vec![(0.0, 5.0), (99.0, 5.0)]
        );
        assert!(m4_points(Vec::new(), (0.0, 1.0), 10).is_empty());
    }
}
