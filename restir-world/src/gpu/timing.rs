use std::fmt;

use super::{GpuContext, GpuError, buffers};

/// Named GPU timestamp spans inside one command encoder, as many as are recorded (the query
/// sets grow by [`SPANS_PER_SET`] spans when full).
///
/// ```no_run
/// # use restir_world::{GpuContext, GpuTimer};
/// # let ctx = GpuContext::new()?;
/// let mut timer = GpuTimer::new(&ctx);
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
    /// `None` without timestamp queries.
    device: Option<wgpu::Device>,
    sets: Vec<QuerySet>,
    period_ns: f32,
    names: Vec<String>,
}

/// Spans per query set.
pub const SPANS_PER_SET: u32 = 16;

#[derive(Debug)]
struct QuerySet {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
}

/// Milliseconds per named span, in recording order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SpanTimes(pub Vec<(String, f64)>);

impl SpanTimes {
    /// Milliseconds of the first span called `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.0.iter().find(|(n, _)| n == name).map(|(_, ms)| *ms)
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
    /// A timer on `ctx`'s device (inert when the adapter has no timestamp queries).
    pub fn new(ctx: &GpuContext) -> Self {
        Self {
            device: ctx.features.timestamps.then(|| ctx.device.clone()),
            sets: Vec::new(),
            period_ns: ctx.queue.get_timestamp_period(),
            names: Vec::new(),
        }
    }

    /// Whether this timer records anything (the adapter has timestamp queries).
    pub fn is_available(&self) -> bool {
        self.device.is_some()
    }

    /// Forgets the recorded spans so the timer can be used for another encoder.
    pub fn reset(&mut self) {
        self.names.clear();
    }

    /// Records `body` into `encoder` between two timestamps named `name`.
    pub fn span<R>(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        name: &str,
        body: impl FnOnce(&mut wgpu::CommandEncoder) -> R,
    ) -> R {
        let index = self.begin(encoder, name);
        let out = body(encoder);
        self.end(encoder, index);
        out
    }

    /// Opens the span `name` (the first timestamp); returns its index for [`GpuTimer::end`].
    pub fn begin(&mut self, encoder: &mut wgpu::CommandEncoder, name: &str) -> u32 {
        let index = self.names.len() as u32;
        self.names.push(name.to_owned());
        if let Some(device) = &self.device {
            if index / SPANS_PER_SET >= self.sets.len() as u32 {
                self.sets.push(QuerySet {
                    set: device.create_query_set(&wgpu::QuerySetDescriptor {
                        label: Some("GpuTimer queries"),
                        ty: wgpu::QueryType::Timestamp,
                        count: SPANS_PER_SET * 2,
                    }),
                    resolve: device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("GpuTimer resolve"),
                        size: u64::from(SPANS_PER_SET) * 16,
                        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                        mapped_at_creation: false,
                    }),
                });
            }
            self.write(encoder, index, 0);
        }
        index
    }

    /// Closes the span `index` (the second timestamp).
    pub fn end(&mut self, encoder: &mut wgpu::CommandEncoder, index: u32) {
        if self.device.is_some() {
            self.write(encoder, index, 1);
        }
    }

    fn write(&self, encoder: &mut wgpu::CommandEncoder, index: u32, which: u32) {
        let set = &self.sets[(index / SPANS_PER_SET) as usize].set;
        encoder.write_timestamp(set, (index % SPANS_PER_SET) * 2 + which);
    }

    /// Records the copy of the timestamps into the resolve buffers; call once after the spans.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        let spans = self.names.len() as u32;
        for (i, q) in self.sets.iter().enumerate() {
            let first = i as u32 * SPANS_PER_SET;
            if first < spans {
                let n = (spans - first).min(SPANS_PER_SET);
                encoder.resolve_query_set(&q.set, 0..n * 2, &q.resolve, 0);
            }
        }
    }

    /// Reads the span times back (blocks). Call after the encoder was submitted.
    pub fn read(&self, ctx: &GpuContext) -> Result<SpanTimes, GpuError> {
        if self.device.is_none() {
            return Err(GpuError::Unavailable("GPU timestamp queries"));
        }
        let mut ticks: Vec<u64> = Vec::new();
        let spans = self.names.len() as u64;
        for (i, q) in self.sets.iter().enumerate() {
            let first = i as u64 * u64::from(SPANS_PER_SET);
            if first < spans {
                let n = (spans - first).min(u64::from(SPANS_PER_SET));
                ticks.extend(buffers::read_range::<u64>(ctx, &q.resolve, 0, n * 16)?);
            }
        }
        let ms_per_tick = f64::from(self.period_ns) * 1e-6;
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

/// Total GPU milliseconds per span name over a number of frames: the one place span times
/// are folded.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PassTimes {
    pub frames: u32,
    pub passes: Vec<(String, f64)>,
}

