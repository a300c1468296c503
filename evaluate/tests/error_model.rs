//! Points generated from a known error model (no noise) give back the model's
//! positioning, straightness, flatness and angular figures: positioning,
//! straightness and flatness to 1e-6 µm, computed analytically from the
//! model's values at the targets; minimum zones are ≤ least squares and equal
//! to an independent linear-programming optimum.

#![allow(clippy::unwrap_used)]

mod common;

use common::{LineModel, campaign, rows};
use evaluate::{LineReport, Report};
use evaluate::{Options, evaluate};
use formats::{Axis, Direction};
use microlp::{ComparisonOp, OptimizationDirection, Problem};

/// Agreement required for µm figures.
const UM: f64 = 1e-6;
/// Agreement required for µrad figures.
const URAD: f64 = 1e-6;

std::thread_local! {
    /// Largest |difference| seen by [`close`] in this test, per tolerance class.
    static WORST: std::cell::RefCell<[f64; 2]> = const { std::cell::RefCell::new([0.0; 2]) };
}

fn close(what: &str, got: f64, want: f64, tol: f64) {
    WORST.with(|w| {
        let angular = ["roll", "pitch", "yaw", "angular"]
            .iter()
            .any(|a| what.contains(a));
        let k = usize::from(angular);
        let mut w = w.borrow_mut();
        w[k] = w[k].max((got - want).abs());
    });
    if std::env::var_os("SHOW_DIFF").is_some() {
        eprintln!("{what}: {:e}", (got - want).abs());
    }
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got}, model {want} (difference {:e})",
        got - want
    );
}

fn max(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(f64::NEG_INFINITY, f64::max)
}

fn min(v: impl Iterator<Item = f64>) -> f64 {
    v.fold(f64::INFINITY, f64::min)
}

/// ISO 230-2 figures of a line model, analytically (µm): the run values are
/// `p ± b/2 + s·z` with `z` of mean 0 and sample std 1, the datum `p_0`.
struct Truth {
    mean_up: Vec<f64>,
    mean_down: Vec<f64>,
    a: f64,
    a_up: f64,
    a_down: f64,
    e: f64,
    e_up: f64,
    e_down: f64,
    m: f64,
    r: f64,
    r_up: f64,
    r_down: f64,
    b: f64,
    b_mean: f64,
    seed: f64,
}

fn truth(l: &LineModel) -> Truth {
    let um = |v: f64| v * 1e3;
    let n = l.c.len();
    let k = 0..n;
    let up: Vec<f64> = k
        .clone()
        .map(|i| um(l.p[i] - l.p[0] + l.b[i] / 2.0))
        .collect();
    let down: Vec<f64> = k
        .clone()
        .map(|i| um(l.p[i] - l.p[0] - l.b[i] / 2.0))
        .collect();
    let su: Vec<f64> = l.s_up.iter().map(|s| um(*s)).collect();
    let sd: Vec<f64> = l.s_down.iter().map(|s| um(*s)).collect();
    let b: Vec<f64> = l.b.iter().map(|b| um(*b)).collect();
    let mean: Vec<f64> = l.p.iter().map(|p| um(p - l.p[0])).collect();
    // Seed: every capture at a target, both directions: mean p − p_0, sum of
    // squares m·(n·b²/2 + (n − 1)(s↑² + s↓²)) + 2n·Σq², over N − 1 = 2nm − 1.
    let (runs, caps) = (l.runs as f64, l.captures as f64);
    let q2: f64 = common::capture_pattern(l.captures, um(l.q))
        .iter()
        .map(|q| q * q)
        .sum();
    let seed_s: Vec<f64> = (0..n)
        .map(|i| {
            let ss = caps
                * (runs * b[i] * b[i] / 2.0 + (runs - 1.0) * (su[i] * su[i] + sd[i] * sd[i]))
                + 2.0 * runs * q2;
            (ss / (2.0 * runs * caps - 1.0)).sqrt()
        })
        .collect();
    Truth {
        a: max(k
            .clone()
            .map(|i| (up[i] + 2.0 * su[i]).max(down[i] + 2.0 * sd[i])))
            - min(k
                .clone()
                .map(|i| (up[i] - 2.0 * su[i]).min(down[i] - 2.0 * sd[i]))),
        a_up: max(k.clone().map(|i| up[i] + 2.0 * su[i]))
            - min(k.clone().map(|i| up[i] - 2.0 * su[i])),
        a_down: max(k.clone().map(|i| down[i] + 2.0 * sd[i]))
            - min(k.clone().map(|i| down[i] - 2.0 * sd[i])),
        e: max(up.iter().chain(&down).copied()) - min(up.iter().chain(&down).copied()),
        e_up: max(up.iter().copied()) - min(up.iter().copied()),
        e_down: max(down.iter().copied()) - min(down.iter().copied()),
        m: max(mean.iter().copied()) - min(mean.iter().copied()),
        r: max(k.clone().map(|i| {
            (2.0 * su[i] + 2.0 * sd[i] + b[i].abs())
                .max(4.0 * su[i])
                .max(4.0 * sd[i])
        })),
        r_up: max(su.iter().map(|s| 4.0 * s)),
        r_down: max(sd.iter().map(|s| 4.0 * s)),
        b: max(b.iter().map(|b| b.abs())),
        b_mean: b.iter().sum::<f64>() / n as f64,
        seed: max(k.clone().map(|i| mean[i] + 3.0 * seed_s[i]))
            - min(k.map(|i| mean[i] - 3.0 * seed_s[i])),
        mean_up: up,
        mean_down: down,
    }
}

