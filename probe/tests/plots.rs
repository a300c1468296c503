//! The plots of every probe report as a reader sees them (issue 23, defect
//! 9), read from the SVG of each page: every text at least 11 px; the
//! tracer's 3-D views with axis titles in millimetres, tick labels that
//! neither overlap nor leave the plot, and a head on every correction
//! arrow; the indexing map's colour scale untouched by one extreme outlier,
//! which is marked and counted.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod pages;
mod tracer_common;

use report::plot::{MAP_HEIGHT, MEAN, OUTLIER, RGBColor, UP, WIDTH, small_texts, svg_texts};

/// The SVG `fill` attribute of a colour, as plotters writes it.
fn fill(c: RGBColor) -> String {
    format!("fill=\"#{:02X}{:02X}{:02X}\"", c.0, c.1, c.2)
}

/// The opening tags of the `<tag …>` elements of `svg` that hold `attribute`.
fn elements<'s>(svg: &'s str, tag: &str, attribute: &str) -> Vec<&'s str> {
    svg.split(&format!("<{tag} "))
        .skip(1)
        .map(|e| &e[..e.find('>').unwrap()])
        .filter(|e| e.contains(attribute))
        .collect()
}

/// How many `<tag …>` elements of `svg` are filled with `c`.
fn filled(svg: &str, tag: &str, c: RGBColor) -> usize {
    elements(svg, tag, &fill(c)).len()
}

/// The `points` of an element's opening tag.
fn points(tag: &str) -> Vec<(i32, i32)> {
    let start = tag.find("points=\"").unwrap() + "points=\"".len();
    tag[start..start + tag[start..].find('"').unwrap()]
        .split_whitespace()
        .map(|p| {
            let (x, y) = p.split_once(',').unwrap();
            (x.parse().unwrap(), y.parse().unwrap())
        })
        .collect()
}

/// The plot `id` of `page`.
fn plot(page: &str, id: &str) -> String {
    report::figures(page)
        .into_iter()
        .find(|(i, _)| i == id)
        .unwrap_or_else(|| panic!("no plot {id}"))
        .1
}

#[test]
fn every_text_of_every_probe_plot_is_readable() {
    let reports = [
        ("rotary", pages::rotary()),
        ("indexing", pages::indexing(&pages::indexing_positions())),
        ("tracer", pages::tracer()),
        ("volumetric", pages::volumetric()),
    ];
    for (method, page) in reports {
        let (plots, small) = small_texts(&page);
        assert!(plots >= 3, "{method}: {plots} plots");
        assert!(small.is_empty(), "{method}: text under 11 px: {small:#?}");
    }
}

#[test]
fn tracer_3d_views_have_titled_axes_clear_labels_and_arrow_heads() {
    let page = pages::tracer();
    for id in ["plot-corrections", "plot-uncertainty"] {
        let svg = plot(&page, id);
        let texts = svg_texts(&svg);
        for title in ["x (mm)", "y (mm)", "z (mm)"] {
            assert!(
                texts.iter().any(|t| t.text == title),
                "{id}: no axis title {title}"
            );
        }
        let numbers = texts
            .iter()
            .filter(|t| t.text.parse::<f64>().is_ok())
            .count();
        assert!(numbers >= 9, "{id}: {numbers} tick labels");
        let (w, h) = (f64::from(WIDTH), f64::from(MAP_HEIGHT));
        for (k, a) in texts.iter().enumerate() {
            let [l, t, r, b] = a.bounds;
            assert!(
                l >= 0.0 && t >= 0.0 && r <= w && b <= h,
                "{id}: {:?} leaves the plot: {:?}",
                a.text,
                a.bounds
            );
            for o in &texts[k + 1..] {
                assert!(
                    !a.overlaps(o),
                    "{id}: {:?} {:?} overlaps {:?} {:?}",
                    a.text,
                    a.bounds,
                    o.text,
                    o.bounds
                );
            }
        }
    }
    // Every arrow drawn (a shaft longer than nothing, one per grid point and
    // its dot) ends in a head: a triangle in its colour with its tip there.
    let svg = plot(&page, "plot-corrections");
    let colour = format!("{:02X}{:02X}{:02X}", UP.0, UP.1, UP.2);
    let shafts: Vec<Vec<(i32, i32)>> = elements(&svg, "polyline", &format!("stroke=\"#{colour}\""))
        .into_iter()
        .map(points)
        .filter(|p| p.len() == 2 && p[0] != p[1])
        .collect();
    let tips: Vec<(i32, i32)> = elements(&svg, "polygon", &fill(UP))
        .into_iter()
        .map(|e| points(e)[0])
        .collect();
    let dots = filled(&svg, "circle", MEAN);
    assert!(dots >= 27, "{dots} grid points");
    assert!(
        shafts.len() * 10 >= dots * 9,
        "{} of {dots} arrows",
        shafts.len()
    );
    for s in &shafts {
        assert!(tips.contains(&s[1]), "the arrow {s:?} has no head");
    }
}

/// The colour bar's upper end `+L ″` of an indexing map.
fn scale_limit(svg: &str) -> f64 {
    svg_texts(svg)
        .iter()
        .find_map(|t| t.text.strip_suffix(" ″")?.strip_prefix('+')?.parse().ok())
        .expect("no colour-bar limit")
}

#[test]
fn one_outlier_leaves_the_indexing_colour_scale_and_is_marked() {
    let clean = pages::indexing_positions();
    let mut spoiled = clean.clone();
    // Position 200 (A = 30°) moved 20 µm along z: ΔθA there ≈ −19″, five
    // times the largest of the others.
    spoiled[200].centre.z += 0.02;
    let map = |positions| plot(&pages::indexing(positions), "plot-map-dA");
    let (before, after) = (map(&clean), map(&spoiled));
    let (l0, l1) = (scale_limit(&before), scale_limit(&after));
    println!("colour scale ±{l0}″ without the outlier, ±{l1}″ with it");
    // The others' scale, up to the outlier's pull on the fitted head axes.
    assert!((l1 - l0).abs() < 0.05 * l0, "{l0} → {l1}");
    // Nothing marked without it; with it, its cell (a triangle in a halo)
    // and the key under the colour bar, which counts it.
    assert_eq!(filled(&before, "polygon", OUTLIER), 0);
    assert_eq!(filled(&after, "polygon", OUTLIER), 2);
    let texts = svg_texts(&after);
    assert!(texts.iter().any(|t| t.text == "1 beyond"), "no key");
    assert!(
        texts.iter().any(|t| t.text == format!("−{l1:.2} ″")),
        "the key names the end it passes"
    );
}
