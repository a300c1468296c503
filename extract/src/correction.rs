//! Corrected centroids: a blob's light re-weighted pixel by pixel with the
//! camera's model — undistortion (positions and the area Jacobian) and the
//! flat-field correction by the lens's relative illumination RI — so that its
//! centroid is that of the radiance image in the ideal (undistorted) image
//! plane, where a luminous sphere is a uniform ellipse.
//!
//! Per pixel of the blob, observed value f:
//! `f′ = (f − b(p))/RI(p)` (b: the background under the blob, a plane fitted
//! to a ring of pixels around it — the dark offset plus any background light);
//! weight `F′·J` with `F′ = f′ − T′` where `f′ > T′` (thresholded weighting)
//! or `F′ = f′` where `f′ ≥ T′` (raw), `T′ = max over the blob of
//! (T(p) − b(p))/RI(p)`: one threshold in radiance units at least as strict as
//! the frame's own, so that every pixel it admits is one the labelling found
//! (the threshold test stays consistent), and the weight of a uniform
//! sphere's pixels depends on their blurred coverage alone.

use geom::fit::HeightPlane;
use geom::{Camera, Illumination, Matrix3, Point2, Point3, RadialIllumination, Vector3};
use std::cell::Cell;

use crate::blob::{Blob, MomentEllipse};
use crate::frame::FrameView;
use crate::label::Weighting;
use crate::noise::{Background, CentroidCovariance, WeightedPixel, centroid_covariance};
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

/// One observed pixel in the corrected image: its position, the area
/// Jacobian `|∂mapped/∂observed|`, and the lens's relative illumination.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mapped {
    /// Position in the corrected image (px).
    pub position: [f64; 2],
    /// Area Jacobian of the mapping.
    pub jacobian: f64,
    /// Relative illumination RI at the observed pixel.
    pub illumination: f64,
}

/// A pixel correction: observed pixel (u, v) → [`Mapped`]; `None` where undefined.
pub trait PixelMap {
    /// Map one pixel centre.
    fn map(&self, u: f64, v: f64) -> Option<Mapped>;

    /// Map the pixels `x0..=x1` of row `y` into `out` (cleared first);
    /// `None` when one of them cannot be mapped. By default pixel by pixel.
    fn map_run(&self, y: u32, x0: u32, x1: u32, out: &mut Vec<Mapped>) -> Option<()> {
        out.clear();
        let v = f64::from(y);
        for x in x0..=x1 {
            out.push(self.map(f64::from(x), v)?);
        }
        Some(())
    }
}

/// Spacing (px) of the lattice of exactly mapped nodes of
/// [`CameraMap::map_run`]: between them the map is the bicubic (tensor
/// Lagrange cubic) through the 4 × 4 nearest nodes. The undistortion, its
/// area Jacobian and the relative illumination are smooth over the field,
/// so the interpolation's error, ≈ (3/128)·h⁴·|f⁗| per direction at
/// mid-interval, is small: ≤ 5e-7 px in the corner of a wide-angle lens
/// whose distortion shifts it by 570 px, 1e-10 px on the campaigns'
/// lenses, against the 1e-4 px a centroid may move (`docs/performance.md`).
pub const NODE_SPACING_PX: u32 = 8;

/// Runs shorter than this many node intervals are mapped pixel by pixel.
const MIN_INTERVALS: u32 = 4;

/// A node's shift p − (u, v), J and RI.
type Node = [f64; 4];

