//! Backend selection (issue 8, point 2): with no adapter, `auto` gives the CPU
//! backend, its result, and the one reason to log; `gpu` fails with that
//! reason; `cpu` never asks for a reason.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use extract::gpu::{GpuOptions, Mode, select};
use extract::{Backend, CpuBackend, ExtractParams, FrameView, Threshold};

/// Two discs on a flat background.
fn frame() -> (u32, u32, Vec<u16>) {
    let (w, h) = (96u32, 64u32);
    let px = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (dx, dy) = (f64::from(x) - 30.3, f64::from(y) - 31.6);
            let (ex, ey) = (f64::from(x) - 70.8, f64::from(y) - 20.1);
            if dx * dx + dy * dy < 100.0 || ex * ex + ey * ey < 30.0 {
                9000 + (x * 7 + y * 3) as u16 % 500
            } else {
                1000
            }
        })
        .collect();
    (w, h, px)
}

fn no_adapter() -> GpuOptions {
    GpuOptions {
        force_no_adapter: true,
        ..GpuOptions::default()
    }
}

#[test]
fn auto_without_adapter_gives_the_cpu_result_and_the_reason() {
    let selection = select(Mode::Auto, &no_adapter()).unwrap();
    let reason = selection.cpu_reason.as_deref().expect("a logged reason");
    assert!(
        reason.contains("no GPU adapter") && reason.contains("TRINOCULAR_NO_GPU"),
        "{reason}"
    );
    assert_eq!(selection.backend.name(), CpuBackend.name());

    let (w, h, px) = frame();
    let f = FrameView::new(w, h, 16, &px).unwrap();
    let params = ExtractParams {
        threshold: Threshold::Fixed(6000),
        ..ExtractParams::default()
    };
    let got = selection.backend.extract(f, &params).unwrap();
    assert_eq!(got.blobs.len(), 2);
    assert_eq!(got, CpuBackend.extract(f, &params).unwrap());
}

#[test]
fn gpu_without_adapter_fails_with_the_reason() {
    let e = select(Mode::Gpu, &no_adapter()).unwrap_err();
    assert!(e.to_string().contains("no GPU adapter"), "{e}");
}

#[test]
fn cpu_is_chosen_without_a_reason() {
    let s = select(Mode::Cpu, &GpuOptions::default()).unwrap();
    assert_eq!(s.cpu_reason, None);
    assert_eq!(s.backend.name(), CpuBackend.name());
}

#[test]
fn auto_on_this_machine_logs_a_reason_exactly_when_it_falls_back() {
    // Whatever adapter exists here: the GPU without a reason, or the CPU with one.
    let s = select(Mode::Auto, &GpuOptions::default()).unwrap();
    let on_gpu = s.backend.name().starts_with("gpu");
    assert_eq!(on_gpu, s.cpu_reason.is_none(), "{s:?}");
    println!("auto on this machine: {s:?}");
}
