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

// Lanes side by side: loops over lane indices into several arrays are what the
// compiler spreads over vector units.
#![allow(clippy::needless_range_loop)]

use geom::{Camera, Illumination, Point2, RadialIllumination};

use crate::blob::{Blob, MomentEllipse};
use crate::frame::FrameView;
use crate::label::Weighting;
use crate::noise::{
    Background, CentroidCovariance, Covariance, CovarianceForm, NoiseSums, NoiseTotals, PixelNoise,
};
#[cfg(test)]
use crate::ring::background_fit;
use crate::ring::{Ring, with_ring};
use crate::threshold::Level;

mod lattice;
pub use lattice::{CameraMap, LATTICE_TOLERANCE_PX, Lattice, NODE_SPACINGS_PX};

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

/// Pixels of a run mapped together, whose arithmetic the compiler can
/// spread over vector lanes: a node interval of the lattice is one or two
/// such groups ([`Lattice::spacing_px`]).
pub const LANES: usize = 8;

/// Lane offsets `0, 1, …, LANES − 1` as reals.
const LANE_OFFSETS: [f64; LANES] = {
    let mut o = [0.0; LANES];
    let mut l = 0;
    while l < LANES {
        o[l] = l as f64;
        l += 1;
    }
    o
};

/// Up to [`LANES`] consecutive pixels of a row, mapped: lane `l` is pixel
/// `x + l`, and the lanes `first..end` are the run's (the others carry
/// finite values that count for nothing).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MappedLanes {
    /// Pixel of lane 0.
    pub x: u32,
    /// First lane of the run.
    pub first: usize,
    /// One past the last lane of the run.
    pub end: usize,
    /// Positions in the corrected image (px), u then v.
    pub position: [[f64; LANES]; 2],
    /// Area Jacobians of the mapping.
    pub jacobian: [f64; LANES],
    /// `1/RI`: the flat-field correction's factor.
    pub inverse_illumination: [f64; LANES],
}

impl MappedLanes {
    /// Lanes from pixel `x` with nothing in them yet.
    fn empty(x: u32) -> Self {
        Self {
            x,
            first: 0,
            end: 0,
            position: [[0.0; LANES]; 2],
            jacobian: [1.0; LANES],
            inverse_illumination: [1.0; LANES],
        }
    }

    /// Put pixel `x + l`'s map in lane `l`, the lane after those put so far.
    fn put(&mut self, l: usize, m: &Mapped) {
        self.end = l + 1;
        self.position[0][l] = m.position[0];
        self.position[1][l] = m.position[1];
        self.jacobian[l] = m.jacobian;
        self.inverse_illumination[l] = 1.0 / m.illumination;
    }

    /// Whether lane `l` is one of the run's, compared as reals and without
    /// branches: inside a loop over the lanes it stays a vector mask.
    #[inline(always)]
    fn holds(&self, l: usize) -> bool {
        let o = LANE_OFFSETS[l];
        (o >= self.first as f64) & (o < self.end as f64)
    }

    /// The run's pixels: `(x, its map)`.
    pub fn pixels(&self) -> impl Iterator<Item = (u32, Mapped)> + '_ {
        (self.first..self.end).map(|l| {
            (
                self.x + l as u32,
                Mapped {
                    position: [self.position[0][l], self.position[1][l]],
                    jacobian: self.jacobian[l],
                    illumination: 1.0 / self.inverse_illumination[l],
                },
            )
        })
    }
}

/// A pixel correction: observed pixel (u, v) → [`Mapped`]; `None` where undefined.
pub trait PixelMap {
    /// Map one pixel centre.
    fn map(&self, u: f64, v: f64) -> Option<Mapped>;

    /// Map the pixels `x0..=x1` of row `y` into `out` (cleared first), in
    /// [`MappedLanes`] in order; `None` when one of them cannot be mapped.
    /// By default pixel by pixel, [`LANES`] at a time from `x0`.
    fn map_run(&self, y: u32, x0: u32, x1: u32, out: &mut Vec<MappedLanes>) -> Option<()> {
        pixel_by_pixel(self, y, x0, x1, out)
    }
}