/// Lagrange weights of the nodes at −1, 0, 1, 2 (in node spacings) at
/// `t` ∈ [0, 1).
fn cubic_weights(t: f64) -> [f64; 4] {
    [
        -t * (t - 1.0) * (t - 2.0) / 6.0,
        (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
        -(t + 1.0) * t * (t - 2.0) / 2.0,
        (t + 1.0) * t * (t - 1.0) / 6.0,
    ]
}

/// The lattice of a camera's exactly mapped nodes every
/// [`NODE_SPACING_PX`] over its sensor, node (i, j) from (−1, −1), each
/// solved on first use and kept for the whole run, shared by every frame
/// and thread. A node is solved from the same start whoever needs it first,
/// so results do not depend on the order of frames or the number of
/// threads. Nodes are held in tiles of [`TILE_NODES`]² made on first use:
/// only the parts of the sensor the spheres cross take memory.
pub struct Lattice {
    /// Nodes per lattice row and column.
    size: [usize; 2],
    /// Tiles per lattice row.
    tile_columns: usize,
    tiles: Vec<std::sync::OnceLock<Tile>>,
}

/// A node of a [`Lattice`]: unsolved, or solved (`None` where the model
/// cannot map it).
type NodeCell = std::sync::OnceLock<Option<Node>>;

/// A tile of [`TILE_NODES`]² nodes, row by row.
type Tile = Box<[NodeCell]>;

/// Nodes along a side of a tile of a [`Lattice`].
pub const TILE_NODES: usize = 16;

impl Lattice {
    /// The (unsolved) lattice of `camera`'s sensor.
    pub fn new(camera: &Camera) -> Self {
        // Nodes −1 ..= ⌊(size − 1)/h⌋ + 2 along each side.
        let count = |size: u32| (size.saturating_sub(1) / NODE_SPACING_PX) as usize + 4;
        let size = [count(camera.width), count(camera.height)];
        let [tc, tr] = size.map(|n| n.div_ceil(TILE_NODES));
        Self {
            size,
            tile_columns: tc,
            tiles: (0..tc * tr).map(|_| std::sync::OnceLock::new()).collect(),
        }
    }

    /// The cell of node (c, r) (from 0), its tile made on first use.
    fn cell(&self, c: usize, r: usize) -> Option<&NodeCell> {
        if c >= self.size[0] || r >= self.size[1] {
            return None;
        }
        let tile = self
            .tiles
            .get((r / TILE_NODES) * self.tile_columns + c / TILE_NODES)?
            .get_or_init(|| {
                (0..TILE_NODES * TILE_NODES)
                    .map(|_| NodeCell::new())
                    .collect()
            });
        tile.get((r % TILE_NODES) * TILE_NODES + c % TILE_NODES)
    }
}

/// Observed pixels of a calibrated camera → ideal (undistorted) pixels, with
/// the area Jacobian and the camera's relative illumination. A single pixel
/// is solved by Newton's method started from the previous one's solution
/// (one or two steps); runs go through the camera's [`Lattice`] of exact
/// nodes every [`NODE_SPACING_PX`].
pub struct CameraMap<'a> {
    camera: &'a Camera,
    illumination: &'a Illumination,
    last: Cell<Option<(Point2<f64>, geom::Vector2<f64>)>>,
    lattice: Nodes<'a>,
}

/// A map's lattice: its own, or a run's.
enum Nodes<'a> {
    Own(Lattice),
    Shared(&'a Lattice),
}

impl<'a> CameraMap<'a> {
    /// The map of `camera` with its lens's `illumination`, with a lattice
    /// of its own.
    pub fn new(camera: &'a Camera, illumination: &'a Illumination) -> Self {
        Self {
            camera,
            illumination,
            last: Cell::new(None),
            lattice: Nodes::Own(Lattice::new(camera)),
        }
    }

    /// The map through `lattice`, the camera's for the whole run
    /// ([`Lattice::new`] of the same camera).
    pub fn with_lattice(
        camera: &'a Camera,
        illumination: &'a Illumination,
        lattice: &'a Lattice,
    ) -> Self {
        Self {
            camera,
            illumination,
            last: Cell::new(None),
            lattice: Nodes::Shared(lattice),
        }
    }

    /// The lattice node (i·h, j·h), solved on first use (Newton from the
    /// model's own start); `None` outside the sensor's lattice or where the
    /// model cannot map it.
    fn node(&self, i: i64, j: i64) -> Option<Node> {
        let lattice = match &self.lattice {
            Nodes::Own(l) => l,
            Nodes::Shared(l) => l,
        };
        let (c, r) = (usize::try_from(i + 1).ok()?, usize::try_from(j + 1).ok()?);
        *lattice.cell(c, r)?.get_or_init(|| {
            let h = f64::from(NODE_SPACING_PX);
            let (u, v) = (i as f64 * h, j as f64 * h);
            let (p, jac) = self.camera.undistort_pixel_area(Point2::new(u, v)).ok()?;
            let m = self.mapped([u, v], p, jac, self.camera.intrinsics.to_normalized(p));
            Some([
                m.position[0] - u,
                m.position[1] - v,
                m.jacobian,
                m.illumination,
            ])
        })
    }

    /// Observed pixel `observed` mapped to ideal pixel `p` (normalised
    /// coordinates `n`) with area Jacobian `j`, and its RI.
    fn mapped(&self, observed: [f64; 2], p: Point2<f64>, j: f64, n: geom::Vector2<f64>) -> Mapped {
        Mapped {
            position: [p.x, p.y],
            jacobian: j,
            illumination: self.illumination.at(observed, n, j),
        }
    }

    /// The pixels `x0..=x1` of row `y` through the lattice; `None` when a
    /// node cannot be mapped.
    fn lattice_run(&self, y: u32, x0: u32, x1: u32, out: &mut Vec<Mapped>) -> Option<()> {
        let h = NODE_SPACING_PX;
        let (j, ty) = (i64::from(y / h), f64::from(y % h) / f64::from(h));
        let wy = cubic_weights(ty);
        // The run's node columns, each interpolated to row y.
        let (i0, i1) = (i64::from(x0 / h) - 1, i64::from(x1 / h) + 2);
        let mut columns: Vec<Node> = Vec::with_capacity((i1 - i0 + 1) as usize);
        for i in i0..=i1 {
            let mut f = [0.0f64; 4];
            for (dj, w) in (-1..=2).zip(wy) {
                let n = self.node(i, j + dj)?;
                for (fc, nc) in f.iter_mut().zip(n) {
                    *fc += w * nc;
                }
            }
            columns.push(f);
        }
        out.clear();
        let v = f64::from(y);
        // The weights of the h offsets a pixel can have within an interval.
        let offsets: [[f64; 4]; NODE_SPACING_PX as usize] =
            std::array::from_fn(|o| cubic_weights(o as f64 / f64::from(h)));
        for x in x0..=x1 {
            // Columns k − 1 ..= k + 2 around x, k = x / h (index from i0).
            let k = (i64::from(x / h) - i0) as usize;
            let wx = offsets[(x % h) as usize];
            let mut f = [0.0f64; 4];
            for (c, w) in columns[k - 1..k + 3].iter().zip(wx) {
                for (fc, nc) in f.iter_mut().zip(c) {
                    *fc += w * nc;
                }
            }
            let u = f64::from(x);
            out.push(Mapped {
                position: [u + f[0], v + f[1]],
                jacobian: f[2],
                illumination: f[3],
            });
        }
        Some(())
    }
}

