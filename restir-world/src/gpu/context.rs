use std::fmt;

use super::kernel::KernelCache;

/// Everything that can go wrong while acquiring or using a GPU.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter at all: on a machine without a GPU, install Mesa's lavapipe.
    #[error(
        "no GPU adapter found (backends: {backends}). On a machine without a GPU install Mesa's \
         CPU Vulkan driver: `apt-get install -y mesa-vulkan-drivers libvulkan1` (or run \
         `cargo xtask test`, which installs it when run as root)"
    )]
    NoAdapter { backends: String },
    /// Adapters exist, but none can present to the window's surface.
    #[error(
        "none of the adapters can present to this window's surface (adapters: {adapters}); the \
         windowing system or the driver has no presentation support for them"
    )]
    NoPresentableAdapter { adapters: String },
    /// `WGPU_BACKEND` names no backend wgpu knows.
    #[error(
        "WGPU_BACKEND={value:?} names no known backend (expected a comma-separated list of \
         vulkan, metal, dx12, gl, webgpu)"
    )]
    BadBackendEnv { value: String },
    /// `WGPU_ADAPTER_NAME` matched none of the adapters present.
    #[error("WGPU_ADAPTER_NAME={wanted:?} matches no adapter; available: {available}")]
    AdapterNotFound { wanted: String, available: String },
    /// The adapter refused the device request.
    #[error("the adapter {adapter:?} refused to create a device: {source}")]
    RequestDevice {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
    /// Waiting for the GPU failed (device lost, timeout).
    #[error("waiting for the GPU failed: {0}")]
    Poll(#[from] wgpu::PollError),
    /// Mapping a buffer for readback failed.
    #[error("mapping a buffer for readback failed: {0}")]
    Map(String),
    /// The feature is not available on this adapter.
    #[error("{0} is unavailable on this adapter")]
    Unavailable(&'static str),
    /// A bind group was bound with a missing, unknown or repeated name (a programming error
    /// caught before wgpu's validation).
    #[error("{0}")]
    Binding(String),
    /// A pipeline declares more storage buffers than the device allows.
    #[error(
        "the {pipeline} pipeline needs {needed} storage buffers per shader stage; the {backend} \
         backend (adapter {adapter:?}) allows {limit} (max_storage_buffers_per_shader_stage). \
         Use a backend that allows more, e.g. WGPU_BACKEND=vulkan"
    )]
    TooManyStorageBuffers {
        pipeline: String,
        needed: u32,
        limit: u32,
        backend: String,
        adapter: String,
    },
    /// A buffer larger than the device allows in one binding.
    #[error("{what} needs {bytes} bytes in one buffer, above the adapter's limit of {limit}")]
    TooLarge {
        what: String,
        bytes: u64,
        limit: u64,
    },
    /// A per-pixel buffer larger than the device allows in one binding: the image is too
    /// large ([`IMAGE_TOO_LARGE`] in the message: the demo names its `--size` flag).
    #[error(
        "{what} needs {} bytes in one binding for an image of {pixels} pixels ({bytes_per_pixel} \
         a pixel), the adapter allows {limit}: {IMAGE_TOO_LARGE} {} pixels",
        pixels * bytes_per_pixel,
        limit / bytes_per_pixel
    )]
    ImageTooLarge {
        what: String,
        pixels: u64,
        bytes_per_pixel: u64,
        limit: u64,
    },
}

/// The words of [`GpuError::ImageTooLarge`]'s message before the largest pixel count that fits.
pub const IMAGE_TOO_LARGE: &str = "the largest image it allows has";

/// Optional adapter features this project uses when they are present.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OptionalFeatures {
    /// `Features::SUBGROUP`: subgroup builtins in compute shaders.
    pub subgroup: bool,
    /// `Features::TIMESTAMP_QUERY` + `TIMESTAMP_QUERY_INSIDE_ENCODERS`: GPU timing spans.
    pub timestamps: bool,
    /// `Features::EXPERIMENTAL_RAY_QUERY`: hardware (or driver) ray queries in WGSL.
    pub ray_query: bool,
}

