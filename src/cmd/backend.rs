//! Choosing the extraction backend (`--backend auto|cpu|gpu`).

use std::io::Write;
use std::sync::{Arc, Mutex, OnceLock};

use anyhow::Result;
use clap::ValueEnum;
use extract::Backend;
use extract::gpu::{GpuOptions, Mode};

/// Which compute backend extracts blobs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BackendChoice {
    /// The GPU where a suitable one exists, else the CPU (with the reason logged).
    Auto,
    /// The CPU (the reference).
    Cpu,
    /// The GPU (any Vulkan adapter, a software one too); fails with the reason when there is none.
    Gpu,
}

impl BackendChoice {
    fn mode(self) -> Mode {
        match self {
            BackendChoice::Auto => Mode::Auto,
            BackendChoice::Cpu => Mode::Cpu,
            BackendChoice::Gpu => Mode::Gpu,
        }
    }
}

/// Backends already opened by this process, by choice: probing the adapters
/// costs time (and Mesa's Vulkan layers print to stderr while it runs), so a
/// process that extracts in several steps (the demo) does it once.
static OPENED: OnceLock<Mutex<Opened>> = OnceLock::new();

/// Opened backends, by choice.
type Opened = Vec<(BackendChoice, Arc<dyn Backend>)>;

/// The backend for a choice (`TRINOCULAR_NO_GPU=1` hides every GPU adapter);
/// when `auto` falls back to the CPU, the reason is logged once on stderr.
pub fn select_backend(choice: BackendChoice) -> Result<Arc<dyn Backend>> {
    let opened = OPENED.get_or_init(|| Mutex::new(Vec::new()));
    let mut opened = opened
        .lock()
        .map_err(|_| anyhow::anyhow!("backend cache poisoned"))?;
    if let Some((_, b)) = opened.iter().find(|(c, _)| *c == choice) {
        return Ok(Arc::clone(b));
    }
    let backend: Arc<dyn Backend> =
        select_backend_logged(choice, &GpuOptions::from_env(), &mut std::io::stderr())?.into();
    opened.push((choice, Arc::clone(&backend)));
    Ok(backend)
}

/// [`select_backend`] with explicit GPU options and log. With `auto`, what
/// the Vulkan drivers print while their adapters are probed (Mesa's
/// "error: XDG_RUNTIME_DIR is invalid …" on a headless machine) is kept off
/// the user's stderr: the choice and its reason are this command's to say.
pub fn select_backend_logged(
    choice: BackendChoice,
    options: &GpuOptions,
    log: &mut dyn Write,
) -> Result<Box<dyn Backend>> {
    let select = || extract::gpu::select(choice.mode(), options);
    let selection = if choice == BackendChoice::Auto {
        without_stderr(select)
    } else {
        select()
    }?;
    if let Some(reason) = &selection.cpu_reason {
        // A log that cannot be written is no reason to stop.
        let _ = writeln!(log, "trinocular: note: using the CPU backend: {reason}");
    }
    Ok(selection.backend)
}

/// `f` run with the process's stderr (file descriptor 2, where libraries
/// write directly) sent to a temporary file that is then dropped; run as is
/// where stderr cannot be redirected.
#[cfg(unix)]
fn without_stderr<T>(f: impl FnOnce() -> T) -> T {
    use std::os::fd::AsFd;
    let stderr = std::io::stderr();
    let redirected = tempfile::tempfile().ok().and_then(|sink| {
        let saved = rustix::io::dup(stderr.as_fd()).ok()?;
        rustix::stdio::dup2_stderr(&sink).ok()?;
        Some(saved)
    });
    let result = f();
    if let Some(saved) = redirected {
        // Restoring fd 2 from its own duplicate cannot fail but on a closed fd.
        let _ = rustix::stdio::dup2_stderr(&saved);
    }
    result
}

#[cfg(not(unix))]
fn without_stderr<T>(f: impl FnOnce() -> T) -> T {
    f()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn no_adapter() -> GpuOptions {
        GpuOptions {
            force_no_adapter: true,
            ..GpuOptions::default()
        }
    }

    #[test]
    fn auto_without_adapter_logs_one_reason() {
        let mut log = Vec::new();
        let backend = select_backend_logged(BackendChoice::Auto, &no_adapter(), &mut log).unwrap();
        assert!(backend.name().starts_with("cpu"), "{}", backend.name());
        let log = String::from_utf8(log).unwrap();
        assert_eq!(log.lines().count(), 1, "{log}");
        assert!(
            log.starts_with("trinocular: note: using the CPU backend: no GPU adapter"),
            "{log}"
        );
    }

    #[test]
    fn gpu_without_adapter_is_an_error_with_the_reason() {
        let mut log = Vec::new();
        let e = select_backend_logged(BackendChoice::Gpu, &no_adapter(), &mut log)
            .err()
            .unwrap();
        assert!(e.to_string().contains("no GPU adapter"), "{e}");
        assert!(log.is_empty());
    }

    #[test]
    fn cpu_logs_nothing() {
        let mut log = Vec::new();
        let backend =
            select_backend_logged(BackendChoice::Cpu, &GpuOptions::default(), &mut log).unwrap();
        assert!(backend.name().starts_with("cpu"));
        assert!(log.is_empty());
    }
}