/// Minimum of `max − min` of `z − a·x − b·y` over (a, b) (or over a with
/// `y = None`), by a linear programme on scaled coordinates: minimise h with
/// `−h ≤ z_i − a·x_i − b·y_i − c ≤ h`. Independent of `geom::min_zone`.
fn chebyshev_lp(x: &[f64], y: Option<&[f64]>, z: &[f64]) -> f64 {
    let scale = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let s = v.iter().map(|t| (t - m).abs()).fold(0.0, f64::max);
        v.iter().map(|t| (t - m) / s).collect::<Vec<f64>>()
    };
    let xs = scale(x);
    let ys = y.map(scale);
    let mut lp = Problem::new(OptimizationDirection::Minimize);
    let free = (f64::NEG_INFINITY, f64::INFINITY);
    let (a, b, c) = (
        lp.add_var(0.0, free),
        lp.add_var(0.0, free),
        lp.add_var(0.0, free),
    );
    let h = lp.add_var(1.0, (0.0, f64::INFINITY));
    for i in 0..z.len() {
        let by = ys.as_ref().map_or(0.0, |ys| ys[i]);
        lp.add_constraint(
            [(a, xs[i]), (b, by), (c, 1.0), (h, 1.0)],
            ComparisonOp::Ge,
            z[i],
        );
        lp.add_constraint(
            [(a, xs[i]), (b, by), (c, 1.0), (h, -1.0)],
            ComparisonOp::Le,
            z[i],
        );
    }
    let sol = lp.solve().unwrap().into_solution().unwrap();
    // The width at the LP's slopes, evaluated exactly (2h up to rounding).
    let (va, vb) = (sol.var_value(a), sol.var_value(b));
    let r: Vec<f64> = (0..z.len())
        .map(|i| z[i] - va * xs[i] - vb * ys.as_ref().map_or(0.0, |ys| ys[i]))
        .collect();
    max(r.iter().copied()) - min(r.iter().copied())
}

