use std::fmt;

use super::{GpuContext, GpuError, buffers};

/// Named GPU timestamp spans inside one command encoder.
///
/// ```no_run
/// # use restir_world::{GpuContext, GpuTimer};
/// # let ctx = GpuContext::new()?;
/// let mut timer = GpuTimer::new(&ctx, 16);
/// let mut encoder = ctx.device.create_command_encoder(&Default::default());
/// timer.span(&mut encoder, "my pass", |enc| {
///     // record compute passes into `enc`
/// #   let _ = enc;
/// });
/// timer.resolve(&mut encoder);
/// ctx.queue.submit([encoder.finish()]);
/// let times = timer.read(&ctx)?; // Err(Unavailable) when the adapter has no timestamps
/// println!("{times}");
/// # Ok::<(), restir_world::GpuError>(())
/// ```
///
/// Spans use encoder-level timestamps (`TIMESTAMP_QUERY_INSIDE_ENCODERS`), so they can wrap
/// work that a primitive records into the encoder itself. Without the feature the closures
/// still run, and [`GpuTimer::read`] answers [`GpuError::Unavailable`]: never a time of 0.
#[derive(Debug)]
pub struct GpuTimer {
    queries: Option<Queries>,
    capacity: u32,
    names: Vec<String>,
}

#[derive(Debug)]
struct Queries {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    period_ns: f32,
}

/// Milliseconds per named span, in recording order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SpanTimes(pub Vec<(String, f64)>);

impl SpanTimes {
    /// Milliseconds of the first span called `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, ms)| *ms)
    }
    /// Sum of all spans whose name starts with `prefix`.
    pub fn sum_prefix(&self, prefix: &str) -> f64 {
        self.0
            .iter()
            .filter(|(n, _)| n.starts_with(prefix))
            .map(|(_, ms)| ms)
            .sum()
    }
    /// Sum of all spans.
    pub fn total(&self) -> f64 {
        self.0.iter().map(|(_, ms)| ms).sum()
    }
}

impl fmt::Display for SpanTimes {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (name, ms)) in self.0.iter().enumerate() {
            if i > 0 {
                write!(f, " ")?;
            }
            write!(f, "{name}={ms:.4}ms")?;
        }
        Ok(())
    }
}

impl GpuTimer {
    /// A timer with room for `capacity` spans per recording.
    pub fn new(ctx: &GpuContext, capacity: u32) -> Self {
        let capacity = capacity.max(1);
        let queries = ctx.features.timestamps.then(|| Queries {
            set: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("GpuTimer queries"),
                ty: wgpu::QueryType::Timestamp,
                count: capacity * 2,
            }),
            resolve: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("GpuTimer resolve"),
                size: u64::from(capacity) * 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            period_ns: ctx.queue.get_timestamp_period(),
        });
        Self {
            queries,
            capacity,
            names: Vec::new(),
        }
    }

    /// Whether this timer records anything (the adapter has timestamp queries).
    pub fn is_available(&self) -> bool {
        self.queries.is_some()
    }

    /// Forgets the recorded spans so the timer can be used for another encoder.
    pub fn reset(&mut self) {
        self.names.clear();
    }

    /// Records `body` into `encoder` between two timestamps named `name`.
    ///
    /// # Panics
    /// When more than `capacity` spans are recorded before [`GpuTimer::reset`]: a programming
    /// error, not a runtime condition.
    pub fn span<R>(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        name: &str,
        body: impl FnOnce(&mut wgpu::CommandEncoder) -> R,
    ) -> R {
        let index = self.names.len() as u32;
        assert!(
            index < self.capacity,
            "GpuTimer: more than {} spans recorded",
            self.capacity
        );
        self.names.push(name.to_owned());
        if let Some(q) = &self.queries {
            encoder.write_timestamp(&q.set, index * 2);
        }
        let out = body(encoder);
        if let Some(q) = &self.queries {
            encoder.write_timestamp(&q.set, index * 2 + 1);
        }
        out
    }

    /// Records the copy of the timestamps into the resolve buffer; call once after the spans.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        if let Some(q) = &self.queries
            && !self.names.is_empty()
        {
            encoder.resolve_query_set(&q.set, 0..self.names.len() as u32 * 2, &q.resolve, 0);
        }
    }

    /// Reads the span times back (blocks). Call after the encoder was submitted.
    pub fn read(&self, ctx: &GpuContext) -> Result<SpanTimes, GpuError> {
        let q = self
            .queries
            .as_ref()
            .ok_or(GpuError::Unavailable("GPU timestamp queries"))?;
        if self.names.is_empty() {
            return Ok(SpanTimes::default());
        }
        let ticks: Vec<u64> =
            buffers::read_range(ctx, &q.resolve, 0, self.names.len() as u64 * 16)?;
        let ms_per_tick = f64::from(q.period_ns) * 1e-6;
        Ok(SpanTimes(
            self.names
                .iter()
                .enumerate()
                .map(|(i, name)| {
                    let (t0, t1) = (ticks[2 * i], ticks[2 * i + 1]);
                    (name.clone(), t1.wrapping_sub(t0) as f64 * ms_per_tick)
                })
                .collect(),
        ))
    }
}
