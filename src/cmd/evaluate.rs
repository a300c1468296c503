//! `trinocular evaluate --points points.csv --out DIR`: ISO 230-2
//! positioning, straightness, flatness and angular errors from `points.csv`;
//! writes `DIR/report.json`, `DIR/report.html` and CSV tables, and prints
//! the headline figures.

use std::path::PathBuf;

use anyhow::{Context, Result};

use crate::cmd::Usage;

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
    let mut output = formats::OutputPlan::new(args.force);
    output.input(&args.points);
    let written = evaluate::write_outputs(&report, &args.out, &mut output)
        .with_context(|| format!("writing the report into {}", args.out.display()))?;
    for (axis, a) in report.axes.iter() {
        let p = &a.main.positioning;
        let fig = |v: Option<f64>| v.map_or_else(|| "—".to_string(), |v| format!("{v:.3}"));
        let [shown_a, shown_e, shown_r] = p.shown_a_e_r();
        println!(
            "{axis}: A {} µm, E {} µm, M {} µm, R {} µm, B {} µm, seed 3σ {} µm",
            fig(shown_a),
            fig(shown_e),
            fig(p.m_um),
            fig(shown_r),
            fig(p.b_um),
            fig(p.seed_3sigma_um)
        );
        for (dir, s) in &a.main.straightness {
            println!(
                "{axis}: straightness in {dir}: LSQ {:.3} µm, min zone {:.3} µm",
                s.lsq_um, s.min_zone_um
            );
        }
        if let Some(ang) = &a.main.angular {
            println!(
                "{axis}: roll {:.2} µrad, pitch {:.2} µrad, yaw {:.2} µrad (ranges)",
                ang.roll_urad, ang.pitch_urad, ang.yaw_urad
            );
        }
    }
    if let Some(f) = &report.flatness {
        println!(
            "flatness: LSQ {:.3} µm, min zone {:.3} µm",
            f.lsq_um, f.min_zone_um
        );
    }
    for w in &report.warnings {
        eprintln!("trinocular: warning: {w}");
    }
    println!("wrote {} files into {}", written.len(), args.out.display());
    Ok(())
}
