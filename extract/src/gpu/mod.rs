//! The GPU backend: wgpu compute on Vulkan, WGSL shaders (cargo feature `gpu`).
//!
//! # What runs where
//! - Host: denoising and the threshold (fixed, automatic from the sparse
//!   background sample, or the local map) exactly as the CPU backend does; a
//!   local threshold map is uploaded beside the frame in the same layout.
//! - GPU (`runs.wgsl`): the frame is uploaded as `u32` words (two
//!   `u16` pixels each, the [`FrameView`](crate::FrameView) layout; 8-bit
//!   frames use the same layout). One invocation per 32-pixel chunk of a row
//!   tests "any pixel ≥ T" and, where there is signal, writes each maximal run
//!   of above-threshold pixels inside the chunk as a *segment*: row, first
//!   column, length, peak, saturated pixels and the exact integer sums ΣF,
//!   ΣF·dx, ΣF·dx² (dx from the segment's first column). Within 32 pixels of
//!   16-bit values the sums fit in `u32` (ΣF·dx² ≤ 65535·Σ₀³¹dx² =
//!   682 612 560 < 2³²), so no carries and no floating point are needed.
//!   Segments are appended to a compact list through an atomic counter.
//! - Read back: the counter and 24 bytes per segment; nothing scales with the
//!   frame, only with the signal (≈ rows of blob × ⌈run length / 32⌉).
//! - Host: segments are sorted, joined into maximal runs (exact `u64`
//!   shifts of the sums), runs of adjacent rows joined by union–find, and the
//!   blobs gathered by `blob::collect`: the blob list
//!   (moments, area, peak, saturation, box, border flag, runs) is identical to
//!   the CPU backend's.
//! - Frames whose storage binding would pass the adapter's limit (at most
//!   128 MiB) are cut into bands of rows, one binding each; runs are joined
//!   across bands on the host like any other rows.
//! - Sequences ([`Backend::extract_batch`](crate::Backend::extract_batch),
//!   [`Backend::extract_frames`](crate::Backend::extract_frames)) are
//!   pipelined over two sets of buffers reused across frames: frame n+1 is
//!   decoded, thresholded and copied into its staging buffers while the GPU
//!   works on frame n, and frame n is labelled on the host while the GPU works
//!   on frame n+1. (wgpu has one queue, so the GPU-side copy of frame n+1
//!   follows the kernel of frame n; what overlaps is all host work with all
//!   GPU work.)
//!
//! Backend choice ([`choose`]) is a pure function of the probed adapter, so
//! the fallback rules are testable without a GPU.

#[cfg(feature = "gpu")]
mod backend;
#[cfg(feature = "gpu")]
mod context;
#[cfg(feature = "gpu")]
mod pass;
#[cfg(feature = "gpu")]
mod segments;
#[cfg(feature = "gpu")]
mod sequence;

#[cfg(feature = "gpu")]
pub use backend::GpuBackend;

/// Largest storage binding the backend uses (bytes), whatever the adapter allows.
pub const MAX_BINDING_BYTES: u64 = 128 << 20;

/// Environment variable that hides every GPU adapter (`TRINOCULAR_NO_GPU=1`).
pub const NO_GPU_ENV: &str = "TRINOCULAR_NO_GPU";

/// How the GPU is set up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GpuOptions {
    /// Behave as if no adapter existed (tests, and `TRINOCULAR_NO_GPU=1`).
    pub force_no_adapter: bool,
    /// A lower limit on the pixel bytes of one band (tests use it to force
    /// band tiling on small frames); the adapter's binding limit and
    /// [`MAX_BINDING_BYTES`] apply in any case.
    pub max_band_bytes: Option<u64>,
    /// A lower limit on the run segments one frame may have before it is
    /// labelled on the CPU (tests use it); by default as many as one storage
    /// binding holds.
    pub max_segments: Option<u64>,
}

impl GpuOptions {
    /// Defaults, with `force_no_adapter` set when `TRINOCULAR_NO_GPU` is set to
    /// anything but `0` or the empty string.
    pub fn from_env() -> Self {
        let hidden = std::env::var_os(NO_GPU_ENV).is_some_and(|v| !v.is_empty() && v != "0");
        Self {
            force_no_adapter: hidden,
            max_band_bytes: None,
            max_segments: None,
        }
    }
}