fn check_line(what: &str, l: &LineModel, r: &LineReport) {
    let t = truth(l);
    let p = &r.positioning;
    for (name, got, want) in [
        ("A", p.a_um, t.a),
        ("A↑", p.a_up_um, t.a_up),
        ("A↓", p.a_down_um, t.a_down),
        ("E", p.e_um, t.e),
        ("E↑", p.e_up_um, t.e_up),
        ("E↓", p.e_down_um, t.e_down),
        ("M", p.m_um, t.m),
        ("R", p.r_um, t.r),
        ("R↑", p.r_up_um, t.r_up),
        ("R↓", p.r_down_um, t.r_down),
        ("B", p.b_um, t.b),
        ("B̄", p.b_mean_um, t.b_mean),
    ] {
        let got = got.unwrap_or_else(|| panic!("{what}: {name} missing"));
        close(&format!("{what} {name}"), got, want, UM);
    }
    close(
        &format!("{what} 3σ band"),
        p.seed_3sigma_um.unwrap(),
        t.seed,
        UM,
    );
    assert_eq!((p.runs_up, p.runs_down), (l.runs, l.runs));
    for (i, row) in p.targets.iter().enumerate() {
        close(
            &format!("{what} x̄↑ at {i}"),
            row.mean_up_um.unwrap(),
            t.mean_up[i],
            UM,
        );
        close(
            &format!("{what} x̄↓ at {i}"),
            row.mean_down_um.unwrap(),
            t.mean_down[i],
            UM,
        );
        close(
            &format!("{what} s↑ at {i}"),
            row.s_up_um.unwrap(),
            l.s_up[i] * 1e3,
            UM,
        );
        close(
            &format!("{what} s↓ at {i}"),
            row.s_down_um.unwrap(),
            l.s_down[i] * 1e3,
            UM,
        );
        assert_eq!(row.nominal, l.c[i]);
    }

    check_geometry(what, l, r);
}

/// The straightness and angular errors of a line: the model's.
fn check_geometry(what: &str, l: &LineModel, r: &LineReport) {
    // Straightness: the model's deviations have a zero least-squares line, so
    // the least-squares figure is their range.
    let perp = l.perpendicular();
    for (k, (world, _)) in perp.iter().enumerate() {
        let s = &r.straightness[world.name()];
        let d: Vec<f64> = l.d[k].iter().map(|v| v * 1e3).collect();
        let lsq = max(d.iter().copied()) - min(d.iter().copied());
        close(
            &format!("{what} straightness {world} LSQ"),
            s.lsq_um,
            lsq,
            UM,
        );
        for (row, want) in s.targets.iter().zip(&d) {
            close(
                &format!("{what} straightness {world} deviation"),
                row.deviation_um,
                *want,
                UM,
            );
        }
        assert!(
            s.min_zone_um <= s.lsq_um + 1e-9,
            "{what}: min zone above LSQ"
        );
        let along: Vec<f64> = (0..l.c.len()).map(|i| l.c[i] + l.p[i]).collect();
        let lp = chebyshev_lp(&along, None, &d);
        close(
            &format!("{what} straightness {world} min zone vs LP"),
            s.min_zone_um,
            lp,
            UM,
        );
    }

    // Angular errors: the model's rotation vectors.
    let ang = r
        .angular
        .as_ref()
        .unwrap_or_else(|| panic!("{what}: no angular errors"));
    let rpy = |w: &geom::Vector3<f64>| match l.axis {
        Axis::X => [w.x, w.y, w.z],
        Axis::Y => [w.y, w.x, w.z],
        Axis::Z => [w.z, w.x, w.y],
    };
    for (row, w) in ang.targets.iter().zip(&l.omega) {
        let [roll, pitch, yaw] = rpy(w).map(|v| v * 1e6);
        close(&format!("{what} roll"), row.roll_urad, roll, URAD);
        close(&format!("{what} pitch"), row.pitch_urad, pitch, URAD);
        close(&format!("{what} yaw"), row.yaw_urad, yaw, URAD);
    }
    let ranges: Vec<[f64; 3]> = l.omega.iter().map(|w| rpy(w).map(|v| v * 1e6)).collect();
    for (j, got) in [ang.roll_urad, ang.pitch_urad, ang.yaw_urad]
        .into_iter()
        .enumerate()
    {
        let want = max(ranges.iter().map(|r| r[j])) - min(ranges.iter().map(|r| r[j]));
        close(&format!("{what} angular range {j}"), got, want, URAD);
    }
    assert!(ang.fit_rms_um < 1e-6);
}

