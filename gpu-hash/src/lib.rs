//! # gpu-hash
//!
//! The world-space hash grid of Boissé 2021 (section 5, Algorithms 4 and 5) as a reusable
//! primitive on wgpu: open addressing in fixed-size buckets of 32-bit checksums, adaptive cell
//! sizes snapped to power-of-two multiples of a minimum, tangent-plane jitter, a lock-free
//! `find_or_insert` (compare-exchange, retrying the same slot on spurious failure), a read-only
//! `find`, per-slot counters and statistics. Every hash has a bit-identical Rust twin.
//!
//! ## Composing the WGSL into your own kernels
//!
//! The library files hold structs and functions only. Buffers are reached through module-scope
//! variables with fixed names that generated headers declare, so a shader is plain
//! concatenation (see [`wgsl::compose`]):
//!
//! ```text
//! constants_wgsl()                              const HASH_FULL, HASH_STATUS_OK, ...
//! bindings_wgsl(g, b)          (table role)     hash_params, hash_checksums, hash_counters, hash_stats
//! lookup_bindings_wgsl(g, b)   (lookup role)    hash_lookup_params, hash_lookup_checksums, hash_lookup_counters
//! HASH_WGSL                                     hashes, hash_cell, hash_jitter (no buffers)
//! TABLE_WGSL                                    hash_find_or_insert, hash_find, hash_insert_position, hash_insert_cell, hash_slot_append
//! LOOKUP_WGSL                                   hash_lookup_find, hash_lookup_position, hash_lookup_slot_count
//! your kernel
//! ```
//!
//! The **table role** (read-write, atomics) builds this frame's grid; the **lookup role**
//! (read-only, plain loads) searches a table nobody writes during the dispatch: this frame's
//! grid after it is built (spatial reuse) or last frame's grid, with that frame's own eye and
//! sizes in its own params buffer (temporal reuse). Both roles can live in one shader (build
//! this frame while reading the last one). Keep two [`HashTable`]s and swap them each frame.
//!
//! On the host: [`bind_group_layout_entries`] / [`lookup_bind_group_layout_entries`] for the
//! layouts, [`HashTable::bind_group_entries`] / [`HashTable::lookup_bind_group_entries`] (or
//! [`TableBuffers`] over buffers you own) for the bind groups, or one [`GridBinding`] value
//! that derives the WGSL declarations, layout entries and bind group entries together;
//! [`HashTable::encode_clear`] before each build; [`HashBatch`] for ready-made
//! insert/find/stats kernels (create with the device, bind once, encode many times).

mod batch;
pub mod cell;
pub mod hash;
mod table;
pub mod wgsl;

pub use batch::{BATCH_STORAGE_BUFFERS_PER_STAGE, BatchBinding, BatchKernel, HashBatch};
pub use cell::{CellSizing, HashCell, HashGridParams, HashKey, jitter};
pub use table::{
    CpuHashTable, HashStats, HashTable, Probe, TableBuffers, TableConfig,
    bind_group_layout_entries, lookup_bind_group_layout_entries,
};
pub use wgsl::{
    GridBinding, HASH_WGSL, LOOKUP_WGSL, Role, TABLE_WGSL, bindings_wgsl, compose_grid,
    constants_wgsl, lookup_bindings_wgsl,
};

/// Returned instead of a slot when every probed slot holds another key (counted in
/// [`HashStats::overflows`]).
pub const HASH_FULL: u32 = 0xffff_ffff;
/// Returned by `find` when the key is not in the table.
pub const HASH_NOT_FOUND: u32 = 0xffff_fffe;
/// Returned for a position that has no cell (non-finite, or coordinates beyond i32).
pub const HASH_REJECTED: u32 = 0xffff_fffd;
/// Every value from here up is a sentinel, never a slot: tables hold fewer slots than this.
pub const HASH_FIRST_SENTINEL: u32 = 0xffff_fff0;

/// Errors of this crate.
#[derive(Debug, thiserror::Error)]
pub enum HashError {
    /// The table dimensions are unusable.
    #[error("invalid hash table config: {0}")]
    InvalidConfig(String),
    /// The cell sizing (or eye) is unusable.
    #[error("invalid cell sizing: {0}")]
    InvalidSizing(String),
    /// The table does not fit the device's storage-binding limit.
    #[error(
        "hash table of {bytes} bytes exceeds the device's max storage binding of {limit} bytes"
    )]
    TooLarge { bytes: u64, limit: u64 },
    /// Params built for another table size.
    #[error(
        "params are for {params_buckets}x{params_slots} slots, the table is {table_buckets}x{table_slots}"
    )]
    ParamsMismatch {
        params_buckets: u32,
        params_slots: u32,
        table_buckets: u32,
        table_slots: u32,
    },
    /// A caller's buffer is too small for the batch.
    #[error("buffer `{name}` holds {have} bytes, the batch needs {need}")]
    BufferTooSmall {
        name: &'static str,
        have: u64,
        need: u64,
    },
    /// A device limit is below what a kernel or binding role needs (see the crate README's
    /// device requirements table).
    #[error("{what} needs {limit} >= {needed}, the device has {available}")]
    DeviceLimit {
        /// What needs it (a kernel or binding role).
        what: &'static str,
        /// The field of [`wgpu::Limits`].
        limit: &'static str,
        needed: u64,
        available: u64,
    },
    /// A caller's buffer range would exceed the device's storage binding limit.
    #[error(
        "buffer `{name}` would be bound with {bytes} bytes, above the device's max storage binding of {limit} bytes"
    )]
    BindingTooLarge {
        name: &'static str,
        bytes: u64,
        limit: u64,
    },
    /// A caller's buffer lacks `BufferUsages::STORAGE` (wgpu would refuse to bind it).
    #[error("the {which} buffer lacks BufferUsages::STORAGE")]
    MissingStorageUsage { which: &'static str },
    /// Two buffers that must differ are the same buffer (`"table"`: one of the table's own).
    #[error("the {0} and {1} buffers must not alias")]
    Aliasing(&'static str, &'static str),
    /// A [`BatchBinding`] made by another [`HashBatch`] was passed to [`HashBatch::encode`].
    #[error("the binding was made by another HashBatch")]
    ForeignBinding,
    /// Reading the stats back failed.
    #[error("reading back hash table stats failed: {0}")]
    Readback(String),
}

/// Storage buffers the table role ([`bindings_wgsl`]) binds: checksums, counters, stats.
pub const TABLE_STORAGE_BUFFERS: u32 = 3;

/// Checks `(limit name, needed, available)` triples for `what`.
pub(crate) fn check_limits(
    what: &'static str,
    checks: &[(&'static str, u32, u32)],
) -> Result<(), HashError> {
    for &(limit, needed, available) in checks {
        if available < needed {
            return Err(HashError::DeviceLimit {
                what,
                limit,
                needed: u64::from(needed),
                available: u64::from(available),
            });
        }
    }
    Ok(())
}

/// Every WGSL module this crate ships, composed as it is used, as `(name, source)`: the
/// workspace's naga checks validate each of them.
pub fn wgsl_modules() -> Vec<(String, String)> {
    vec![
        ("gpu-hash/batch_insert".into(), batch::insert_module()),
        ("gpu-hash/batch_lookup".into(), batch::lookup_module()),
        (
            "gpu-hash/library_both_roles".into(),
            wgsl::compose(
                Some(wgsl::BindAt {
                    group: 2,
                    first_binding: 3,
                }),
                Some(wgsl::BindAt {
                    group: 3,
                    first_binding: 0,
                }),
            ),
        ),
    ]
}
