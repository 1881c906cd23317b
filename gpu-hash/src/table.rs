//! The table: dimensions, GPU buffers, binding helpers, statistics and the CPU twin.

use std::num::NonZeroU64;

use bytemuck::{Pod, Zeroable};

use crate::{HASH_FIRST_SENTINEL, HashError, HashGridParams};

/// Table dimensions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableConfig {
    /// Number of buckets (default 100,000 as in the paper).
    pub num_buckets: u32,
    /// Slots per bucket (default 32 as in the paper).
    pub slots_per_bucket: u32,
    /// Buckets probed before giving up (default 1, the paper's behaviour: a full bucket is an
    /// overflow). With `k > 1` a key whose bucket is full spills into the next `k - 1` buckets
    /// (wrapping), which keeps inserts from failing at high load; `find` follows the same path.
    pub probe_buckets: u32,
}

impl Default for TableConfig {
    fn default() -> Self {
        Self {
            num_buckets: 100_000,
            slots_per_bucket: 32,
            probe_buckets: 1,
        }
    }
}

impl TableConfig {
    /// Total number of slots.
    pub fn num_slots(&self) -> u64 {
        u64::from(self.num_buckets) * u64::from(self.slots_per_bucket)
    }

    /// Checks the dimensions (non-zero, fewer slots than the first sentinel, probes within the
    /// table).
    pub fn validate(&self) -> Result<(), HashError> {
        if self.num_buckets == 0 || self.slots_per_bucket == 0 {
            return Err(HashError::InvalidConfig(format!(
                "{} buckets x {} slots: both must be non-zero",
                self.num_buckets, self.slots_per_bucket
            )));
        }
        if self.num_slots() >= u64::from(HASH_FIRST_SENTINEL) {
            return Err(HashError::InvalidConfig(format!(
                "{} slots: must stay below {HASH_FIRST_SENTINEL:#x} so no slot looks like a \
                 sentinel",
                self.num_slots()
            )));
        }
        if self.probe_buckets == 0 || self.probe_buckets > self.num_buckets {
            return Err(HashError::InvalidConfig(format!(
                "probe_buckets {} must be in 1..={}",
                self.probe_buckets, self.num_buckets
            )));
        }
        Ok(())
    }
}

/// The stats buffer (`HashStatsAtomic` in `table.wgsl`). Inserts maintain the first four
/// fields; [`crate::HashBatch::bind_stats`] recomputes the next three from the table.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct HashStats {
    /// find_or_insert calls that found every probed slot taken (each returned `HASH_FULL`).
    pub overflows: u32,
    /// Insert positions with a NaN or infinite coordinate.
    pub rejected_nonfinite: u32,
    /// Insert positions whose cell coordinates fall outside (-2^31, 2^31).
    pub rejected_out_of_range: u32,
    /// Longest probe (in slots) of an insert that left its home bucket; 0 when none did.
    pub max_spill_probe: u32,
    /// Non-empty slots.
    pub used_slots: u32,
    /// Slots used in the fullest bucket: the longest probe within a home bucket.
    pub max_bucket_fill: u32,
    /// Buckets with every slot used.
    pub full_buckets: u32,
    pub reserved: u32,
}

impl HashStats {
    /// Byte offset of the fields the stats kernel recomputes.
    pub(crate) const COMPUTED_OFFSET: u64 = 16;

    /// Keys rejected for either reason.
    pub fn rejected(&self) -> u32 {
        self.rejected_nonfinite + self.rejected_out_of_range
    }

    /// Longest probe in slots of any stored key.
    pub fn max_probe(&self) -> u32 {
        self.max_bucket_fill.max(self.max_spill_probe)
    }
}

fn uniform_entry(binding: u32, size: u64) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: NonZeroU64::new(size),
        },
        count: None,
    }
}

fn storage_entry(binding: u32, read_only: bool, size: u64) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: NonZeroU64::new(size),
        },
        count: None,
    }
}

/// Layout entries of the table role (params, checksums, counters, stats) at
/// `first_binding..first_binding + 4`, for [`crate::bindings_wgsl`].
pub fn bind_group_layout_entries(first_binding: u32) -> Vec<wgpu::BindGroupLayoutEntry> {
    let stats_size = size_of::<HashStats>() as u64;
    let mut entries = table_entries(first_binding, false);
    entries.push(storage_entry(first_binding + 3, false, stats_size));
    entries
}

