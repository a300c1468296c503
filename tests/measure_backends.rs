//! `measure --backend gpu` gives what `--backend cpu` gives: the GPU finds
//! the same blobs (exact integer sums, `extract/tests/gpu_parity.rs`), so
//! every centroid, sphere centre and pose agrees to the byte. Runs on
//! whatever Vulkan adapter exists (CI: Mesa's lavapipe); without one it
//! prints a notice and passes, unless `TRINOCULAR_REQUIRE_ADAPTER=1`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{bin, ok, render_campaign, s, stderr, write_true_rig};

#[test]
fn measure_on_the_gpu_gives_the_cpus_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let c = dir.path().join("c");
    render_campaign(&c, (320, 240), [2, 1, 1], &[]);
    let rig = dir.path().join("rig.json");
    write_true_rig(&c, &rig);
    let run = |backend: &str| {
        let out = dir.path().join(format!("{backend}.csv"));
        let output = bin()
            .args([
                "measure",
                "--all-cameras",
                "--backend",
                backend,
                "--rig",
                s(&rig),
                "--manifest",
                s(&c.join("manifest.csv")),
                "--spheres",
                s(&c.join("spheres.csv")),
                "--out",
                s(&out),
            ])
            .output()
            .unwrap();
        (out, output)
    };
    let (cpu, output) = run("cpu");
    ok(&output);
    let (gpu, output) = run("gpu");
    if !output.status.success()
        && std::env::var_os("TRINOCULAR_REQUIRE_ADAPTER").is_none_or(|v| v != "1")
    {
        eprintln!("no usable GPU adapter; skipped: {}", stderr(&output));
        return;
    }
    ok(&output);
    for sidecar in ["", ".observations", ".poses"] {
        let name = |p: &std::path::Path| {
            p.with_extension("").to_string_lossy().to_string() + sidecar + ".csv"
        };
        let (a, b) = (name(&cpu), name(&gpu));
        let (a, b) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
        assert!(a.len() > 100 && a == b, "{sidecar}: the backends differ");
    }
}
