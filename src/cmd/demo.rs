//! `trinocular demo`: the whole job on built-in data. Renders a small campaign
//! of the seed's rig (reduced resolution) through its lenses, calibrates the
//! cameras from the rendered target and their relative illumination from the
//! flat fields, measures the campaign, evaluates it, and prints the
//! measured figures beside the true ones. Each step runs the same code as its
//! command, and the commands are printed so that every step can be rerun.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args as ClapArgs, FromArgMatches};
use formats::{AxisFigures, PositioningFigures, ReportFigures, ZoneFigures};
use formats::{PointRow, Truth};

use crate::cmd;

/// Arguments of `trinocular demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output folder (default: a fresh ./trinocular-demo[-N]).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Image width (px) of the rendered campaign; the field of view is the seed rig's.
    #[arg(long, default_value_t = 1024)]
    width: u32,
    /// Targets per axis.
    #[arg(long, default_value_t = 8)]
    targets: u32,
    /// Runs per direction.
    #[arg(long, default_value_t = 3)]
    runs: u32,
    /// Captures per target.
    #[arg(long, default_value_t = 2)]
    captures: u32,
    /// Replace the files of an earlier demo in --out.
    #[arg(long)]
    force: bool,
}

/// Parse a subcommand's arguments exactly as the command line would.
fn parse<A: ClapArgs + FromArgMatches>(name: &'static str, args: &[String]) -> Result<A> {
    let command = A::augment_args(clap::Command::new(name).no_binary_name(true));
    let matches = command
        .try_get_matches_from(args)
        .with_context(|| format!("demo: bad arguments for {name}"))?;
    Ok(A::from_arg_matches(&matches)?)
}

/// A fresh folder: `trinocular-demo`, else `trinocular-demo-2`, ….
fn fresh_folder() -> PathBuf {
    let mut folder = PathBuf::from("trinocular-demo");
    let mut n = 1;
    while folder.exists() {
        n += 1;
        folder = PathBuf::from(format!("trinocular-demo-{n}"));
    }
    folder
}

fn show(step: &str, line: &[String]) {
    eprintln!("\n== {step}\n$ trinocular {}", line.join(" "));
}

fn path(p: &Path) -> String {
    p.display().to_string()
}

/// Run one step: print its command line, parse it, run it, report the time.
/// Every step runs with `--force` (the demo has checked its folder: fresh,
/// or `--force` given), so that the line printed reruns it as it is.
fn step<A: ClapArgs + FromArgMatches>(
    title: &str,
    name: &'static str,
    mut args: Vec<String>,
    run: fn(&A) -> Result<()>,
) -> Result<()> {
    args.push("--force".into());
    let mut line = name.split(' ').map(str::to_string).collect::<Vec<_>>();
    line.extend(args.iter().cloned());
    show(title, &line);
    let start = Instant::now();
    let parsed: A = parse(name, &args)?;
    run(&parsed).with_context(|| format!("demo step '{title}'"))?;
    eprintln!("   ({:.1} s)", start.elapsed().as_secs_f64());
    Ok(())
}

/// Largest |measured − true| of roll, pitch and yaw over the targets of an axis's main line (µrad).
fn angular_worst(report: &ReportFigures, truth: &ReportFigures, axis: &str) -> Option<f64> {
    let targets = |f: &ReportFigures| Some(f.axes.get(axis)?.angular.as_ref()?.targets.clone());
    let (m, t) = (targets(report)?, targets(truth)?);
    let mut worst: f64 = 0.0;
    for (a, b) in m.iter().zip(&t) {
        for (a, b) in a.angles().into_iter().zip(b.angles()) {
            worst = worst.max((a? - b?).abs());
        }
    }
    Some(worst)
}

/// The positioning value of an axis by its report.json key.
fn positioning(p: &PositioningFigures, key: &str) -> Option<f64> {
    match key {
        "A_um" => p.a_um,
        "E_um" => p.e_um,
        "R_um" => p.r_um,
        "B_um" => p.b_um,
        "M_um" => p.m_um,
        "seed_3sigma_um" => p.seed_3sigma_um,
        _ => None,
    }
}

/// A zone's width by its report.json key.
fn zone(z: &ZoneFigures, key: &str) -> Option<f64> {
    match key {
        "lsq_um" => z.lsq_um,
        "min_zone_um" => z.min_zone_um,
        _ => None,
    }
}

