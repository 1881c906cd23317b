//! `HashBatch::bind` as an outside crate uses it (issue 27, 28): every mistake `gpu-scan`'s
//! `Scan::bind` refuses with a typed error, `gpu-hash` refuses too, before wgpu sees it (its
//! validation would fail inside `bind`: a panic under the default error handler). One case
//! per check, and a control that binds.

use glam::Vec3;
use gpu_hash::{BatchKernel, CellSizing, HashBatch, HashError, HashGridParams, HashTable};
use tests::{buffers, gpu};

/// A buffer of `bytes` with only `usage` (plus COPY_DST).
fn buffer(d: &wgpu::Device, label: &str, bytes: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
    d.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

#[test]
fn bind_refuses_what_wgpu_would_refuse() {
    let ctx = gpu::context();
    let d = &ctx.device;
    let batch = HashBatch::new(d).expect("hash batch");
    let p = HashGridParams::new(&Default::default(), &CellSizing::default(), Vec3::ZERO).unwrap();
    let t = HashTable::new(d, &ctx.queue, &p).unwrap();
    let n = 64u32;
    let storage = wgpu::BufferUsages::STORAGE;
    let input = buffers::storage_zeroed(d, "input", u64::from(n) * 16);
    let output = buffers::storage_zeroed(d, "output", u64::from(n) * 16);
    let uniform_in = buffer(
        d,
        "input without STORAGE",
        u64::from(n) * 16,
        wgpu::BufferUsages::UNIFORM,
    );
    let vertex_out = buffer(
        d,
        "output without STORAGE",
        u64::from(n) * 16,
        wgpu::BufferUsages::VERTEX,
    );
    let big = buffers::storage_zeroed(d, "both", u64::from(n) * 16);
    let k = BatchKernel::InsertKeys;

    let err = |r: Result<gpu_hash::BatchBinding, HashError>| r.expect_err("bind must refuse");
    let e = err(batch.bind(d, k, &t, &uniform_in, &output, n));
    assert!(
        matches!(e, HashError::MissingStorageUsage { which: "input" }),
        "{e}"
    );
    let e = err(batch.bind(d, BatchKernel::FindKeys, &t, &input, &vertex_out, n));
    assert!(
        matches!(e, HashError::MissingStorageUsage { which: "output" }),
        "{e}"
    );
    let e = err(batch.bind(d, k, &t, &big, &big, n));
    assert!(matches!(e, HashError::Aliasing("input", "output")), "{e}");
    // A table's own buffer as the output (bound read-write twice in one pass).
    for (name, b) in [("counters", t.counters()), ("stats", t.stats())] {
        assert!(b.usage().contains(storage), "{name}");
        let e = err(batch.bind(d, k, &t, &input, b, n));
        assert!(
            matches!(e, HashError::Aliasing("output", "table")),
            "{name}: {e}"
        );
        let e = err(batch.bind(d, k, &t, b, &output, n));
        assert!(
            matches!(e, HashError::Aliasing("input", "table")),
            "{name}: {e}"
        );
    }
    // Control: the same call with proper buffers binds and records.
    let b = batch.bind(d, k, &t, &input, &output, n).expect("bind");
    gpu::run(ctx, |enc| {
        t.encode_clear(enc);
        batch.encode(enc, &b).unwrap();
    });
}
