//! `trinocular fit KIND FILE`: least-squares fit of a geometric element to a
//! point file (CSV `x,y[,z]` or a NIST `.ds` file), and minimum-zone
//! straightness/flatness. Prints one JSON object.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::ValueEnum;
use formats::{FitResult, ResidualSummary};
use geom::{Point2, Point3, Vector3, fit, min_zone, stats};

/// Element to fit.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum Kind {
    /// 2-D line through (x, y), orthogonal least squares.
    Line2d,
    /// 3-D line.
    Line3d,
    /// Plane.
    Plane,
    /// Circle in space (least-squares plane, then 2-D circle: NIST two-step).
    Circle,
    /// Sphere.
    Sphere,
    /// Cylinder.
    Cylinder,
    /// Straightness of (x, y) profile: least-squares and minimum-zone widths.
    Straightness,
    /// Flatness of (x, y, z): least-squares plane z = ax + by + c and minimum zone.
    Flatness,
}

/// Arguments of `trinocular fit`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Element to fit.
    #[arg(value_enum)]
    kind: Kind,
    /// Points: CSV with columns `x,y[,z]` (mm), or a NIST `.ds` file.
    file: PathBuf,
}

/// Residual figures of a fit.
fn summary(residuals: &[f64]) -> Result<ResidualSummary> {
    let (min, max) = stats::min_max(residuals)?;
    Ok(ResidualSummary {
        rms: stats::rms(residuals)?,
        min,
        max,
        points: residuals.len(),
    })
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let need_z = !matches!(args.kind, Kind::Line2d | Kind::Straightness);
    let pts = formats::read_cloud(&args.file, need_z)?;
    let xy: Vec<Point2<f64>> = pts.iter().map(|p| Point2::new(p.x, p.y)).collect();
    let ctx = || format!("{}", args.file.display());
    let p3 = |p: &Point3<f64>| [p.x, p.y, p.z];
    let v3 = |v: &Vector3<f64>| [v.x, v.y, v.z];
    let out = match args.kind {
        Kind::Line2d => {
            let f = fit::line_2d(&xy).with_context(ctx)?;
            FitResult::Line2d {
                point: [f.point.x, f.point.y],
                direction: [f.direction.x, f.direction.y],
                residuals: summary(&f.residuals)?,
            }
        }
        Kind::Line3d => {
            let f = fit::line_3d(&pts).with_context(ctx)?;
            FitResult::Line3d {
                point: p3(&f.point),
                direction: v3(&f.direction),
                residuals: summary(&f.residuals)?,
            }
        }
        Kind::Plane => {
            let f = fit::plane(&pts).with_context(ctx)?;
            FitResult::Plane {
                point: p3(&f.point),
                normal: v3(&f.normal),
                residuals: summary(&f.residuals)?,
            }
        }
        Kind::Circle => {
            let f = fit::circle_3d(&pts).with_context(ctx)?;
            FitResult::Circle {
                centre: p3(&f.centre),
                normal: v3(&f.normal),
                diameter: f.diameter,
                residuals: summary(&f.residuals)?,
            }
        }
        Kind::Sphere => {
            let f = fit::sphere(&pts).with_context(ctx)?;
            FitResult::Sphere {
                centre: p3(&f.centre),
                diameter: f.diameter,
                residuals: summary(&f.residuals)?,
            }
        }
        Kind::Cylinder => {
            let f = fit::cylinder(&pts).with_context(ctx)?;
            FitResult::Cylinder {
                point: p3(&f.point),
                direction: v3(&f.direction),
                diameter: f.diameter,
                residuals: summary(&f.residuals)?,
            }
        }
        Kind::Straightness => {
            let lsq = fit::line_2d(&xy).with_context(ctx)?;
            let zone = min_zone::straightness(&xy).with_context(ctx)?;
            FitResult::Straightness {
                lsq: stats::range(&lsq.residuals)?,
                min_zone: zone.width,
                direction: [zone.direction.x, zone.direction.y],
            }
        }
        Kind::Flatness => {
            let lsq = fit::plane_z_on_xy(&pts).with_context(ctx)?;
            let zone = min_zone::flatness(&pts).with_context(ctx)?;
            FitResult::Flatness {
                lsq: stats::range(&lsq.residuals)?,
                lsq_plane: [lsq.a, lsq.b, lsq.c],
                min_zone: zone.width,
                min_zone_plane: [zone.a, zone.b, zone.c],
            }
        }
    };
    println!("{}", out.to_json()?);
    Ok(())
}