impl PixelMap for CameraMap<'_> {
    /// Through the lattice of exact nodes ([`NODE_SPACING_PX`]): each pixel
    /// the bicubic of the shift p − (u, v), J and RI; a run shorter than
    /// [`MIN_INTERVALS`] node spacings, or one near a node the model cannot
    /// map (beyond the lens model's reach), pixel by pixel.
    fn map_run(&self, y: u32, x0: u32, x1: u32, out: &mut Vec<Mapped>) -> Option<()> {
        if (x1 - x0) / NODE_SPACING_PX + 1 >= MIN_INTERVALS
            && self.lattice_run(y, x0, x1, out).is_some()
        {
            return Some(());
        }
        out.clear();
        let v = f64::from(y);
        for x in x0..=x1 {
            out.push(self.map(f64::from(x), v)?);
        }
        Some(())
    }

    fn map(&self, u: f64, v: f64) -> Option<Mapped> {
        let observed = Point2::new(u, v);
        let (p, j, n) = match self.last.get() {
            Some(near) => self.camera.undistort_pixel_area_near(observed, near).ok()?,
            None => {
                let (p, j) = self.camera.undistort_pixel_area(observed).ok()?;
                (p, j, self.camera.intrinsics.to_normalized(p))
            }
        };
        self.last.set(Some((observed, n)));
        Some(self.mapped([u, v], p, j, n))
    }
}

/// Observed pixels as they are, flat-field corrected by a fitted relative
/// illumination (`trinocular extract --flat-field`: no camera model).
pub struct FlatFieldMap<'a>(pub &'a RadialIllumination);

impl PixelMap for FlatFieldMap<'_> {
    fn map(&self, u: f64, v: f64) -> Option<Mapped> {
        Some(Mapped {
            position: [u, v],
            jacobian: 1.0,
            illumination: self.0.at(u, v),
        })
    }
}

/// The ring of pixels of [`background_fit`], relative to the
/// centre of the blob's bounding box (u, v, f).
fn ring_points(frame: &FrameView<'_>, blob: &Blob, level: &Level) -> Vec<Point3<f64>> {
    let b = &blob.bbox;
    let (gap, width) = (RING_GAP_PX, RING_WIDTH_PX);
    let inner = (
        i64::from(b.x0) - i64::from(gap),
        i64::from(b.y0) - i64::from(gap),
        i64::from(b.x1) + i64::from(gap),
        i64::from(b.y1) + i64::from(gap),
    );
    let x0 = (inner.0 - i64::from(width)).max(0);
    let y0 = (inner.1 - i64::from(width)).max(0);
    let x1 = (inner.2 + i64::from(width)).min(i64::from(frame.width) - 1);
    let y1 = (inner.3 + i64::from(width)).min(i64::from(frame.height) - 1);
    let mut points = Vec::new();
    for y in y0..=y1 {
        let row = frame.row(y as u32);
        let inside_rows = y >= inner.1 && y <= inner.3;
        for x in x0..=x1 {
            if inside_rows && x >= inner.0 && x <= inner.2 {
                continue;
            }
            let f = row[x as usize];
            if f >= level.at(x as u32, y as u32, frame.width) {
                continue;
            }
            // Coordinates relative to the box centre keep the fit well conditioned.
            points.push(Point3::new(
                x as f64 - f64::from(b.x0 + b.x1) / 2.0,
                y as f64 - f64::from(b.y0 + b.y1) / 2.0,
                f64::from(f),
            ));
        }
    }
    points
}

