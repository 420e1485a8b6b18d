//! One column of values on a recording's rows, as the explain step holds a simulated output
//! ([`super::evaluator::Eval`]): dense (a value on every row), sparse (values on a set of rows,
//! one fill value on every other) or patched (another column's values with runs of rows of its
//! own), and cheap to clone in every form (the storage is shared).
//!
//! Why: the explain step keeps a simulation of every view for each of its probes and fits, and
//! on a long drive each full-length column is 8 bytes a row (14.4 MB for 10 hours at 50 Hz).
//! The event views (the shuffle modes, the torque reversals) have a value on one row per
//! engagement or reversal and the same fill on every other, and the clutch-actuation view reads
//! the engine speed the speeds view already holds; stored sparse and shared, they cost their
//! events and nothing. A probe of an effect that acts only now and then (a clutch that slips
//! only at its lowest capacities, a lash crossed only at torque reversals) leaves most windows'
//! rows as the base simulation's, bit for bit; stored patched over the base's storage, it costs
//! the windows it changes. Reading a row gives the same value, bit for bit, as the dense column
//! the simulation produced, so no result depends on the storage.

use std::borrow::Cow;
use std::ops::Index;
use std::sync::Arc;

/// Values on `len` rows in one of three forms (module doc). Cloning shares the storage.
#[derive(Debug, Clone)]
pub struct RowColumn {
    len: usize,
    store: Store,
}

#[derive(Debug, Clone)]
enum Store {
    /// A value on every row.
    Dense(Arc<Vec<f64>>),
    /// `values` on the sorted `rows`, `fill` on every other row.
    Sparse {
        rows: Arc<[usize]>,
        values: Arc<Vec<f64>>,
        fill: f64,
    },
    /// `values` on the rows of `runs` (in row order, disjoint), `base` on every other row.
    Patched {
        base: Arc<Vec<f64>>,
        runs: Arc<[Run]>,
        values: Arc<Vec<f64>>,
    },
}

/// Rows `start..end` of a patched column, their values from `offset` on in its `values`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Run {
    start: usize,
    end: usize,
    offset: usize,
}

/// Rows of equal values a run of a patched column takes in rather than ending: fewer, longer
/// runs for a cheaper search, at 8 bytes a row taken in.
const RUN_GAP_ROWS: usize = 64;

impl RowColumn {
    /// A dense column.
    pub fn dense(values: Vec<f64>) -> Self {
        Self::shared(Arc::new(values))
    }

    /// A dense column sharing `values`' storage.
    pub fn shared(values: Arc<Vec<f64>>) -> Self {
        Self {
            len: values.len(),
            store: Store::Dense(values),
        }
    }

    /// `dense` stored on `rows` alone (sorted, unique, each `< dense.len()`), with `fill` on
    /// every other row. Exact when `dense` holds `fill` (bit for bit, or NaN for a NaN fill)
    /// on every row outside `rows`: reading any row then gives `dense`'s value.
    ///
    /// # Panics
    /// When a row is out of range; in debug builds also when `rows` is not strictly increasing.
    pub fn sparse(dense: &[f64], rows: Arc<[usize]>, fill: f64) -> Self {
        debug_assert!(rows.windows(2).all(|w| w[0] < w[1]));
        debug_assert!(rows.last().is_none_or(|&r| r < dense.len()));
        let values = rows.iter().map(|&i| dense[i]).collect();
        Self {
            len: dense.len(),
            store: Store::Sparse {
                rows,
                values: Arc::new(values),
                fill,
            },
        }
    }

