//! Adapter probe, device and the compiled extraction pipeline.

use std::sync::{Arc, Mutex};

use super::segments::SEGMENT_BYTES;
use super::{AdapterKind, AdapterSummary, GpuOptions, MAX_BINDING_BYTES};
use crate::{ExtractError, Result};

/// The WGSL kernel: run segments of 32-pixel row chunks.
const RUNS_WGSL: &str = include_str!("runs.wgsl");
/// Invocations per workgroup along x (must match `@workgroup_size` in runs.wgsl).
pub(crate) const WORKGROUP: u32 = 64;
/// Pixels per chunk (must match `CHUNK` in runs.wgsl).
pub(crate) const CHUNK: u32 = 32;
/// Storage buffers the kernel binds.
const STORAGE_BUFFERS: u32 = 4;
/// Smallest storage binding the backend accepts from an adapter.
const MIN_BINDING_BYTES: u64 = 1 << 20;

/// A probed adapter: the wgpu handles and what [`choose`](super::choose) needs.
pub(crate) struct Probe {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub summary: AdapterSummary,
}

fn kind(t: wgpu::DeviceType) -> AdapterKind {
    match t {
        wgpu::DeviceType::DiscreteGpu => AdapterKind::Discrete,
        wgpu::DeviceType::IntegratedGpu => AdapterKind::Integrated,
        wgpu::DeviceType::VirtualGpu => AdapterKind::Virtual,
        wgpu::DeviceType::Cpu => AdapterKind::Cpu,
        wgpu::DeviceType::Other => AdapterKind::Other,
    }
}

/// What the adapter lacks for the kernel, if anything.
fn unmet(adapter: &wgpu::Adapter) -> Option<String> {
    let down = adapter.get_downlevel_capabilities();
    if !down.flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS) {
        return Some("no compute shader support".into());
    }
    let l = adapter.limits();
    if l.max_storage_buffers_per_shader_stage < STORAGE_BUFFERS {
        return Some(format!(
            "{} storage buffers per shader stage, the kernel needs {STORAGE_BUFFERS}",
            l.max_storage_buffers_per_shader_stage
        ));
    }
    if l.max_compute_workgroup_size_x < WORKGROUP
        || l.max_compute_invocations_per_workgroup < WORKGROUP
    {
        return Some(format!(
            "compute workgroups of at most {} invocations, the kernel needs {WORKGROUP}",
            l.max_compute_invocations_per_workgroup
                .min(l.max_compute_workgroup_size_x)
        ));
    }
    let binding = l.max_storage_buffer_binding_size.min(l.max_buffer_size);
    if binding < MIN_BINDING_BYTES {
        return Some(format!(
            "storage bindings of at most {binding} bytes, the kernel needs {MIN_BINDING_BYTES}"
        ));
    }
    None
}

/// Find the best Vulkan adapter (discrete before integrated before software),
/// or say why there is none.
pub(crate) fn probe(options: &GpuOptions) -> std::result::Result<Probe, String> {
    if let Some(reason) = super::hidden(options) {
        return Err(reason);
    }
    if !wgpu::Instance::enabled_backend_features().contains(wgpu::Backends::VULKAN) {
        return Err("this build has no Vulkan backend for this platform".into());
    }
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    desc.flags = wgpu::InstanceFlags::empty();
    let instance = wgpu::Instance::new(desc);
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
    let best = adapters
        .into_iter()
        .map(|a| {
            let info = a.get_info();
            let summary = AdapterSummary {
                name: info.name.clone(),
                driver: [info.driver.as_str(), info.driver_info.as_str()]
                    .iter()
                    .filter(|s| !s.is_empty())
                    .copied()
                    .collect::<Vec<_>>()
                    .join(" "),
                kind: kind(info.device_type),
                unmet: unmet(&a),
            };
            (a, summary)
        })
        // Usable before unusable, then by kind.
        .max_by_key(|(_, s)| (s.unmet.is_none(), s.kind.rank()));
    match best {
        Some((adapter, summary)) => Ok(Probe {
            instance,
            adapter,
            summary,
        }),
        None => Err("no Vulkan adapter found (is a Vulkan driver installed, e.g. Debian's mesa-vulkan-drivers?)".into()),
    }
}

/// An open device with the compiled kernel.
pub(crate) struct Context {
    /// Kept alive with the device.
    _instance: wgpu::Instance,
    pub adapter: AdapterSummary,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub pipeline: wgpu::ComputePipeline,
    pub layout: wgpu::BindGroupLayout,
    /// Bound as the threshold map when the threshold is constant.
    pub no_levels: wgpu::Buffer,
    /// Pixel bytes of one band at most (one storage binding).
    pub band_bytes: u64,
    /// Segments one frame may have at most (one storage binding).
    pub max_segments: u64,
    /// Workgroups per dispatch dimension at most.
    pub max_workgroups: u32,
    /// Validation and device errors reported by wgpu since the last check.
    errors: Arc<Mutex<Vec<String>>>,
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl Context {
    /// Open the probed adapter and compile the kernel.
    pub fn open(probe: Probe, options: &GpuOptions) -> Result<Self> {
        let Probe {
            instance,
            adapter,
            summary,
        } = probe;
        let fail = |message: String| ExtractError::Backend {
            backend: format!("gpu ({})", summary.describe()),
            message,
        };
        if let Some(u) = &summary.unmet {
            return Err(fail(u.clone()));
        }
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("trinocular extract"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| fail(format!("cannot open the device: {e}")))?;
        let errors: Arc<Mutex<Vec<String>>> = Arc::default();
        let sink = Arc::clone(&errors);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("runs.wgsl"),
            source: wgpu::ShaderSource::Wgsl(RUNS_WGSL.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("runs"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                storage_entry(1, true),
                storage_entry(2, true),
                storage_entry(3, false),
                storage_entry(4, false),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("runs"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("runs"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let no_levels = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("no threshold map"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let binding_bytes = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            .min(MAX_BINDING_BYTES)
            & !3;
        let band_bytes = options
            .max_band_bytes
            .map_or(binding_bytes, |b| binding_bytes.min(b.max(64) & !3));
        let max_segments = options
            .max_segments
            .map_or(u64::MAX, |m| m.max(1))
            .min(binding_bytes / SEGMENT_BYTES);
        let context = Self {
            _instance: instance,
            adapter: summary,
            device,
            queue,
            pipeline,
            layout,
            no_levels,
            band_bytes,
            max_segments,
            max_workgroups: limits.max_compute_workgroups_per_dimension,
            errors,
        };
        context.check()?;
        Ok(context)
    }

    /// The error for `message`, naming the adapter.
    pub fn error(&self, message: impl Into<String>) -> ExtractError {
        ExtractError::Backend {
            backend: format!("gpu ({})", self.adapter.describe()),
            message: message.into(),
        }
    }

    /// Fail with the errors wgpu reported since the last check, if any.
    pub fn check(&self) -> Result<()> {
        let reported: Vec<String> = match self.errors.lock() {
            Ok(mut v) => std::mem::take(&mut *v),
            Err(_) => vec!["error log poisoned".into()],
        };
        if reported.is_empty() {
            Ok(())
        } else {
            Err(self.error(reported.join("; ")))
        }
    }

    /// Block until submission `index` has completed and its callbacks ran.
    pub fn wait(&self, index: Option<wgpu::SubmissionIndex>) -> Result<()> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: index,
                timeout: None,
            })
            .map_err(|e| self.error(format!("waiting for the GPU: {e}")))?;
        self.check()
    }
}