/// The background under a blob as a plane `b(u, v) = c + a·u + b·v` (DN),
/// fitted to the pixels of a ring [`RING_GAP_PX`] outside its bounding box,
/// [`RING_WIDTH_PX`] wide: pixels at or above the threshold (other blobs)
/// are left out, and the fit is repeated without pixels beyond
/// [`RING_CLIP_SIGMA`]·σ; with what its noise needs: the residual σ of the
/// last fit and `XᵀX` of its design. `None` when too few pixels remain.
fn background_fit(frame: &FrameView<'_>, blob: &Blob, level: &Level) -> Option<Background> {
    let b = &blob.bbox;
    let mut points = ring_points(frame, blob, level);
    let centre = [f64::from(b.x0 + b.x1) / 2.0, f64::from(b.y0 + b.y1) / 2.0];
    let mut background = None;
    for _ in 0..3 {
        if points.len() < RING_MIN_PIXELS {
            return None;
        }
        let normal = normal_matrix(&points);
        let fit = ring_plane(&points, &normal)?;
        let n = fit.residuals.len() as f64;
        let sigma = (fit.residuals.iter().map(|r| r * r).sum::<f64>() / (n - 3.0)).sqrt();
        let before = points.len();
        let mut k = 0;
        points.retain(|_| {
            let keep = fit.residuals[k].abs() <= RING_CLIP_SIGMA * sigma;
            k += 1;
            keep
        });
        // Back to absolute pixel coordinates: b = c + a·(u − uc) + b·(v − vc).
        let (uc, vc) = (centre[0], centre[1]);
        background = Some(Background {
            plane: [fit.c - fit.a * uc - fit.b * vc, fit.a, fit.b],
            sigma_dn: sigma,
            centre,
            normal,
        });
        if points.len() == before {
            break;
        }
    }
    background
}

/// The least-squares plane `f = c + a·u + b·v` through the ring `points`
/// (coordinates relative to the box centre) by the normal equations
/// `XᵀX θ = Xᵀf` with the ring's `normal` = XᵀX (Cholesky): the ring
/// surrounds the centre, so XᵀX is well conditioned and the solution agrees
/// with an orthogonal factorisation to rounding, at a fraction of its cost
/// for 10⁴ ring pixels; `None` for a degenerate ring.
fn ring_plane(points: &[Point3<f64>], normal: &Matrix3<f64>) -> Option<HeightPlane> {
    let rhs = points.iter().fold(Vector3::zeros(), |acc, p| {
        acc + Vector3::new(1.0, p.x, p.y) * p.z
    });
    let theta = normal.cholesky()?.solve(&rhs);
    let (c, a, b) = (theta[0], theta[1], theta[2]);
    if !(a.is_finite() && b.is_finite() && c.is_finite()) {
        return None;
    }
    Some(HeightPlane {
        a,
        b,
        c,
        residuals: points.iter().map(|p| p.z - c - a * p.x - b * p.y).collect(),
    })
}

/// `XᵀX` of the ring's design matrix, rows `(1, u − uc, v − vc)`.
fn normal_matrix(points: &[Point3<f64>]) -> Matrix3<f64> {
    let mut m = Matrix3::zeros();
    for p in points {
        let x = Vector3::new(1.0, p.x, p.y);
        m += x * x.transpose();
    }
    m
}

/// A blob's corrected light (module docs): the weights `w = F′·J` at the
/// undistorted positions p′ of its pixels, summed into its centroid and
/// central second moments — in the corrected (ideal) image, where a luminous
/// sphere is the ellipse of `geom::sphere_image` whatever the lens.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MappedLight {
    /// Centroid `c = Σ p′·w / Σ w` (px).
    pub centroid: [f64; 2],
    /// Central second moments `(μ20, μ02, μ11) = Σ w·(p′ − c)(p′ − c)ᵀ / Σ w` (px²).
    pub central: (f64, f64, f64),
    /// The centroid's covariance from the pixels' noise (`crate::noise`,
    /// px² of the corrected image); `None` without a system gain K, with
    /// the raw weighting, or when the background plane's covariance is
    /// undefined.
    pub covariance: Option<CentroidCovariance>,
}

impl MappedLight {
    /// The moment ellipse of the corrected light (its axes and circularity).
    pub fn ellipse(&self) -> MomentEllipse {
        MomentEllipse::of_central(self.central)
    }
}

/// The weight `F′` of a pixel of corrected value `f′` against the threshold
/// `T′` (before the area Jacobian); `None` for a pixel without weight.
fn corrected_weight(weighting: Weighting, f: f64, t: f64) -> Option<f64> {
    match weighting {
        Weighting::Subtracted if f > t => Some(f - t),
        Weighting::Raw if f >= t => Some(f),
        _ => None,
    }
}

/// The blob's corrected light: centroid `Σ p′·F′·J / Σ F′·J` and the second
/// moments about it over its pixels, with the background plane, flat-field
/// correction and threshold of the module docs; with the system gain
/// `gain_dn_per_e` (K, DN/e⁻), the centroid's covariance (`crate::noise`).
/// `frame` must be the frame the blob was extracted from (after denoising;
/// a denoised frame's pixels are correlated, so give no K for one). `None`
/// when the background cannot be estimated, a pixel cannot be mapped, or no
/// weight remains.
pub fn mapped_light(
    frame: &FrameView<'_>,
    blob: &Blob,
    level: &Level,
    weighting: Weighting,
    map: &dyn PixelMap,
    gain_dn_per_e: Option<f64>,
) -> Option<MappedLight> {
    let background = background_fit(frame, blob, level)?;
    // Buffers kept per thread between blobs: a blob of 10⁵ pixels would
    // otherwise cost fresh pages (and their faults) every time.
    SCRATCH.with(|scratch| {
        let mut fresh = Scratch::default();
        let mut held = scratch.try_borrow_mut();
        let buffers = match held.as_mut() {
            Ok(s) => &mut **s,
            Err(_) => &mut fresh,
        };
        let light = Light {
            frame,
            blob,
            level,
            weighting,
            map,
            gain_dn_per_e,
        };
        light.of(&background, buffers)
    })
}