/// Counters of a [`GpuBackend`]: what ran and how much was read back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GpuStats {
    /// Frames extracted on the GPU.
    pub frames: u64,
    /// Kernel dispatches over bands of rows (equal to `frames` unless frames were cut into bands).
    pub bands: u64,
    /// Run segments the kernel found.
    pub segments: u64,
    /// Bytes read back from the GPU (counters and segments).
    pub bytes_read: u64,
    /// Frames read back a second time (more segments than the estimate, or a larger buffer needed).
    pub rereads: u64,
    /// Frames with more segments than a binding holds, labelled on the CPU instead.
    pub cpu_labelled: u64,
}

/// Which backend the user asked for (`--backend auto|cpu|gpu`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// A suitable GPU if there is one, else the CPU with the reason.
    #[default]
    Auto,
    /// The CPU, the reference.
    Cpu,
    /// The GPU, or an error with the reason.
    Gpu,
}

/// Kind of a GPU adapter (wgpu's `DeviceType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdapterKind {
    /// A discrete GPU.
    Discrete,
    /// A GPU integrated with the CPU.
    Integrated,
    /// A virtualised GPU.
    Virtual,
    /// A software implementation running on the CPU (e.g. Mesa's lavapipe, "llvmpipe").
    Cpu,
    /// Unknown.
    Other,
}

impl AdapterKind {
    /// Preference among several adapters: larger is better.
    pub fn rank(self) -> u8 {
        match self {
            AdapterKind::Discrete => 4,
            AdapterKind::Integrated => 3,
            AdapterKind::Virtual => 2,
            AdapterKind::Other => 1,
            AdapterKind::Cpu => 0,
        }
    }
}

/// What the probe learnt about the best adapter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AdapterSummary {
    /// Adapter name as the driver reports it.
    pub name: String,
    /// Driver name and version.
    pub driver: String,
    /// Kind of device.
    pub kind: AdapterKind,
    /// Why the adapter cannot run the extraction kernel (missing compute
    /// support, limits too small), if it cannot.
    pub unmet: Option<String>,
}

impl AdapterSummary {
    /// `name [driver]` for messages.
    pub fn describe(&self) -> String {
        if self.driver.is_empty() {
            self.name.clone()
        } else {
            format!("{} [{}]", self.name, self.driver)
        }
    }
}

/// What [`choose`] decided.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Decision {
    /// Run on the probed GPU adapter.
    Gpu,
    /// Run on the CPU; `reason` says why not on the GPU (none when the CPU was asked for).
    Cpu {
        /// Why the GPU is not used.
        reason: Option<String>,
    },
    /// `--backend gpu` cannot be honoured, for this reason.
    Fail {
        /// Why.
        reason: String,
    },
}

/// The backend for `mode` given the probe's answer: the best adapter, or the
/// reason there is none. `auto` prefers the CPU on a software (CPU-type)
/// adapter, which is slower than the CPU backend; `gpu` uses it anyway.
pub fn choose(mode: Mode, probe: Result<&AdapterSummary, &str>) -> Decision {
    let cpu = |reason: String| Decision::Cpu {
        reason: Some(reason),
    };
    match (mode, probe) {
        (Mode::Cpu, _) => Decision::Cpu { reason: None },
        (Mode::Auto, Err(reason)) => cpu(reason.to_string()),
        (Mode::Gpu, Err(reason)) => Decision::Fail {
            reason: reason.to_string(),
        },
        (mode, Ok(adapter)) => match (&adapter.unmet, adapter.kind, mode) {
            (Some(unmet), _, Mode::Gpu) => Decision::Fail {
                reason: format!("adapter {}: {unmet}", adapter.describe()),
            },
            (Some(unmet), _, _) => cpu(format!("adapter {}: {unmet}", adapter.describe())),
            (None, AdapterKind::Cpu, Mode::Auto) => cpu(format!(
                "the only Vulkan adapter, {}, is a software implementation on the CPU (slower than the CPU backend; \
                 --backend gpu uses it anyway)",
                adapter.describe()
            )),
            (None, _, _) => Decision::Gpu,
        },
    }
}

/// The best Vulkan adapter as [`select`] would see it, or why there is none
/// (without opening a device).
pub fn probe(options: &GpuOptions) -> std::result::Result<AdapterSummary, String> {
    #[cfg(feature = "gpu")]
    {
        context::probe(options).map(|p| p.summary)
    }
    #[cfg(not(feature = "gpu"))]
    {
        Err(hidden(options).unwrap_or_else(|| NO_GPU_BUILD.into()))
    }
}

/// The reason to give when the options hide every adapter.
fn hidden(options: &GpuOptions) -> Option<String> {
    options
        .force_no_adapter
        .then(|| format!("no GPU adapter ({NO_GPU_ENV} is set)"))
}