/// [`PixelMap::map_run`] through [`PixelMap::map`], pixel by pixel.
fn pixel_by_pixel<M: PixelMap + ?Sized>(
    map: &M,
    y: u32,
    x0: u32,
    x1: u32,
    out: &mut Vec<MappedLanes>,
) -> Option<()> {
    out.clear();
    let v = f64::from(y);
    for x in (x0..=x1).step_by(LANES) {
        let mut lanes = MappedLanes::empty(x);
        for (l, xl) in (x..=x1).take(LANES).enumerate() {
            lanes.put(l, &map.map(f64::from(xl), v)?);
        }
        out.push(lanes);
    }
    Some(())
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
    /// px² of the corrected image) at the system gain K given; `None`
    /// without one, with the raw weighting, or when the background plane's
    /// covariance is undefined.
    pub covariance: Option<CentroidCovariance>,
    /// The same as the form linear in K, when a covariance was wanted
    /// ([`Covariance::AtGain`] or [`Covariance::Form`]).
    pub covariance_form: Option<CovarianceForm>,
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
/// correction and threshold of the module docs; with the centroid's
/// `covariance` (`crate::noise`) as wanted. `frame` must be the frame the
/// blob was extracted from (after denoising; a denoised frame's pixels are
/// correlated, so want no covariance for one). `None`
/// when the background cannot be estimated, a pixel cannot be mapped, or no
/// weight remains.
pub fn mapped_light(
    frame: &FrameView<'_>,
    blob: &Blob,
    level: &Level,
    weighting: Weighting,
    map: &dyn PixelMap,
    covariance: Covariance,
) -> Option<MappedLight> {
    Light {
        frame,
        blob,
        level,
        weighting,
        map,
        covariance,
    }
    .of()
}

/// What [`mapped_light`] was given.
struct Light<'a, 'f> {
    frame: &'a FrameView<'f>,
    blob: &'a Blob,
    level: &'a Level,
    weighting: Weighting,
    map: &'a dyn PixelMap,
    covariance: Covariance,
}

/// `T′` and the observed position and RI of the pixel that sets it.
struct Threshold {
    value: f64,
    at: ([f64; 2], f64),
}

impl Threshold {
    /// Before any pixel.
    fn none() -> Self {
        Self {
            value: f64::NEG_INFINITY,
            at: ([0.0; 2], 1.0),
        }
    }

    /// Raised by the run of row `v` mapped as `mapped`, whose pixels'
    /// `(T − b)/RI` reach `top`: where the run holds a larger one, that level
    /// and the first of its pixels that holds it. Runs come in raster order,
    /// so the first pixel in raster order that holds `T′` sets it, as a scan
    /// pixel by pixel would find it.
    fn raise(&mut self, top: &RunTop, mapped: &[MappedLanes], v: f64) {
        let mut best: Option<(f64, usize)> = None;
        for l in 0..LANES {
            let (t, k) = (top.level[l], top.interval[l]);
            // The largest level; on a tie the first interval, then lane.
            if best.is_none_or(|(bk, bl)| {
                let b = top.level[bl];
                t > b || (t == b && k < bk)
            }) && t > f64::NEG_INFINITY
            {
                best = Some((k, l));
            }
        }
        let Some((k, l)) = best else { return };
        let m = top.level[l];
        if m <= self.value {
            return;
        }
        if let Some(lanes) = mapped.get(k as usize) {
            self.value = m;
            self.at = (
                [f64::from(lanes.x) + LANE_OFFSETS[l], v],
                1.0 / lanes.inverse_illumination[l],
            );
        }
    }
}

/// The largest `(T − b)/RI` of a run's pixels so far, lane by lane, with
/// the first of its intervals that holds it.
struct RunTop {
    level: [f64; LANES],
    interval: [f64; LANES],
}

impl RunTop {
    fn new() -> Self {
        Self {
            level: [f64::NEG_INFINITY; LANES],
            interval: [0.0; LANES],
        }
    }

    /// Raised by the run's interval `k`, its pixels `p` mapped as `lanes`.
    #[inline(always)]
    fn raise(&mut self, k: f64, lanes: &MappedLanes, p: &PixelLanes) {
        for l in 0..LANES {
            self.raise_lane(l, k, lanes, p);
        }
    }

    /// Lane `l` raised by its pixel's `(T − b)/RI` in interval `k` (inside
    /// a loop over the lanes, without branches), if the pixel is the run's.
    #[inline(always)]
    fn raise_lane(&mut self, l: usize, k: f64, lanes: &MappedLanes, p: &PixelLanes) {
        let t = (p.level[l] - p.background[l]) * lanes.inverse_illumination[l];
        let higher = lanes.holds(l) & (t > self.level[l]);
        // Stored whatever `higher`, as maxima (k grows along the run): a
        // store of "new or as it was" compiles to a masked store, slow on
        // AMD's cores.
        self.level[l] = self.level[l].max(if higher { t } else { f64::NEG_INFINITY });
        self.interval[l] = self.interval[l].max(if higher { k } else { -1.0 });
    }
}

/// The observed side of [`MappedLanes`]: per lane the pixel's column u,
/// value f, threshold T and background b(u, v) (DN); and the row v.
struct PixelLanes {
    u: [f64; LANES],
    v: f64,
    value: [f64; LANES],
    level: [f64; LANES],
    background: [f64; LANES],
}

impl PixelLanes {
    /// The pixels of `lanes` in `row` (v), with their thresholds `levels`
    /// over the background `plane`.
    #[inline(always)]
    fn of(lanes: &MappedLanes, row: &[u16], levels: &Levels<'_>, plane: [f64; 3], v: f64) -> Self {
        let [c, a, b] = plane;
        let mut p = PixelLanes {
            u: [0.0; LANES],
            v,
            value: gather(row, lanes.x),
            level: match levels {
                Levels::Constant(t) => [*t; LANES],
                Levels::Row(r) => gather(r, lanes.x),
            },
            background: [0.0; LANES],
        };
        let u0 = f64::from(lanes.x);
        for l in 0..LANES {
            p.u[l] = u0 + LANE_OFFSETS[l];
            p.background[l] = c + a * p.u[l] + b * v;
        }
        p
    }
}

/// [`LANES`] values of `row` from `x`, 0 beyond its end.
#[inline(always)]
fn gather(row: &[u16], x: u32) -> [f64; LANES] {
    let x = x as usize;
    let mut out = [0.0; LANES];
    match row
        .get(x..x + LANES)
        .and_then(|px| <&[u16; LANES]>::try_from(px).ok())
    {
        // A whole interval: converted in vector lanes.
        Some(px) => out = px.map(f64::from),
        None => {
            for (o, &p) in out.iter_mut().zip(row.iter().skip(x)) {
                *o = f64::from(p);
            }
        }
    }
    out
}

/// A frame's thresholds along one row.
enum Levels<'a> {
    Constant(f64),
    Row(&'a [u16]),
}

impl<'a> Levels<'a> {
    /// Row `y` of `level` over a frame `width` wide.
    fn of(level: &'a Level, y: u32, width: u32) -> Option<Self> {
        match level {
            Level::Constant(t) => Some(Levels::Constant(f64::from(*t))),
            Level::Map(m) => {
                let start = y as usize * width as usize;
                m.get(start..start + width as usize).map(Levels::Row)
            }
        }
    }
}

/// Weighted sums `Σ w`, `Σ w·d`, `Σ w·(d_u², d_v², d_u·d_v)` of positions
/// `d = p′ − r` about a reference point r near the blob, gathered before the
/// centroid is known: the centroid is `r + Σ w·d / Σ w`, and the second
/// moments about any point follow ([`Moments::about`]); with r within the
/// blob the difference loses no precision that matters.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Moments {
    pub(crate) w: f64,
    pub(crate) wd: [f64; 2],
    pub(crate) wdd: [f64; 3],
}

