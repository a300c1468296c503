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
/// of the blob's bounding box, value f − f₀ (f₀: the first pixel's, so that
/// `Σ f²` keeps the residuals' precision), and 1 while the pixel is kept (0
/// once clipped, and for the padding to a whole number of lanes).
pub(crate) struct Ring {
    u: Vec<f64>,
    v: Vec<f64>,
    f: Vec<f64>,
    kept: Vec<f64>,
    f0: f64,
    /// (uc, vc): the centre of the blob's bounding box.
    centre: [f64; 2],
}

/// The sums of the fit over the kept pixels: n, Σu, Σv, Σu², Σuv, Σv², Σf,
/// Σuf, Σvf and Σf² (u, v about the centre, f about f₀).
#[derive(Debug, Clone, Copy, PartialEq)]
struct RingSums([f64; 10]);

impl RingSums {
    /// The terms one pixel adds.
    #[inline(always)]
    fn of(u: f64, v: f64, f: f64) -> [f64; 10] {
        [1.0, u, v, u * u, u * v, v * v, f, u * f, v * f, f * f]
    }

    /// `XᵀX` (design rows `(1, u − uc, v − vc)`) and `Xᵀf`.
    fn normal_equations(&self) -> (Matrix3<f64>, Vector3<f64>) {
        let [n, su, sv, suu, suv, svv, sf, suf, svf, _] = self.0;
        (
            Matrix3::new(n, su, sv, su, suu, suv, sv, suv, svv),
            Vector3::new(sf, suf, svf),
        )
    }

    /// `Σ (f − xᵀθ)² = Σf² − 2θᵀXᵀf + θᵀXᵀXθ` of the plane θ = `[c, a, b]`.
    fn residual_squares(&self, plane: [f64; 3]) -> f64 {
        let (normal, rhs) = self.normal_equations();
        let theta = Vector3::from(plane);
        (self.0[9] - 2.0 * theta.dot(&rhs) + theta.dot(&(normal * theta))).max(0.0)
    }
}

impl Ring {
    /// No pixels, room for none.
    const fn new() -> Self {
        Ring {
            u: Vec::new(),
            v: Vec::new(),
            f: Vec::new(),
            kept: Vec::new(),
            f0: 0.0,
            centre: [0.0; 2],
        }
    }

