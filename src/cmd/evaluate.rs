//! `trinocular evaluate --points points.csv --out DIR`: ISO 230-2
//! positioning, straightness, flatness and angular errors from `points.csv`;
//! writes `DIR/report.json`, `DIR/report.html` and CSV tables, and prints
//! the headline figures. With the rig (`--rig`) and the images the points
//! were fused from (`<stem>.observations.csv` beside the points), every
//! figure carries its expanded uncertainty U (k = 2) by Monte Carlo.

use std::path::PathBuf;

use anyhow::{Context, Result};

use crate::cmd::Usage;
use report::num_u;

/// Arguments of `trinocular evaluate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Measured sphere centres (`points.csv`, docs/formats.md).
    #[arg(long)]
    points: PathBuf,
    /// Output directory (created if missing), written as one set: an
    /// existing report in it is replaced only with --force, and as a whole.
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing report in the output directory.
    #[arg(long)]
    force: bool,
    /// Sphere that carries positioning, straightness and flatness (default: A,
    /// or the first sphere in the file).
    #[arg(long)]
    sphere: Option<String>,
    /// Also compute the VDI/DGQ 3441 figures (P, Ps, U, Pa).
    #[arg(long)]
    vdi3441: bool,
    /// The rig the points were measured with (`rig.json` with each camera's
    /// covariance): needed for the figures' uncertainty.
    #[arg(long)]
    rig: Option<PathBuf>,
    /// The images the points were fused from (default: `<stem>.observations.csv`
    /// beside the points, as `measure` writes it).
    #[arg(long)]
    observations: Option<PathBuf>,
    /// Monte Carlo trials of the uncertainty (0: figures without U).
    #[arg(long, default_value_t = evaluate::uncertainty::DEFAULT_TRIALS)]
    trials: usize,
    /// Seed of the Monte Carlo draws (the same seed gives the same U).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// The figures' uncertainty: propagated from the observations beside the
/// points and the rig, or why there is none.
fn uncertainty(
    args: &Args,
    report: &evaluate::Report,
    options: &evaluate::Options,
) -> Result<formats::uncertainty::Uncertainty> {
    use formats::uncertainty::Uncertainty;
    let not_given = |reason: String| Ok(Uncertainty::NotGiven { reason });
    if args.trials == 0 {
        return not_given(formats::uncertainty::TRIALS_OFF.into());
    }
    let observations = args
        .observations
        .clone()
        .unwrap_or_else(|| formats::beside(&args.points, "points", ".observations.csv"));
    if !observations.exists() {
        return not_given(format!(
            "no observations: {} does not exist (points measured elsewhere carry no record of their              images, and an uncertainty is never invented)",
            observations.display()
        ));
    }
    let Some(rig_path) = &args.rig else {
        return not_given(
            "no rig given (--rig rig.json): the calibration's covariance is unknown".into(),
        );
    };
    let rig = formats::read_rig(rig_path)?;
    let mut cameras = std::collections::BTreeMap::new();
    let mut covariance = std::collections::BTreeMap::new();
    for c in &rig.cameras {
        cameras.insert(c.model.id, c.validate()?);
        if let Some(cov) = &c.covariance {
            covariance.insert(c.model.id, cov.clone());
        }
    }
    let rows: Vec<formats::ObservationRow> = formats::read_csv(&observations)?
        .into_iter()
        .map(|r| r.record)
        .collect();
    let points: Vec<formats::PointRow> = evaluate::read_points(&args.points)?
        .into_iter()
        .map(|r| r.record)
        .collect();
    Ok(evaluate::uncertainty::propagate(
        report,
        &points,
        &rows,
        evaluate::uncertainty::Instrument {
            cameras: &cameras,
            covariance: &covariance,
        },
        options,
        evaluate::uncertainty::Propagation {
            trials: args.trials,
            seed: args.seed,
        },
    ))
}

/// Run the evaluation and write the report.
pub fn run(args: &Args) -> Result<()> {
    let options = evaluate::Options {
        sphere: args.sphere.clone(),
        vdi3441: args.vdi3441,
    };
    let report = evaluate::evaluate_file(&args.points, &options).map_err(|e| match e {
        // --sphere naming a sphere the points do not have.
        evaluate::EvaluateError::UnknownSphere { .. } => Usage::error(e),
        e => e.into(),
    })?;
    let mut report = report;
    report.uncertainty = Some(uncertainty(args, &report, &options)?);
    let mut output = formats::OutputPlan::new(args.force);
    output.input(&args.points);
    output.inputs(args.rig.iter());
    output.inputs(args.observations.iter());
    let written = evaluate::write_outputs(&report, &args.out, &mut output)
        .with_context(|| format!("writing the report into {}", args.out.display()))?;
    let u = |path: String| report.expanded(&path);
    for (axis, a) in report.axes.iter() {
        let p = &a.main.positioning;
        let at = |key: &str| format!("axes.{}.positioning.{key}", axis.name());
        let [(shown_a, key_a), (shown_e, key_e), (shown_r, key_r)] = p.shown_a_e_r();
        println!(
            "{axis}: A {} µm, E {} µm, M {} µm, R {} µm, B {} µm, seed 3σ {} µm",
            num_u(shown_a, u(at(key_a))),
            num_u(shown_e, u(at(key_e))),
            num_u(p.m_um, u(at("M_um"))),
            num_u(shown_r, u(at(key_r))),
            num_u(p.b_um, u(at("B_um"))),
            num_u(p.seed_3sigma_um, u(at("seed_3sigma_um")))
        );
        for (dir, s) in &a.main.straightness {
            let at = |key: &str| format!("axes.{}.straightness.{dir}.{key}", axis.name());
            println!(
                "{axis}: straightness in {dir}: LSQ {} µm, min zone {} µm",
                num_u(Some(s.lsq_um), u(at("lsq_um"))),
                num_u(Some(s.min_zone_um), u(at("min_zone_um")))
            );
        }
        if let Some(ang) = &a.main.angular {
            let at = |key: &str| format!("axes.{}.angular.{key}", axis.name());
            println!(
                "{axis}: roll {} µrad, pitch {} µrad, yaw {} µrad (ranges)",
                num_u(Some(ang.roll_urad), u(at("roll_urad"))),
                num_u(Some(ang.pitch_urad), u(at("pitch_urad"))),
                num_u(Some(ang.yaw_urad), u(at("yaw_urad")))
            );
        }
    }
    if let Some(f) = &report.flatness {
        println!(
            "flatness: LSQ {} µm, min zone {} µm",
            num_u(Some(f.lsq_um), u("flatness.lsq_um".into())),
            num_u(Some(f.min_zone_um), u("flatness.min_zone_um".into()))
        );
    }
    match &report.uncertainty {
        Some(formats::uncertainty::Uncertainty::Given(p)) => println!(
            "uncertainty: U (k = 2) by Monte Carlo, {} trials, seed {}{}",
            p.trials,
            p.seed,
            if p.failed_trials > 0 {
                format!(" ({} trials failed and were left out)", p.failed_trials)
            } else {
                String::new()
            }
        ),
        Some(formats::uncertainty::Uncertainty::NotGiven { reason }) => {
            eprintln!("trinocular: note: the figures carry no uncertainty: {reason}");
        }
        None => {}
    }
    for w in &report.warnings {
        eprintln!("trinocular: warning: {w}");
    }
    println!("wrote {} files into {}", written.len(), args.out.display());
    Ok(())
}
