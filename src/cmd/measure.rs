//! `trinocular measure`: sphere centres of every instant of a campaign into
//! `points.csv`; bad instants into `points.problems.csv`, table poses into
//! `points.poses.csv` and the images each centre was fused from into
//! `points.observations.csv` beside it (named after the output; `evaluate`
//! propagates the uncertainty from them). An interrupted run, started
//! again, resumes.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::ValueEnum;
use formats::{OutputPlan, SphereRow, read_spheres};
use fuse::{CalibratedRig, Fusion, Inputs, MeasureOptions, measure};

use crate::cmd::extraction::ExtractOptions;
use crate::cmd::output::print_notes;
use crate::cmd::{Finished, progress};

/// What the interrupt message says of a rerun: it resumes.
pub const RERUN: &str = "run the same command again to resume from the instants already measured";

/// Fusion method.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum FusionArg {
    /// Rigorous triangulation (linear, then reprojection-error refinement).
    Triangulate,
    /// The source method's two-camera pixel-scale fusion, relative to the first instant of
    /// each line (`seed`, its former name, is accepted).
    #[value(alias = "seed")]
    PixelScale,
}

/// Arguments of `trinocular measure`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Calibrated rig (rig.json).
    #[arg(long)]
    rig: PathBuf,
    /// Campaign manifest (manifest.csv; image paths relative to it).
    #[arg(long)]
    manifest: PathBuf,
    /// Sphere set (spheres.csv: name,diameter).
    #[arg(long)]
    spheres: PathBuf,
    /// Output points.csv (<stem>.problems.csv, <stem>.poses.csv and <stem>.observations.csv are written beside it).
    #[arg(long)]
    out: PathBuf,
    /// How cameras are fused.
    #[arg(long, value_enum, default_value_t = FusionArg::Triangulate)]
    fusion: FusionArg,
    /// Use all cameras, including the one looking along the motion.
    #[arg(long)]
    all_cameras: bool,
    /// Do not remove the perspective bias of the spheres' images (diagnostics only).
    #[arg(long)]
    no_bias_correction: bool,
    /// Replace existing outputs (points.csv and its poses, problems and observations) and discard a partial one.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    extract: ExtractOptions,
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let CalibratedRig { rig, sensor } = CalibratedRig::read(&args.rig)?;
    let spheres: Vec<SphereRow> = read_spheres(&args.spheres)?
        .into_iter()
        .map(|r| r.record)
        .collect();
    let options = MeasureOptions {
        fusion: match args.fusion {
            FusionArg::Triangulate => Fusion::Triangulate,
            FusionArg::PixelScale => Fusion::PixelScale,
        },
        all_cameras: args.all_cameras,
        bias_correction: !args.no_bias_correction,
        extract: args.extract.params()?,
    };
    let backend = args.extract.backend()?;
    for (id, maps) in sensor.iter().filter(|(_, m)| !m.is_identity()) {
        eprintln!(
            "trinocular: note: camera {id}: frames corrected pixel by pixel ({})",
            super::sensor::describe(maps)
        );
    }
    let mut output = OutputPlan::new(args.force);
    output.input(&args.rig).input(&args.spheres);
    let bar = progress::bar(0, "measure");
    let result = measure(
        &Inputs {
            manifest: &args.manifest,
            rig: &rig,
            spheres: &spheres,
            sensor: &sensor,
        },
        &args.out,
        &options,
        backend.as_ref(),
        &mut output,
        &|done, total| {
            bar.set_length(total);
            bar.set_position(done);
        },
    );
    bar.finish_and_clear();
    print_notes(&output);
    let summary = result.with_context(|| format!("measuring {}", args.manifest.display()))?;
    if !summary.assumed_ideal_lens.is_empty() {
        let ids: Vec<String> = summary
            .assumed_ideal_lens
            .iter()
            .map(u8::to_string)
            .collect();
        eprintln!(
            "trinocular: note: camera{} {}: {} has no flat-field model: pixels corrected for an ideal lens \
             (cos⁴θ relative illumination); calibrate with --flat-fields and --dark-frames for a real lens",
            if ids.len() == 1 { "" } else { "s" },
            ids.join(", "),
            args.rig.display()
        );
    }
    for camera in &summary.mapped_pixel_by_pixel {
        eprintln!(
            "trinocular: note: camera {camera}: the lens model bends too fast for a lattice of interpolated \
             nodes (within {} px), or folds over within the sensor's reach: its pixels are undistorted \
             exactly, one by one (slower)",
            extract::LATTICE_TOLERANCE_PX
        );
    }
    for (camera, noise) in &summary.noise {
        eprintln!(
            "trinocular: camera {camera}: image noise {}",
            noise.describe()
        );
    }
    for (camera, s) in summary.saturation.iter().filter(|(_, s)| s.saturated > 0) {
        eprintln!(
            "trinocular: warning: camera {camera}: {} of {} sphere images measured have saturated pixels \
             (at the sensor's maximum): their centres are biased and their noise is not known; lower the \
             exposure or the spheres' brightness",
            s.saturated, s.images
        );
    }
    eprintln!(
        "measured {} of {} instants{}{} → {}",
        summary.measured,
        summary.instants,
        if summary.partial > 0 {
            format!(
                " ({} without a sphere and so without the table pose)",
                summary.partial
            )
        } else {
            String::new()
        },
        if summary.resumed > 0 {
            format!(" ({} resumed from an interrupted run)", summary.resumed)
        } else {
            String::new()
        },
        summary.points.display()
    );
    let Some(problems) = &summary.problems_file else {
        return Ok(());
    };
    let failed = summary.instants - summary.measured;
    let refused = if summary.implausible > 0 {
        format!(
            " ({} of them implausible against the campaign's residuals, {})",
            summary.implausible,
            summary.gate.map(|g| g.describe()).unwrap_or_default()
        )
    } else {
        String::new()
    };
    if summary.measured == 0 {
        // Nothing measured is a failure, not a batch with a few bad items:
        // the run's outputs go (the failure's cleanup, src/main.rs).
        anyhow::bail!(
            "{}",
            crate::cmd::none_could(
                summary.instants,
                "instant",
                &format!("be measured{refused}"),
                summary.first_problem.as_deref()
            )
        );
    }
    let mut what = Vec::new();
    if failed > 0 {
        what.push(format!(
            "{failed} of {} instants could not be measured{refused}",
            summary.instants
        ));
    }
    if summary.partial > 0 {
        what.push(format!("{} lack a sphere and their pose", summary.partial));
    }
    if summary.without_pose > 0 {
        what.push(format!("{} lack their pose", summary.without_pose));
    }
    match summary.reduced {
        0 => {}
        1 => what.push("1 instant measured without one of its cameras".into()),
        n => what.push(format!(
            "{n} instants measured without one of their cameras"
        )),
    }
    Err(Finished::with_problems(format!(
        "{}; listed in {}",
        what.join("; "),
        problems.display()
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `--fusion seed`, the pixel-scale fusion's former name, still works.
    #[test]
    fn the_pixel_scale_fusion_answers_to_its_former_name() {
        for name in ["pixel-scale", "seed"] {
            assert!(
                matches!(FusionArg::from_str(name, false), Ok(FusionArg::PixelScale)),
                "{name}"
            );
        }
    }
}