    /// `column` stored over `base` when that takes less memory: the runs of rows where the
    /// two differ (bit for bit; runs closer than `RUN_GAP_ROWS` (64) joined) keep `column`'s
    /// values and every other row reads `base`'s storage. Patched when the runs hold at most a
    /// quarter of the rows (a quarter of the dense column's memory, and a short search per
    /// read), else `column` as it is. Reading any row gives `column`'s value, bit for bit.
    /// A column that is not dense, or of another length than `base`, is returned as it is.
    pub fn over(column: &RowColumn, base: &Arc<Vec<f64>>) -> RowColumn {
        let Store::Dense(own) = &column.store else {
            return column.clone();
        };
        if own.len() != base.len() || Arc::ptr_eq(own, base) {
            return column.clone();
        }
        let n = own.len();
        let differs = |i: usize| own[i].to_bits() != base[i].to_bits();
        let mut runs: Vec<Run> = Vec::new();
        let mut stored = 0usize;
        let mut i = 0;
        while i < n {
            if !differs(i) {
                i += 1;
                continue;
            }
            let start = i;
            let mut end = i + 1;
            // extend over differing rows and gaps shorter than RUN_GAP_ROWS
            let mut j = end;
            while j < n && j - end < RUN_GAP_ROWS {
                if differs(j) {
                    end = j + 1;
                }
                j += 1;
            }
            stored += end - start;
            if 4 * stored > n {
                return column.clone();
            }
            runs.push(Run {
                start,
                end,
                offset: stored - (end - start),
            });
            i = end;
        }
        let values: Vec<f64> = runs
            .iter()
            .flat_map(|r| own[r.start..r.end].iter().copied())
            .collect();
        RowColumn {
            len: n,
            store: Store::Patched {
                base: Arc::clone(base),
                runs: Arc::from(runs),
                values: Arc::new(values),
            },
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the column has no rows.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether the column is stored patched over another's storage ([`RowColumn::over`]).
    pub fn is_patched(&self) -> bool {
        matches!(self.store, Store::Patched { .. })
    }

    /// A dense column's storage, to share with other holders of the same values (`None` for a
    /// sparse or patched column).
    pub fn dense_storage(&self) -> Option<&Arc<Vec<f64>>> {
        match &self.store {
            Store::Dense(v) => Some(v),
            _ => None,
        }
    }

    /// The stored rows of a sparse column (`None` for a dense or patched one).
    pub fn stored_rows(&self) -> Option<&Arc<[usize]>> {
        match &self.store {
            Store::Sparse { rows, .. } => Some(rows),
            _ => None,
        }
    }

    /// Every row's value: borrowed from a dense column, built for the other forms.
    pub fn values(&self) -> Cow<'_, [f64]> {
        match &self.store {
            Store::Dense(v) => Cow::Borrowed(v.as_slice()),
            _ => Cow::Owned(self.to_vec()),
        }
    }

    /// A sparse column's stored rows, their values and the fill of every other row (`None` for
    /// a dense or patched column).
    pub fn sparse_parts(&self) -> Option<(&[usize], &[f64], f64)> {
        match &self.store {
            Store::Sparse { rows, values, fill } => Some((&rows[..], values.as_slice(), *fill)),
            _ => None,
        }
    }

    /// Every row's value.
    pub fn to_vec(&self) -> Vec<f64> {
        match &self.store {
            Store::Dense(v) => v.as_ref().clone(),
            Store::Sparse { rows, values, fill } => {
                let mut out = vec![*fill; self.len];
                for (&i, &v) in rows.iter().zip(values.iter()) {
                    out[i] = v;
                }
                out
            }
            Store::Patched { base, runs, values } => {
                let mut out = base.as_ref().clone();
                for r in runs.iter() {
                    out[r.start..r.end]
                        .copy_from_slice(&values[r.offset..r.offset + (r.end - r.start)]);
                }
                out
            }
        }
    }

    /// `f` of `a`, `b` and `c` row by row. Sparse when all three are sparse on the same rows
    /// (then `f` of their fills fills the rest, which is `f` row by row on every other row),
    /// dense otherwise.
    ///
    /// # Panics
    /// When the columns differ in length.
    pub fn map3(a: &Self, b: &Self, c: &Self, f: impl Fn(f64, f64, f64) -> f64) -> Self {
        assert!(
            a.len == b.len && a.len == c.len,
            "columns of different lengths"
        );
        if let (
            Store::Sparse {
                rows: ra,
                values: va,
                fill: fa,
            },
            Store::Sparse {
                rows: rb,
                values: vb,
                fill: fb,
            },
            Store::Sparse {
                rows: rc,
                values: vc,
                fill: fc,
            },
        ) = (&a.store, &b.store, &c.store)
        {
            if ra == rb && ra == rc {
                let values = va
                    .iter()
                    .zip(vb.iter())
                    .zip(vc.iter())
                    .map(|((x, y), z)| f(*x, *y, *z))
                    .collect();
                return Self {
                    len: a.len,
                    store: Store::Sparse {
                        rows: Arc::clone(ra),
                        values: Arc::new(values),
                        fill: f(*fa, *fb, *fc),
                    },
                };
            }
        }
        Self::dense((0..a.len).map(|i| f(a[i], b[i], c[i])).collect())
    }
}

/// The value every row outside a sparse column's rows reads, when the fill is NaN.
static NAN: f64 = f64::NAN;

impl Index<usize> for RowColumn {
    type Output = f64;