/// Why a build without the `gpu` feature has no GPU backend.
#[cfg(not(feature = "gpu"))]
const NO_GPU_BUILD: &str = "this build has no GPU backend (cargo feature `gpu` of extract is off)";

/// The backend [`select`] chose, and why it is not the GPU when it is not.
pub struct Selection {
    /// The backend to extract with.
    pub backend: Box<dyn crate::Backend>,
    /// Set when `auto` fell back to the CPU: the one reason to log.
    pub cpu_reason: Option<String>,
}

impl std::fmt::Debug for Selection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Selection")
            .field("backend", &self.backend.name())
            .field("cpu_reason", &self.cpu_reason)
            .finish()
    }
}

/// Probe the adapters and open the backend `mode` asks for (`--backend`):
/// `cpu` → the CPU; `gpu` → the GPU or an error with the reason; `auto` → the
/// GPU when [`choose`] says so and the device opens, else the CPU with the reason.
pub fn select(mode: Mode, options: &GpuOptions) -> crate::Result<Selection> {
    let cpu = |reason: Option<String>| Selection {
        backend: Box::new(crate::CpuBackend),
        cpu_reason: reason,
    };
    let fail = |message: String| crate::ExtractError::Backend {
        backend: "gpu".into(),
        message,
    };
    if mode == Mode::Cpu {
        return Ok(cpu(None));
    }
    #[cfg(feature = "gpu")]
    {
        let probe = context::probe(options);
        match choose(
            mode,
            probe.as_ref().map(|p| &p.summary).map_err(String::as_str),
        ) {
            Decision::Cpu { reason } => Ok(cpu(reason)),
            Decision::Fail { reason } => Err(fail(reason)),
            Decision::Gpu => {
                let probe = probe.map_err(fail)?;
                match GpuBackend::open(probe, options) {
                    Ok(b) => Ok(Selection {
                        backend: Box::new(b),
                        cpu_reason: None,
                    }),
                    Err(e) if mode == Mode::Auto => Ok(cpu(Some(e.to_string()))),
                    Err(e) => Err(e),
                }
            }
        }
    }
    #[cfg(not(feature = "gpu"))]
    {
        let reason = hidden(options).unwrap_or_else(|| NO_GPU_BUILD.into());
        match choose(mode, Err(&reason)) {
            Decision::Fail { reason } => Err(fail(reason)),
            Decision::Cpu { reason } => Ok(cpu(reason)),
            Decision::Gpu => Err(fail(reason)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn adapter(kind: AdapterKind, unmet: Option<&str>) -> AdapterSummary {
        AdapterSummary {
            name: "test adapter".into(),
            driver: "test driver".into(),
            kind,
            unmet: unmet.map(str::to_string),
        }
    }

    #[test]
    fn auto_uses_a_hardware_gpu() {
        for kind in [
            AdapterKind::Discrete,
            AdapterKind::Integrated,
            AdapterKind::Virtual,
            AdapterKind::Other,
        ] {
            assert_eq!(choose(Mode::Auto, Ok(&adapter(kind, None))), Decision::Gpu);
            assert_eq!(choose(Mode::Gpu, Ok(&adapter(kind, None))), Decision::Gpu);
        }
    }

    #[test]
    fn auto_prefers_the_cpu_over_a_software_adapter() {
        let a = adapter(AdapterKind::Cpu, None);
        match choose(Mode::Auto, Ok(&a)) {
            Decision::Cpu { reason: Some(r) } => {
                assert!(r.contains("software") && r.contains("test adapter"), "{r}")
            }
            d => panic!("{d:?}"),
        }
        assert_eq!(choose(Mode::Gpu, Ok(&a)), Decision::Gpu);
    }

    #[test]
    fn no_adapter_or_unmet_limits() {
        assert_eq!(
            choose(Mode::Auto, Err("no Vulkan adapter")),
            Decision::Cpu {
                reason: Some("no Vulkan adapter".into())
            }
        );
        assert_eq!(
            choose(Mode::Gpu, Err("no Vulkan adapter")),
            Decision::Fail {
                reason: "no Vulkan adapter".into()
            }
        );
        let weak = adapter(AdapterKind::Discrete, Some("storage bindings of 1 MiB"));
        assert!(
            matches!(choose(Mode::Auto, Ok(&weak)), Decision::Cpu { reason: Some(r) } if r.contains("1 MiB"))
        );
        assert!(
            matches!(choose(Mode::Gpu, Ok(&weak)), Decision::Fail { reason } if reason.contains("1 MiB"))
        );
        assert_eq!(choose(Mode::Cpu, Ok(&weak)), Decision::Cpu { reason: None });
    }
}
