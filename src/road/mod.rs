//! Roads: slope filtering (seed 000 §5); synthetic roads come later.