/// Print measured against true figures.
fn compare(report: &ReportFigures, truth: &ReportFigures) {
    println!(
        "\n{:<34} {:>12} {:>12} {:>10}",
        "figure (µm, µrad)", "measured", "true", "difference"
    );
    let row = |label: String, figure: &dyn Fn(&ReportFigures) -> Option<f64>| {
        if let (Some(m), Some(t)) = (figure(report), figure(truth)) {
            println!("{label:<34} {m:>12.2} {t:>12.2} {:>+10.2}", m - t);
        }
    };
    for axis in ["X", "Y"] {
        let of = |f: &ReportFigures| -> Option<AxisFigures> { f.axes.get(axis).cloned() };
        for (key, label) in [
            ("A_um", "A  positioning accuracy"),
            ("E_um", "E  systematic deviation"),
            ("R_um", "R  repeatability"),
            ("B_um", "B  reversal value"),
            ("M_um", "M  mean deviation"),
            ("seed_3sigma_um", "3σ band positioning error"),
        ] {
            row(format!("{axis} {label}"), &|f| {
                positioning(&of(f)?.positioning, key)
            });
        }
        for dir in ["X", "Y", "Z"] {
            for (key, what) in [("lsq_um", "LSQ"), ("min_zone_um", "min zone")] {
                row(format!("{axis} straightness in {dir}, {what}"), &|f| {
                    zone(of(f)?.straightness.get(dir)?, key)
                });
            }
        }
        for key in ["roll_urad", "pitch_urad", "yaw_urad"] {
            row(
                format!("{axis} {} range", key.trim_end_matches("_urad")),
                &|f| of(f)?.angular?.range.get(key),
            );
        }
    }
    row("flatness, LSQ".into(), &|f| f.flatness.as_ref()?.lsq_um);
    row("flatness, min zone".into(), &|f| {
        f.flatness.as_ref()?.min_zone_um
    });
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    // Made by the first step's plan, so that a failed demo removes it again.
    let out = args.out.clone().unwrap_or_else(fresh_folder);
    // Said once, for the command typed, before anything is rendered.
    let earlier = std::fs::read_dir(&out).is_ok_and(|mut entries| entries.next().is_some());
    if earlier && !args.force {
        anyhow::bail!(
            "{}: the folder holds files already (an earlier demo?): give --force to replace \
             them, or another --out",
            out.display()
        );
    }
    let campaign = out.join("campaign");
    let height = args.width * 3 / 4;
    let start = Instant::now();
    eprintln!(
        "trinocular demo: the seed rig at {}×{height} px, {} targets per axis, {} runs, {} captures → {}",
        args.width,
        args.targets,
        args.runs,
        args.captures,
        path(&out)
    );

    step::<cmd::synth::Args>(
        "1/4 render a campaign with known errors",
        "synth",
        [
            "campaign",
            "--out",
            &path(&campaign),
            "--width",
            &args.width.to_string(),
            "--height",
            &height.to_string(),
            "--targets",
            &args.targets.to_string(),
            "--runs",
            &args.runs.to_string(),
            "--captures",
            &args.captures.to_string(),
        ]
        .map(str::to_string)
        .to_vec(),
        cmd::synth::run,
    )?;
    let c = |f: &str| path(&campaign.join(f));
    let rig = path(&out.join("rig.json"));
    step::<cmd::calibrate::Args>(
        "2/4 calibrate the cameras from the rendered 3-D target, their lenses from flat fields",
        "calibrate",
        vec![
            "--target".into(),
            c("target.csv"),
            "--nominal".into(),
            c("nominal.json"),
            "--images".into(),
            c("calib/cam1.tif"),
            c("calib/cam2.tif"),
            c("calib/cam3.tif"),
            "--flat-fields".into(),
            c("calib/flat_cam1.tif"),
            c("calib/flat_cam2.tif"),
            c("calib/flat_cam3.tif"),
            "--dark-frames".into(),
            c("calib/dark_cam1.tif"),
            c("calib/dark_cam2.tif"),
            c("calib/dark_cam3.tif"),
            "--out".into(),
            rig.clone(),
        ],
        cmd::calibrate::run,
    )?;
    let points = path(&out.join("points.csv"));
    // A measurement that finished with problems (instants lacking a sphere,
    // say) is evaluated all the same; the demo then ends with its status.
    let measured = step::<cmd::measure::Args>(
        "3/4 measure every instant",
        "measure",
        vec![
            "--rig".into(),
            rig.clone(),
            "--manifest".into(),
            c("manifest.csv"),
            "--spheres".into(),
            c("spheres.csv"),
            "--out".into(),
            points.clone(),
        ],
        cmd::measure::run,
    );
    let unmeasured = match measured {
        Err(e) if e.downcast_ref::<cmd::Finished>().is_some() => {
            eprintln!("trinocular: note: {e:#}");
            Some(e)
        }
        other => {
            other?;
            None
        }
    };
    let report_dir = out.join("report");
    step::<cmd::evaluate::Args>(
        "4/4 evaluate (ISO 230-2, straightness, flatness, angular)",
        "evaluate",
        vec![
            "--points".into(),
            points,
            "--rig".into(),
            rig,
            "--out".into(),
            path(&report_dir),
        ],
        cmd::evaluate::run,
    )?;

    let report: ReportFigures = formats::read_json(&report_dir.join("report.json"))?;
    let truth_path = campaign.join("truth.json");
    let truth: Truth = formats::read_json(&truth_path)?;
    let truth_figures = truth
        .figures()
        .with_context(|| format!("{}: no reference figures", truth_path.display()))?
        .with_context(|| format!("{}: figures", truth_path.display()))?;
    compare(&report, &truth_figures);
    let read = |p: &Path| -> Result<Vec<PointRow>> {
        Ok(formats::read_csv(p)?
            .into_iter()
            .map(|r| r.record)
            .collect())
    };
    let measured = read(&out.join("points.csv"))?;
    let exact = read(&campaign.join("truth_points.csv"))?;
    let errors = synth::truth::displacement_errors(&measured, &exact, "A");
    if let Some(rms) = synth::truth::rms(&errors) {
        let n = errors.len();
        println!(
            "\nsphere A displacement from each line's first instant: {:.2} µm RMS against the truth ({n} instants)",
            rms * 1e3
        );
    }
    for axis in ["X", "Y"] {
        if let Some(w) = angular_worst(&report, &truth_figures, axis) {
            println!(
                "{axis}: roll, pitch, yaw per target: largest difference from the truth {w:.1} µrad"
            );
        }
    }
    println!(
        "\nmeasured = from the rendered images; true = the same evaluation on the exact sphere positions.\n\
         Finished in {:.0} s. Report: {}",
        start.elapsed().as_secs_f64(),
        report_dir.join("report.html").display()
    );
    unmeasured.map_or(Ok(()), Err)
}