impl Moments {
    /// `self + t·other`, sum by sum.
    pub(crate) fn added(&self, t: f64, other: &Moments) -> Moments {
        Moments {
            w: self.w + t * other.w,
            wd: [self.wd[0] + t * other.wd[0], self.wd[1] + t * other.wd[1]],
            wdd: [
                self.wdd[0] + t * other.wdd[0],
                self.wdd[1] + t * other.wdd[1],
                self.wdd[2] + t * other.wdd[2],
            ],
        }
    }

    /// `Σ w·(d − e)(d − e)ᵀ = Σ w·ddᵀ − (Σ w·d)eᵀ − e(Σ w·d)ᵀ + (Σ w)eeᵀ` as
    /// (uu, vv, uv): the second moments about the point `e` from r.
    pub(crate) fn about(&self, e: [f64; 2]) -> [f64; 3] {
        [
            self.wdd[0] - 2.0 * e[0] * self.wd[0] + self.w * e[0] * e[0],
            self.wdd[1] - 2.0 * e[1] * self.wd[1] + self.w * e[1] * e[1],
            self.wdd[2] - e[0] * self.wd[1] - e[1] * self.wd[0] + self.w * e[0] * e[1],
        ]
    }
}

/// [`Moments`] gathered in `N` lanes side by side (lane l sums lane l of
/// every [`MappedLanes`] added; N = 1: pixel by pixel), totalled at the end.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MomentSums<const N: usize> {
    w: [f64; N],
    wd: [[f64; N]; 2],
    wdd: [[f64; N]; 3],
}

impl<const N: usize> Default for MomentSums<N> {
    fn default() -> Self {
        Self {
            w: [0.0; N],
            wd: [[0.0; N]; 2],
            wdd: [[0.0; N]; 3],
        }
    }
}

impl<const N: usize> MomentSums<N> {
    /// Add weights `w` at positions `d` (u, v), lane by lane.
    #[inline(always)]
    pub(crate) fn add(&mut self, d: &[[f64; N]; 2], w: &[f64; N]) {
        for l in 0..N {
            let (wu, wv) = (w[l] * d[0][l], w[l] * d[1][l]);
            self.w[l] += w[l];
            self.wd[0][l] += wu;
            self.wd[1][l] += wv;
            self.wdd[0][l] += wu * d[0][l];
            self.wdd[1][l] += wv * d[1][l];
            self.wdd[2][l] += wu * d[1][l];
        }
    }

    /// The sums over every lane.
    pub(crate) fn total(&self) -> Moments {
        Moments {
            w: lane_total(&self.w),
            wd: self.wd.each_ref().map(lane_total),
            wdd: self.wdd.each_ref().map(lane_total),
        }
    }
}

/// The sum of a lane sum's lanes, in lane order.
pub(crate) fn lane_total<const N: usize>(lanes: &[f64; N]) -> f64 {
    lanes.iter().sum()
}

/// What a pass sums over the pixels surely above `T′`, lane by lane:
/// `Σ f′·J·φ`, `Σ J·φ` and the noise's sums (where wanted), of positions
/// about the `reference` point.
struct AboveSums {
    reference: [f64; 2],
    pixel_noise: Option<PixelNoise>,
    fj: MomentSums<LANES>,
    j: MomentSums<LANES>,
    noise: NoiseSums<LANES>,
}

impl AboveSums {
    /// No pixels yet.
    fn new(reference: [f64; 2], pixel_noise: Option<PixelNoise>) -> Self {
        Self {
            reference,
            pixel_noise,
            fj: MomentSums::default(),
            j: MomentSums::default(),
            noise: NoiseSums::default(),
        }
    }

    /// Weigh the run's `lanes` (its interval `k`): those above `guess`
    /// summed, the others set aside, `top` raised by their `(T − b)/RI`;
    /// `false` when one of the run's pixels has no positive J or RI.
    #[inline(always)]
    fn weigh(
        &mut self,
        lanes: &MappedLanes,
        p: &PixelLanes,
        guess: f64,
        aside: &mut Vec<Aside>,
        top: &mut RunTop,
        k: f64,
    ) -> bool {
        let (jac, inv) = (&lanes.jacobian, &lanes.inverse_illumination);
        let reference = self.reference;
        let (mut d, mut fj, mut j, mut g) =
            ([[0.0; LANES]; 2], [0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let (mut signal, mut unmappable, mut set_aside) = ([0.0; LANES], false, false);
        // One loop without branches: its lanes side by side, the masks in
        // vector registers.
        for l in 0..LANES {
            top.raise_lane(l, k, lanes, p);
            let held = lanes.holds(l);
            signal[l] = p.value[l] - p.background[l];
            let corrected = signal[l] * inv[l];
            let kept = held & (corrected > guess);
            let mappable = (inv[l] > 0.0) & (jac[l] > 0.0);
            unmappable |= held & !mappable;
            set_aside |= held & !kept;
            d[0][l] = if kept {
                lanes.position[0][l] - reference[0]
            } else {
                0.0
            };
            d[1][l] = if kept {
                lanes.position[1][l] - reference[1]
            } else {
                0.0
            };
            fj[l] = if kept { corrected * jac[l] } else { 0.0 };
            j[l] = if kept { jac[l] } else { 0.0 };
            g[l] = if kept { jac[l] * inv[l] } else { 0.0 };
        }
        if unmappable {
            return false;
        }
        self.fj.add(&d, &fj);
        self.j.add(&d, &j);
        if let Some(noise) = &self.pixel_noise {
            self.noise.add(noise, &p.u, p.v, &d, &j, &g, &signal);
        }
        if set_aside {
            let kept = |l: usize| signal[l] * inv[l] > guess;
            for l in (lanes.first..lanes.end).filter(|&l| !kept(l)) {
                aside.push(Aside {
                    observed: [p.u[l], p.v],
                    d: [
                        lanes.position[0][l] - reference[0],
                        lanes.position[1][l] - reference[1],
                    ],
                    jacobian: jac[l],
                    inverse_illumination: inv[l],
                    corrected: signal[l] * inv[l],
                    signal: signal[l],
                });
            }
        }
        true
    }
}

/// A pixel of the single pass kept aside, its weight waiting for `T′`.
struct Aside {
    observed: [f64; 2],
    d: [f64; 2],
    jacobian: f64,
    inverse_illumination: f64,
    corrected: f64,
    signal: f64,
}

/// The guess at `T′` from the blob's first run: `M + ½·|M|`, M the largest
/// `(T − b)/RI` there. Pixels above it carry weight whatever `T′` turns out
/// to be, provided `T′` stays at or below it — which it does unless the
/// threshold in radiance units rises by half across the blob.
const GUESS_MARGIN: f64 = 0.5;

/// [`Light::of`]: the background fit and the passes over a blob, to be
/// compiled for each kind of vector unit.
struct Passes<'a, 'b, 'f> {
    light: &'a Light<'b, 'f>,
    ring: &'a mut Ring,
}

impl pulp::WithSimd for Passes<'_, '_, '_> {
    type Output = Option<MappedLight>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Option<MappedLight> {
        let light = self.light;
        let background = &self.ring.fit(light.frame, light.blob, light.level)?;
        match light.pass(background, None) {
            Pass::Done(done) => done,
            Pass::Again(threshold) => match light.pass(background, Some(threshold)) {
                Pass::Done(done) => done,
                // The second pass finds the same T′ as the first.
                Pass::Again(_) => None,
            },
        }
    }
}

