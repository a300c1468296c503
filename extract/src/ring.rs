//! The background under a blob for its corrected light (`crate::correction`):
//! a plane fitted to a ring of pixels around the blob's bounding box, with
//! what the centroid's noise needs of it (`crate::noise::Background`).

use geom::{Matrix3, Vector3};

use crate::blob::Blob;
use crate::frame::FrameView;
use crate::noise::Background;
use crate::threshold::Level;

/// Gap (px) between a blob's bounding box and the ring its background is
/// fitted on: the blur's tail beyond the threshold contour stays inside it.
pub const RING_GAP_PX: u32 = 8;
/// Width (px) of that ring.
pub const RING_WIDTH_PX: u32 = 8;
/// Fewest usable ring pixels for a background plane.
const RING_MIN_PIXELS: usize = 32;
/// Ring pixels further than this many σ from the plane are refitted without.
const RING_CLIP_SIGMA: f64 = 3.0;
/// Sums over the ring are kept in this many lanes side by side (the
/// compiler spreads them over vector units), each added in pixel order.
const LANES: usize = 4;

/// The ring's pixels, column by column: (u − uc, v − vc) about the centre
/// of the blob's bounding box, value f, and 1 while the pixel is kept (0
/// once clipped, and for the padding to a whole number of lanes).
struct Ring {
    u: Vec<f64>,
    v: Vec<f64>,
    f: Vec<f64>,
    kept: Vec<f64>,
}

impl Ring {
    /// The pixels of the ring [`RING_GAP_PX`] outside `blob`'s bounding box,
    /// [`RING_WIDTH_PX`] wide, below the threshold `level` (other blobs'
    /// pixels are left out).
    #[inline(always)]
    fn around(frame: &FrameView<'_>, blob: &Blob, level: &Level) -> Self {
        let b = &blob.bbox;
        let (gap, width) = (i64::from(RING_GAP_PX), i64::from(RING_WIDTH_PX));
        let inner = (
            i64::from(b.x0) - gap,
            i64::from(b.y0) - gap,
            i64::from(b.x1) + gap,
            i64::from(b.y1) + gap,
        );
        let x0 = (inner.0 - width).max(0);
        let y0 = (inner.1 - width).max(0);
        let x1 = (inner.2 + width).min(i64::from(frame.width) - 1);
        let y1 = (inner.3 + width).min(i64::from(frame.height) - 1);
        // Coordinates relative to the box centre keep the fit well conditioned.
        let centre = [f64::from(b.x0 + b.x1) / 2.0, f64::from(b.y0 + b.y1) / 2.0];
        let mut ring = Ring {
            u: Vec::new(),
            v: Vec::new(),
            f: Vec::new(),
            kept: Vec::new(),
        };
        for y in y0..=y1 {
            let row = frame.row(y as u32);
            // Rows beside the box: the strips left and right of it only.
            let spans = if y >= inner.1 && y <= inner.3 {
                [(x0, inner.0 - 1), (inner.2 + 1, x1)]
            } else {
                [(x0, x1), (1, 0)]
            };
            for (xa, xb) in spans {
                for x in xa..=xb {
                    let f = row[x as usize];
                    if f < level.at(x as u32, y as u32, frame.width) {
                        ring.u.push(x as f64 - centre[0]);
                        ring.v.push(y as f64 - centre[1]);
                        ring.f.push(f64::from(f));
                    }
                }
            }
        }
        ring.kept = vec![1.0; ring.u.len()];
        let padded = ring.u.len().next_multiple_of(LANES);
        for column in [&mut ring.u, &mut ring.v, &mut ring.f, &mut ring.kept] {
            column.resize(padded, 0.0);
        }
        ring
    }

