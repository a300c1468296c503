//! The lattice of exactly mapped nodes through which a camera's pixels are
//! mapped ([`CameraMap`]): the undistortion, its area Jacobian and the
//! relative illumination at nodes every 16 or 8 px, bicubic between them.

use std::cell::{Cell, RefCell};

use geom::{Camera, Illumination, Point2};

use super::{LANE_OFFSETS, LANES, Mapped, MappedLanes, PixelMap, pixel_by_pixel};

/// Spacings (px) of the lattice of exactly mapped nodes of
/// [`CameraMap::map_run`], coarse then fine: between the nodes the map is
/// the bicubic (tensor Lagrange cubic) through the 4 × 4 nearest nodes. The
/// undistortion, its area Jacobian and the relative illumination are smooth
/// over the field, so the interpolation's error, ≈ (3/128)·h⁴·|f⁗| per
/// direction at mid-interval, is small: at 16 px 7.2e-6 px in the corner of
/// a wide-angle lens whose distortion shifts it by 570 px, 4e-9 px on a
/// long lens; at 8 px 16 × less. A camera's lattice takes the coarsest
/// spacing whose error ([`interpolation_error`]) is within
/// [`LATTICE_TOLERANCE_PX`]; with neither, or where the lens model folds over
/// within reach of the sensor, its pixels are mapped exactly, one by one
/// (`docs/performance.md`).
pub const NODE_SPACINGS_PX: [u32; 2] = [16, 8];

/// The largest interpolation error of a lattice's positions (px): half the
/// 1e-4 px a centroid may move (a centroid, a mean of its pixels' positions
/// with positive weights, errs by no more than its worst pixel), for the
/// estimate ([`interpolation_error`], within 0.7–1.4 × of the error
/// measured over whole sensors) missing the worst interval.
pub const LATTICE_TOLERANCE_PX: f64 = 5e-5;

/// A node's shift p − (u, v), J and 1/RI.
pub(super) type Node = [f64; 4];