/// Least-squares plane z = a·x + b·y + c by the normal equations on centred
/// coordinates (Cramer's rule), and the range of the vertical residuals.
fn lsq_flatness(pts: &[geom::Point3<f64>]) -> f64 {
    let n = pts.len() as f64;
    let (mx, my, mz) = (
        pts.iter().map(|p| p.x).sum::<f64>() / n,
        pts.iter().map(|p| p.y).sum::<f64>() / n,
        pts.iter().map(|p| p.z).sum::<f64>() / n,
    );
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in pts {
        let (x, y, z) = (p.x - mx, p.y - my, p.z - mz);
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
        sxz += x * z;
        syz += y * z;
    }
    let det = sxx * syy - sxy * sxy;
    let a = (sxz * syy - syz * sxy) / det;
    let b = (sxx * syz - sxy * sxz) / det;
    let r: Vec<f64> = pts
        .iter()
        .map(|p| (p.z - mz) - a * (p.x - mx) - b * (p.y - my))
        .collect();
    max(r.iter().copied()) - min(r.iter().copied())
}

/// The flatness of every per-target mean of sphere A on the X and Y lines:
/// least squares as [`lsq_flatness`], minimum zone as [`chebyshev_lp`].
fn check_flatness<'r>(report: &'r Report, lines: &[LineModel]) -> &'r evaluate::FlatnessReport {
    let pts: Vec<geom::Point3<f64>> = lines
        .iter()
        .flat_map(|l| (0..l.c.len()).map(|k| l.mean_a(k)))
        .collect();
    let f = report.flatness.as_ref().unwrap();
    assert_eq!(f.points.len(), pts.len());
    close("flatness LSQ", f.lsq_um, lsq_flatness(&pts) * 1e3, UM);
    assert!(f.min_zone_um <= f.lsq_um + 1e-9);
    let (xs, ys, zs): (Vec<f64>, Vec<f64>, Vec<f64>) = (
        pts.iter().map(|p| p.x).collect(),
        pts.iter().map(|p| p.y).collect(),
        pts.iter().map(|p| p.z * 1e3).collect(),
    );
    close(
        "flatness min zone vs LP",
        f.min_zone_um,
        chebyshev_lp(&xs, Some(&ys), &zs),
        UM,
    );
    f
}

fn evaluated(lines: &[LineModel], options: &Options) -> Report {
    evaluate(&rows(lines), options).unwrap()
}

/// The VDI/DGQ 3441 figures of the X axis's main line, if evaluated.
fn vdi3441_x(report: &Report) -> Option<evaluate::Vdi3441Report> {
    report
        .axes
        .x
        .as_ref()
        .unwrap()
        .main
        .positioning
        .vdi3441
        .clone()
}

#[test]
fn campaign_gives_back_the_model() {
    let lines = campaign();
    let report = evaluated(&lines, &Options::default());
    assert_eq!(report.sphere, "A");
    let x = report.axes.x.as_ref().unwrap();
    assert_eq!(x.lines.len(), 3);
    // The middle line has the most runs: it is axes.X.
    assert_eq!(x.main.off_axis["y"], 0.0);
    assert_eq!(x.main, x.lines[1]);
    for (i, l) in lines[..3].iter().enumerate() {
        check_line(&format!("X line {i}"), l, &x.lines[i]);
        // The fitted direction is the model's (free of its 0.8 mrad yaw).
        let d = x.lines[i].direction;
        assert!((geom::Vector3::from(d) - l.e()).norm() < 1e-12, "{d:?}");
    }
    let y = report.axes.y.as_ref().unwrap();
    check_line("Y line", &lines[3], &y.main);
    assert!(report.axes.z.is_none());

    let f = check_flatness(&report, &lines);
    assert!(
        f.min_zone_um < f.lsq_um - 0.01,
        "the model's min zone should be visibly below LSQ"
    );
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    WORST.with(|w| {
        let w = w.borrow();
        eprintln!(
            "error model: largest deviation {:e} µm, {:e} µrad",
            w[0], w[1]
        );
    });
}

