//! Blobs and their moments: the thresholded gray centroid
//! `u0 = Σu·F/ΣF`, `v0 = Σv·F/ΣF` (docs/methods.md), area, equivalent diameter,
//! second moments (ellipse axes and orientation), circularity, peak, flags.
//!
//! The sums are kept as exact integers (u128), so a blob's moments do not
//! depend on the order in which its runs were added — the same on any number
//! of threads and on any backend that sums exactly.

use crate::frame::FrameView;
use crate::label::{Labelling, Run};

/// Raw weighted moment sums of a blob: S = ΣF, Sx = ΣF·u, … (pixel units).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Moments {
    /// ΣF.
    pub s: u128,
    /// ΣF·u.
    pub sx: u128,
    /// ΣF·v.
    pub sy: u128,
    /// ΣF·u².
    pub sxx: u128,
    /// ΣF·v².
    pub syy: u128,
    /// ΣF·u·v.
    pub sxy: u128,
}

impl Moments {
    /// Add one run's sums (converting its run-relative x to absolute u).
    pub fn add_run(&mut self, r: &Run) {
        let (f, fdx, fdx2) = (
            u128::from(r.sum_f),
            u128::from(r.sum_fdx),
            u128::from(r.sum_fdx2),
        );
        let (x0, y) = (u128::from(r.x0), u128::from(r.y));
        let fx = x0 * f + fdx;
        self.s += f;
        self.sx += fx;
        self.sy += y * f;
        self.sxx += x0 * x0 * f + 2 * x0 * fdx + fdx2;
        self.syy += y * y * f;
        self.sxy += y * fx;
    }

    /// Sum of two sets of moments.
    pub fn merge(&mut self, o: &Moments) {
        self.s += o.s;
        self.sx += o.sx;
        self.sy += o.sy;
        self.sxx += o.sxx;
        self.syy += o.syy;
        self.sxy += o.sxy;
    }

    /// Centroid (u0, v0) = (Sx/S, Sy/S); `None` when S = 0.
    pub fn centroid(&self) -> Option<(f64, f64)> {
        (self.s > 0).then(|| {
            (
                self.sx as f64 / self.s as f64,
                self.sy as f64 / self.s as f64,
            )
        })
    }

    /// Central second moments (μ20, μ02, μ11) in px², from exact integer
    /// numerators `S·Sxx − Sx²` etc. (no cancellation).
    pub fn central(&self) -> (f64, f64, f64) {
        if self.s == 0 {
            return (0.0, 0.0, 0.0);
        }
        let s = self.s as f64;
        let s2 = s * s;
        let var = |a: u128, b: u128, c: u128| -> f64 {
            // S·Sab − Sa·Sb, signed.
            let p = self.s * a;
            let q = b * c;
            if p >= q {
                (p - q) as f64 / s2
            } else {
                -((q - p) as f64) / s2
            }
        };
        (
            var(self.sxx, self.sx, self.sx),
            var(self.syy, self.sy, self.sy),
            var(self.sxy, self.sx, self.sy),
        )
    }
}

/// Inclusive pixel bounding box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundingBox {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// Last column.
    pub x1: u32,
    /// Last row.
    pub y1: u32,
}

/// A connected blob of above-threshold pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Blob {
    /// Centroid u (px).
    pub u: f64,
    /// Centroid v (px).
    pub v: f64,
    /// Pixels in the blob.
    pub area_px: u64,
    /// Exact weighted sums.
    pub moments: Moments,
    /// Largest pixel value (DN).
    pub peak: u16,
    /// Pixels at the saturation level.
    pub saturated_px: u64,
    /// The blob touches the frame border.
    pub touches_border: bool,
    /// Bounding box.
    pub bbox: BoundingBox,
    /// The blob's runs in raster order (for re-weighting, e.g. undistorted centroids).
    pub runs: Vec<Run>,
}

/// Ellipse of the same second moments: full axis lengths and orientation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MomentEllipse {
    /// Major axis length, `4·√λ1` (px; the diameter of a uniform disc).
    pub major_px: f64,
    /// Minor axis length, `4·√λ2` (px).
    pub minor_px: f64,
    /// Angle of the major axis from +u towards +v (rad), `½·atan2(2μ11, μ20 − μ02)`.
    pub orientation_rad: f64,
}