/// What a pass came to.
enum Pass {
    /// The corrected light, or `None` where it is undefined.
    Done(Option<MappedLight>),
    /// `T′` (given) exceeded the guess: a second pass, with it as the guess.
    Again(f64),
}

impl Light<'_, '_> {
    /// [`mapped_light`]: the background under the blob ([`Ring::fit`]),
    /// then, keeping nothing per pixel but those near the threshold, one
    /// pass over the blob's runs that finds `T′` while it sums the pixels
    /// surely above it — as `Σ f′·J·φ` and `Σ J·φ` (φ = 1, d, d·dᵀ), since
    /// `w = (f′ − T′)·J` — and keeps aside the pixels that might fall below
    /// it ([`GUESS_MARGIN`]); when `T′` exceeds the guess, the first pass has
    /// found it, and a second takes it as the guess. On the CPU's widest
    /// vector units: the same arithmetic in the same order, so the same
    /// result, on any.
    fn of(&self) -> Option<MappedLight> {
        with_ring(|ring| pulp::Arch::new().dispatch(Passes { light: self, ring }))
    }

    /// The pixels' noise, where the centroid's covariance is wanted.
    fn pixel_noise(&self, background: &Background) -> Option<PixelNoise> {
        match (self.covariance, self.weighting) {
            (Covariance::Off, _) | (_, Weighting::Raw) => None,
            (Covariance::AtGain(_) | Covariance::Form, Weighting::Subtracted) => {
                Some(PixelNoise::new(background))
            }
        }
    }

    /// `T′` subtracted from the weights: `T′` (thresholded) or 0 (raw).
    fn subtracted(&self, threshold: f64) -> f64 {
        match self.weighting {
            Weighting::Subtracted => threshold,
            Weighting::Raw => 0.0,
        }
    }

    /// One pass over the runs ([`Light::of`]) with the guess at `T′`, or
    /// with the first run's when `None`: a node interval's pixels at a time
    /// ([`MappedLanes`]).
    #[inline(always)]
    fn pass(&self, background: &Background, guess: Option<f64>) -> Pass {
        let reference = [self.blob.u, self.blob.v];
        let noise = self.pixel_noise(background);
        let mut above = AboveSums::new(reference, noise);
        let mut aside = Vec::new();
        let mut best = Threshold::none();
        let mut guess = guess;
        let mut mapped = Vec::new();
        for run in &self.blob.runs {
            let row = self.frame.row(run.y);
            let levels = Levels::of(self.level, run.y, self.frame.width);
            let (Some(_), Some(levels)) = (row.get(run.x0 as usize..=run.x1 as usize), levels)
            else {
                return Pass::Done(None);
            };
            if self
                .map
                .map_run(run.y, run.x0, run.x1, &mut mapped)
                .is_none()
            {
                return Pass::Done(None);
            }
            let v = f64::from(run.y);
            let pixels =
                |lanes: &MappedLanes| PixelLanes::of(lanes, row, &levels, background.plane, v);
            // T′ so far: over the first run before its pixels are weighed
            // when that run sets the guess, with them after.
            let first = guess.is_none();
            let mut top = RunTop::new();
            if first {
                for (k, lanes) in mapped.iter().enumerate() {
                    top.raise(k as f64, lanes, &pixels(lanes));
                }
                best.raise(&top, &mapped, v);
            }
            let g = *guess.get_or_insert_with(|| best.value + GUESS_MARGIN * best.value.abs());
            for (k, lanes) in mapped.iter().enumerate() {
                let p = pixels(lanes);
                if !above.weigh(lanes, &p, g, &mut aside, &mut top, k as f64) {
                    return Pass::Done(None);
                }
            }
            if !first {
                best.raise(&top, &mapped, v);
            }
        }
        match guess {
            Some(g) if best.value <= g => {}
            _ => return Pass::Again(best.value),
        }
        let (mut near, mut near_noise) = (MomentSums::<1>::default(), NoiseSums::<1>::default());
        for p in &aside {
            if let Some(w) = corrected_weight(self.weighting, p.corrected, best.value) {
                let d = [[p.d[0]], [p.d[1]]];
                near.add(&d, &[w * p.jacobian]);
                if let Some(noise) = &noise {
                    let g = p.jacobian * p.inverse_illumination;
                    near_noise.add(
                        noise,
                        &[p.observed[0]],
                        p.observed[1],
                        &d,
                        &[p.jacobian],
                        &[g],
                        &[p.signal],
                    );
                }
            }
        }
        let sums = above
            .fj
            .total()
            .added(-self.subtracted(best.value), &above.j.total())
            .added(1.0, &near.total());
        let noise_sums = noise.map(|_| above.noise.total().added(&near_noise.total()));
        Pass::Done(self.finish(&sums, noise_sums, background, &best))
    }