    /// The pixels of the ring [`RING_GAP_PX`] outside `blob`'s bounding box,
    /// [`RING_WIDTH_PX`] wide, below the threshold `level` (other blobs'
    /// pixels are left out), in place of the ring's pixels before (their
    /// room reused: fresh memory for each blob costs a page fault every
    /// 4 kB).
    #[inline(always)]
    fn around(&mut self, frame: &FrameView<'_>, blob: &Blob, level: &Level) {
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
        self.centre = centre;
        let capacity = 2 * (width as usize) * ((x1 - x0 + 1) + (y1 - y0 + 1)).max(0) as usize;
        for column in [&mut self.u, &mut self.v, &mut self.f, &mut self.kept] {
            column.clear();
            column.reserve(capacity + LANES);
        }
        let mut f0 = None;
        for y in y0..=y1 {
            let row = frame.row(y as u32);
            let v = y as f64 - centre[1];
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
                        let f0 = *f0.get_or_insert(f64::from(f));
                        self.u.push(x as f64 - centre[0]);
                        self.v.push(v);
                        self.f.push(f64::from(f) - f0);
                    }
                }
            }
        }
        self.f0 = f0.unwrap_or(0.0);
        self.kept.resize(self.u.len(), 1.0);
        let padded = self.u.len().next_multiple_of(LANES);
        for column in [&mut self.u, &mut self.v, &mut self.f, &mut self.kept] {
            column.resize(padded, 0.0);
        }
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

    /// The fit's sums over the kept pixels.
    #[inline(always)]
    fn sums(&self) -> RingSums {
        let mut s = [[0.0f64; LANES]; 10];
        for [u, v, f, k] in self.chunks() {
            // The terms of `RingSums::of` written out, k times each (k is 1
            // or 0), so that they stay in vector lanes.
            for l in 0..LANES {
                let (ku, kv, kf) = (k[l] * u[l], k[l] * v[l], k[l] * f[l]);
                s[0][l] += k[l];
                s[1][l] += ku;
                s[2][l] += kv;
                s[3][l] += ku * u[l];
                s[4][l] += ku * v[l];
                s[5][l] += kv * v[l];
                s[6][l] += kf;
                s[7][l] += ku * f[l];
                s[8][l] += kv * f[l];
                s[9][l] += kf * f[l];
            }
        }
        RingSums(s.map(|lanes| lanes.iter().sum::<f64>()))
    }

    /// Clip the kept pixels further than `limit` from the plane `[c, a, b]`
    /// (about the centre and f₀), taking them out of `sums`; how many were
    /// clipped.
    #[inline(always)]
    fn clip(&mut self, plane: [f64; 3], limit: f64, sums: &mut RingSums) -> usize {
        let mut clipped = 0;
        let Ring { u, v, f, kept, .. } = self;
        let columns = u
            .chunks_exact(LANES)
            .zip(v.chunks_exact(LANES))
            .zip(f.chunks_exact(LANES))
            .zip(kept.chunks_exact_mut(LANES));
        for (((u, v), f), k) in columns {
            // The lanes side by side; the rare clipped pixel one at a time.
            let mut out = [false; LANES];
            for l in 0..LANES {
                out[l] = (k[l] > 0.0) & (residual(plane, u[l], v[l], f[l]).abs() > limit);
            }
            if out.contains(&true) {
                for l in (0..LANES).filter(|&l| out[l]) {
                    k[l] = 0.0;
                    clipped += 1;
                    for (s, t) in sums.0.iter_mut().zip(RingSums::of(u[l], v[l], f[l])) {
                        *s -= t;
                    }
                }
            }
        }
        clipped
    }

    /// The background under `blob` as a plane `b(u, v) = c + a·u + b·v`
    /// (DN), least squares on the pixels of its ring ([`Ring::around`], in
    /// this ring's room), refitted without the pixels beyond
    /// [`RING_CLIP_SIGMA`]·σ until none is (at most three fits; the sums are
    /// gathered once and the clipped pixels taken out of them); with what
    /// its noise needs: the residual σ of the last fit and `XᵀX` of its
    /// design. `None` when too few pixels remain or the ring is degenerate.
    #[inline(always)]
    pub(crate) fn fit(
        &mut self,
        frame: &FrameView<'_>,
        blob: &Blob,
        level: &Level,
    ) -> Option<Background> {
        self.around(frame, blob, level);
        let centre = self.centre;
        let mut sums = self.sums();
        let mut count = sums.0[0] as usize;
        let mut background = None;
        for _ in 0..3 {
            if count < RING_MIN_PIXELS {
                return None;
            }
            let (normal, rhs) = sums.normal_equations();
            let plane = ring_plane(&normal, &rhs)?;
            let sigma = (sums.residual_squares(plane) / (count as f64 - 3.0)).sqrt();
            // Back to absolute pixel coordinates and values:
            // b = f₀ + c + a·(u − uc) + b·(v − vc).
            let [c, a, b] = plane;
            background = Some(Background {
                plane: [self.f0 + c - a * centre[0] - b * centre[1], a, b],
                sigma_dn: sigma,
                centre,
                normal,
            });
            let clipped = self.clip(plane, RING_CLIP_SIGMA * sigma, &mut sums);
            if clipped == 0 {
                break;
            }
            count -= clipped;
        }
        background
    }
}

/// The residual `f − (c + a·u + b·v)` of a ring pixel about `[c, a, b]`.
#[inline(always)]
fn residual([c, a, b]: [f64; 3], u: f64, v: f64, f: f64) -> f64 {
    f - c - a * u - b * v
}

/// [`Ring::fit`] with this thread's ring.
#[cfg(test)]
pub(crate) fn background_fit(
    frame: &FrameView<'_>,
    blob: &Blob,
    level: &Level,
) -> Option<Background> {
    with_ring(|ring| ring.fit(frame, blob, level))
}

thread_local! {
    /// Each thread's ring, its room reused from blob to blob.
    static RING: std::cell::RefCell<Ring> = const { std::cell::RefCell::new(Ring::new()) };
}