/// How rays are traced: the same WGSL interface (`trace_closest`, `trace_any`) on either.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tracer {
    /// Our software traversal of an obvhs compressed wide BVH: runs on every adapter.
    Bvh,
    /// WGSL ray queries on the adapter's acceleration structures
    /// (`Features::EXPERIMENTAL_RAY_QUERY`).
    RayQuery,
}

impl Tracer {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Tracer::Bvh => "bvh",
            Tracer::RayQuery => "ray-query",
        }
    }
}

impl std::str::FromStr for Tracer {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "bvh" => Ok(Tracer::Bvh),
            "ray-query" => Ok(Tracer::RayQuery),
            _ => Err(format!("unknown tracer {s:?}; known: auto, bvh, ray-query")),
        }
    }
}

/// An adapter, its device and queue, and what we learned about them.
///
/// `wgpu::Device` and `wgpu::Queue` are cheap handles: clone them freely.
#[derive(Clone)]
pub struct GpuContext {
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub features: OptionalFeatures,
    /// How renderers on this context trace rays ([`GpuContext::auto_tracer`] unless set with
    /// [`GpuContext::set_tracer`]).
    pub tracer: Tracer,
    /// The kernels created on this context (shared by its clones).
    pub kernels: KernelCache,
    /// The widest per-pixel binding checked on this context (shared by its clones but for
    /// [`GpuContext::measuring_pixel_bindings`]'s), for [`GpuContext::largest_pixel_binding`].
    pub pixel_peak: PixelPeak,
}

/// The widest per-pixel binding [`GpuContext::check_pixel_binding`] saw: bytes a pixel and
/// what the buffer is (shared by clones, fresh in [`GpuContext::measuring_pixel_bindings`]).
pub type PixelPeak = std::sync::Arc<std::sync::Mutex<Option<(u64, String)>>>;

impl fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.info.name)
            .field("backend", &self.info.backend)
            .field("features", &self.features)
            .field("tracer", &self.tracer)
            .finish()
    }
}

fn type_rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

impl GpuContext {
    /// Acquires an adapter and device, blocking.
    ///
    /// `WGPU_BACKEND` (e.g. `vulkan`, `gl`) restricts the backends; `WGPU_ADAPTER_NAME` picks the
    /// first adapter whose name contains it (case-insensitive). Otherwise a discrete GPU is
    /// preferred over an integrated one, then over a CPU adapter such as llvmpipe.
    ///
    /// The device gets the adapter's full limits plus `SUBGROUP` and timestamp queries when the
    /// adapter has them; [`GpuContext::features`] says which it got.
    pub fn new() -> Result<Self, GpuError> {
        pollster::block_on(Self::new_async())
    }

