//! The proof's drives on `jobs` workers, each its own single-thread rayon pool.
//!
//! A drive's diagnosis is parallel inside (a fit's start grid, the candidate fits, the noise
//! floor's copies). Run as items of one shared pool, a thread waiting for its own drive's
//! parallel work can steal another drive whole and finish it first, so a drive's measured time
//! can hold other drives' work and drives in flight can pile up on one thread's stack. On workers
//! of their own, each drive runs from start to end on one thread, with its inner parallel work
//! done in turn there: a drive's time is the core-seconds it took, and `jobs` drives are in
//! flight at most. The outputs are the same whatever the thread count (the diagnosis is
//! deterministic), so this changes times, never results.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// `f` over `items` on `jobs` workers (at least one), results in `items`' order; `done` is
/// called with the count finished after each item.
///
/// # Errors
/// The pool's message when a worker's thread pool cannot be built.
pub fn on_workers<T, R, F>(
    jobs: usize,
    items: &[T],
    f: F,
    done: &(dyn Fn(usize) + Sync),
) -> Result<Vec<R>, String>
where
    T: Sync,
    R: Send,
    F: Fn(&T) -> R + Sync,
{
    let next = AtomicUsize::new(0);
    let finished = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<R>>> = Mutex::new((0..items.len()).map(|_| None).collect());
    let workers = jobs.clamp(1, items.len().max(1));
    let errors: Vec<String> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| -> Result<(), String> {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(1)
                        .build()
                        .map_err(|e| e.to_string())?;
                    pool.install(|| loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(item) = items.get(i) else {
                            break;
                        };
                        let r = f(item);
                        slots.lock().unwrap_or_else(|p| p.into_inner())[i] = Some(r);
                        done(finished.fetch_add(1, Ordering::Relaxed) + 1);
                    });
                    Ok(())
                })
            })
            .collect();
        handles
            .into_iter()
            .filter_map(|h| match h.join() {
                Ok(r) => r.err(),
                Err(p) => std::panic::resume_unwind(p),
            })
            .collect()
    });
    if let Some(e) = errors.into_iter().next() {
        return Err(e);
    }
    Ok(slots
        .into_inner()
        .unwrap_or_else(|p| p.into_inner())
        .into_iter()
        .map(|r| r.expect("every item run"))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_in_the_items_order_each_on_a_single_thread_pool() {
        let items: Vec<u64> = (0..20).collect();
        let count = AtomicUsize::new(0);
        let got = on_workers(
            3,
            &items,
            |&x| {
                // inner parallel work runs on the worker's own one-thread pool
                assert_eq!(rayon::current_num_threads(), 1);
                x * x
            },
            &|_| {
                count.fetch_add(1, Ordering::Relaxed);
            },
        )
        .unwrap();
        assert_eq!(got, items.iter().map(|x| x * x).collect::<Vec<_>>());
        assert_eq!(count.load(Ordering::Relaxed), 20);
        let none: Vec<u64> = on_workers(2, &[], |&x: &u64| x, &|_| {}).unwrap();
        assert!(none.is_empty());
    }
}
