//! The phases of `trinocular bench measure` on a small campaign: decode
//! only over a manifest, and the peak memory a run reports at exit.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{ok, render_campaign, s};

#[test]
fn decode_only_reads_every_frame_and_the_run_reports_its_peak_memory() {
    let tmp = tempfile::tempdir().unwrap();
    let c = tmp.path().join("c");
    render_campaign(&c, (128, 96), [2, 1, 1], &[]);
    let peak = tmp.path().join("peak");
    let out = common::bin()
        .args(["bench", "decode", "--manifest", s(&c.join("manifest.csv"))])
        .env("TRINOCULAR_PEAK_RSS_FILE", &peak)
        .output()
        .unwrap();
    ok(&out);
    let frames = formats::read_csv::<formats::ManifestRow>(&c.join("manifest.csv"))
        .unwrap()
        .len();
    let said = String::from_utf8(out.stdout).unwrap();
    assert!(
        said.contains(&format!(
            "decoded {frames} frames, {} pixels",
            frames * 128 * 96
        )),
        "{said}"
    );
    // VmHWM in kB: a real process holds at least its binary's pages.
    let kb: u64 = std::fs::read_to_string(&peak)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!(kb > 1000, "{kb} kB");
    // A frame that cannot be decoded names its file.
    let first = formats::read_csv::<formats::ManifestRow>(&c.join("manifest.csv")).unwrap()[0]
        .record
        .image
        .clone();
    std::fs::write(c.join(&first), b"not an image").unwrap();
    let out = common::trinocular(&["bench", "decode", "--manifest", s(&c.join("manifest.csv"))]);
    assert!(!out.status.success());
    assert!(
        common::stderr(&out).contains(&first),
        "{}",
        common::stderr(&out)
    );
}
