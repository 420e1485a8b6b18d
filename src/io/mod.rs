//! File output: Parquet tables with units, provenance metadata and atomic writes.

mod atomic;
mod escape;
mod fingerprint;
pub mod json_f64;
mod parquet_out;

pub use atomic::{remove_stale_temps, AtomicFile};
pub use escape::escape;
pub use fingerprint::canonical;
pub use parquet_out::{
    config_hash, drive_log_columns, write_column_refs_with_constants, write_table,
    write_table_with, write_table_with_constants, ColumnRef, DataRef, OutColumn, OutData,
    OutputError, TableEncoding, TableMeta,
};