/// `f` with this thread's ring (its room reused from blob to blob), or with
/// a ring of its own where that one is in use (a call from within `f`).
pub(crate) fn with_ring<R>(f: impl FnOnce(&mut Ring) -> R) -> R {
    RING.with(|ring| match ring.try_borrow_mut() {
        Ok(mut ring) => f(&mut ring),
        Err(_) => f(&mut Ring::new()),
    })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::{Backend, CpuBackend, ExtractParams};
    use crate::threshold::Threshold;
    use geom::nalgebra::{DMatrix, DVector};

    /// The background of a disc on a sloping, noisy background with hot
    /// pixels in its ring, against the fit done directly: the ring's pixels
    /// collected by distance from the box, each refit by the singular value
    /// decomposition of its design and the residuals computed pixel by
    /// pixel, clipping at 3σ until none is.
    #[test]
    fn the_ring_fit_is_the_clipped_least_squares_plane() {
        const W: u32 = 200;
        const H: u32 = 160;
        let plane = |u: f64, v: f64| 900.0 + 0.8 * u - 0.5 * v;
        // A fixed pseudo-random ±8 DN texture, and hot pixels every 37th.
        let noise = |x: u32, y: u32| {
            let h = (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663)) % 17;
            f64::from(h) - 8.0
        };
        let mut pixels = vec![0u16; (W * H) as usize];
        for y in 0..H {
            for x in 0..W {
                let (u, v) = (f64::from(x), f64::from(y));
                let inside = (u - 97.3).hypot(v - 81.6) < 30.0;
                let hot = (x * 7 + y * 13) % 37 == 0;
                let f = plane(u, v)
                    + noise(x, y)
                    + if inside { 20_000.0 } else { 0.0 }
                    + if hot { 600.0 } else { 0.0 };
                pixels[(y * W + x) as usize] = f.round() as u16;
            }
        }
        let frame = FrameView::new(W, H, 16, &pixels).unwrap();
        let params = ExtractParams {
            threshold: Threshold::Fixed(5000),
            ..ExtractParams::default()
        };
        let ex = CpuBackend.extract(frame, &params).unwrap();
        assert_eq!(ex.blobs.len(), 1);
        let blob = &ex.blobs[0];
        let fitted = background_fit(&frame, blob, &ex.level).unwrap();

        // The direct fit.
        let b = &blob.bbox;
        let centre = [f64::from(b.x0 + b.x1) / 2.0, f64::from(b.y0 + b.y1) / 2.0];
        let (gap, width) = (i64::from(RING_GAP_PX), i64::from(RING_WIDTH_PX));
        let mut ring = Vec::new();
        for y in 0..i64::from(H) {
            for x in 0..i64::from(W) {
                let outside =
                    |lo: u32, hi: u32, p: i64| (i64::from(lo) - p).max(p - i64::from(hi)).max(0);
                let d = outside(b.x0, b.x1, x).max(outside(b.y0, b.y1, y));
                let f = pixels[(y * i64::from(W) + x) as usize];
                if d > gap && d <= gap + width && f < 5000 {
                    ring.push((x as f64 - centre[0], y as f64 - centre[1], f64::from(f)));
                }
            }
        }
        let mut kept = vec![true; ring.len()];
        let mut last = None;
        for _ in 0..3 {
            let rows: Vec<_> = ring.iter().zip(&kept).filter(|(_, k)| **k).collect();
            let x = DMatrix::from_fn(rows.len(), 3, |i, j| match j {
                0 => 1.0,
                1 => rows[i].0.0,
                _ => rows[i].0.1,
            });
            let f = DVector::from_iterator(rows.len(), rows.iter().map(|r| r.0.2));
            let theta = x.clone().svd(true, true).solve(&f, 1e-12).unwrap();
            let r = &f - &x * &theta;
            let sigma = (r.norm_squared() / (rows.len() as f64 - 3.0)).sqrt();
            last = Some((theta.clone(), sigma, rows.len()));
            let mut clipped = 0;
            for (p, k) in ring.iter().zip(kept.iter_mut()) {
                let res = p.2 - theta[0] - theta[1] * p.0 - theta[2] * p.1;
                if *k && res.abs() > RING_CLIP_SIGMA * sigma {
                    *k = false;
                    clipped += 1;
                }
            }
            if clipped == 0 {
                break;
            }
        }
        let (theta, sigma, n) = last.unwrap();
        let direct = [
            theta[0] - theta[1] * centre[0] - theta[2] * centre[1],
            theta[1],
            theta[2],
        ];
        // The hot pixels were clipped: the plane is the true one to the noise.
        assert!(n < ring.len(), "{n} of {}", ring.len());
        for (got, want) in fitted.plane.iter().zip(direct) {
            assert!(
                (got - want).abs() < 1e-9 * want.abs().max(1.0),
                "{got} vs {want}"
            );
        }
        assert!(
            (fitted.sigma_dn - sigma).abs() < 1e-9 * sigma,
            "{} vs {sigma}",
            fitted.sigma_dn
        );
        assert!((fitted.normal[(0, 0)] - n as f64).abs() < 0.5);
        // Within a fit of this thread's ring, another one gets a ring of its
        // own, and the same plane.
        let nested = with_ring(|_| background_fit(&frame, blob, &ex.level)).unwrap();
        assert_eq!(nested, fitted);
        let truth = [plane(0.0, 0.0), 0.8, -0.5];
        assert!(
            (fitted.plane[1] - truth[1]).abs() < 0.01 && (fitted.plane[2] - truth[2]).abs() < 0.01
        );
    }
}