impl MomentEllipse {
    /// The ellipse of central second moments (μ20, μ02, μ11) (px²):
    /// eigen-decomposition of the covariance, axes `4·√λ`.
    pub fn of_central((a, b, c): (f64, f64, f64)) -> Self {
        let mean = 0.5 * (a + b);
        let d = (0.25 * (a - b) * (a - b) + c * c).sqrt();
        Self {
            major_px: 4.0 * (mean + d).max(0.0).sqrt(),
            minor_px: 4.0 * (mean - d).max(0.0).sqrt(),
            orientation_rad: 0.5 * (2.0 * c).atan2(a - b),
        }
    }

    /// Circularity: minor/major axis ratio (1 for a disc, 0 when degenerate).
    pub fn circularity(&self) -> f64 {
        if self.major_px > 0.0 {
            self.minor_px / self.major_px
        } else {
            0.0
        }
    }
}

impl Blob {
    /// Equivalent diameter `√(4·area/π)` (px).
    pub fn diameter_px(&self) -> f64 {
        (4.0 * self.area_px as f64 / std::f64::consts::PI).sqrt()
    }

    /// Σ F (DN·px).
    pub fn signal(&self) -> u128 {
        self.moments.s
    }

    /// Moment ellipse of the blob's weighted covariance.
    pub fn ellipse(&self) -> MomentEllipse {
        MomentEllipse::of_central(self.moments.central())
    }

    /// Circularity: minor/major axis ratio of the moment ellipse (1 for a disc).
    pub fn circularity(&self) -> f64 {
        self.ellipse().circularity()
    }

    /// The blob is saturated somewhere.
    pub fn saturated(&self) -> bool {
        self.saturated_px > 0
    }
}

/// The blobs of a labelling, and how many were dropped for having no weight.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Collected {
    /// Blobs with a centroid, ordered by their first run in raster order.
    pub blobs: Vec<Blob>,
    /// Blobs dropped because every pixel is exactly at the threshold (no
    /// weight, no centroid): with T at the saturation level, saturated blobs.
    pub weightless: usize,
    /// Of those, blobs at the frame's saturation level.
    pub weightless_saturated: usize,
}

/// Gather the labelled runs into blobs, ordered by their first run in raster
/// order; blobs with zero weight (all pixels exactly at T) are dropped and
/// counted.
pub fn collect(frame: &FrameView<'_>, labelling: Labelling) -> Collected {
    let Labelling {
        runs,
        component,
        components,
    } = labelling;
    let (w, h) = (frame.width, frame.height);
    let mut blobs: Vec<Blob> = Vec::with_capacity(components as usize);
    for (run, &c) in runs.iter().zip(&component) {
        if c as usize == blobs.len() {
            blobs.push(Blob {
                u: 0.0,
                v: 0.0,
                area_px: 0,
                moments: Moments::default(),
                peak: 0,
                saturated_px: 0,
                touches_border: false,
                bbox: BoundingBox {
                    x0: run.x0,
                    y0: run.y,
                    x1: run.x1,
                    y1: run.y,
                },
                runs: Vec::new(),
            });
        }
        let b = &mut blobs[c as usize];
        b.moments.add_run(run);
        b.area_px += u64::from(run.len());
        b.peak = b.peak.max(run.peak);
        b.saturated_px += u64::from(run.saturated);
        b.touches_border |= run.x0 == 0 || run.x1 == w - 1 || run.y == 0 || run.y == h - 1;
        b.bbox.x0 = b.bbox.x0.min(run.x0);
        b.bbox.x1 = b.bbox.x1.max(run.x1);
        b.bbox.y1 = b.bbox.y1.max(run.y);
        b.runs.push(*run);
    }
    let (mut weightless, mut weightless_saturated) = (0, 0);
    blobs.retain_mut(|b| match b.moments.centroid() {
        Some((u, v)) => {
            b.u = u;
            b.v = v;
            true
        }
        None => {
            weightless += 1;
            weightless_saturated += usize::from(b.saturated());
            false
        }
    });
    Collected {
        blobs,
        weightless,
        weightless_saturated,
    }
}