#[test]
fn vdi3441_from_the_model() {
    let lines = campaign();
    let options = Options {
        vdi3441: true,
        ..Options::default()
    };
    let report = evaluated(&lines[1..2], &options);
    let v = vdi3441_x(&report).unwrap();
    let l = &lines[1];
    let um = |v: f64| v * 1e3;
    let n = l.c.len();
    let mean: Vec<f64> = (0..n).map(|i| um(l.p[i] - l.p[0])).collect();
    let u: Vec<f64> = l.b.iter().map(|b| um(b.abs())).collect();
    let ps: Vec<f64> = (0..n)
        .map(|i| 6.0 * um(l.s_up[i] + l.s_down[i]) / 2.0)
        .collect();
    close(
        "P",
        v.p_um,
        max((0..n).map(|i| mean[i] + (u[i] + ps[i]) / 2.0))
            - min((0..n).map(|i| mean[i] - (u[i] + ps[i]) / 2.0)),
        UM,
    );
    close("Ps", v.ps_um, max(ps.iter().copied()), UM);
    close("U", v.u_um, max(u.iter().copied()), UM);
    close(
        "Pa",
        v.pa_um,
        max(mean.iter().copied()) - min(mean.iter().copied()),
        UM,
    );
    // Not asked for: absent.
    let plain = evaluated(&lines[1..2], &Options::default());
    assert!(vdi3441_x(&plain).is_none());
}

#[test]
fn one_direction_gives_unidirectional_figures_and_omits_the_rest() {
    let mut l = campaign().swap_remove(1);
    l.directions = vec![Direction::Down];
    let report = evaluated(std::slice::from_ref(&l), &Options::default());
    let p = &report.axes.x.as_ref().unwrap().main.positioning;
    let t = truth(&l);
    close("E↓", p.e_down_um.unwrap(), t.e_down, UM);
    close("A↓", p.a_down_um.unwrap(), t.a_down, UM);
    close("R↓", p.r_down_um.unwrap(), t.r_down, UM);
    assert!(p.a_um.is_none() && p.b_um.is_none() && p.e_up_um.is_none() && p.m_um.is_none());
    let json = serde_json::to_value(&report).unwrap();
    let pos = &json["axes"]["X"]["positioning"];
    for key in [
        "A_um",
        "A_up_um",
        "E_um",
        "E_up_um",
        "M_um",
        "R_um",
        "R_up_um",
        "B_um",
        "B_mean_um",
    ] {
        assert!(pos.get(key).is_none(), "{key} should be omitted: {pos}");
    }
    for key in [
        "A_down_um",
        "E_down_um",
        "R_down_um",
        "seed_3sigma_um",
        "targets",
    ] {
        assert!(pos.get(key).is_some(), "{key} missing");
    }
    assert!(pos["targets"][0].get("mean_up_um").is_none());
    assert!(json["axes"].get("Y").is_none(), "{}", json["axes"]);
    assert!(json.get("flatness").is_none(), "{}", json["flatness"]);
    // A single line does not span a plane: flatness is left out, with a warning.
    assert!(report.warnings.iter().any(|w| w.contains("flatness")));
}

/// Every positioning key of report.json a line can have.
const POSITIONING_FIGURES: [&str; 13] = [
    "A_um",
    "A_up_um",
    "A_down_um",
    "E_um",
    "E_up_um",
    "E_down_um",
    "M_um",
    "R_um",
    "R_up_um",
    "R_down_um",
    "B_um",
    "B_mean_um",
    "seed_3sigma_um",
];

