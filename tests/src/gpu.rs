//! The GPU context shared by all tests of one test binary.

use std::sync::OnceLock;

use restir_world::GpuContext;

/// The shared context. Panics with the fix (install lavapipe) when no adapter exists: GPU tests
/// must fail loudly, never pass vacuously.
pub fn context() -> &'static GpuContext {
    static CTX: OnceLock<Result<GpuContext, String>> = OnceLock::new();
    let ctx = CTX.get_or_init(|| {
        let ctx = GpuContext::new().map_err(|e| e.to_string())?;
        eprintln!("GPU tests run on {}", ctx.describe());
        Ok(ctx)
    });
    match ctx {
        Ok(ctx) => ctx,
        Err(e) => panic!("GPU test needs an adapter: {e}"),
    }
}

/// The shared context if it has `SUBGROUP`; otherwise prints why the caller skips and returns
/// `None`.
pub fn with_subgroups(test: &str) -> Option<&'static GpuContext> {
    let ctx = context();
    if ctx.features.subgroup {
        Some(ctx)
    } else {
        eprintln!("SKIPPED {test}: adapter {:?} lacks SUBGROUP", ctx.info.name);
        None
    }
}

/// Records work with `record`, submits it and waits for it.
pub fn run(ctx: &GpuContext, record: impl FnOnce(&mut wgpu::CommandEncoder)) {
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("test"),
        });
    record(&mut encoder);
    ctx.queue.submit([encoder.finish()]);
    ctx.wait().expect("GPU wait failed");
}
