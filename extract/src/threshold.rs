//! The detection threshold T: fixed (the seed: 6000 on 16-bit frames, raised
//! for busy backgrounds) or automatic, k·σ above the estimated background.

use serde::{Deserialize, Serialize};

use formats::limits::MAX_IMAGE_SIDE_PX;

use crate::background::{self, BackgroundMesh, BackgroundStats};
use crate::frame::FrameView;
use crate::{ParameterProblem, Result};

/// How the threshold is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Threshold {
    /// A fixed level T (DN).
    Fixed(u16),
    /// `T = background + k·σ` from a global clipped estimate.
    Auto {
        /// Multiple of the background noise σ.
        k: f64,
    },
    /// `T(x, y) = background(x, y) + k·σ(x, y)` from a mesh of boxes (for
    /// gradients and stray light).
    Local {
        /// Multiple of the local noise σ.
        k: f64,
        /// Box size of the background mesh (px).
        mesh: u32,
    },
}

impl Default for Threshold {
    fn default() -> Self {
        Threshold::Auto { k: DEFAULT_K }
    }
}

/// Default k of the automatic thresholds.
pub const DEFAULT_K: f64 = 8.0;

/// The threshold resolved for one frame: integer DN, ≥ 1 everywhere.
#[derive(Debug, Clone, PartialEq)]
pub enum Level {
    /// One level for the whole frame.
    Constant(u16),
    /// One level per pixel, row-major.
    Map(Vec<u16>),
}

impl Level {
    /// Short description for messages.
    pub fn describe(&self) -> String {
        match self {
            Level::Constant(t) => format!("{t} DN"),
            Level::Map(m) => {
                let lo = m.iter().min().copied().unwrap_or(0);
                let hi = m.iter().max().copied().unwrap_or(0);
                format!("local {lo}..{hi} DN")
            }
        }
    }

    /// Threshold at pixel (x, y) of a frame `width` wide.
    pub fn at(&self, x: u32, y: u32, width: u32) -> u16 {
        match self {
            Level::Constant(t) => *t,
            Level::Map(m) => m[y as usize * width as usize + x as usize],
        }
    }
}

/// Round a real level up to an integer DN in `1..=max` (a pixel is above the
/// threshold when f ≥ T, so rounding up never admits a pixel below the real level).
fn to_dn(level: f64, max: u16) -> u16 {
    level.ceil().clamp(1.0, f64::from(max)) as u16
}

impl Threshold {
    /// Check the parameters on their own: k finite and positive, the mesh
    /// `MIN_MESH_PX..=MAX_IMAGE_SIDE_PX` px.
    pub fn validate(&self) -> Result<()> {
        match *self {
            Threshold::Fixed(0) => Err(ParameterProblem::ZeroThreshold.into()),
            Threshold::Fixed(_) => Ok(()),
            Threshold::Auto { k } => check_k(k),
            Threshold::Local { k, mesh } => {
                check_k(k)?;
                if (background::MIN_MESH_PX..=MAX_IMAGE_SIDE_PX).contains(&mesh) {
                    Ok(())
                } else {
                    Err(ParameterProblem::Mesh {
                        mesh,
                        min: background::MIN_MESH_PX,
                        max: MAX_IMAGE_SIDE_PX,
                    }
                    .into())
                }
            }
        }
    }

    /// Resolve for `frame`; also returns the background estimate when one was made.
    pub fn resolve(&self, frame: &FrameView<'_>) -> Result<(Level, Option<BackgroundStats>)> {
        match *self {
            Threshold::Fixed(t) => {
                if t == 0 || t > frame.max_value() {
                    return Err(ParameterProblem::ThresholdRange {
                        threshold: t,
                        max: frame.max_value(),
                        bit_depth: frame.bit_depth,
                    }
                    .into());
                }
                Ok((Level::Constant(t), None))
            }
            Threshold::Auto { k } => {
                check_k(k)?;
                let b = background::global(frame);
                Ok((
                    Level::Constant(to_dn(b.level + k * b.sigma, frame.max_value())),
                    Some(b),
                ))
            }
            Threshold::Local { k, mesh } => {
                check_k(k)?;
                let m = BackgroundMesh::estimate(frame, mesh);
                let max = frame.max_value();
                let mut map = Vec::with_capacity(frame.pixels.len());
                for y in 0..frame.height {
                    for x in 0..frame.width {
                        let (lvl, s) = m.at(x, y);
                        map.push(to_dn(lvl + k * s, max));
                    }
                }
                Ok((Level::Map(map), None))
            }
        }
    }
}

fn check_k(k: f64) -> Result<()> {
    if k.is_finite() && k > 0.0 {
        Ok(())
    } else {
        Err(ParameterProblem::ThresholdFactor(k).into())
    }
}
