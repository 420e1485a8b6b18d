//! One column of values on a recording's rows, as the explain step holds a simulated output
//! ([`super::evaluator::Eval`]): dense (a value on every row) or sparse (values on a set of
//! rows, one fill value on every other), and cheap to clone either way (the storage is shared).
//!
//! Why: the explain step keeps a simulation of every view for each of its probes and fits, and
//! on a long drive each full-length column is 8 bytes a row (14.4 MB for 10 hours at 50 Hz).
//! The event views (the shuffle modes, the torque reversals) have a value on one row per
//! engagement or reversal and the same fill on every other, and the clutch-actuation view reads
//! the engine speed the speeds view already holds; stored sparse and shared, they cost their
//! events and nothing. Reading a row gives the same value, bit for bit, as the dense column the
//! simulation produced, so no result depends on the storage.

use std::borrow::Cow;
use std::ops::Index;
use std::sync::Arc;

/// Values on `len` rows: dense, or sparse (sorted `rows` with their `values`, `fill` on every
/// other row). Cloning shares the storage.
#[derive(Debug, Clone)]
pub struct RowColumn {
    len: usize,
    rows: Option<Arc<[usize]>>,
    values: Arc<Vec<f64>>,
    fill: f64,
}

impl RowColumn {
    /// A dense column.
    pub fn dense(values: Vec<f64>) -> Self {
        Self::shared(Arc::new(values))
    }

    /// A dense column sharing `values`' storage.
    pub fn shared(values: Arc<Vec<f64>>) -> Self {
        Self {
            len: values.len(),
            rows: None,
            values,
            fill: f64::NAN,
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
            rows: Some(rows),
            values: Arc::new(values),
            fill,
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

    /// A dense column's storage, to share with other holders of the same values (`None` for a
    /// sparse column).
    pub fn dense_storage(&self) -> Option<&Arc<Vec<f64>>> {
        match self.rows {
            None => Some(&self.values),
            Some(_) => None,
        }
    }

    /// The stored rows of a sparse column (`None` for a dense one).
    pub fn stored_rows(&self) -> Option<&Arc<[usize]>> {
        self.rows.as_ref()
    }

    /// Every row's value: borrowed from a dense column, built for a sparse one.
    pub fn values(&self) -> Cow<'_, [f64]> {
        match &self.rows {
            None => Cow::Borrowed(self.values.as_slice()),
            Some(_) => Cow::Owned(self.to_vec()),
        }
    }

    /// A sparse column's stored rows, their values and the fill of every other row (`None` for
    /// a dense column).
    pub fn sparse_parts(&self) -> Option<(&[usize], &[f64], f64)> {
        self.rows
            .as_ref()
            .map(|r| (&r[..], self.values.as_slice(), self.fill))
    }

    /// Every row's value.
    pub fn to_vec(&self) -> Vec<f64> {
        match &self.rows {
            None => self.values.as_ref().clone(),
            Some(rows) => {
                let mut out = vec![self.fill; self.len];
                for (&i, &v) in rows.iter().zip(self.values.iter()) {
                    out[i] = v;
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
        if let (Some(ra), Some(rb), Some(rc)) = (&a.rows, &b.rows, &c.rows) {
            if ra == rb && ra == rc {
                let values = a
                    .values
                    .iter()
                    .zip(b.values.iter())
                    .zip(c.values.iter())
                    .map(|((x, y), z)| f(*x, *y, *z))
                    .collect();
                return Self {
                    len: a.len,
                    rows: Some(ra.clone()),
                    values: Arc::new(values),
                    fill: f(a.fill, b.fill, c.fill),
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
        match &self.rows {
            None => &self.values[i],
            Some(rows) => {
                assert!(i < self.len, "row {i} of a column of {} rows", self.len);
                match rows.binary_search(&i) {
                    Ok(p) => &self.values[p],
                    Err(_) if self.fill.is_nan() => &NAN,
                    Err(_) => &self.fill,
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
}