    /// The centroid, central moments and covariance from the sums.
    fn finish(
        &self,
        sums: &Moments,
        noise_sums: Option<NoiseTotals>,
        background: &Background,
        threshold: &Threshold,
    ) -> Option<MappedLight> {
        if sums.w.is_nan() || sums.w <= 0.0 {
            return None;
        }
        let reference = [self.blob.u, self.blob.v];
        let e = [sums.wd[0] / sums.w, sums.wd[1] / sums.w];
        let [uu, vv, uv] = sums.about(e).map(|m| m / sums.w);
        let form = noise_sums.and_then(|n| n.covariance(e, sums.w, background, threshold.at));
        Some(MappedLight {
            centroid: [reference[0] + e[0], reference[1] + e[1]],
            central: (uu, vv, uv),
            covariance: match self.covariance {
                Covariance::AtGain(k) => form.map(|f| f.at(k)),
                Covariance::Off | Covariance::Form => None,
            },
            covariance_form: form,
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
    mapped_light(frame, blob, level, weighting, map, Covariance::Off).map(|l| l.centroid)
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
    use super::lattice::{
        COARSE_WEIGHTS, FINE_WEIGHTS, Intervals, Node, cubic_weights, interpolation_error,
    };
    use super::*;
    use crate::backend::{Backend, CpuBackend, ExtractParams, Extraction};
    use crate::threshold::Threshold;
    use geom::Vector3;

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
    /// corners where the map bends most, for runs of every length — through
    /// the coarse lattice the lens is given and through the fine one.
    #[test]
    fn runs_mapped_through_nodes_agree_with_the_exact_map() {
        let (w, h) = (4096u32, 3072u32);
        let camera = lens(2600.0, [-0.2, 0.05, 4e-4, -3e-4], w, h);
        let illumination = Illumination::Ideal;
        let exact = CameraMap::new(&camera, &illumination);
        assert_eq!(
            Lattice::new(&camera).spacing_px(),
            Some(NODE_SPACINGS_PX[0])
        );
        // Position (px), J and RI (relative): 7.2e-6 px and 2.5e-8 at
        // 16 px, 4.6e-7 px and 1.3e-9 at 8 px, against the 1e-4 px
        // centroids must agree to.
        for (spacing, bounds) in NODE_SPACINGS_PX
            .into_iter()
            .zip([[LATTICE_TOLERANCE_PX, 1e-7], [1e-6, 1e-8]])
        {
            let lattice = Lattice::with_spacing(&camera, Some(spacing));
            let map = CameraMap::with_lattice(&camera, &illumination, &lattice);
            let runs = [
                (40u32, 30u32, 330u32),
                (1536, 3700, 4050),
                (3000, 10, 45),
                (2900, 3800, 3831),
                (700, 100, 112),
            ];
            let (worst, off) = worst_through_lattice(&map, &exact, runs);
            assert_eq!(off, 0, "runs off the lattice");
            println!("{spacing} px: worst {worst:?}");
            assert!(worst[0] < bounds[0], "position {:e} px", worst[0]);
            assert!(worst[1] < bounds[1] && worst[2] < bounds[1], "{worst:?}");
        }
    }

    /// The largest differences of `map` through its lattice from the exact
    /// map `exact` over `runs` (y, x0, x1), at the pixels the exact map
    /// maps: position (px), J and RI (relative); and how many of the runs
    /// left the lattice (near a node the model cannot map).
    fn worst_through_lattice(
        map: &CameraMap<'_>,
        exact: &CameraMap<'_>,
        runs: impl IntoIterator<Item = (u32, u32, u32)>,
    ) -> ([f64; 3], usize) {
        let (mut worst, mut off, mut out) = ([0.0f64; 3], 0, Vec::new());
        for (y, x0, x1) in runs {
            out.clear();
            if map.lattice_run(y, x0, x1, &mut out).is_none() {
                off += 1;
                continue;
            }
            let pixels: Vec<(u32, Mapped)> = out.iter().flat_map(MappedLanes::pixels).collect();
            assert!(pixels.iter().map(|p| p.0).eq(x0..=x1));
            for (x, m) in pixels {
                let Some(e) = exact.map(f64::from(x), f64::from(y)) else {
                    continue;
                };
                let dp = (m.position[0] - e.position[0]).hypot(m.position[1] - e.position[1]);
                worst[0] = worst[0].max(dp);
                worst[1] = worst[1].max((m.jacobian / e.jacobian - 1.0).abs());
                worst[2] = worst[2].max((m.illumination / e.illumination - 1.0).abs());
            }
        }
        (worst, off)
    }

    /// A camera's lattice takes the coarsest spacing whose largest error,
    /// measured against the exact map over the whole sensor, is within the
    /// tolerance, and none where neither is: from a long lens to wide
    /// angles on small sensors; the estimate it is chosen by follows the
    /// measured error. A lens model that folds over inside the sensor gets
    /// none.
    #[test]
    fn the_lattice_is_as_coarse_as_the_lens_allows() {
        let illumination = Illumination::Ideal;
        for camera in [
            lens(12_000.0, [0.3, 0.0, 1e-4, 0.0], 4096, 3072),
            lens(2600.0, [-0.2, 0.05, 4e-4, -3e-4], 4096, 3072),
            lens(1500.0, [-0.3, 0.08, 1e-3, 0.0], 2048, 1536),
            lens(700.0, [-0.3, 0.08, 1e-3, 0.0], 1280, 1024),
        ] {
            let exact = CameraMap::new(&camera, &illumination);
            let mut within = None;
            for h in NODE_SPACINGS_PX {
                let lattice = Lattice::with_spacing(&camera, Some(h));
                let map = CameraMap::with_lattice(&camera, &illumination, &lattice);
                // Every 16th row, from edge to edge.
                let rows = (0..camera.height).step_by(16).chain([camera.height - 1]);
                let runs = rows.map(|y| (y, 0, camera.width - 1));
                let ([worst, ..], off) = worst_through_lattice(&map, &exact, runs);
                assert_eq!(off, 0, "runs off the lattice");
                let estimate = interpolation_error(&camera, h);
                println!(
                    "f = {} px, h = {h} px: error {worst:.2e} px, estimated {estimate:.2e} px",
                    camera.intrinsics.fx
                );
                assert!(estimate > 0.5 * worst && estimate < 2.0 * worst);
                if within.is_none() && worst <= LATTICE_TOLERANCE_PX {
                    within = Some(h);
                }
            }
            assert_eq!(Lattice::new(&camera).spacing_px(), within);
        }
        // A model that folds over inside the sensor (k1 = −0.6 at
        // f = 2000 px: nothing maps beyond ≈ 990 px from the centre) has no
        // lattice: next to the fold, where the nodes still map, even the
        // fine one is off by a large fraction of a pixel.
        let folding = lens(2000.0, [-0.6, 0.0, 0.0, 0.0], 4096, 3072);
        assert_eq!(Lattice::new(&folding).spacing_px(), None);
        let lattice = Lattice::with_spacing(&folding, Some(NODE_SPACINGS_PX[1]));
        let map = CameraMap::with_lattice(&folding, &illumination, &lattice);
        let exact = CameraMap::new(&folding, &illumination);
        let runs = (1300..1400)
            .step_by(8)
            .flat_map(|y| (0..4096).step_by(64).map(move |x0| (y, x0, x0 + 63)));
        let ([worst, ..], _) = worst_through_lattice(&map, &exact, runs);
        println!("folding model, fine lattice beside the fold: {worst:.2e} px");
        assert!(worst > 100.0 * LATTICE_TOLERANCE_PX, "{worst:e} px");
    }

    /// A run whose lattice nodes reach beyond where the lens model can be
    /// inverted (k1 = −0.5 at f = 100 px folds 54 px from the centre) is
    /// mapped pixel by pixel, as the exact map maps it; a run beyond the
    /// fold cannot be mapped at all.
    #[test]
    fn runs_near_where_the_model_folds_are_mapped_pixel_by_pixel() {
        let camera = lens(100.0, [-0.5, 0.0, 0.0, 0.0], W, H);
        let illumination = Illumination::Ideal;
        let lattice = fine(&camera);
        let map = CameraMap::with_lattice(&camera, &illumination, &lattice);
        let (y, x0, x1) = (60u32, 90u32, 126u32);
        assert!(
            map.node(i64::from(x1 / NODE_SPACINGS_PX[1]) + 2, 7)
                .is_none()
        );
        let mut out = Vec::new();
        map.map_run(y, x0, x1, &mut out).unwrap();
        let exact = CameraMap::new(&camera, &illumination);
        let pixels: Vec<(u32, Mapped)> = out.iter().flat_map(MappedLanes::pixels).collect();
        assert!(pixels.iter().map(|p| p.0).eq(x0..=x1));
        for (x, m) in pixels {
            let e = exact.map(f64::from(x), f64::from(y)).unwrap();
            assert!((m.position[0] - e.position[0]).abs() < 1e-9, "{m:?} {e:?}");
            assert!((m.jacobian / e.jacobian - 1.0).abs() < 1e-12, "{m:?} {e:?}");
        }
        assert!(map.map_run(y, 136, 150, &mut out).is_none());
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
        // The lattice's error grows as h⁴/f³ (2e-5 px at f = 120 px).
        let camera = wide_angle();
        let (cu, cv, r) = (75.3, 58.6, 22.0);
        let pixels = render(
            |u, v| (u - cu).hypot(v - cv) <= r,
            |u, _, inside| 600.0 + 0.5 * u + 30_000.0 * inside,
        );
        let frame = FrameView::new(W, H, 16, &pixels).unwrap();
        let (ex, params) = extract_one(frame);
        let blob = &ex.blobs[0];
        assert!(
            blob.runs
                .iter()
                .any(|r| r.x1 - r.x0 > 4 * NODE_SPACINGS_PX[1])
        );
        let illumination = Illumination::Ideal;
        let light = |map: &dyn PixelMap| {
            mapped_light(
                &frame,
                blob,
                &ex.level,
                params.weighting,
                map,
                Covariance::AtGain(4.0),
            )
            .unwrap()
        };
        let nodes = fine(&camera);
        let lattice = light(&CameraMap::with_lattice(&camera, &illumination, &nodes));
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

    /// The fine lattice of `camera`, whatever its lens: the small test
    /// frame's wide angles bend too fast for [`Lattice::new`] to give one,
    /// and the tests of the lattice's arithmetic want one.
    fn fine(camera: &Camera) -> Lattice {
        Lattice::with_spacing(camera, Some(NODE_SPACINGS_PX[1]))
    }

    /// A wide angle on the small test frame: 44° across, k1 = −0.2.
    fn wide_angle() -> Camera {
        lens(200.0, [-0.2, 0.05, 1e-3, -5e-4], W, H)
    }

    /// A `width`×`height` camera at the origin, focal length `focal_px`
    /// centred, with Brown distortion `[k1, k2, p1, p2]` (k3 = 0).
    fn lens(focal_px: f64, [k1, k2, p1, p2]: [f64; 4], width: u32, height: u32) -> Camera {
        Camera {
            intrinsics: geom::Intrinsics::centred(focal_px, width, height),
            distortion: geom::Distortion {
                k1,
                k2,
                k3: 0.0,
                p1,
                p2,
            },
            pose: geom::Isometry3::identity(),
            width,
            height,
        }
    }

    /// The corrected light by its formulas applied directly (module docs,
    /// `crate::noise`): every pixel kept, `T′` first, then the centroid,
    /// the central moments about it and `Σ_c` term by term: the oracle for
    /// the streaming sums of [`Light::of`].
    fn direct_light(
        frame: &FrameView<'_>,
        blob: &Blob,
        level: &Level,
        map: &dyn PixelMap,
        k: f64,
    ) -> MappedLight {
        let bg = background_fit(frame, blob, level).unwrap();
        let [c, a, b] = bg.plane;
        let (mut pixels, mut mapped) = (Vec::new(), Vec::new());
        for run in &blob.runs {
            map.map_run(run.y, run.x0, run.x1, &mut mapped).unwrap();
            for (x, m) in mapped.iter().flat_map(MappedLanes::pixels) {
                let (u, v) = (f64::from(x), f64::from(run.y));
                let s = f64::from(frame.row(run.y)[x as usize]) - (c + a * u + b * v);
                let t = (f64::from(level.at(x, run.y, frame.width)) - (c + a * u + b * v))
                    / m.illumination;
                pixels.push(([u, v], m, s, t));
            }
        }
        let (mut t_max, mut t_at) = (f64::NEG_INFINITY, ([0.0, 0.0], 1.0));
        for &(o, m, _, t) in &pixels {
            if t > t_max {
                (t_max, t_at) = (t, (o, m.illumination));
            }
        }
        pixels.retain(|&(_, m, s, _)| s / m.illumination > t_max);
        let w: Vec<f64> = pixels
            .iter()
            .map(|&(_, m, s, _)| (s / m.illumination - t_max) * m.jacobian)
            .collect();
        let sw: f64 = w.iter().sum();
        let mean = |f: &dyn Fn(&Mapped) -> f64| {
            pixels.iter().zip(&w).map(|(p, w)| f(&p.1) * w).sum::<f64>() / sw
        };
        let cen = [mean(&|m| m.position[0]), mean(&|m| m.position[1])];
        let du = |m: &Mapped| m.position[0] - cen[0];
        let dv = |m: &Mapped| m.position[1] - cen[1];
        let central = (
            mean(&|m| du(m) * du(m)),
            mean(&|m| dv(m) * dv(m)),
            mean(&|m| du(m) * dv(m)),
        );
        // Σ σᵢ²·gᵢgᵢᵀ + G_θ·Σ_θ·G_θᵀ.
        let x_k = bg.design(t_at.0) / t_at.1;
        let (mut pix, mut gu, mut gv) = ([0.0; 3], Vector3::zeros(), Vector3::zeros());
        for &(o, m, s, _) in &pixels {
            let scale = m.jacobian / m.illumination / sw;
            let g = [du(&m) * scale, dv(&m) * scale];
            let var = bg.sigma_dn.powi(2) + k * s.max(0.0);
            pix[0] += var * g[0] * g[0];
            pix[1] += var * g[1] * g[1];
            pix[2] += var * g[0] * g[1];
            let dw = (x_k - bg.design(o) / m.illumination) * m.jacobian;
            gu += dw * (du(&m) / sw);
            gv += dw * (dv(&m) / sw);
        }
        let cov = bg.covariance().unwrap();
        let form = |a: &Vector3<f64>, b: &Vector3<f64>| a.dot(&(cov * b));
        MappedLight {
            centroid: cen,
            central,
            covariance: Some(CentroidCovariance {
                uu_px2: pix[0] + form(&gu, &gu),
                vv_px2: pix[1] + form(&gv, &gv),
                uv_px2: pix[2] + form(&gu, &gv),
            }),
            covariance_form: None,
        }
    }

    /// The streaming sums — one pass, and a second with the first's `T′` as
    /// its guess where the first's guess fails — give what the formulas give
    /// directly from the same mapped pixels, on a distorted lens with its
    /// fall-off and a tilted background, a blob wide enough for its runs to go through the
    /// lattice's bands: to rounding.
    #[test]
    fn the_streaming_sums_give_the_direct_formulas() {
        let camera = wide_angle();
        let (cu, cv, r) = (71.7, 63.2, 26.0);
        // A mild tilt: T′ stays within the single pass's guess. A steep one
        // (the threshold 2000 DN lies 620 DN above the background at the
        // blob's top row, 1350 DN at its bottom): the guess fails and a
        // second pass runs.
        type Plane = fn(f64, f64) -> f64;
        let backgrounds: [(Plane, bool); 2] = [
            (|u, v| 700.0 + 0.8 * u - 0.6 * v, true),
            (|_, v| 1900.0 - 14.0 * v, false),
        ];
        for (background, single) in backgrounds {
            let pixels = render(
                |u, v| (u - cu).hypot(v - cv) <= r,
                |u, v, inside| background(u, v) + 25_000.0 * inside * (1.0 - u / 900.0),
            );
            let frame = FrameView::new(W, H, 16, &pixels).unwrap();
            let (ex, params) = extract_one(frame);
            let blob = &ex.blobs[0];
            assert!(
                blob.runs
                    .iter()
                    .any(|r| r.x1 - r.x0 > 5 * NODE_SPACINGS_PX[1])
            );
            let illumination = Illumination::Ideal;
            let lattice = fine(&camera);
            let map = CameraMap::with_lattice(&camera, &illumination, &lattice);
            let k = 3.5;
            let light = Light {
                frame: &frame,
                blob,
                level: &ex.level,
                weighting: params.weighting,
                map: &map,
                covariance: Covariance::AtGain(k),
            };
            let fitted = background_fit(&frame, blob, &ex.level).unwrap();
            assert_eq!(matches!(light.pass(&fitted, None), Pass::Done(_)), single);
            let got = mapped_light(
                &frame,
                blob,
                &ex.level,
                params.weighting,
                &map,
                Covariance::AtGain(k),
            )
            .unwrap();
            let want = direct_light(&frame, blob, &ex.level, &map, k);
            let d = (got.centroid[0] - want.centroid[0]).hypot(got.centroid[1] - want.centroid[1]);
            println!("single pass {single}: streaming − direct: {d:e} px");
            assert!(d < 1e-10, "centroids {d:e} px apart");
            let (a, b) = (got.central, want.central);
            assert!((a.0 - b.0).abs() + (a.1 - b.1).abs() + (a.2 - b.2).abs() < 1e-10 * a.0);
            let (ka, kb) = (got.covariance.unwrap(), want.covariance.unwrap());
            for (x, y) in [(ka.uu_px2, kb.uu_px2), (ka.vv_px2, kb.vv_px2)] {
                assert!((x / y - 1.0).abs() < 1e-10, "{ka:?} {kb:?}");
            }
            assert!(
                (ka.uv_px2 - kb.uv_px2).abs() < 1e-10 * ka.uu_px2,
                "{ka:?} {kb:?}"
            );
            // Without K in the pass: its form, given K after, is the same
            // covariance, at this gain and at another.
            let deferred = mapped_light(
                &frame,
                blob,
                &ex.level,
                params.weighting,
                &map,
                Covariance::Form,
            )
            .unwrap();
            assert!(deferred.covariance.is_none());
            assert_eq!(deferred.centroid, got.centroid);
            let form = deferred.covariance_form.unwrap();
            assert_eq!(form.at(k), ka);
            let other = direct_light(&frame, blob, &ex.level, &map, 0.25 * k)
                .covariance
                .unwrap();
            let at = form.at(0.25 * k);
            assert!(
                (at.uu_px2 / other.uu_px2 - 1.0).abs() < 1e-10,
                "{at:?} {other:?}"
            );
            assert!(
                (at.vv_px2 / other.vv_px2 - 1.0).abs() < 1e-10,
                "{at:?} {other:?}"
            );
        }
    }

    /// The corrected light and the lattice's runs compiled for the CPU's
    /// widest vector units (AVX-512 where it has them), and for AVX2, give
    /// the bits of the same code without them (pulp's scalar build): results
    /// do not depend on the machine's CPU.
    #[test]
    fn vector_units_give_the_scalar_codes_bits() {
        let camera = wide_angle();
        let (cu, cv, r) = (71.7, 63.2, 26.0);
        let pixels = render(
            |u, v| (u - cu).hypot(v - cv) <= r,
            |u, v, inside| 700.0 + 0.8 * u - 0.6 * v + 25_000.0 * inside,
        );
        let frame = FrameView::new(W, H, 16, &pixels).unwrap();
        let (ex, params) = extract_one(frame);
        let blob = &ex.blobs[0];
        let illumination = Illumination::Ideal;
        // A map each: a run mapped pixel by pixel is solved from the previous pixel's.
        let lattice = fine(&camera);
        let maps = [0, 1, 2].map(|_| CameraMap::with_lattice(&camera, &illumination, &lattice));
        let light = |map| Light {
            frame: &frame,
            blob,
            level: &ex.level,
            weighting: params.weighting,
            map,
            covariance: Covariance::AtGain(3.5),
        };
        let scalar = with_ring(|ring| {
            pulp::WithSimd::with_simd(
                Passes {
                    light: &light(&maps[0]),
                    ring,
                },
                pulp::Scalar::new(),
            )
        });
        assert!(scalar.is_some_and(|s| s.covariance.is_some()));
        assert_eq!(light(&maps[1]).of(), scalar);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = pulp::x86::V3::try_new() {
            let light = light(&maps[2]);
            let on_avx2 = with_ring(|ring| {
                pulp::Simd::vectorize(
                    avx2,
                    Passes {
                        light: &light,
                        ring,
                    },
                )
            });
            assert_eq!(on_avx2, scalar);
        }
        // Node columns 13/h − 1 ..= 70/h + 2 around the run 13..=70: 11 at
        // the fine spacing, the first 8 of them at the coarse.
        let rows: [Vec<Node>; 4] = std::array::from_fn(|r| {
            (0..11)
                .map(|i| {
                    let (i, r) = (f64::from(i), r as f64);
                    [
                        0.1 * i - 0.2 * r,
                        -0.3 + 0.01 * i * r,
                        1.0 + 1e-3 * i,
                        0.9 - 1e-3 * r,
                    ]
                })
                .collect()
        });
        fn intervals<'a>(
            rows: &'a [Vec<Node>; 4],
            groups: &'a [[[f64; LANES]; 4]],
            columns: &'a mut Vec<Node>,
            out: &'a mut Vec<MappedLanes>,
        ) -> Intervals<'a> {
            let nodes = 70 / (groups.len() * LANES) - 13 / (groups.len() * LANES) + 4;
            Intervals {
                rows: rows.each_ref().map(|r| &r[..nodes]),
                weights: cubic_weights(0.375),
                groups,
                columns,
                x0: 13,
                x1: 70,
                v: 41.0,
                out,
            }
        }
        for groups in [&COARSE_WEIGHTS[..], &FINE_WEIGHTS[..]] {
            let (mut vector, mut scalar, mut columns) = (Vec::new(), Vec::new(), Vec::new());
            assert!(pulp::Arch::new().dispatch(intervals(
                &rows,
                groups,
                &mut columns,
                &mut vector
            )));
            assert!(pulp::WithSimd::with_simd(
                intervals(&rows, groups, &mut columns, &mut scalar),
                pulp::Scalar::new()
            ));
            // Lanes from pixel 8 to pixel 64, each with some of the run.
            assert_eq!(vector.len(), 8);
            assert_eq!(vector, scalar);
            #[cfg(target_arch = "x86_64")]
            if let Some(avx2) = pulp::x86::V3::try_new() {
                let mut on_avx2 = Vec::new();
                let op = intervals(&rows, groups, &mut columns, &mut on_avx2);
                assert!(pulp::Simd::vectorize(avx2, op));
                assert_eq!(on_avx2, scalar);
            }
            let pixels: Vec<u32> = vector
                .iter()
                .flat_map(|l| l.pixels().map(|p| p.0))
                .collect();
            assert!(pixels.into_iter().eq(13..=70));
        }
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
        let light = mapped_light(
            &frame,
            blob,
            &ex.level,
            params.weighting,
            &stretch,
            Covariance::Off,
        )
        .unwrap();
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
                Covariance::AtGain(K * k_factor),
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