impl PassTimes {
    /// Adds spans (same names add up, new names go last; frames are counted by the caller).
    pub fn add(&mut self, times: &SpanTimes) {
        self.add_passes(&times.0);
    }

    /// Adds another's frames and pass totals.
    pub fn merge(&mut self, other: &PassTimes) {
        self.add_passes(&other.passes);
        self.frames += other.frames;
    }

    /// The frames of `runs` together.
    pub fn sum<'a>(runs: impl IntoIterator<Item = &'a PassTimes>) -> PassTimes {
        let mut sum = PassTimes::default();
        for r in runs {
            sum.merge(r);
        }
        sum
    }

    fn add_passes(&mut self, passes: &[(String, f64)]) {
        for (name, ms) in passes {
            match self.passes.iter_mut().find(|(n, _)| n == name) {
                Some((_, total)) => *total += ms,
                None => self.passes.push((name.clone(), *ms)),
            }
        }
    }

    /// Total milliseconds of the pass `name` (0 when it did not run).
    pub fn pass_ms(&self, name: &str) -> f64 {
        self.passes
            .iter()
            .filter(|(n, _)| n == name)
            .map(|(_, ms)| ms)
            .sum()
    }

    /// Total over all passes and frames.
    pub fn total_ms(&self) -> f64 {
        self.passes.iter().map(|(_, ms)| ms).sum()
    }

    /// Mean milliseconds of a frame.
    pub fn ms_per_frame(&self) -> f64 {
        self.total_ms() / f64::from(self.frames.max(1))
    }

    /// Mean milliseconds per frame of each pass.
    pub fn per_frame(&self) -> Vec<(String, f64)> {
        let f = f64::from(self.frames.max(1));
        self.passes
            .iter()
            .map(|(n, ms)| (n.clone(), ms / f))
            .collect()
    }

    /// The median over `runs` of each run's milliseconds per frame (`None` without runs):
    /// robust to the odd slow frame where the mean is not.
    pub fn median_ms_per_frame(runs: &[PassTimes]) -> Option<f64> {
        median(runs.iter().map(PassTimes::ms_per_frame).collect())
    }

    /// Per pass (in the order of [`PassTimes::sum`]), the median over `runs` of its
    /// milliseconds per frame; a run without the pass counts 0 ms.
    pub fn median_per_frame(runs: &[PassTimes]) -> Vec<(String, f64)> {
        let per_frame = |r: &PassTimes, name: &str| r.pass_ms(name) / f64::from(r.frames.max(1));
        PassTimes::sum(runs)
            .passes
            .into_iter()
            .map(|(name, _)| {
                let ms = median(runs.iter().map(|r| per_frame(r, &name)).collect());
                (name, ms.unwrap_or(0.0))
            })
            .collect()
    }

    /// `name=ms ...` per frame, for logs.
    pub fn line(&self) -> String {
        self.per_frame()
            .iter()
            .map(|(n, ms)| format!("{n}={ms:.3}"))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// The middle value (the mean of the two middle ones for an even count); `None` when empty.
fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(match n % 2 {
        1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(passes: &[(&str, f64)]) -> PassTimes {
        PassTimes {
            frames: 1,
            passes: passes
                .iter()
                .map(|(n, ms)| ((*n).to_owned(), *ms))
                .collect(),
        }
    }

    /// Sums keep the first-recorded order; medians count a missing pass as 0 ms and take
    /// the middle of an even count.
    #[test]
    fn sums_and_medians_of_frames() {
        let runs = [
            frame(&[("a", 1.0), ("b", 2.0)]),
            frame(&[("b", 4.0), ("c", 1.0)]),
            frame(&[("a", 3.0), ("b", 9.0)]),
            frame(&[("a", 5.0), ("b", 1.0)]),
        ];
        let sum = PassTimes::sum(&runs);
        assert_eq!(sum.frames, 4);
        assert_eq!(
            sum.passes,
            [("a".into(), 9.0), ("b".into(), 16.0), ("c".into(), 1.0)]
        );
        assert_eq!(sum.ms_per_frame(), 26.0 / 4.0);
        // Totals 3, 5, 12, 6.
        assert_eq!(PassTimes::median_ms_per_frame(&runs), Some(5.5));
        assert_eq!(
            PassTimes::median_per_frame(&runs),
            [("a".into(), 2.0), ("b".into(), 3.0), ("c".into(), 0.0)]
        );
        assert_eq!(PassTimes::median_ms_per_frame(&[]), None);
        assert!(PassTimes::median_per_frame(&[]).is_empty());
    }
}