/// Lagrange weights of the nodes at −1, 0, 1, 2 (in node spacings) at
/// `t` ∈ [0, 1).
pub(super) const fn cubic_weights(t: f64) -> [f64; 4] {
    [
        -t * (t - 1.0) * (t - 2.0) / 6.0,
        (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
        -(t + 1.0) * t * (t - 2.0) / 2.0,
        (t + 1.0) * t * (t - 1.0) / 6.0,
    ]
}

/// The weights of the node columns (of the four around a node interval
/// of `GROUPS`·[`LANES`] px) at each pixel of the interval: group g, column
/// m, lane l is pixel g·LANES + l.
const fn offset_weights<const GROUPS: usize>() -> [[[f64; LANES]; 4]; GROUPS] {
    let mut w = [[[0.0; LANES]; 4]; GROUPS];
    let mut o = 0;
    while o < GROUPS * LANES {
        let c = cubic_weights(o as f64 / (GROUPS * LANES) as f64);
        let mut m = 0;
        while m < 4 {
            w[o / LANES][m][o % LANES] = c[m];
            m += 1;
        }
        o += 1;
    }
    w
}

/// [`offset_weights`] of the coarse and of the fine spacing.
pub(super) const COARSE_WEIGHTS: [[[f64; LANES]; 4]; 2] = offset_weights::<2>();
pub(super) const FINE_WEIGHTS: [[[f64; LANES]; 4]; 1] = offset_weights::<1>();

/// The lattice of a camera's exactly mapped nodes every
/// [`Lattice::spacing_px`] over its sensor, node (i, j) from (−1, −1), each
/// solved on first use and kept for the whole run, shared by every frame
/// and thread. A node is solved from the same start whoever needs it first,
/// so results do not depend on the order of frames or the number of
/// threads. Nodes are held in tiles of `TILE_NODES`² made on first use:
/// only the parts of the sensor the spheres cross take memory.
pub struct Lattice {
    /// Node spacing (px), one of [`NODE_SPACINGS_PX`]; `None`: no nodes,
    /// every pixel mapped exactly.
    spacing: Option<u32>,
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
    /// The (unsolved) lattice of `camera`'s sensor: the coarsest of
    /// [`NODE_SPACINGS_PX`] within [`LATTICE_TOLERANCE_PX`]
    /// ([`interpolation_error`]), or none.
    pub fn new(camera: &Camera) -> Self {
        let spacing = NODE_SPACINGS_PX
            .into_iter()
            .find(|&h| interpolation_error(camera, h) <= LATTICE_TOLERANCE_PX);
        Self::with_spacing(camera, spacing)
    }

    /// The (unsolved) lattice of `camera`'s sensor, nodes every `spacing`
    /// px (none for `None`).
    pub(super) fn with_spacing(camera: &Camera, spacing: Option<u32>) -> Self {
        // Nodes −1 ..= ⌊(size − 1)/h⌋ + 2 along each side.
        let count = |size: u32| spacing.map_or(0, |h| (size.saturating_sub(1) / h) as usize + 4);
        let size = [count(camera.width), count(camera.height)];
        let [tc, tr] = size.map(|n| n.div_ceil(TILE_NODES));
        Self {
            spacing,
            size,
            tile_columns: tc,
            tiles: (0..tc * tr).map(|_| std::sync::OnceLock::new()).collect(),
        }
    }

    /// The node spacing (px), one of [`NODE_SPACINGS_PX`]; `None` where the
    /// lens bends too fast for either, and every pixel is mapped exactly.
    pub fn spacing_px(&self) -> Option<u32> {
        self.spacing
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

/// The largest error of the position interpolated through a lattice of
/// nodes every `h` px: at the middle of node intervals (in both directions,
/// where a cubic's error peaks) on a 5 × 5 grid of them from corner to
/// corner — a lens's distortion changes fastest at the edges. Infinite where
/// the model cannot map one of those nodes: its distortion folds over
/// within reach of the sensor (the corners reach farthest), and near the
/// fold the map bends faster than any lattice follows (0.2–0.8 px off at
/// 8 px on such lenses).
pub(super) fn interpolation_error(camera: &Camera, h: u32) -> f64 {
    let shift = |i: u32, j: u32, t: f64| {
        let (u, v) = (
            (f64::from(i) + t) * f64::from(h),
            (f64::from(j) + t) * f64::from(h),
        );
        let p = camera.undistort_pixel(Point2::new(u, v)).ok()?;
        Some([p.x - u, p.y - v])
    };
    let weights = cubic_weights(0.5);
    let last = [camera.width, camera.height].map(|n| n.saturating_sub(1) / h);
    let mut worst = 0.0f64;
    for a in 0..=4 {
        for b in 0..=4 {
            let (i, j) = (last[0] * a / 4, last[1] * b / 4);
            let mut interpolated = Some([0.0; 2]);
            for (m, wm) in weights.iter().enumerate() {
                for (n, wn) in weights.iter().enumerate() {
                    // Node (i + m − 1, j + n − 1): −1 as t = −1 about i.
                    let node = shift(i + m as u32, j + n as u32, -1.0);
                    interpolated = interpolated
                        .zip(node)
                        .map(|(s, d)| [s[0] + wm * wn * d[0], s[1] + wm * wn * d[1]]);
                }
            }
            let Some((s, exact)) = interpolated.zip(shift(i, j, 0.5)) else {
                return f64::INFINITY;
            };
            worst = worst.max((s[0] - exact[0]).hypot(s[1] - exact[1]));
        }
    }
    worst
}

/// Observed pixels of a calibrated camera → ideal (undistorted) pixels, with
/// the area Jacobian and the camera's relative illumination. A single pixel
/// is solved by Newton's method started from the previous one's solution
/// (one or two steps); runs go through the camera's [`Lattice`] of exact
/// nodes.
pub struct CameraMap<'a> {
    camera: &'a Camera,
    illumination: &'a Illumination,
    last: Cell<Option<(Point2<f64>, geom::Vector2<f64>)>>,
    lattice: Nodes<'a>,
    rows: RefCell<NodeRows>,
}

/// Rows of lattice nodes copied out of the shared lattice for the runs of
/// a blob, instead of looked up node by node for every run: node row r in
/// slot r mod 4, so that the rows j − 1 ..= j + 2 that the pixel rows
/// between node rows j and j + 1 are interpolated from are at hand, and
/// the next band of pixel rows copies one more.
struct NodeRows {
    slots: [NodeRow; 4],
    /// A run's node columns interpolated to its row (kept between runs).
    interpolated: Vec<Node>,
}

/// A row of nodes: row `r`, node columns from `i0` (NaN where unmappable,
/// which every interpolation through them carries).
struct NodeRow {
    r: i64,
    i0: i64,
    nodes: Vec<Node>,
}

/// Node columns copied beyond a run's own on either side, so that the
/// wider runs that follow seldom need a fresh copy.
const ROW_MARGIN: i64 = 4;

impl NodeRows {
    fn empty() -> Self {
        Self {
            slots: std::array::from_fn(|_| NodeRow {
                r: i64::MIN,
                i0: 0,
                nodes: Vec::new(),
            }),
            interpolated: Vec::new(),
        }
    }
}

impl NodeRow {
    /// Nodes `i0..=i1` of the row, when copied.
    fn span(&self, i0: i64, i1: i64) -> Option<&[Node]> {
        let (a, b) = (i0 - self.i0, i1 - self.i0);
        self.nodes
            .get(usize::try_from(a).ok()?..=usize::try_from(b).ok()?)
    }
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
            rows: RefCell::new(NodeRows::empty()),
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
            rows: RefCell::new(NodeRows::empty()),
        }
    }

    /// The lattice node (i·h, j·h), solved on first use (Newton from the
    /// model's own start); `None` outside the sensor's lattice or where the
    /// model cannot map it.
    pub(super) fn node(&self, i: i64, j: i64) -> Option<&Node> {
        let lattice = self.lattice();
        let (c, r) = (usize::try_from(i + 1).ok()?, usize::try_from(j + 1).ok()?);
        lattice
            .cell(c, r)?
            .get_or_init(|| {
                let h = f64::from(lattice.spacing?);
                let (u, v) = (i as f64 * h, j as f64 * h);
                let (p, jac) = self.camera.undistort_pixel_area(Point2::new(u, v)).ok()?;
                let m = self.mapped([u, v], p, jac, self.camera.intrinsics.to_normalized(p));
                Some([
                    m.position[0] - u,
                    m.position[1] - v,
                    m.jacobian,
                    1.0 / m.illumination,
                ])
            })
            .as_ref()
    }

    /// The camera's lattice.
    fn lattice(&self) -> &Lattice {
        match &self.lattice {
            Nodes::Own(l) => l,
            Nodes::Shared(l) => l,
        }
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

    /// The pixels `x0..=x1` of row `y` through the lattice, pushed onto
    /// `out` a node interval at a time; `None` when a node cannot be mapped.
    pub(super) fn lattice_run(
        &self,
        y: u32,
        x0: u32,
        x1: u32,
        out: &mut Vec<MappedLanes>,
    ) -> Option<()> {
        let h = self.lattice().spacing?;
        let (j, ty) = (i64::from(y / h), f64::from(y % h) / f64::from(h));
        let wy = cubic_weights(ty);
        // The run's node columns, each interpolated to row y.
        let (i0, i1) = (i64::from(x0 / h) - 1, i64::from(x1 / h) + 2);
        let mut rows = self.rows.borrow_mut();
        for r in j - 1..=j + 2 {
            let slot = &mut rows.slots[r.rem_euclid(4) as usize];
            let end = slot.i0 + slot.nodes.len() as i64;
            if slot.r != r || i0 < slot.i0 || i1 >= end {
                // A fresh copy of the row, widened to the run's.
                let held = slot.r == r;
                let lo = if held { slot.i0.min(i0) } else { i0 } - ROW_MARGIN;
                let hi = if held { (end - 1).max(i1) } else { i1 } + ROW_MARGIN;
                slot.nodes.clear();
                slot.nodes
                    .extend((lo..=hi).map(|i| self.node(i, r).copied().unwrap_or([f64::NAN; 4])));
                (slot.r, slot.i0) = (r, lo);
            }
        }
        let rows = &mut *rows;
        let [a, b, c, d] =
            [-1, 0, 1, 2].map(|dj| rows.slots[(j + dj).rem_euclid(4) as usize].span(i0, i1));
        // On the CPU's widest vector units: the same arithmetic in the same
        // order, so the same result, on any.
        pulp::Arch::new()
            .dispatch(Intervals {
                rows: [a?, b?, c?, d?],
                weights: wy,
                groups: if h == NODE_SPACINGS_PX[0] {
                    &COARSE_WEIGHTS
                } else {
                    &FINE_WEIGHTS
                },
                columns: &mut rows.interpolated,
                x0,
                x1,
                v: f64::from(y),
                out,
            })
            .then_some(())
    }
}

/// A run's four rows of node columns, to be interpolated to its row `v`
/// with `weights` (into `columns`) and spread over the run's pixels
/// `x0..=x1` interval by interval, [`LANES`] pixels at a time with the
/// weights of `groups` ([`offset_weights`]).
pub(super) struct Intervals<'a> {
    pub(super) rows: [&'a [Node]; 4],
    pub(super) weights: [f64; 4],
    pub(super) groups: &'a [[[f64; LANES]; 4]],
    pub(super) columns: &'a mut Vec<Node>,
    pub(super) x0: u32,
    pub(super) x1: u32,
    pub(super) v: f64,
    pub(super) out: &'a mut Vec<MappedLanes>,
}

impl pulp::WithSimd for Intervals<'_> {
    /// Whether every node was mappable (else nothing is pushed).
    type Output = bool;

    /// Each node column interpolated to row v; then pixels
    /// k·h ..= k·h + h − 1 of the run between node columns k − 1 ..= k + 2,
    /// k from x0 / h.
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> bool {
        let ([r0, r1, r2, r3], [w0, w1, w2, w3]) = (self.rows, self.weights);
        let columns = self.columns;
        columns.clear();
        columns.extend(
            r0.iter()
                .zip(r1)
                .zip(r2)
                .zip(r3)
                .map(|(((n0, n1), n2), n3)| {
                    std::array::from_fn(|q| w0 * n0[q] + w1 * n1[q] + w2 * n2[q] + w3 * n3[q])
                }),
        );
        // Without an early exit, so that the check runs in vector lanes.
        if columns
            .iter()
            .flatten()
            .fold(false, |nan, x| nan | x.is_nan())
        {
            return false;
        }
        let (h, x0, x1) = ((self.groups.len() * LANES) as u32, self.x0, self.x1);
        debug_assert_eq!(columns.len() as u32, x1 / h - x0 / h + 4);
        let mut start = (x0 / h) * h;
        for c in columns.windows(4) {
            for weights in self.groups {
                // The lanes' pixels start ..= start + LANES − 1, if the run's.
                if start <= x1 && start + LANES as u32 > x0 {
                    let [sx, sy, jacobian, inverse_illumination] = interval(c, weights);
                    let u0 = f64::from(start);
                    self.out.push(MappedLanes {
                        x: start,
                        first: (x0.max(start) - start) as usize,
                        end: (x1 - start).min(LANES as u32 - 1) as usize + 1,
                        position: [
                            std::array::from_fn(|l| (u0 + LANE_OFFSETS[l]) + sx[l]),
                            std::array::from_fn(|l| self.v + sy[l]),
                        ],
                        jacobian,
                        inverse_illumination,
                    });
                }
                start += LANES as u32;
            }
        }
        true
    }
}

