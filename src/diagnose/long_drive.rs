//! How a diagnosis spreads its simulations over the threads, by the length of the drive.
//!
//! The steps that simulate the whole drive many times — the noise floor's copies, the tolerance
//! band's edges, the screen's probes, the candidates' fits — run their items in parallel on a
//! drive of ordinary length: each item's simulation holds the drive's inputs and outputs, a few
//! tens of MB for an hour. On a long drive ([`is_long`]: 2 hours or more at 50 Hz) an item holds
//! 0.1–0.3 GB, so the items run one after the other and each simulation is parallel inside,
//! over its 20 s windows ([`super::longitudinal_model::LongitudinalModel::simulate_windows`]):
//! one whole-drive simulation in flight instead of one per thread. Both orders give the same
//! results in the same order; only the memory and the threads' use differ (a drive's axle model
//! has no windows, so a drive of ordinary length keeps the items' parallelism).
//!
//! Between its steps a long drive's diagnosis also hands the allocator's free pages back to the
//! operating system ([`crate::heap::release_free_memory`]): on a 10-hour drive that took about
//! 0.2 GB off the resident peak in one measured pair of runs; on a 20-minute drive the freed
//! columns are small and faulting
//! the returned pages in again costs more (1.5 % of the diagnosis's time on one thread, seed 1's
//! first 17 proof drives). Measured in docs/validation/benchmarks.md.

use rayon::prelude::*;

/// Rows from which a drive is long: 2 hours at 50 Hz.
pub const LONG_DRIVE_MIN_ROWS: usize = 360_000;

/// Whether a drive of `rows` rows runs its simulations one at a time (see the module
/// documentation).
pub fn is_long(rows: usize) -> bool {
    rows >= LONG_DRIVE_MIN_ROWS
}

/// Between two steps of a drive of `rows` rows: on a long drive ([`is_long`]), the allocator's
/// free pages go back to the operating system ([`crate::heap::release_free_memory`]; module
/// documentation); on a drive of ordinary length, nothing.
pub fn release_between_steps(rows: usize) {
    if is_long(rows) {
        crate::heap::release_free_memory();
    }
}

/// `f` over `items`, results in `items`' order: one after the other on this thread when
/// `one_at_a_time` (each simulation then parallel inside), in parallel otherwise.
pub fn map_in_order<T, R, F>(one_at_a_time: bool, items: &[T], f: F) -> Vec<R>
where
    T: Sync,
    R: Send,
    F: Fn(&T) -> R + Sync + Send,
{
    if one_at_a_time {
        items.iter().map(f).collect()
    } else {
        items.par_iter().map(f).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_orders_give_the_results_in_the_items_order() {
        let items: Vec<u64> = (0..100).collect();
        let serial = map_in_order(true, &items, |x| x * x);
        let parallel = map_in_order(false, &items, |x| x * x);
        assert_eq!(serial, parallel);
        assert_eq!(serial[7], 49);
        assert!(is_long(LONG_DRIVE_MIN_ROWS) && !is_long(LONG_DRIVE_MIN_ROWS - 1));
    }
}