/// Layout entries of the lookup role (params, checksums, counters; read-only) at
/// `first_binding..first_binding + 3`, for [`crate::lookup_bindings_wgsl`].
pub fn lookup_bind_group_layout_entries(first_binding: u32) -> Vec<wgpu::BindGroupLayoutEntry> {
    table_entries(first_binding, true)
}

/// The entries both roles have: params, checksums and counters from `first_binding` on.
fn table_entries(first_binding: u32, read_only: bool) -> Vec<wgpu::BindGroupLayoutEntry> {
    let b = first_binding;
    vec![
        uniform_entry(b, size_of::<HashGridParams>() as u64),
        storage_entry(b + 1, read_only, 4),
        storage_entry(b + 2, read_only, 4),
    ]
}

/// The buffers of one table, owned by a [`HashTable`] or by the caller. Sizes: params
/// `size_of::<HashGridParams>()` (UNIFORM), checksums and counters 4 bytes per slot, stats
/// `size_of::<HashStats>()` (STORAGE).
#[derive(Debug, Clone, Copy)]
pub struct TableBuffers<'a> {
    pub params: &'a wgpu::Buffer,
    pub checksums: &'a wgpu::Buffer,
    pub counters: &'a wgpu::Buffer,
    pub stats: &'a wgpu::Buffer,
}

impl<'a> TableBuffers<'a> {
    /// Bind group entries of the table role at `first_binding..first_binding + 4`.
    pub fn bind_group_entries(&self, first_binding: u32) -> Vec<wgpu::BindGroupEntry<'a>> {
        let mut entries = self.lookup_bind_group_entries(first_binding);
        entries.push(entry(first_binding + 3, self.stats));
        entries
    }

    /// Bind group entries of the lookup role at `first_binding..first_binding + 3`.
    pub fn lookup_bind_group_entries(&self, first_binding: u32) -> Vec<wgpu::BindGroupEntry<'a>> {
        let b = first_binding;
        vec![
            entry(b, self.params),
            entry(b + 1, self.checksums),
            entry(b + 2, self.counters),
        ]
    }

    /// Records the per-frame reset: every slot empty, every counter and stat 0.
    pub fn encode_clear(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(self.checksums, 0, None);
        encoder.clear_buffer(self.counters, 0, None);
        encoder.clear_buffer(self.stats, 0, None);
    }
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// A table on the GPU: its params uniform, checksums, per-slot counters and stats.
#[derive(Debug)]
pub struct HashTable {
    config: TableConfig,
    params: wgpu::Buffer,
    checksums: wgpu::Buffer,
    counters: wgpu::Buffer,
    stats: wgpu::Buffer,
}

impl HashTable {
    /// Allocates a zeroed table of `params`' dimensions and uploads `params` (written on the
    /// next queue submission).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        params: &HashGridParams,
    ) -> Result<Self, HashError> {
        let config = TableConfig {
            num_buckets: params.num_buckets,
            slots_per_bucket: params.slots_per_bucket,
            probe_buckets: params.probe_buckets,
        };
        config.validate()?;
        let limits = device.limits();
        crate::check_limits(
            "HashTable (table role)",
            &[
                (
                    "max_storage_buffers_per_shader_stage",
                    crate::TABLE_STORAGE_BUFFERS,
                    limits.max_storage_buffers_per_shader_stage,
                ),
                (
                    "max_uniform_buffers_per_shader_stage",
                    1,
                    limits.max_uniform_buffers_per_shader_stage,
                ),
            ],
        )?;
        let bytes = config.num_slots() * 4;
        let limit = device
            .limits()
            .max_storage_buffer_binding_size
            .min(device.limits().max_buffer_size);
        if bytes > limit {
            return Err(HashError::TooLarge { bytes, limit });
        }
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let table = Self {
            config,
            params: buffer(
                "gpu-hash params",
                size_of::<HashGridParams>() as u64,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            ),
            checksums: buffer("gpu-hash checksums", bytes, storage),
            counters: buffer("gpu-hash counters", bytes, storage),
            stats: buffer("gpu-hash stats", size_of::<HashStats>() as u64, storage),
        };
        table.set_params(queue, params)?;
        Ok(table)
    }

    /// Replaces the params (eye, sizing) through `queue.write_buffer`: they take effect at the
    /// next submission. The dimensions must match the table's.
    pub fn set_params(
        &self,
        queue: &wgpu::Queue,
        params: &HashGridParams,
    ) -> Result<(), HashError> {
        let c = &self.config;
        if params.num_buckets != c.num_buckets
            || params.slots_per_bucket != c.slots_per_bucket
            || params.probe_buckets != c.probe_buckets
        {
            return Err(HashError::ParamsMismatch {
                params_buckets: params.num_buckets,
                params_slots: params.slots_per_bucket,
                table_buckets: c.num_buckets,
                table_slots: c.slots_per_bucket,
            });
        }
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        Ok(())
    }

    pub fn config(&self) -> &TableConfig {
        &self.config
    }

    pub fn buffers(&self) -> TableBuffers<'_> {
        TableBuffers {
            params: &self.params,
            checksums: &self.checksums,
            counters: &self.counters,
            stats: &self.stats,
        }
    }

    /// Bind group entries of the table role (see [`crate::bindings_wgsl`]).
    pub fn bind_group_entries(&self, first_binding: u32) -> Vec<wgpu::BindGroupEntry<'_>> {
        self.buffers().bind_group_entries(first_binding)
    }

    /// Bind group entries of the lookup role (see [`crate::lookup_bindings_wgsl`]).
    pub fn lookup_bind_group_entries(&self, first_binding: u32) -> Vec<wgpu::BindGroupEntry<'_>> {
        self.buffers().lookup_bind_group_entries(first_binding)
    }

    /// Records the per-frame reset into the caller's encoder.
    pub fn encode_clear(&self, encoder: &mut wgpu::CommandEncoder) {
        self.buffers().encode_clear(encoder);
    }

    pub fn checksums(&self) -> &wgpu::Buffer {
        &self.checksums
    }

    pub fn counters(&self) -> &wgpu::Buffer {
        &self.counters
    }

    pub fn stats(&self) -> &wgpu::Buffer {
        &self.stats
    }

    pub fn params(&self) -> &wgpu::Buffer {
        &self.params
    }
}