/// What [`mapped_light`] was given.
struct Light<'a, 'f> {
    frame: &'a FrameView<'f>,
    blob: &'a Blob,
    level: &'a Level,
    weighting: Weighting,
    map: &'a dyn PixelMap,
    gain_dn_per_e: Option<f64>,
}

/// The buffers of [`Light::of`].
#[derive(Default)]
struct Scratch {
    pixels: Vec<WeightedPixel>,
    weights: Vec<f64>,
    mapped: Vec<Mapped>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::default();
}

impl Light<'_, '_> {
    /// [`mapped_light`] over `background`, in the given buffers.
    fn of(&self, background: &Background, scratch: &mut Scratch) -> Option<MappedLight> {
        let Scratch {
            pixels,
            weights,
            mapped,
        } = scratch;
        let [c, a, b] = background.plane;
        pixels.clear();
        let mut t_max = f64::NEG_INFINITY;
        // Observed position and RI of the pixel that sets T′.
        let mut t_at = ([0.0, 0.0], 1.0);
        for run in &self.blob.runs {
            let row = self.frame.row(run.y);
            let v = f64::from(run.y);
            self.map.map_run(run.y, run.x0, run.x1, mapped)?;
            for (x, &m) in (run.x0..=run.x1).zip(mapped.iter()) {
                let u = f64::from(x);
                if !(m.illumination > 0.0 && m.jacobian > 0.0) {
                    return None;
                }
                let bg = c + a * u + b * v;
                let t = f64::from(self.level.at(x, run.y, self.frame.width));
                let t_pixel = (t - bg) / m.illumination;
                if t_pixel > t_max {
                    t_at = ([u, v], m.illumination);
                }
                t_max = t_max.max(t_pixel);
                let signal = f64::from(row[x as usize]) - bg;
                pixels.push(WeightedPixel {
                    observed: [u, v],
                    mapped: m,
                    signal_dn: signal,
                });
            }
        }
        // The pixels that carry weight (kept in place), with their weights
        // and the centroid's sums.
        weights.clear();
        let (mut su, mut sv, mut sw) = (0.0f64, 0.0f64, 0.0f64);
        pixels.retain(|p| {
            let f = p.signal_dn / p.mapped.illumination;
            match corrected_weight(self.weighting, f, t_max) {
                Some(w) => {
                    let w = w * p.mapped.jacobian;
                    su += p.mapped.position[0] * w;
                    sv += p.mapped.position[1] * w;
                    sw += w;
                    weights.push(w);
                    true
                }
                None => false,
            }
        });
        let centroid = (sw > 0.0).then(|| [su / sw, sv / sw])?;
        let (mut suu, mut svv, mut suv) = (0.0f64, 0.0f64, 0.0f64);
        for (p, &w) in pixels.iter().zip(weights.iter()) {
            let (du, dv) = (
                p.mapped.position[0] - centroid[0],
                p.mapped.position[1] - centroid[1],
            );
            suu += du * du * w;
            svv += dv * dv * w;
            suv += du * dv * w;
        }
        let covariance = match (self.gain_dn_per_e, self.weighting) {
            (Some(k), Weighting::Subtracted) => {
                centroid_covariance(pixels, centroid, sw, background, t_at, k)
            }
            _ => None,
        };
        Some(MappedLight {
            centroid,
            central: (suu / sw, svv / sw, suv / sw),
            covariance,
        })
    }
}

/// The blob's corrected centroid: that of its [`mapped_light`].
pub fn mapped_centroid(
    frame: &FrameView<'_>,
    blob: &Blob,
    level: &Level,
    weighting: Weighting,
    map: &dyn PixelMap,
) -> Option<[f64; 2]> {
    mapped_light(frame, blob, level, weighting, map, None).map(|l| l.centroid)
}