    /// Async form of [`GpuContext::new`].
    pub async fn new_async() -> Result<Self, GpuError> {
        let backends = Self::backends_from_env()?;
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);
        let adapters = instance.enumerate_adapters(backends).await;
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter {
                backends: format!("{backends:?}"),
            });
        }
        Self::pick_adapter(adapters).await
    }

    /// The backends `WGPU_BACKEND` allows (all by default), as [`GpuContext::new`] reads them.
    pub fn backends_from_env() -> Result<wgpu::Backends, GpuError> {
        let backends = wgpu::Backends::from_env().unwrap_or_default();
        if backends.is_empty() {
            return Err(GpuError::BadBackendEnv {
                value: std::env::var("WGPU_BACKEND").unwrap_or_default(),
            });
        }
        Ok(backends)
    }

    /// Like [`GpuContext::new`], on the caller's `instance` and among the adapters that can
    /// present to `surface` only (a window's, created from `instance`): the device that
    /// computes is then the one that presents. Same preferences and `WGPU_ADAPTER_NAME`.
    pub async fn for_surface(
        instance: &wgpu::Instance,
        surface: &wgpu::Surface<'_>,
    ) -> Result<Self, GpuError> {
        let backends = Self::backends_from_env()?;
        let all = instance.enumerate_adapters(backends).await;
        if all.is_empty() {
            return Err(GpuError::NoAdapter {
                backends: format!("{backends:?}"),
            });
        }
        let names = all
            .iter()
            .map(|a| {
                let i = a.get_info();
                format!("{:?} ({:?})", i.name, i.backend)
            })
            .collect::<Vec<_>>()
            .join(", ");
        let adapters: Vec<wgpu::Adapter> = all
            .into_iter()
            .filter(|a| a.is_surface_supported(surface))
            .collect();
        if adapters.is_empty() {
            return Err(GpuError::NoPresentableAdapter { adapters: names });
        }
        Self::pick_adapter(adapters).await
    }

    /// Picks among `adapters` (not empty) by `WGPU_ADAPTER_NAME`, else by device type, and
    /// creates the device.
    async fn pick_adapter(mut adapters: Vec<wgpu::Adapter>) -> Result<Self, GpuError> {
        adapters.sort_by_key(|a| type_rank(a.get_info().device_type));
        let adapter = match std::env::var("WGPU_ADAPTER_NAME") {
            Ok(wanted) if !wanted.is_empty() => {
                let needle = wanted.to_lowercase();
                let pos = adapters
                    .iter()
                    .position(|a| a.get_info().name.to_lowercase().contains(&needle));
                match pos {
                    Some(i) => adapters.swap_remove(i),
                    None => {
                        let available = adapters
                            .iter()
                            .map(|a| format!("{:?}", a.get_info().name))
                            .collect::<Vec<_>>()
                            .join(", ");
                        return Err(GpuError::AdapterNotFound { wanted, available });
                    }
                }
            }
            _ => adapters.swap_remove(0),
        };
        Self::from_adapter(adapter).await
    }

    /// Creates the device on a given adapter (the caller chose it).
    #[allow(unsafe_code)] // opting into wgpu's experimental ray queries, see below
    pub async fn from_adapter(adapter: wgpu::Adapter) -> Result<Self, GpuError> {
        let info = adapter.get_info();
        let available = adapter.features();
        let timestamp_features =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        let features = OptionalFeatures {
            subgroup: available.contains(wgpu::Features::SUBGROUP),
            timestamps: available.contains(timestamp_features),
            ray_query: available.contains(wgpu::Features::EXPERIMENTAL_RAY_QUERY),
        };
        let mut required = wgpu::Features::empty();
        if features.subgroup {
            required |= wgpu::Features::SUBGROUP;
        }
        if features.timestamps {
            required |= timestamp_features;
        }
        let mut experimental_features = wgpu::ExperimentalFeatures::disabled();
        if features.ray_query {
            required |= wgpu::Features::EXPERIMENTAL_RAY_QUERY;
            // SAFETY: wgpu marks ray queries experimental (its validation may be incomplete);
            // our ray-query WGSL only traces opaque triangles of one validated BLAS, and the
            // differential tests check every hit against obvhs's CPU traversal.
            experimental_features = unsafe { wgpu::ExperimentalFeatures::enabled() };
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("restir-world device"),
                required_features: required,
                required_limits: adapter.limits(),
                experimental_features,
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|source| GpuError::RequestDevice {
                adapter: info.name.clone(),
                source,
            })?;
        let tracer = Self::auto_tracer_for(&info, &features);
        Ok(Self {
            adapter,
            device,
            queue,
            info,
            features,
            tracer,
            kernels: KernelCache::default(),
            pixel_peak: PixelPeak::default(),
        })
    }

    /// The tracer `auto` picks: ray queries on GPUs that have them; the software BVH on CPU
    /// adapters (llvmpipe's ray queries traverse on the same cores, measured slower than our
    /// CWBVH there) and wherever ray queries are missing.
    pub fn auto_tracer(&self) -> Tracer {
        Self::auto_tracer_for(&self.info, &self.features)
    }

    fn auto_tracer_for(info: &wgpu::AdapterInfo, features: &OptionalFeatures) -> Tracer {
        match features.ray_query && info.device_type != wgpu::DeviceType::Cpu {
            true => Tracer::RayQuery,
            false => Tracer::Bvh,
        }
    }

    /// Forces a tracer (`None`: [`GpuContext::auto_tracer`]); ray queries need the feature.
    pub fn set_tracer(&mut self, tracer: Option<Tracer>) -> Result<(), GpuError> {
        let tracer = tracer.unwrap_or_else(|| self.auto_tracer());
        if tracer == Tracer::RayQuery && !self.features.ray_query {
            return Err(GpuError::Unavailable(
                "ray queries (wgpu Features::EXPERIMENTAL_RAY_QUERY; on lavapipe from Mesa 25)",
            ));
        }
        self.tracer = tracer;
        Ok(())
    }

    /// The device's limits (equal to the adapter's: we request all of them).
    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }

    /// Largest number of `u32` one storage binding can hold on this device.
    pub fn max_storage_u32s(&self) -> u64 {
        self.max_binding_bytes() / 4
    }

    /// Largest size in bytes of one storage binding on this device.
    pub fn max_binding_bytes(&self) -> u64 {
        let l = self.limits();
        l.max_storage_buffer_binding_size.min(l.max_buffer_size)
    }

    /// Checks that a buffer of `bytes_per_pixel` for each of `pixels` fits one storage binding
    /// (the error says how many pixels would).
    pub fn check_pixel_binding(
        &self,
        what: &str,
        pixels: u64,
        bytes_per_pixel: u64,
    ) -> Result<(), GpuError> {
        if let Ok(mut peak) = self.pixel_peak.lock()
            && peak.as_ref().is_none_or(|(b, _)| bytes_per_pixel > *b)
        {
            *peak = Some((bytes_per_pixel, what.to_owned()));
        }
        let limit = self.max_binding_bytes();
        if pixels.saturating_mul(bytes_per_pixel) > limit {
            return Err(GpuError::ImageTooLarge {
                what: what.to_owned(),
                pixels,
                bytes_per_pixel,
                limit,
            });
        }
        Ok(())
    }

    /// A clone of this context (the same device and kernels) that measures the per-pixel
    /// bindings checked through it afresh: build a method on it, then ask
    /// [`GpuContext::largest_pixel_binding`] how large an image that method can render.
    pub fn measuring_pixel_bindings(&self) -> Self {
        Self {
            pixel_peak: PixelPeak::default(),
            ..self.clone()
        }
    }

    /// The widest per-pixel binding checked on this context so far, in bytes a pixel, with
    /// what it holds, and the most pixels it allows in one of the adapter's bindings.
    pub fn largest_pixel_binding(&self) -> Option<(u64, String, u64)> {
        let peak = self.pixel_peak.lock().ok()?.clone()?;
        Some((peak.0, peak.1, self.max_binding_bytes() / peak.0.max(1)))
    }

    /// Checks that a buffer of `bytes` for `what` fits one storage binding.
    pub fn check_binding_size(&self, what: &str, bytes: u64) -> Result<(), GpuError> {
        let limit = self.max_binding_bytes();
        if bytes > limit {
            return Err(GpuError::TooLarge {
                what: what.to_owned(),
                bytes,
                limit,
            });
        }
        Ok(())
    }

    /// Checks that a pipeline whose bind groups are `sets` fits the device's
    /// `max_storage_buffers_per_shader_stage`.
    pub fn check_storage_buffers(
        &self,
        pipeline: &str,
        sets: &[&super::BindingSet],
    ) -> Result<(), GpuError> {
        let needed = sets.iter().map(|s| s.storage_buffers()).sum();
        let limit = self.limits().max_storage_buffers_per_shader_stage;
        if needed > limit {
            return Err(GpuError::TooManyStorageBuffers {
                pipeline: pipeline.to_owned(),
                needed,
                limit,
                backend: format!("{:?}", self.info.backend),
                adapter: self.info.name.clone(),
            });
        }
        Ok(())
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely())?;
        Ok(())
    }

    /// One line naming the adapter, backend, driver and optional features.
    pub fn describe(&self) -> String {
        format!(
            "adapter \"{}\" ({:?}, {:?}, driver {} {}); subgroup: {}; timestamps: {}; ray \
             queries: {}; tracer: {}",
            self.info.name,
            self.info.device_type,
            self.info.backend,
            self.info.driver,
            self.info.driver_info,
            if self.features.subgroup {
                "yes"
            } else {
                "unavailable"
            },
            if self.features.timestamps {
                "yes"
            } else {
                "unavailable"
            },
            if self.features.ray_query {
                "yes"
            } else {
                "unavailable"
            },
            self.tracer.name(),
        )
    }
}