/// Outcome of one CPU-twin probe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Probe {
    /// The slot, or `None` (insert: every probed slot taken; find: not present).
    pub slot: Option<u32>,
    /// Slots examined.
    pub probes: u32,
}

/// The CPU twin of the table role: same probe sequence, same slots for a sequential insertion
/// order. Used for expectations in tests and for planning table sizes.
#[derive(Debug, Clone)]
pub struct CpuHashTable {
    pub config: TableConfig,
    pub checksums: Vec<u32>,
    pub overflows: u32,
}

impl CpuHashTable {
    pub fn new(config: TableConfig) -> Result<Self, HashError> {
        config.validate()?;
        Ok(Self {
            config,
            checksums: vec![0; config.num_slots() as usize],
            overflows: 0,
        })
    }

    /// Walks the probe sequence of `bucket`: `Ok(slot)` where `checksum` is, `Err(Some(slot))`
    /// at the first empty slot, `Err(None)` when every probed slot holds another checksum;
    /// with the number of slots examined.
    fn walk(&self, bucket: u32, checksum: u32) -> (Result<u32, Option<u32>>, u32) {
        let spb = self.config.slots_per_bucket;
        let mut b = bucket;
        let mut probes = 0;
        for _ in 0..self.config.probe_buckets {
            for i in 0..spb {
                let idx = b * spb + i;
                probes += 1;
                match self.checksums[idx as usize] {
                    c if c == checksum => return (Ok(idx), probes),
                    0 => return (Err(Some(idx)), probes),
                    _ => {}
                }
            }
            b = if b + 1 == self.config.num_buckets {
                0
            } else {
                b + 1
            };
        }
        (Err(None), probes)
    }

    /// Twin of `hash_find_or_insert` (`checksum` must be non-zero).
    pub fn find_or_insert(&mut self, bucket: u32, checksum: u32) -> Probe {
        let (found, probes) = self.walk(bucket, checksum);
        let slot = match found {
            Ok(slot) => Some(slot),
            Err(Some(empty)) => {
                self.checksums[empty as usize] = checksum;
                Some(empty)
            }
            Err(None) => {
                self.overflows += 1;
                None
            }
        };
        Probe { slot, probes }
    }

    /// Twin of `hash_find`.
    pub fn find(&self, bucket: u32, checksum: u32) -> Probe {
        let (found, probes) = self.walk(bucket, checksum);
        Probe {
            slot: found.ok(),
            probes,
        }
    }