/// The corrected centroids of `blobs` with `camera`'s model and its lens's
/// `illumination` ([`mapped_centroid`] through a [`CameraMap`]), mapped back
/// through the lens distortion to observed pixels: where the camera model
/// says the centre of each blob's radiance image is seen. `None` for a blob
/// whose corrected centroid is undefined.
pub fn observed_centroids(
    frame: &FrameView<'_>,
    blobs: &[&Blob],
    level: &Level,
    weighting: Weighting,
    camera: &Camera,
    illumination: &Illumination,
) -> Vec<Option<Point2<f64>>> {
    let map = CameraMap::new(camera, illumination);
    blobs
        .iter()
        .map(|b| {
            mapped_centroid(frame, b, level, weighting, &map)
                .map(|q| camera.distort_pixel(Point2::new(q[0], q[1])))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::{Backend, CpuBackend, ExtractParams, Extraction};
    use crate::threshold::Threshold;

    const W: u32 = 160;
    const H: u32 = 120;

    /// A W×H frame's pixels: `value(u, v, c)`, c the area of the unit pixel
    /// where `inside(u, v)` holds, by 8×8 supersampling (exact to ≈ 1/64 of
    /// an edge pixel's area).
    fn render(inside: impl Fn(f64, f64) -> bool, value: impl Fn(f64, f64, f64) -> f64) -> Vec<u16> {
        let mut pixels = vec![0u16; (W * H) as usize];
        for y in 0..H {
            for x in 0..W {
                let (u, v) = (f64::from(x), f64::from(y));
                let mut c = 0.0f64;
                for i in 0..8 {
                    for j in 0..8 {
                        let (su, sv) = (0.125 * f64::from(i), 0.125 * f64::from(j));
                        if inside(u - 0.4375 + su, v - 0.4375 + sv) {
                            c += 1.0 / 64.0;
                        }
                    }
                }
                pixels[(y * W + x) as usize] = value(u, v, c).round() as u16;
            }
        }
        pixels
    }

    /// The frame's blobs at a fixed threshold of 2000 DN; there is one.
    fn extract_one(frame: FrameView<'_>) -> (Extraction, ExtractParams) {
        let params = ExtractParams {
            threshold: Threshold::Fixed(2000),
            ..ExtractParams::default()
        };
        let ex = CpuBackend.extract(frame, &params).unwrap();
        assert_eq!(ex.blobs.len(), 1);
        (ex, params)
    }

    /// A disc of radiance `l` over a background plane, both times a linear
    /// illumination fall-off, plus an offset: the corrected centroid is the
    /// disc's centre, the plain one is pulled towards the brighter side.
    /// Runs mapped through exact nodes and cubics agree with the exact map
    /// pixel by pixel, on a wide-angle lens with strong barrel distortion
    /// (k1 = −0.2: ≈ 570 px of shift at the corner of a full frame), in the
    /// corners where the map bends most, for runs of every length.
    #[test]
    fn runs_mapped_through_nodes_agree_with_the_exact_map() {
        let (w, h) = (4096u32, 3072u32);
        let camera = Camera {
            intrinsics: geom::Intrinsics::centred(2600.0, w, h),
            distortion: geom::Distortion {
                k1: -0.2,
                k2: 0.05,
                k3: 0.0,
                p1: 4e-4,
                p2: -3e-4,
            },
            pose: geom::Isometry3::identity(),
            width: w,
            height: h,
        };
        let illumination = Illumination::Ideal;
        let map = CameraMap::new(&camera, &illumination);
        let mut out = Vec::new();
        let mut worst = [0.0f64; 3];
        for (y, x0, x1) in [
            (40u32, 30u32, 330u32),
            (1536, 3700, 4050),
            (3000, 10, 45),
            (2900, 3800, 3831),
            (700, 100, 112),
        ] {
            map.map_run(y, x0, x1, &mut out).unwrap();
            assert_eq!(out.len(), (x1 - x0 + 1) as usize);
            for (x, m) in (x0..=x1).zip(&out) {
                let exact = CameraMap::new(&camera, &illumination)
                    .map(f64::from(x), f64::from(y))
                    .unwrap();
                let dp =
                    (m.position[0] - exact.position[0]).hypot(m.position[1] - exact.position[1]);
                worst[0] = worst[0].max(dp);
                worst[1] = worst[1].max((m.jacobian / exact.jacobian - 1.0).abs());
                worst[2] = worst[2].max((m.illumination / exact.illumination - 1.0).abs());
            }
        }
        // 4.6e-7 px here, against the 1e-4 px centroids must agree to.
        println!("worst: {worst:?}");
        assert!(worst[0] < 1e-6, "position {:e} px", worst[0]);
        assert!(worst[1] < 1e-8 && worst[2] < 1e-8, "{worst:?}");
    }

    #[test]
    fn flat_field_correction_recovers_the_radiance_centroid() {
        let (cu, cv, r) = (70.3, 58.6, 20.0);
        let ri = RadialIllumination {
            centre: [0.0, 0.0],
            scale_px: 200.0,
            coefficients: vec![1.0, -0.3],
        };
        let pixels = render(
            |u, v| (u - cu).hypot(v - cv) <= r,
            |u, v, inside| 500.0 + ri.at(u, v) * (300.0 + 0.8 * u + 40_000.0 * inside),
        );
        let frame = FrameView::new(W, H, 16, &pixels).unwrap();
        let (ex, params) = extract_one(frame);
        let blob = &ex.blobs[0];
        let plane = background_fit(&frame, blob, &ex.level).unwrap().plane;
        assert!((plane[0] - 800.0).abs() < 30.0, "{plane:?}");
        let got = mapped_centroid(
            &frame,
            blob,
            &ex.level,
            params.weighting,
            &FlatFieldMap(&ri),
        )
        .unwrap();
        let plain = (blob.u, blob.v);
        let err = ((got[0] - cu).powi(2) + (got[1] - cv).powi(2)).sqrt();
        let plain_err = ((plain.0 - cu).powi(2) + (plain.1 - cv).powi(2)).sqrt();
        // Supersampled coverage is exact to ≈ 1/64 of an edge pixel's area: the
        // disc's centroid to ≈ 1e-3 px; the fall-off moves the plain one by ≈ 0.03 px.
        assert!(err < 2e-3, "corrected centroid {got:?}, error {err}");
        assert!(
            plain_err > 10.0 * err,
            "plain centroid only {plain_err} px off"
        );
    }

    /// [`CameraMap`] pixel by pixel: the exact map, without the lattice.
    struct Exact<'a>(CameraMap<'a>);

    impl PixelMap for Exact<'_> {
        fn map(&self, u: f64, v: f64) -> Option<Mapped> {
            self.0.map(u, v)
        }
    }

    /// A bright disc seen through a strongly distorting lens with the
    /// ideal lens's fall-off, measured through the lattice and through the
    /// exact map pixel by pixel: the centroids, moments and covariances of
    /// the corrected light agree far inside the 1e-4 px they may differ by.
    #[test]
    fn the_lattice_gives_the_exact_maps_corrected_light() {
        let camera = Camera {
            // A wide angle on this small frame: 44° across, k1 = −0.2. The
            // lattice's error grows as h⁴/f³ (2e-5 px at f = 120 px).
            intrinsics: geom::Intrinsics::centred(200.0, W, H),
            distortion: geom::Distortion {
                k1: -0.2,
                k2: 0.05,
                k3: 0.0,
                p1: 1e-3,
                p2: -5e-4,
            },
            pose: geom::Isometry3::identity(),
            width: W,
            height: H,
        };
        let (cu, cv, r) = (75.3, 58.6, 22.0);
        let pixels = render(
            |u, v| (u - cu).hypot(v - cv) <= r,
            |u, _, inside| 600.0 + 0.5 * u + 30_000.0 * inside,
        );
        let frame = FrameView::new(W, H, 16, &pixels).unwrap();
        let (ex, params) = extract_one(frame);
        let blob = &ex.blobs[0];
        assert!(blob.runs.iter().any(|r| r.x1 - r.x0 > 4 * NODE_SPACING_PX));
        let illumination = Illumination::Ideal;
        let light = |map: &dyn PixelMap| {
            mapped_light(&frame, blob, &ex.level, params.weighting, map, Some(4.0)).unwrap()
        };
        let lattice = light(&CameraMap::new(&camera, &illumination));
        let exact = light(&Exact(CameraMap::new(&camera, &illumination)));
        let [u, v] = lattice.centroid;
        let d = (u - exact.centroid[0]).hypot(v - exact.centroid[1]);
        println!("lattice − exact: {d:e} px");
        assert!(d < 1e-5, "centroids {d:e} px apart");
        let (a, b) = (lattice.central, exact.central);
        assert!((a.0 - b.0).abs() + (a.1 - b.1).abs() + (a.2 - b.2).abs() < 1e-5 * a.0);
        let (ka, kb) = (lattice.covariance.unwrap(), exact.covariance.unwrap());
        assert!((ka.uu_px2 / kb.uu_px2 - 1.0).abs() < 1e-5, "{ka:?} {kb:?}");
    }

    /// Observed positions stretched by `s` along u about `cu`: ideal
    /// `u′ = cu + (u − cu)/s`, area Jacobian 1/s (a strong local distortion).
    struct Stretch {
        cu: f64,
        s: f64,
    }

    impl PixelMap for Stretch {
        fn map(&self, u: f64, v: f64) -> Option<Mapped> {
            Some(Mapped {
                position: [self.cu + (u - self.cu) / self.s, v],
                jacobian: 1.0 / self.s,
                illumination: 1.0,
            })
        }
    }

    /// A disc of the ideal image seen through [`Stretch`]: the observed blob
    /// is an ellipse of circularity 1/s, its corrected light the disc again —
    /// round, with the disc's diameter as its minor axis and its centre as
    /// the centroid.
    #[test]
    fn the_corrected_light_is_measured_in_the_ideal_image() {
        let (cu, cv, r, s) = (70.3, 58.6, 15.0, 1.6);
        let pixels = render(
            |u, v| ((u - cu) / s).hypot(v - cv) <= r,
            |_, _, inside| 800.0 + 40_000.0 * inside,
        );
        let frame = FrameView::new(W, H, 16, &pixels).unwrap();
        let (ex, params) = extract_one(frame);
        let blob = &ex.blobs[0];
        assert!(
            (blob.circularity() - 1.0 / s).abs() < 0.01,
            "{}",
            blob.circularity()
        );
        let stretch = Stretch { cu, s };
        let light =
            mapped_light(&frame, blob, &ex.level, params.weighting, &stretch, None).unwrap();
        let e = light.ellipse();
        assert!(e.circularity() > 0.995, "{e:?}");
        // The thresholded weights thin the edge pixels: within 1 % of 2R.
        assert!((e.minor_px / (2.0 * r) - 1.0).abs() < 0.01, "{e:?}");
        let [u, v] = light.centroid;
        assert!((u - cu).hypot(v - cv) < 2e-3, "{:?}", light.centroid);
        assert_eq!(
            mapped_centroid(&frame, blob, &ex.level, params.weighting, &stretch),
            Some(light.centroid)
        );
    }

    /// Standard normal draws from a seed (SplitMix64 and Box–Muller): the
    /// test's own noise, independent of the crate.
    struct Normal(u64);

    impl Normal {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }

        fn next(&mut self) -> f64 {
            let (a, b) = (self.uniform().max(1e-300), self.uniform());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        }
    }

    /// A stretch with a relative illumination falling along u: J and RI
    /// both differ from 1, as through a real lens.
    struct StretchAndFalloff;

    impl PixelMap for StretchAndFalloff {
        fn map(&self, u: f64, v: f64) -> Option<Mapped> {
            Some(Mapped {
                position: [70.0 + (u - 70.0) / 1.3, v],
                jacobian: 1.0 / 1.3,
                illumination: 1.0 - 0.003 * (u - 70.0),
            })
        }
    }

    /// `(σ_u, σ_v, ρ)` of the scatter of the centroids and the mean of
    /// their analytic covariances (with K scaled by `k_factor`) over
    /// `draws` noisy frames of one blurred disc: dark offset 400 DN, read
    /// noise 20 DN, shot noise of gain K = 4 DN/e⁻.
    fn scatter_and_model(draws: u64, k_factor: f64) -> ([f64; 3], [f64; 3]) {
        const K: f64 = 4.0;
        let (cu, cv, r) = (70.3, 58.6, 11.0);
        let mean = render(
            |u, v| (u - cu).hypot(v - cv) <= r,
            |u, _, inside| 400.0 + 800.0 + (1.0 - 0.003 * (u - 70.0)) * 20_000.0 * inside,
        );
        let mut noise = Normal(7);
        let (mut centroids, mut model) = (Vec::new(), [0.0f64; 3]);
        for _ in 0..draws {
            let pixels: Vec<u16> = mean
                .iter()
                .map(|&m| {
                    let m = f64::from(m);
                    let sd = (20.0f64.powi(2) + K * (m - 400.0)).sqrt();
                    (m + sd * noise.next()).round() as u16
                })
                .collect();
            let frame = FrameView::new(W, H, 16, &pixels).unwrap();
            let (ex, params) = extract_one(frame);
            let light = mapped_light(
                &frame,
                &ex.blobs[0],
                &ex.level,
                params.weighting,
                &StretchAndFalloff,
                Some(K * k_factor),
            )
            .unwrap();
            let c = light.covariance.unwrap();
            model[0] += c.uu_px2 / draws as f64;
            model[1] += c.vv_px2 / draws as f64;
            model[2] += c.uv_px2 / draws as f64;
            centroids.push(light.centroid);
        }
        let n = draws as f64;
        let mu = [0, 1].map(|i| centroids.iter().map(|c| c[i]).sum::<f64>() / n);
        let cov = |i: usize, j: usize| {
            centroids
                .iter()
                .map(|c| (c[i] - mu[i]) * (c[j] - mu[j]))
                .sum::<f64>()
                / (n - 1.0)
        };
        let sigmas = |uu: f64, vv: f64, uv: f64| [uu.sqrt(), vv.sqrt(), uv / (uu * vv).sqrt()];
        (
            sigmas(cov(0, 0), cov(1, 1), cov(0, 1)),
            sigmas(model[0], model[1], model[2]),
        )
    }

    /// The analytic covariance (METHODS §7) against the scatter of 400
    /// noisy frames of one scene: a sample σ of n = 400 draws has a
    /// relative standard error of 1/√(2(n − 1)) = 3.5 %, so the ratio lies in
    /// 0.9…1.1 (±2.8 standard errors) unless the model is wrong; with K
    /// a quarter of the truth (σ of the shot noise halved) it does not.
    #[test]
    fn the_centroid_covariance_matches_the_scatter_of_repeated_frames() {
        let (scatter, model) = scatter_and_model(400, 1.0);
        let ratio = [scatter[0] / model[0], scatter[1] / model[1]];
        eprintln!(
            "scatter σ_u {:.5} σ_v {:.5} ρ {:+.3}; model σ_u {:.5} σ_v {:.5} ρ {:+.3}; \
             ratio {:.3} {:.3}",
            scatter[0], scatter[1], scatter[2], model[0], model[1], model[2], ratio[0], ratio[1]
        );
        assert!(ratio.iter().all(|r| (0.9..=1.1).contains(r)), "{ratio:?}");
        // ρ of 400 draws has a standard error of ≈ 0.05.
        assert!(
            (scatter[2] - model[2]).abs() < 0.15,
            "{scatter:?} {model:?}"
        );
        let (scatter, wrong) = scatter_and_model(400, 0.25);
        let ratio = [scatter[0] / wrong[0], scatter[1] / wrong[1]];
        eprintln!("K/4: ratio {:.3} {:.3}", ratio[0], ratio[1]);
        assert!(ratio.iter().all(|r| *r > 1.25), "{ratio:?}");
    }
}
