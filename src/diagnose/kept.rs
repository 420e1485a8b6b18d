//! What a model keeps of its earlier work for the parameter sets that follow: the explain step
//! simulates its base parameters, then probes and fits one effect at a time from them, and most
//! of those parameter sets share the base's inputs (a drag area, a clutch capacity or a lash does
//! not change what is read from the recording) or, for the axle model, its whole simulation.
//! [`Kept`] holds a few such items, each with the number of times it was reused: a new item
//! takes a free place or the oldest place whose item was never reused, so a base that serves
//! several probes stays while one-off items pass through.
//!
//! Keeping never changes a result: an item is taken only where building it again would give
//! the same bits (each model states its key). On a long drive ([`is_long`]) nothing is kept
//! besides what a model always keeps: an item holds a whole drive's columns, 0.1 GB or more
//! for 10 hours, and the long drive's memory comes first.

use super::long_drive::is_long;
use std::sync::Mutex;

/// Most items kept on a drive of ordinary length.
pub const KEPT_ITEMS: usize = 2;

/// A few items kept for reuse, each with its reuse count (module doc). Shared between threads.
#[derive(Debug)]
pub struct Kept<T> {
    items: Mutex<Vec<(T, u32)>>,
    capacity: usize,
}

impl<T> Kept<T> {
    /// Room for [`KEPT_ITEMS`] on a drive of `rows` rows, none on a long drive.
    pub fn for_rows(rows: usize) -> Self {
        Self::with_capacity(if is_long(rows) { 0 } else { KEPT_ITEMS })
    }

    /// Room for `capacity` items.
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            items: Mutex::new(Vec::with_capacity(capacity)),
            capacity,
        }
    }

    /// Whether an item can be kept at all (not on a long drive): a caller builds what it would
    /// keep only then.
    pub fn keeps(&self) -> bool {
        self.capacity > 0
    }

    /// `take` of the first item (oldest first) for which it gives something; that item counts
    /// one more reuse.
    pub fn find<R>(&self, mut take: impl FnMut(&T) -> Option<R>) -> Option<R> {
        let mut items = self.items.lock().unwrap_or_else(|e| e.into_inner());
        items.iter_mut().find_map(|(item, hits)| {
            let r = take(item)?;
            *hits += 1;
            Some(r)
        })
    }

    /// Keeps `item` in a free place, or in place of the oldest item never reused; else drops it.
    pub fn keep(&self, item: T) {
        let mut items = self.items.lock().unwrap_or_else(|e| e.into_inner());
        if items.len() < self.capacity {
            items.push((item, 0));
        } else if let Some(i) = items.iter().position(|(_, hits)| *hits == 0) {
            items.remove(i);
            items.push((item, 0));
        }
    }
}

impl<T: Clone> Clone for Kept<T> {
    fn clone(&self) -> Self {
        let items = self.items.lock().unwrap_or_else(|e| e.into_inner());
        Self {
            items: Mutex::new(items.clone()),
            capacity: self.capacity,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reused_item_stays_while_one_off_items_pass_through() {
        let kept = Kept::with_capacity(2);
        kept.keep("base");
        assert_eq!(kept.find(|s| (*s == "base").then_some(1)), Some(1));
        kept.keep("a");
        kept.keep("b"); // replaces "a", never reused
        assert_eq!(kept.find(|s| (*s == "a").then_some(())), None);
        assert_eq!(kept.find(|s| (*s == "b").then_some(())), Some(()));
        kept.keep("c"); // both reused: dropped
        assert_eq!(kept.find(|s| (*s == "c").then_some(())), None);
        assert_eq!(kept.find(|s| (*s == "base").then_some(2)), Some(2));
    }

    #[test]
    fn nothing_is_kept_on_a_long_drive() {
        let kept = Kept::for_rows(crate::diagnose::long_drive::LONG_DRIVE_MIN_ROWS);
        assert!(!kept.keeps());
        kept.keep(1);
        assert_eq!(kept.find(|x| Some(*x)), None);
        let kept = Kept::for_rows(1000);
        kept.keep(1);
        assert_eq!(kept.find(|x| Some(*x)), Some(1));
    }
}