#[test]
fn report_json_has_the_contract_shape() {
    let lines = campaign();
    let json = serde_json::to_value(evaluated(&lines, &Options::default())).unwrap();
    for axis in ["X", "Y"] {
        let a = &json["axes"][axis];
        for key in POSITIONING_FIGURES {
            assert!(
                a["positioning"][key].is_f64(),
                "axes.{axis}.positioning.{key}"
            );
        }
        for key in [
            "target",
            "nominal",
            "mean_up_um",
            "mean_down_um",
            "s_up_um",
            "s_down_um",
            "B_um",
        ] {
            assert!(
                !a["positioning"]["targets"][0][key].is_null(),
                "targets[].{key}"
            );
        }
        let perp = if axis == "X" { ["Y", "Z"] } else { ["X", "Z"] };
        for d in perp {
            assert!(
                a["straightness"][d]["lsq_um"].is_f64()
                    && a["straightness"][d]["min_zone_um"].is_f64()
            );
        }
        for key in ["roll_urad", "pitch_urad", "yaw_urad"] {
            assert!(a["angular"][key].is_f64(), "axes.{axis}.angular.{key}");
        }
        assert!(a["lines"].is_array());
    }
    assert_eq!(json["axes"]["X"]["lines"].as_array().unwrap().len(), 3);
    assert!(json["axes"]["X"]["lines"][0]["off_axis"]["y"].is_f64());
    assert!(json["flatness"]["lsq_um"].is_f64() && json["flatness"]["min_zone_um"].is_f64());
}

/// The campaign's three X lines, each with `runs` runs.
fn x_lines(runs: usize) -> Vec<LineModel> {
    let mut lines = campaign();
    lines.truncate(3);
    for l in &mut lines {
        l.runs = runs;
    }
    lines
}

#[test]
fn equal_runs_pick_the_line_nearest_the_origin() {
    let lines = x_lines(3);
    let report = evaluated(&lines, &Options::default());
    assert_eq!(report.axes.x.as_ref().unwrap().main.off_axis["y"], 0.0);
    // With the middle line gone, the tie between y = ±20 goes to the first.
    let report = evaluated(&[lines[2].clone(), lines[0].clone()], &Options::default());
    assert_eq!(report.axes.x.as_ref().unwrap().main.off_axis["y"], -20.0);
}

#[test]
fn two_spheres_give_no_angular_errors() {
    let lines = campaign();
    let rows: Vec<_> = rows(&lines[1..2])
        .into_iter()
        .filter(|r| r.sphere != "C")
        .collect();
    let report = evaluate(&rows, &Options::default()).unwrap();
    assert!(report.axes.x.as_ref().unwrap().main.angular.is_none());
    // Another sphere can carry the figures; B rides on the rotations, so only
    // its presence is checked here.
    let options = Options {
        sphere: Some("B".into()),
        ..Options::default()
    };
    assert_eq!(evaluate(&rows, &options).unwrap().sphere, "B");
    let options = Options {
        sphere: Some("Q".into()),
        ..Options::default()
    };
    let e = evaluate(&rows, &options).unwrap_err().to_string();
    assert!(e.contains("'Q'") && e.contains("A, B"), "{e}");
}

