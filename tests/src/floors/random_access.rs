pub(crate) const SOURCE: &str = include_str!("random_access.wgsl");
/// Mixed into the item index before hashing it to a random line or word.
const SEED: u32 = 0x2545_f491;

/// Random-access floors: per item one random 128-byte line read, or one random atomic add,
/// each plus one coalesced u32 write. The floors of a hash table's find and insert.
#[derive(Debug)]
pub struct RandomAccessKernel {
    read: wgpu::ComputePipeline,
    atomic: wgpu::ComputePipeline,
}

/// Which floor to record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RandomAccess {
    /// `out[i] = xor of the 128-byte line pcg(i) % lines` of `table`.
    Read128,
    /// `out[i] = atomicAdd(table[pcg(i) % words], 1)`.
    Atomic,
}

impl RandomAccessKernel {
    pub fn new(device: &wgpu::Device) -> Self {
        let entries = ["random_read_128", "random_atomic"];
        let [read, atomic] = super::item_pipelines(device, "floors/random_access", SOURCE, entries);
        Self { read, atomic }
    }

    /// Records `n` items of `kind` over `table` (128-byte lines or u32 words, its whole size)
    /// writing `out` (at least `4 n` bytes).
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        kind: RandomAccess,
        table: &wgpu::Buffer,
        out: &wgpu::Buffer,
        n: u32,
    ) {
        let lines = (table.size() / 128).max(1) as u32;
        let words = (table.size() / 4).max(1) as u32;
        let params = super::params(
            device,
            "floors/random_access params",
            [n, lines, words, SEED],
        );
        // Each entry point uses one view of the table: lines (binding 0) or words (1).
        let (pipeline, table_binding) = match kind {
            RandomAccess::Read128 => (&self.read, 0),
            RandomAccess::Atomic => (&self.atomic, 1),
        };
        let buffers = [(table_binding, table), (2, out), (3, &params)];
        let pass = ("floors/random_access", pipeline);
        super::dispatch_items(device, encoder, pass, &buffers, n);
    }
}
