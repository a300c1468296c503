//! What every probe `report.html` must show in Chromium (`report::browser`),
//! shared by the `*_browser` tests.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

use report::browser::{self, PAGE_WIDTH, check_region};
use report::plot::WIDTH;

/// Render `page` in `chromium` and check it: no console errors, exceptions
/// or failed loads; the plots `ids`, in this order; no wider than the
/// window; each plot laid out at `WIDTH` × the height `look` gives for its
/// id and drawn in the colours it gives. `TRINOCULAR_KEEP_SCREENSHOT` names
/// a file to keep the screenshot in.
pub fn check_page(
    chromium: &Path,
    page: &Path,
    ids: &[&str],
    look: impl Fn(&str) -> (u32, Vec<[u8; 3]>),
) {
    let shown = browser::render(chromium, page).unwrap();
    if let Ok(keep) = std::env::var("TRINOCULAR_KEEP_SCREENSHOT") {
        shown.screenshot.save(&keep).unwrap();
        eprintln!("screenshot saved to {keep}");
    }
    assert!(
        shown.errors.is_empty(),
        "console errors: {:#?}",
        shown.errors
    );
    let shown_ids: Vec<&str> = shown.plots.iter().map(|p| p.id.as_str()).collect();
    assert_eq!(shown_ids, ids, "plots on the page");
    assert!(
        shown.width <= PAGE_WIDTH,
        "page {} px wider than the window",
        shown.width
    );
    for p in &shown.plots {
        let (height, colours) = look(&p.id);
        assert_eq!(
            (p.w, p.h),
            (WIDTH, height),
            "{} laid out at {}×{}",
            p.id,
            p.w,
            p.h
        );
        check_region(&shown.screenshot, p, &colours).unwrap();
    }
}