/// The four quantities of a [`Node`] at [`LANES`] pixels of a node
/// interval, from the four node columns around it (already interpolated to
/// the row) with the columns' weights `w` at those pixels.
#[inline(always)]
fn interval(c: &[Node], w: &[[f64; LANES]; 4]) -> [[f64; LANES]; 4] {
    let mut q = [[0.0; LANES]; 4];
    for (n, qn) in q.iter_mut().enumerate() {
        let (c0, c1, c2, c3) = (c[0][n], c[1][n], c[2][n], c[3][n]);
        for l in 0..LANES {
            qn[l] = w[0][l] * c0 + w[1][l] * c1 + w[2][l] * c2 + w[3][l] * c3;
        }
    }
    q
}

impl PixelMap for CameraMap<'_> {
    /// Through the lattice of exact nodes ([`Lattice::spacing_px`]): each pixel
    /// the bicubic of the shift p − (u, v), J and 1/RI; a run near a node
    /// the model cannot map (beyond the lens model's reach), or of a camera
    /// without a lattice, pixel by pixel.
    fn map_run(&self, y: u32, x0: u32, x1: u32, out: &mut Vec<MappedLanes>) -> Option<()> {
        out.clear();
        if self.lattice_run(y, x0, x1, out).is_some() {
            return Some(());
        }
        pixel_by_pixel(self, y, x0, x1, out)
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