    /// The columns a lane group at a time: u, v, f and kept.
    #[inline(always)]
    fn chunks(&self) -> impl Iterator<Item = [&[f64]; 4]> + '_ {
        self.u
            .chunks_exact(LANES)
            .zip(self.v.chunks_exact(LANES))
            .zip(self.f.chunks_exact(LANES))
            .zip(self.kept.chunks_exact(LANES))
            .map(|(((u, v), f), k)| [u, v, f, k])
    }

    /// The kept pixels' `XᵀX` (design rows `(1, u − uc, v − vc)`) and `Xᵀf`.
    #[inline(always)]
    fn normal_equations(&self) -> (Matrix3<f64>, Vector3<f64>) {
        // n, Σu, Σv, Σu², Σuv, Σv², Σf, Σuf, Σvf.
        let mut s = [[0.0f64; LANES]; 9];
        for [u, v, f, k] in self.chunks() {
            for l in 0..LANES {
                let (ku, kv) = (k[l] * u[l], k[l] * v[l]);
                s[0][l] += k[l];
                s[1][l] += ku;
                s[2][l] += kv;
                s[3][l] += ku * u[l];
                s[4][l] += ku * v[l];
                s[5][l] += kv * v[l];
                s[6][l] += k[l] * f[l];
                s[7][l] += ku * f[l];
                s[8][l] += kv * f[l];
            }
        }
        let [n, su, sv, suu, suv, svv, sf, suf, svf] = s.map(|lanes| lanes.iter().sum::<f64>());
        (
            Matrix3::new(n, su, sv, su, suu, suv, sv, suv, svv),
            Vector3::new(sf, suf, svf),
        )
    }

    /// The kept pixels' sum of squared residuals about the plane `[c, a, b]`.
    #[inline(always)]
    fn residual_squares(&self, plane: [f64; 3]) -> f64 {
        let mut s = [0.0f64; LANES];
        for [u, v, f, k] in self.chunks() {
            for l in 0..LANES {
                let r = residual(plane, u[l], v[l], f[l]);
                s[l] += k[l] * (r * r);
            }
        }
        s.iter().sum()
    }

    /// Clip the kept pixels further than `limit` from the plane `[c, a, b]`;
    /// how many remain.
    #[inline(always)]
    fn clip(&mut self, plane: [f64; 3], limit: f64) -> usize {
        let Ring { u, v, f, kept } = self;
        for (i, k) in kept.iter_mut().enumerate() {
            let keep = residual(plane, u[i], v[i], f[i]).abs() <= limit;
            if !keep {
                *k = 0.0;
            }
        }
        kept.iter().sum::<f64>() as usize
    }
}

/// The residual `f − (c + a·u + b·v)` of a ring pixel about `[c, a, b]`.
#[inline(always)]
fn residual([c, a, b]: [f64; 3], u: f64, v: f64, f: f64) -> f64 {
    f - c - a * u - b * v
}

/// The background under a blob as a plane `b(u, v) = c + a·u + b·v` (DN),
/// least squares on the pixels of its ring ([`Ring::around`]), refitted
/// without the pixels beyond [`RING_CLIP_SIGMA`]·σ until none is; with what
/// its noise needs: the residual σ of the last fit and `XᵀX` of its design.
/// `None` when too few pixels remain or the ring is degenerate.
#[inline(always)]
pub(crate) fn background_fit(
    frame: &FrameView<'_>,
    blob: &Blob,
    level: &Level,
) -> Option<Background> {
    let b = &blob.bbox;
    let centre = [f64::from(b.x0 + b.x1) / 2.0, f64::from(b.y0 + b.y1) / 2.0];
    let mut ring = Ring::around(frame, blob, level);
    let mut count = ring.kept.iter().sum::<f64>() as usize;
    let mut background = None;
    for _ in 0..3 {
        if count < RING_MIN_PIXELS {
            return None;
        }
        let (normal, rhs) = ring.normal_equations();
        let plane = ring_plane(&normal, &rhs)?;
        let sigma = (ring.residual_squares(plane) / (count as f64 - 3.0)).sqrt();
        // Back to absolute pixel coordinates: b = c + a·(u − uc) + b·(v − vc).
        let [c, a, b] = plane;
        background = Some(Background {
            plane: [c - a * centre[0] - b * centre[1], a, b],
            sigma_dn: sigma,
            centre,
            normal,
        });
        let before = count;
        count = ring.clip(plane, RING_CLIP_SIGMA * sigma);
        if count == before {
            break;
        }
    }
    background
}

/// The least-squares plane `f = c + a·u + b·v`, as `[c, a, b]`, from its
/// normal equations `XᵀX θ = Xᵀf` (Cholesky): the ring surrounds its
/// centre, so XᵀX is well conditioned and the solution agrees with an
/// orthogonal factorisation to rounding, at a fraction of its cost for 10⁴
/// ring pixels; `None` for a degenerate ring.
fn ring_plane(normal: &Matrix3<f64>, rhs: &Vector3<f64>) -> Option<[f64; 3]> {
    let theta = normal.cholesky()?.solve(rhs);
    let plane = [theta[0], theta[1], theta[2]];
    plane.iter().all(|x| x.is_finite()).then_some(plane)
}