#[test]
fn instants_lacking_a_sphere_are_evaluated_from_the_others() {
    // `measure` leaves a sphere out of an instant when a camera does not see
    // it whole; positioning rests on sphere A, angular errors on the instants
    // that have all three.
    let lines = campaign();
    let all = rows(&lines);
    let at = |r: &formats::PointRow,
              off: f64,
              target: u32,
              direction: Direction,
              run: u32,
              capture: Option<u32>| {
        r.nominal_y == off
            && r.axis == Axis::X
            && r.target == target
            && r.direction == direction
            && r.run == run
            && capture.is_none_or(|c| r.capture == c)
    };
    let lacking: Vec<formats::PointRow> = all
        .iter()
        .filter(|r| {
            // Middle X line: B missing in a whole ↑ approach at target 3, C at
            // one capture of target 5 and B at one capture of the first target
            // (the angular datum).
            !(r.sphere == "B" && at(r, 0.0, 3, Direction::Up, 2, None)
                || r.sphere == "C" && at(r, 0.0, 5, Direction::Down, 1, Some(2))
                || r.sphere == "B" && at(r, 0.0, 0, Direction::Up, 4, Some(1))
                // Line y = −20: A missing in a whole ↓ approach at target 2.
                || r.sphere == "A" && at(r, -20.0, 2, Direction::Down, 3, None))
        })
        .cloned()
        .collect();
    assert_eq!(all.len() - lacking.len(), 3 + 1 + 1 + 3);
    let report = evaluate(&lacking, &Options::default()).unwrap();
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    let x = report.axes.x.as_ref().unwrap();
    // The middle line keeps every figure of the model, the angular ones exact
    // because they come from the instants with all three spheres.
    check_line(
        "X line 1 lacking B and C at some instants",
        &lines[1],
        &x.lines[1],
    );
    check_line("Y line", &lines[3], &report.axes.y.as_ref().unwrap().main);
    // Without A at an approach, that approach is not in the positioning: the
    // figures are those of the line without the instant at all, and the
    // angular errors still the model's.
    let without: Vec<formats::PointRow> = all
        .iter()
        .filter(|r| !at(r, -20.0, 2, Direction::Down, 3, None))
        .cloned()
        .collect();
    let reference = evaluate(&without, &Options::default()).unwrap();
    let line0 = &x.lines[0];
    assert_eq!(
        line0.positioning,
        reference.axes.x.as_ref().unwrap().lines[0].positioning
    );
    assert_eq!(line0.positioning.targets[2].runs_down_um.len(), 2);
    let ang = line0.angular.as_ref().unwrap();
    for (row, w) in ang.targets.iter().zip(&lines[0].omega) {
        close("X line 0 roll", row.roll_urad, w.x * 1e6, URAD);
        close("X line 0 pitch", row.pitch_urad, w.y * 1e6, URAD);
        close("X line 0 yaw", row.yaw_urad, w.z * 1e6, URAD);
    }

    // A sphere missing at every instant of a target: no angular errors for
    // that line (with the reason), the rest as before.
    let gone: Vec<formats::PointRow> = all
        .iter()
        .filter(|r| !(r.sphere == "C" && r.axis == Axis::Y && r.target == 8))
        .cloned()
        .collect();
    let report = evaluate(&gone, &Options::default()).unwrap();
    let y = &report.axes.y.as_ref().unwrap().main;
    assert!(y.angular.is_none());
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("axis Y") && w.contains("sphere(s) C missing")),
        "{:?}",
        report.warnings
    );
    assert_eq!(
        y.positioning,
        evaluate(&all, &Options::default())
            .unwrap()
            .axes
            .y
            .unwrap()
            .main
            .positioning
    );
}

/// A flatness grid as it is measured in practice: the main X line with 5
/// runs, the off-axis X lines (y = ∓20 mm) with a single run each way, the Y
/// line with 4. The lines with runs keep the figures they have alone; the
/// single-run lines give the model's straightness and angular errors, their
/// run deviations and their place in the flatness, and say why their
/// positioning is left out.
#[test]
fn single_run_lines_are_evaluated_without_positioning() {
    let mut lines = campaign();
    for i in [0, 2] {
        lines[i].runs = 1;
    }
    let report = evaluated(&lines, &Options::default());
    let alone = |l: &LineModel| evaluated(std::slice::from_ref(l), &Options::default());
    let x = report.axes.x.as_ref().unwrap();
    assert_eq!(
        x.main, x.lines[1],
        "the line with the most runs is the main one"
    );
    let main_alone = alone(&lines[1]).axes.x.unwrap().main;
    assert_eq!(
        x.lines[1],
        LineReport {
            line: 1,
            ..main_alone
        }
    );
    check_line("X main line beside single-run lines", &lines[1], &x.main);
    let y = &report.axes.y.as_ref().unwrap().main;
    assert_eq!(*y, alone(&lines[3]).axes.y.unwrap().main);

    let json = serde_json::to_value(&report).unwrap();
    for i in [0, 2] {
        let what = format!("single-run X line {i}");
        check_geometry(&what, &lines[i], &x.lines[i]);
        let t = truth(&lines[i]);
        for (k, row) in x.lines[i].positioning.targets.iter().enumerate() {
            assert_eq!((row.runs_up_um.len(), row.runs_down_um.len()), (1, 1));
            close(
                &format!("{what} x↑ at {k}"),
                row.runs_up_um[0],
                t.mean_up[k],
                UM,
            );
            close(
                &format!("{what} x↓ at {k}"),
                row.runs_down_um[0],
                t.mean_down[k],
                UM,
            );
            assert!(row.mean_up_um.is_none() && row.s_down_um.is_none() && row.b_um.is_none());
        }
        let pos = &json["axes"]["X"]["lines"][i]["positioning"];
        for key in POSITIONING_FIGURES {
            assert!(
                pos.get(key).is_none(),
                "{what}: {key} should be left out: {pos}"
            );
        }
        let reason = pos["left_out"].as_str().unwrap_or_else(|| panic!("{pos}"));
        assert!(
            reason.contains("at least 2") && reason.contains("run 1"),
            "{reason}"
        );
        let name = format!("axis X at y = {}, z = 0 mm", lines[i].off[0]);
        assert!(
            report
                .warnings
                .iter()
                .any(|w| w.contains(&name) && w.contains(reason)),
            "{what}: {:?}",
            report.warnings
        );
    }
    assert_eq!(report.warnings.len(), 2, "{:?}", report.warnings);

    // Flatness: the single-run lines' points too.
    check_flatness(&report, &lines);
}