    /// Non-empty slots.
    pub fn used_slots(&self) -> usize {
        self.checksums.iter().filter(|&&c| c != 0).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{HashKey, hash};

    fn key(i: u32, level: u32) -> HashKey {
        HashKey {
            coords: [hash::pcg(i) as i32, hash::pcg(i ^ 0x5555) as i32, i as i32],
            level,
        }
    }

    #[test]
    fn full_bucket_overflows_without_touching_anything_else() {
        let config = TableConfig {
            num_buckets: 8,
            slots_per_bucket: 4,
            probe_buckets: 1,
        };
        let mut t = CpuHashTable::new(config).unwrap();
        for c in 1..=4 {
            assert_eq!(t.find_or_insert(3, c).slot, Some(12 + c - 1));
        }
        let before = t.checksums.clone();
        assert_eq!(
            t.find_or_insert(3, 99),
            Probe {
                slot: None,
                probes: 4
            }
        );
        assert_eq!((t.checksums == before, t.overflows), (true, 1));
        assert_eq!(t.find_or_insert(3, 2).slot, Some(13));
        assert_eq!(t.find(3, 99).slot, None);
        // With two probe buckets the key spills into bucket 4.
        let mut s = CpuHashTable::new(TableConfig {
            probe_buckets: 2,
            ..config
        })
        .unwrap();
        for c in 1..=5 {
            s.find_or_insert(7, c);
        }
        assert_eq!(
            s.find(7, 5),
            Probe {
                slot: Some(0),
                probes: 5
            }
        );
    }

    #[test]
    fn invalid_configs_are_errors() {
        for c in [
            TableConfig {
                num_buckets: 0,
                ..TableConfig::default()
            },
            TableConfig {
                slots_per_bucket: 0,
                ..TableConfig::default()
            },
            TableConfig {
                probe_buckets: 0,
                ..TableConfig::default()
            },
            TableConfig {
                num_buckets: 1 << 28,
                slots_per_bucket: 16,
                probe_buckets: 1,
            },
        ] {
            assert!(c.validate().is_err(), "{c:?}");
        }
    }

    /// Measured false matches of absent keys with `bits`-bit checksums, and the count the theory
    /// expects with its variance. `planted` makes `find` compare one bit fewer (the negative
    /// control: a real defect the test must catch).
    fn false_matches(bits: u32, planted: bool) -> (f64, f64, f64) {
        let mask = (1u32 << bits) - 1;
        let narrow = |k: &HashKey| (hash::xxhash32(k.checksum()) & mask).max(1);
        let config = TableConfig {
            num_buckets: 1024,
            slots_per_bucket: 32,
            probe_buckets: 1,
        };
        let nb = config.num_buckets;
        let mut t = CpuHashTable::new(config).unwrap();
        for i in 0..(0.6 * config.num_slots() as f64) as u32 {
            let k = key(i, 0);
            t.find_or_insert(k.bucket(nb), narrow(&k));
        }
        // P(two independent checksums are equal): value 1 has probability 2/2^b, the others 1/2^b.
        let q = (2f64.powi(bits as i32) + 2.0) / 4f64.powi(bits as i32);
        let (mut measured, mut expected, mut variance) = (0.0, 0.0, 0.0);
        let compare_mask = if planted { mask >> 1 } else { mask };
        for i in 0..200_000 {
            let k = key(i, 99); // level 99: never inserted
            let (b, c) = (k.bucket(nb), narrow(&k));
            let slots = &t.checksums[(b * 32) as usize..(b * 32 + 32) as usize];
            let occupied = slots.iter().take_while(|&&s| s != 0).count();
            let hit = slots[..occupied]
                .iter()
                .any(|&s| (s ^ c) & compare_mask == 0);
            if !planted {
                assert_eq!(hit, t.find(b, c).slot.is_some());
            }
            measured += f64::from(u8::from(hit));
            let p = 1.0 - (1.0 - q).powi(occupied as i32);
            expected += p;
            variance += p * (1.0 - p);
        }
        (measured, expected, variance)
    }

    #[test]
    fn checksum_false_match_rate_follows_theory() {
        // 12-bit checksums make false matches frequent enough to count (~900 expected); the
        // 32-bit rate is the same formula with q ~ 2^-32. Tolerance: 5 standard deviations.
        let (m, e, v) = false_matches(12, false);
        assert!(
            (m - e).abs() < 5.0 * v.sqrt(),
            "measured {m}, expected {e} +- {}",
            v.sqrt()
        );
        // Negative control: comparing 11 of the 12 bits doubles the rate and is caught.
        let (m, e, v) = false_matches(12, true);
        assert!(
            (m - e).abs() > 5.0 * v.sqrt(),
            "planted defect not detected: {m} vs {e}"
        );
    }
}
