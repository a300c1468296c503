//! Every text of every plot of `report.html` is readable at 100 % zoom —
//! at least `report::plot::MIN_TEXT_PX` = 11 px (issue 23, defect 9) —
//! read from the SVG of the page of the tests' common campaign.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

#[test]
fn every_text_of_every_plot_is_readable() {
    let report =
        evaluate::evaluate(&common::rows(&common::campaign()), &Default::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    evaluate::write_outputs(&report, &out, &mut formats::OutputPlan::new(false), None).unwrap();
    let page = std::fs::read_to_string(out.join("report.html")).unwrap();
    let (plots, small) = report::plot::small_texts(&page);
    // Positioning, straightness in two directions and angular per axis; flatness.
    assert_eq!(plots, 9);
    assert!(small.is_empty(), "text under 11 px: {small:#?}");
}