    fn index(&self, i: usize) -> &f64 {
        match &self.store {
            Store::Dense(v) => &v[i],
            Store::Sparse { rows, values, fill } => {
                assert!(i < self.len, "row {i} of a column of {} rows", self.len);
                match rows.binary_search(&i) {
                    Ok(p) => &values[p],
                    Err(_) if fill.is_nan() => &NAN,
                    Err(_) => fill,
                }
            }
            Store::Patched { base, runs, values } => {
                let p = runs.partition_point(|r| r.start <= i);
                match p.checked_sub(1).map(|q| runs[q]) {
                    Some(r) if i < r.end => &values[r.offset + i - r.start],
                    _ => &base[i],
                }
            }
        }
    }
}

impl PartialEq for RowColumn {
    /// Equal row by row (NaN equal to nothing, as for `f64`).
    fn eq(&self, other: &Self) -> bool {
        self.len == other.len && (0..self.len).all(|i| self[i] == other[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sparse_column_reads_every_row_as_the_dense_one() {
        let mut dense = vec![0.0; 50];
        let rows: Arc<[usize]> = Arc::from(vec![3, 17, 40]);
        for (k, &i) in rows.iter().enumerate() {
            dense[i] = 1.5 + k as f64;
        }
        let s = RowColumn::sparse(&dense, rows.clone(), 0.0);
        assert_eq!(s.len(), 50);
        for (i, v) in dense.iter().enumerate() {
            assert_eq!(s[i].to_bits(), v.to_bits(), "row {i}");
        }
        assert_eq!(s.to_vec(), dense);
        // a NaN fill reads NaN off the rows
        let mut nan = vec![f64::NAN; 50];
        nan[17] = 2.0;
        let s = RowColumn::sparse(&nan, Arc::from(vec![17]), f64::NAN);
        assert!(s[16].is_nan() && s[18].is_nan());
        assert_eq!(s[17], 2.0);
    }

    #[test]
    fn map3_keeps_shared_rows_sparse_and_equals_the_dense_map() {
        let rows: Arc<[usize]> = Arc::from(vec![1, 4]);
        let col = |a: f64, b: f64| {
            let mut d = vec![0.0; 6];
            d[1] = a;
            d[4] = b;
            RowColumn::sparse(&d, rows.clone(), 0.0)
        };
        let (a, b, c) = (col(1.0, 2.0), col(3.0, 5.0), col(0.5, 1.0));
        let f = |x: f64, y: f64, z: f64| x + 2.0 * (y - z);
        let m = RowColumn::map3(&a, &b, &c, f);
        assert!(m.stored_rows().is_some());
        let d = RowColumn::map3(
            &RowColumn::dense(a.to_vec()),
            &RowColumn::dense(b.to_vec()),
            &RowColumn::dense(c.to_vec()),
            f,
        );
        assert!(d.stored_rows().is_none());
        assert_eq!(m.to_vec(), d.to_vec());
        assert_eq!(m, d);
    }

    #[test]
    #[should_panic(expected = "row 6 of a column of 6 rows")]
    fn a_sparse_column_refuses_a_row_past_its_end() {
        let s = RowColumn::sparse(&[0.0; 6], Arc::from(vec![2]), 0.0);
        let _ = s[6];
    }

    #[test]
    fn a_patched_column_reads_every_row_as_the_dense_one_and_stores_its_runs_alone() {
        let n = 10_000;
        let base: Arc<Vec<f64>> = Arc::new((0..n).map(|i| (i as f64 * 0.01).sin()).collect());
        // a column that departs on two windows, one of them with an equal row inside, and is
        // NaN on its last row
        let mut own = base.as_ref().clone();
        for v in &mut own[1_000..1_500] {
            *v += 1e-12;
        }
        own[1_200] = base[1_200];
        for v in &mut own[7_000..7_010] {
            *v = -*v;
        }
        own[n - 1] = f64::NAN;
        let dense = RowColumn::dense(own.clone());
        let p = RowColumn::over(&dense, &base);
        assert!(p.is_patched());
        for (i, v) in own.iter().enumerate() {
            assert_eq!(p[i].to_bits(), v.to_bits(), "row {i}");
        }
        assert_eq!(
            p.to_vec().iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            own.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        // three runs, the equal row inside the first taken in: 500 + 10 + 1 values stored
        let Store::Patched { runs, values, .. } = &p.store else {
            unreachable!()
        };
        assert_eq!(runs.len(), 3);
        assert_eq!(values.len(), 511);
        assert!(p.dense_storage().is_none() && p.sparse_parts().is_none());
        // equal to the base on every row: no runs at all
        let same = RowColumn::over(&RowColumn::dense(base.as_ref().clone()), &base);
        assert!(same.is_patched());
        assert_eq!(same.to_vec(), *base);
    }

    #[test]
    fn a_column_that_differs_on_many_rows_or_is_the_base_stays_dense() {
        let base: Arc<Vec<f64>> = Arc::new(vec![1.0; 1_000]);
        // every row differs: patching would cost more than the column
        let all = RowColumn::dense(vec![2.0; 1_000]);
        let p = RowColumn::over(&all, &base);
        assert!(!p.is_patched() && p.dense_storage().is_some());
        // a difference every 50 rows joins into one run over the column: over a quarter
        let mut every = base.as_ref().clone();
        for i in (0..1_000).step_by(50) {
            every[i] = 3.0;
        }
        assert!(!RowColumn::over(&RowColumn::dense(every), &base).is_patched());
        // the base's own storage, and another length, are left as they are
        let shared = RowColumn::shared(Arc::clone(&base));
        assert!(RowColumn::over(&shared, &base).dense_storage().is_some());
        let short = RowColumn::dense(vec![1.0; 10]);
        assert!(!RowColumn::over(&short, &base).is_patched());
    }
}