/// Every X line measured once each way: the main line is still the one
/// nearest the origin, and the report says it has no positioning.
#[test]
fn a_main_line_without_positioning_is_named() {
    let lines = x_lines(1);
    let report = evaluated(&lines, &Options::default());
    let x = report.axes.x.as_ref().unwrap();
    assert_eq!(x.main, x.lines[1]);
    for (i, l) in lines.iter().enumerate() {
        check_geometry(&format!("X line {i}"), l, &x.lines[i]);
    }
    let json = serde_json::to_value(&report).unwrap();
    let reason = json["axes"]["X"]["positioning"]["left_out"]
        .as_str()
        .unwrap();
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("main line") && w.contains("axis X at y = 0, z = 0 mm")),
        "{:?}",
        report.warnings
    );
    assert!(reason.contains("at least 2"), "{reason}");
    assert!(report.flatness.is_some());
}

/// A line measured in one direction gives that direction's figures and says
/// that the ones needing both are left out; with a single run in the other
/// direction, the same, and why.
#[test]
fn one_direction_says_what_is_left_out() {
    let full = campaign().swap_remove(1);
    let t = truth(&full);
    let reason_of = |json: &serde_json::Value| {
        let p = &json["axes"]["X"]["positioning"];
        p["left_out"]
            .as_str()
            .unwrap_or_else(|| panic!("no left_out: {}", p["A_um"]))
            .to_string()
    };

    let mut down = full.clone();
    down.directions = vec![Direction::Down];
    let report = evaluated(std::slice::from_ref(&down), &Options::default());
    let reason = reason_of(&serde_json::to_value(&report).unwrap());
    assert!(
        reason.contains("↓ only") && reason.contains("A, E, M, R, B"),
        "{reason}"
    );
    assert!(report.warnings.iter().any(|w| w.contains(&reason)));

    // ↓ runs 2–5 lost: ↓ has one run left, ↑ all five.
    let rows: Vec<formats::PointRow> = rows(std::slice::from_ref(&full))
        .into_iter()
        .filter(|r| r.direction == Direction::Up || r.run == 1)
        .collect();
    let report = evaluate(&rows, &Options::default()).unwrap();
    let p = &report.axes.x.as_ref().unwrap().main.positioning;
    close("E↑", p.e_up_um.unwrap(), t.e_up, UM);
    close("A↑", p.a_up_um.unwrap(), t.a_up, UM);
    close("R↑", p.r_up_um.unwrap(), t.r_up, UM);
    assert!(p.a_um.is_none() && p.e_down_um.is_none() && p.b_um.is_none() && p.m_um.is_none());
    let reason = reason_of(&serde_json::to_value(&report).unwrap());
    assert!(
        reason.contains("↓") && reason.contains("at least 2"),
        "{reason}"
    );
    assert!(report.warnings.iter().any(|w| w.contains(&reason)));
}
