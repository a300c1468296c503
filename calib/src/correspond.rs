//! Automatic correspondences between detected markers and target ids, from a
//! nominal camera that may be off by several degrees and millimetres.
//!
//! 1. **Global alignment.** The nominal camera's image of the target differs
//!    from the real one mostly by a 2-D similarity (a small camera rotation is
//!    a homography close to a shift and roll; a small position error adds a
//!    little parallax). Similarity hypotheses come from pairing a well-spaced
//!    pair of predicted markers with every pair of detections of compatible
//!    length and direction (a RANSAC over minimal sets, enumerated); each is
//!    scored by how many predicted markers land within a gate of a detection.
//! 2. **Gated assignment, re-estimation, repeat.** For the best distinct
//!    hypotheses: one-to-one assignment within the gate, a 2-D affine fit,
//!    then the normalised DLT on the matches, reprojection of every marker,
//!    re-assignment with a gate of `GATE_SIGMAS`·σ of the current residuals,
//!    until the assignment no longer changes.
//! 3. **Decision.** Candidates whose DLT camera is turned more than
//!    `max_rotation` from the nominal camera are dropped (a target with a
//!    near-symmetry can be fitted by a camera on another side of it). Among
//!    the remaining candidates whose residual scale is
//!    comparable to the best one's, the one with most matches wins; if another
//!    such candidate assigns most of its detections differently and has
//!    nearly as many matches, the assignment is ambiguous and an error —
//!    unless the nominal prediction is clearly nearer to the winner. A winner
//!    whose DLT residuals exceed the gate (σ > gate/`GATE_SIGMAS`), or that
//!    matches fewer than three quarters of the detections, fits no camera:
//!    the image or the nominal rig is wrong, also an error.

use std::collections::{HashMap, HashSet};

use geom::nalgebra::{Matrix3, Vector3};
use geom::{Camera, Matrix3x4, Point2, Point3, Vector2};

use crate::dlt::{self, MIN_POINTS, Spread};
use crate::error::Ambiguity;
use crate::outliers::robust_sigma;
use crate::{CalibError, OptionProblem, Result};

/// Gate of the final assignment in multiples of the robust σ of the DLT residuals.
pub const GATE_SIGMAS: f64 = 6.0;
/// Smallest gate of the final assignment (px): the DLT ignores lens
/// distortion, whose residuals are of this order on a good lens.
pub const MIN_GATE_PX: f64 = 2.0;
/// A candidate is comparable to the best when its σ is within this factor
/// of the best σ (σ floored at [`SIGMA_FLOOR_PX`]).
const CONSISTENT_FACTOR: f64 = 4.0;
/// Floor of σ in the comparison of candidates (px).
const SIGMA_FLOOR_PX: f64 = 0.1;
/// Two comparable, conflicting candidates are ambiguous when the runner-up
/// has at least this fraction of the winner's matches (the assignment must
/// tolerate 20 % missing detections, so fewer matches alone do not decide).
const AMBIGUOUS_FRACTION: f64 = 0.8;
/// Fewest matches, as a fraction of the detections (or of the markers, if
/// fewer), for an assignment to be believed. 20 % of the markers missing and
/// 20 % spurious blobs give 0.8; the lattice-like seed target fits a wrong
/// camera's image with ≈ 0.73 of its markers under a near-symmetry.
const MIN_MATCHED_FRACTION: f64 = 0.75;
/// Between two equally good assignments, the nominal rig decides when the
/// winner's displacement from the nominal prediction is below this fraction
/// of the other's.
const NOMINAL_PREFERENCE: f64 = 0.5;
/// Distinct hypotheses carried through the re-estimation.
const CANDIDATES: usize = 20;
/// Base pairs of predicted markers for the similarity hypotheses.
const BASE_PAIRS: usize = 12;

/// A marker of the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Marker {
    /// Marker id.
    pub id: u32,
    /// Centre, target frame (mm).
    pub centre: Point3<f64>,
}

/// The markers of `target.csv` rows.
pub fn markers(target: &[formats::TargetRow]) -> Vec<Marker> {
    target
        .iter()
        .map(|t| Marker {
            id: t.id,
            centre: Point3::new(t.x, t.y, t.z),
        })
        .collect()
}

/// Search limits of the automatic assignment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CorrespondOptions {
    /// Largest roll of the real image against the nominal prediction (rad).
    pub max_roll: f64,
    /// Largest rotation of the camera a candidate implies against the nominal camera (rad).
    pub max_rotation: f64,
    /// Largest scale ratio between the real image and the nominal prediction (≥ 1).
    pub max_scale: f64,
    /// Gate of the global alignment as a fraction of the median nearest-neighbour
    /// distance between detections.
    pub gate_fraction: f64,
    /// Most re-estimation rounds per candidate.
    pub max_iterations: usize,
    /// Leave out, instead of failing on, the markers whose assignment is
    /// locally ambiguous (two markers imaged within the gate of one blob, or
    /// a second blob within a marker's gate): for one of many views, where
    /// a moved target may put two markers on one line of sight.
    pub leave_out_ambiguous: bool,
}

impl Default for CorrespondOptions {
    fn default() -> Self {
        Self {
            max_roll: 20f64.to_radians(),
            max_rotation: 20f64.to_radians(),
            max_scale: 1.3,
            gate_fraction: 0.3,
            max_iterations: 30,
            leave_out_ambiguous: false,
        }
    }
}

/// One marker matched to one detection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// Marker id.
    pub id: u32,
    /// Index of the detection.
    pub detection: usize,
    /// Distance between the detection and the marker reprojected by the final DLT (px).
    pub residual_px: f64,
}

/// The assignment and how it was reached.
#[derive(Debug, Clone)]
pub struct Correspondence {
    /// Matches, by increasing id.
    pub matches: Vec<Match>,
    /// Normalised DLT of the matches.
    pub projection: Matrix3x4<f64>,
    /// Robust σ of the DLT residuals (px, per coordinate).
    pub sigma_px: f64,
    /// Gate of the final assignment (px).
    pub gate_px: f64,
    /// Detections not matched to any marker.
    pub unmatched_detections: Vec<usize>,
    /// Markers that project into the image under the DLT but were not matched.
    pub missing_markers: Vec<u32>,
    /// Distinct candidates that were refined.
    pub candidates: usize,
}

/// Pairs (marker index, detection index, distance).
type Assignment = Vec<(usize, usize, f64)>;

/// Uniform grid over the detections for radius queries.
struct Grid {
    cell: f64,
    cells: HashMap<(i64, i64), Vec<usize>>,
}

impl Grid {
    fn new(points: &[Point2<f64>], cell: f64) -> Self {
        let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (j, p) in points.iter().enumerate() {
            cells.entry(Self::key(p, cell)).or_default().push(j);
        }
        Self { cell, cells }
    }

    fn key(p: &Point2<f64>, cell: f64) -> (i64, i64) {
        ((p.x / cell).floor() as i64, (p.y / cell).floor() as i64)
    }

    /// Detections within `radius` (≤ cell size) of `p`.
    fn near<'a>(
        &'a self,
        p: &Point2<f64>,
        radius: f64,
        points: &'a [Point2<f64>],
    ) -> impl Iterator<Item = (usize, f64)> + 'a {
        let (cx, cy) = Self::key(p, self.cell);
        let p = *p;
        (-1..=1)
            .flat_map(move |dx| (-1..=1).map(move |dy| (cx + dx, cy + dy)))
            .filter_map(move |k| self.cells.get(&k))
            .flatten()
            .map(move |&j| (j, (points[j] - p).norm()))
            .filter(move |&(_, d)| d <= radius)
    }
}

/// Median distance from each point to its nearest neighbour.
fn median_spacing(points: &[Point2<f64>]) -> f64 {
    let mut d: Vec<f64> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            points
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, q)| (q - p).norm())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.0)
}

/// Greedy one-to-one assignment by increasing distance within `gate`.
fn assign(
    positions: &[Option<Point2<f64>>],
    detections: &[Point2<f64>],
    grid: &Grid,
    gate: f64,
) -> Assignment {
    let mut pairs: Vec<(usize, usize, f64)> = Vec::new();
    for (i, p) in positions.iter().enumerate() {
        if let Some(p) = p {
            pairs.extend(grid.near(p, gate, detections).map(|(j, d)| (i, j, d)));
        }
    }
    pairs.sort_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)).then(a.1.cmp(&b.1)));
    let (mut used_i, mut used_j) = (HashSet::new(), HashSet::new());
    let mut out: Assignment = pairs
        .into_iter()
        .filter(|&(i, j, _)| {
            if used_i.contains(&i) || used_j.contains(&j) {
                false
            } else {
                used_i.insert(i);
                used_j.insert(j);
                true
            }
        })
        .collect();
    out.sort_by_key(|&(i, j, _)| (i, j));
    out
}

/// One re-estimation step: the robust σ of the residuals of `pairs` at the
/// predicted `positions`, the gate `GATE_SIGMAS·σ` clamped to
/// `[min(MIN_GATE_PX, gate0), gate0]` (px), and the assignment within it.
/// Returns the assignment, σ and the gate.
fn reassign(
    pairs: &Assignment,
    positions: &[Option<Point2<f64>>],
    detections: &[Point2<f64>],
    grid: &Grid,
    gate0: f64,
) -> (Assignment, f64, f64) {
    let res: Vec<Vector2<f64>> = pairs
        .iter()
        .filter_map(|p| positions[p.0].map(|q| q - detections[p.1]))
        .collect();
    let sigma = robust_sigma(&res);
    let gate = (GATE_SIGMAS * sigma).clamp(MIN_GATE_PX.min(gate0), gate0);
    (assign(positions, detections, grid, gate), sigma, gate)
}

fn same_pairs(a: &Assignment, b: &Assignment) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.0 == y.0 && x.1 == y.1)
}

/// 2-D similarity `x ↦ s·R(θ)·(x − a) + c`.
#[derive(Debug, Clone, Copy)]
struct Similarity {
    a: Vector2<f64>,
    c: Vector2<f64>,
    s: f64,
    cos: f64,
    sin: f64,
}

impl Similarity {
    fn apply(&self, x: &Point2<f64>) -> Point2<f64> {
        let d = x.coords - self.a;
        Point2::from(
            self.c
                + Vector2::new(
                    self.cos * d.x - self.sin * d.y,
                    self.sin * d.x + self.cos * d.y,
                ) * self.s,
        )
    }
}

/// Least-squares 2-D affine map from `from` to `to` (≥ 3 non-collinear pairs).
fn fit_affine(from: &[Point2<f64>], to: &[Point2<f64>]) -> Option<[[f64; 3]; 2]> {
    let mut ata = Matrix3::zeros();
    let (mut atu, mut atv) = (Vector3::zeros(), Vector3::zeros());
    for (p, q) in from.iter().zip(to) {
        let r = Vector3::new(p.x, p.y, 1.0);
        ata += r * r.transpose();
        atu += r * q.x;
        atv += r * q.y;
    }
    let inv = ata.try_inverse()?;
    let (mu, mv) = (inv * atu, inv * atv);
    Some([[mu.x, mu.y, mu.z], [mv.x, mv.y, mv.z]])
}

/// A converged candidate.
#[derive(Debug, Clone)]
struct Candidate {
    pairs: Assignment,
    projection: Matrix3x4<f64>,
    positions: Vec<Option<Point2<f64>>>,
    sigma: f64,
    gate: f64,
}

/// Find which detection images which target marker (module docs): returns
/// at least [`MIN_POINTS`] one-to-one matches with the normalised DLT that
/// explains them, or a [`CalibError`] saying why not (too few matches,
/// coplanar target, ambiguous assignment).
pub fn correspond(
    markers: &[Marker],
    detections: &[Point2<f64>],
    nominal: &Camera,
    options: &CorrespondOptions,
) -> Result<Correspondence> {
    let search = Search::new(markers, detections, nominal, options)?;
    // 1. Global alignment.
    let hypotheses = similarity_hypotheses(
        &search.predicted,
        &search.visible,
        detections,
        &search.grid,
        search.gate0,
        options,
    );
    // 2. Gated assignment, re-estimation, repeat.
    let refined = search.refine(&hypotheses);
    // 3. Decision.
    let best = search.decide(refined.candidates, refined.started)?;
    Ok(search.correspondence(&best, refined.starts))
}

/// What every step of [`correspond`] works on: the checked input, the
/// nominal prediction and the search scale.
struct Search<'a> {
    markers: &'a [Marker],
    detections: &'a [Point2<f64>],
    nominal: &'a Camera,
    options: &'a CorrespondOptions,
    /// Marker centres (target frame, mm).
    world: Vec<Point3<f64>>,
    /// Marker images through the nominal camera (px), `None` behind it.
    predicted: Vec<Option<Point2<f64>>>,
    /// Markers with a prediction.
    visible: Vec<usize>,
    /// The first gate: `gate_fraction` of the detections' median spacing (px).
    gate0: f64,
    grid: Grid,
}

/// The candidates of step 2 and how many distinct starts were refined.
struct Refined {
    candidates: Vec<Candidate>,
    /// Distinct starting assignments refined.
    starts: usize,
    /// Matches of the largest starting assignment.
    started: usize,
}

impl<'a> Search<'a> {
    /// Check the input and set up the search (nominal prediction, gate, grid).
    fn new(
        markers: &'a [Marker],
        detections: &'a [Point2<f64>],
        nominal: &'a Camera,
        options: &'a CorrespondOptions,
    ) -> Result<Self> {
        check_input(markers, detections, options)?;
        let world: Vec<Point3<f64>> = markers.iter().map(|m| m.centre).collect();
        if markers.len() < MIN_POINTS {
            return Err(CalibError::TooFewPoints {
                what: "automatic correspondence",
                needed: MIN_POINTS,
                got: markers.len(),
            });
        }
        Spread::of(&world).check()?;
        if detections.len() < MIN_POINTS {
            return Err(CalibError::TooFewDetections {
                detections: detections.len(),
                needed: MIN_POINTS,
            });
        }
        let predicted: Vec<Option<Point2<f64>>> =
            world.iter().map(|x| nominal.project(x).ok()).collect();
        let visible: Vec<usize> = (0..markers.len())
            .filter(|&i| predicted[i].is_some())
            .collect();
        if visible.len() < MIN_POINTS {
            return Err(too_few(0, detections.len(), markers.len()));
        }
        let spacing = median_spacing(detections);
        if spacing.is_nan() || spacing <= 0.0 {
            return Err(CalibError::Option(OptionProblem::CoincidentDetections));
        }
        let gate0 = options.gate_fraction * spacing;
        Ok(Search {
            markers,
            detections,
            nominal,
            options,
            world,
            predicted,
            visible,
            gate0,
            grid: Grid::new(detections, gate0),
        })
    }

    fn too_few(&self, matched: usize) -> CalibError {
        too_few(matched, self.detections.len(), self.markers.len())
    }

    /// Step 2: refine the best distinct hypotheses into converged candidates.
    fn refine(&self, hypotheses: &[Similarity]) -> Refined {
        let mut starts: Vec<Assignment> = Vec::new();
        let mut candidates: Vec<Candidate> = Vec::new();
        for h in hypotheses {
            if starts.len() >= CANDIDATES {
                break;
            }
            let positions: Vec<Option<Point2<f64>>> = self
                .predicted
                .iter()
                .map(|p| p.map(|p| h.apply(&p)))
                .collect();
            let start = assign(&positions, self.detections, &self.grid, self.gate0);
            if start.len() < 3 || starts.iter().any(|s| same_pairs(s, &start)) {
                continue;
            }
            starts.push(start.clone());
            if let Some(c) = converge(
                start,
                &self.predicted,
                &self.world,
                self.detections,
                &self.grid,
                self.gate0,
                self.options,
            ) && !candidates.iter().any(|o| same_pairs(&o.pairs, &c.pairs))
            {
                candidates.push(c);
            }
        }
        Refined {
            candidates,
            starts: starts.len(),
            started: starts.iter().map(Vec::len).max().unwrap_or(0),
        }
    }

    /// Step 3: the winning candidate — oriented as the nominal camera,
    /// believable, not ambiguous — extended through a distorting camera.
    fn decide(&self, mut candidates: Vec<Candidate>, started: usize) -> Result<Candidate> {
        let best_count = candidates.iter().map(|c| c.pairs.len()).max().unwrap_or(0);
        if best_count < MIN_POINTS {
            return Err(self.too_few(if candidates.is_empty() {
                started
            } else {
                best_count
            }));
        }
        candidates.retain(|c| c.pairs.len() >= MIN_POINTS);
        self.drop_turned(&mut candidates)?;
        let floor = |s: f64| s.max(SIGMA_FLOOR_PX);
        let sigma_min = candidates
            .iter()
            .map(|c| floor(c.sigma))
            .fold(f64::INFINITY, f64::min);
        let comparable: Vec<&Candidate> = candidates
            .iter()
            .filter(|c| floor(c.sigma) <= CONSISTENT_FACTOR * sigma_min)
            .collect();
        let Some(best) = comparable.iter().copied().max_by(|a, b| {
            a.pairs
                .len()
                .cmp(&b.pairs.len())
                .then(b.sigma.total_cmp(&a.sigma))
        }) else {
            return Err(self.too_few(best_count));
        };
        self.believable(best)?;
        let best = self.unambiguous(best, &comparable)?;
        self.believable(best)?;
        let ambiguous = local_ambiguities(best, self.markers, self.detections, &self.grid);
        if let Some((_, first)) = ambiguous.first()
            && !self.options.leave_out_ambiguous
        {
            return Err(CalibError::Ambiguous(first.clone()));
        }
        let extended = with_distortion(
            best,
            &self.world,
            self.detections,
            &self.grid,
            self.gate0,
            self.nominal.width,
            self.nominal.height,
        );
        let mut chosen = extended.unwrap_or_else(|| best.clone());
        // The ambiguous markers and their blobs left out (they stay counted
        // as missing and unmatched).
        let (markers, blobs): (HashSet<usize>, HashSet<usize>) =
            ambiguous.iter().map(|(pair, _)| *pair).unzip();
        chosen
            .pairs
            .retain(|(i, j, _)| !markers.contains(i) && !blobs.contains(j));
        if chosen.pairs.len() < MIN_POINTS {
            return Err(self.too_few(chosen.pairs.len()));
        }
        Ok(chosen)
    }

    /// A candidate is a camera: drop those turned more than `max_rotation`
    /// from the nominal one; an error when that drops them all.
    fn drop_turned(&self, candidates: &mut Vec<Candidate>) -> Result<()> {
        let nominal_rotation = self.nominal.rotation();
        let turn = |c: &Candidate| -> f64 {
            geom::camera::decompose_projection(&c.projection).map_or(f64::INFINITY, |(_, r, _)| {
                // Angle of R_nominalᵀ·R from its trace, clamped against round-off.
                let m = (nominal_rotation.inverse() * r).into_inner();
                ((m.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos()
            })
        };
        let smallest_turn = candidates.iter().map(turn).fold(f64::INFINITY, f64::min);
        candidates.retain(|c| turn(c) <= self.options.max_rotation);
        if candidates.is_empty() && smallest_turn.is_finite() {
            return Err(CalibError::FarFromNominal {
                angle_deg: smallest_turn.to_degrees(),
                limit_deg: self.options.max_rotation.to_degrees(),
            });
        }
        Ok(())
    }

    /// A winner must fit a camera: σ within the gate and most detections matched.
    fn believable(&self, c: &Candidate) -> Result<()> {
        let limit = self.gate0 / GATE_SIGMAS;
        let expected = self.detections.len().min(self.markers.len());
        if c.sigma > limit || (c.pairs.len() as f64) < MIN_MATCHED_FRACTION * expected as f64 {
            return Err(CalibError::Inconsistent {
                matched: c.pairs.len(),
                detections: self.detections.len(),
                sigma_px: c.sigma,
                limit_px: limit,
            });
        }
        Ok(())
    }

    /// How far a candidate moved the markers from the nominal prediction (median, px).
    fn displacement(&self, c: &Candidate) -> f64 {
        let mut d: Vec<f64> = c
            .pairs
            .iter()
            .filter_map(|p| Some((c.positions[p.0]? - self.predicted[p.0]?).norm()))
            .collect();
        d.sort_by(f64::total_cmp);
        d.get(d.len() / 2).copied().unwrap_or(f64::INFINITY)
    }

    /// The winner among rivals: the nominal rig decides between equally good
    /// assignments when it is clearly nearer to one of them; otherwise a
    /// rival is an ambiguity.
    fn unambiguous<'c>(
        &self,
        mut best: &'c Candidate,
        comparable: &[&'c Candidate],
    ) -> Result<&'c Candidate> {
        if let Some((nearer, _)) = rivals(best, comparable)
            .into_iter()
            .filter(|(o, _)| self.displacement(o) < NOMINAL_PREFERENCE * self.displacement(best))
            .min_by(|a, b| self.displacement(a.0).total_cmp(&self.displacement(b.0)))
        {
            best = nearer;
        }
        let d_best = self.displacement(best);
        if let Some((other, conflicts)) = rivals(best, comparable)
            .into_iter()
            .find(|(o, _)| d_best > NOMINAL_PREFERENCE * self.displacement(o))
        {
            return Err(CalibError::Ambiguous(Ambiguity::TwoAssignments {
                best: best.pairs.len(),
                best_sigma_px: best.sigma,
                best_offset_px: d_best,
                other: other.pairs.len(),
                other_sigma_px: other.sigma,
                other_offset_px: self.displacement(other),
                conflicts,
            }));
        }
        Ok(best)
    }

    /// The result: matches by id, unmatched detections, and the markers that
    /// the winner predicts inside the image but nothing matched.
    fn correspondence(&self, best: &Candidate, candidates: usize) -> Correspondence {
        let (w, h) = (
            f64::from(self.nominal.width),
            f64::from(self.nominal.height),
        );
        let inside = |p: &Option<Point2<f64>>| {
            p.is_some_and(|p| p.x >= -0.5 && p.y >= -0.5 && p.x <= w - 0.5 && p.y <= h - 0.5)
        };
        let matched_markers: HashSet<usize> = best.pairs.iter().map(|p| p.0).collect();
        let matched_detections: HashSet<usize> = best.pairs.iter().map(|p| p.1).collect();
        let mut matches: Vec<Match> = best
            .pairs
            .iter()
            .map(|&(i, j, d)| Match {
                id: self.markers[i].id,
                detection: j,
                residual_px: d,
            })
            .collect();
        matches.sort_by_key(|m| m.id);
        Correspondence {
            matches,
            projection: best.projection,
            sigma_px: best.sigma,
            gate_px: best.gate,
            unmatched_detections: (0..self.detections.len())
                .filter(|j| !matched_detections.contains(j))
                .collect(),
            missing_markers: (0..self.markers.len())
                .filter(|i| !matched_markers.contains(i))
                .filter(|&i| inside(&best.positions[i]))
                .map(|i| self.markers[i].id)
                .collect(),
            candidates,
        }
    }
}

/// Fewer than [`MIN_POINTS`] matches found.
fn too_few(matched: usize, detections: usize, markers: usize) -> CalibError {
    CalibError::TooFewMatches {
        matched,
        needed: MIN_POINTS,
        detections,
        markers,
    }
}

/// Finite, unique markers; finite detections; options in range.
fn check_input(
    markers: &[Marker],
    detections: &[Point2<f64>],
    options: &CorrespondOptions,
) -> Result<()> {
    let mut ids = HashSet::new();
    for m in markers {
        for (field, value) in [("x", m.centre.x), ("y", m.centre.y), ("z", m.centre.z)] {
            if !value.is_finite() {
                return Err(CalibError::NonFinite {
                    id: m.id,
                    field,
                    value,
                });
            }
        }
        if !ids.insert(m.id) {
            return Err(CalibError::DuplicateId { id: m.id });
        }
    }
    for (j, d) in detections.iter().enumerate() {
        if !(d.x.is_finite() && d.y.is_finite()) {
            return Err(CalibError::Option(OptionProblem::DetectionNotFinite {
                index: j,
                x: d.x,
                y: d.y,
            }));
        }
    }
    if !(options.max_scale >= 1.0 && options.gate_fraction > 0.0 && options.gate_fraction < 0.5) {
        return Err(CalibError::Option(OptionProblem::Search {
            max_scale: options.max_scale,
            gate_fraction: options.gate_fraction,
        }));
    }
    Ok(())
}

/// Rivals of `of`: comparable candidates with nearly as many matches that
/// assign most of their detections differently, with their conflict counts.
fn rivals<'c>(of: &Candidate, comparable: &[&'c Candidate]) -> Vec<(&'c Candidate, usize)> {
    let partner_of_marker: HashMap<usize, usize> = of.pairs.iter().map(|p| (p.0, p.1)).collect();
    let partner_of_detection: HashMap<usize, usize> = of.pairs.iter().map(|p| (p.1, p.0)).collect();
    comparable
        .iter()
        .filter(|o| !std::ptr::eq(**o, of))
        .map(|o| {
            let conflicts = o
                .pairs
                .iter()
                .filter(|(i, j, _)| {
                    partner_of_marker.get(i).is_some_and(|bj| bj != j)
                        || partner_of_detection.get(j).is_some_and(|bi| bi != i)
                })
                .count();
            (*o, conflicts)
        })
        .filter(|(o, conflicts)| {
            2 * conflicts > o.pairs.len()
                && o.pairs.len() as f64 >= AMBIGUOUS_FRACTION * of.pairs.len() as f64
        })
        .collect()
}

/// Similarity hypotheses, best first: the identity, then every pairing of a
/// base pair of predicted markers with a detection pair whose length ratio
/// and direction are within the limits, scored by the number of predicted
/// markers within `gate` of a detection (ties: smaller sum of squared
/// distances, then smaller displacement from the nominal).
fn similarity_hypotheses(
    predicted: &[Option<Point2<f64>>],
    visible: &[usize],
    detections: &[Point2<f64>],
    grid: &Grid,
    gate: f64,
    options: &CorrespondOptions,
) -> Vec<Similarity> {
    let pts: Vec<Point2<f64>> = visible.iter().filter_map(|&i| predicted[i]).collect();
    let centroid = pts.iter().fold(Vector2::zeros(), |s, p| s + p.coords) / pts.len() as f64;
    let pred_spacing = median_spacing(&pts);
    let score = |t: &Similarity| -> (usize, f64, f64) {
        let (mut n, mut cost) = (0usize, 0.0);
        for p in &pts {
            let q = t.apply(p);
            let best = grid
                .near(&q, gate, detections)
                .map(|(_, d)| d)
                .fold(f64::INFINITY, f64::min);
            if best.is_finite() {
                n += 1;
                cost += best * best;
            } else {
                cost += gate * gate;
            }
        }
        let shift = (t.apply(&Point2::from(centroid)).coords - centroid).norm();
        (n, cost, shift)
    };
    let identity = Similarity {
        a: Vector2::zeros(),
        c: Vector2::zeros(),
        s: 1.0,
        cos: 1.0,
        sin: 0.0,
    };
    let mut scored = vec![(score(&identity), identity)];

    // Base pairs: anchors spread from the centre to the rim of the pattern,
    // each with the partner closest to three spacings away.
    let mut order: Vec<usize> = (0..pts.len()).collect();
    order.sort_by(|&a, &b| {
        (pts[a].coords - centroid)
            .norm()
            .total_cmp(&(pts[b].coords - centroid).norm())
    });
    let mut base: Vec<(usize, usize)> = Vec::new();
    for k in 0..BASE_PAIRS.min(pts.len()) {
        let a = order[k * pts.len() / BASE_PAIRS.min(pts.len())];
        let partner = (0..pts.len())
            .filter(|&b| b != a && !base.contains(&(b, a)))
            .map(|b| (b, (pts[b] - pts[a]).norm()))
            .filter(|&(_, d)| d > 0.0)
            .min_by(|x, y| {
                (x.1 - 3.0 * pred_spacing)
                    .abs()
                    .total_cmp(&(y.1 - 3.0 * pred_spacing).abs())
            });
        if let Some((b, _)) = partner {
            base.push((a, b));
        }
    }
    for &(a, b) in &base {
        let ab = pts[b] - pts[a];
        let (len, phi) = (ab.norm(), ab.y.atan2(ab.x));
        for (c, pc) in detections.iter().enumerate() {
            for (d, pd) in detections.iter().enumerate() {
                if c == d {
                    continue;
                }
                let cd = pd - pc;
                let s = cd.norm() / len;
                if !(s <= options.max_scale && s * options.max_scale >= 1.0) {
                    continue;
                }
                let mut theta = cd.y.atan2(cd.x) - phi;
                theta = (theta + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                if theta.abs() > options.max_roll {
                    continue;
                }
                let t = Similarity {
                    a: pts[a].coords,
                    c: pc.coords,
                    s,
                    cos: theta.cos(),
                    sin: theta.sin(),
                };
                scored.push((score(&t), t));
            }
        }
    }
    scored.sort_by(|(x, _), (y, _)| {
        y.0.cmp(&x.0)
            .then(x.1.total_cmp(&y.1))
            .then(x.2.total_cmp(&y.2))
    });
    scored.into_iter().map(|(_, t)| t).collect()
}

/// From a starting assignment: affine re-alignment, then DLT, reprojection
/// and gated re-assignment until the assignment is stable. `None` when the
/// candidate never reaches a DLT (too few or coplanar matches).
fn converge(
    start: Assignment,
    predicted: &[Option<Point2<f64>>],
    world: &[Point3<f64>],
    detections: &[Point2<f64>],
    grid: &Grid,
    gate0: f64,
    options: &CorrespondOptions,
) -> Option<Candidate> {
    let mut pairs = start;
    for _ in 0..3 {
        let from: Vec<Point2<f64>> = pairs.iter().filter_map(|p| predicted[p.0]).collect();
        let to: Vec<Point2<f64>> = pairs.iter().map(|p| detections[p.1]).collect();
        let Some(a) = fit_affine(&from, &to) else {
            break;
        };
        let positions: Vec<Option<Point2<f64>>> = predicted
            .iter()
            .map(|p| {
                p.map(|p| {
                    Point2::new(
                        a[0][0] * p.x + a[0][1] * p.y + a[0][2],
                        a[1][0] * p.x + a[1][1] * p.y + a[1][2],
                    )
                })
            })
            .collect();
        let next = assign(&positions, detections, grid, gate0);
        if same_pairs(&next, &pairs) {
            break;
        }
        pairs = next;
    }
    let mut last: Option<Candidate> = None;
    for _ in 0..options.max_iterations {
        let w: Vec<Point3<f64>> = pairs.iter().map(|p| world[p.0]).collect();
        let d: Vec<Point2<f64>> = pairs.iter().map(|p| detections[p.1]).collect();
        let projection = dlt::dlt(&w, &d).ok()?;
        let positions: Vec<Option<Point2<f64>>> =
            world.iter().map(|x| dlt::project(&projection, x)).collect();
        let (next, sigma, gate) = reassign(&pairs, &positions, detections, grid, gate0);
        let stable = same_pairs(&next, &pairs);
        last = Some(Candidate {
            pairs: next.clone(),
            projection,
            positions,
            sigma,
            gate,
        });
        if stable || next.len() < MIN_POINTS {
            break;
        }
        pairs = next;
    }
    last
}

/// Final re-assignment through a camera with radial distortion: a pinhole DLT
/// cannot follow a lens's barrel or pincushion into the corners of the image
/// (≈ 12 px at the corner of the seed sensor for k1 = −0.045), so corner
/// markers fall outside its gate. Fit k1, k2 to the matched pairs (no outlier
/// rejection: the gate decides), predict every marker through the full model
/// and re-assign within `GATE_SIGMAS`·σ of the residuals, until stable.
/// `None` when the fit fails (the DLT assignment then stands).
fn with_distortion(
    start: &Candidate,
    world: &[Point3<f64>],
    detections: &[Point2<f64>],
    grid: &Grid,
    gate0: f64,
    width: u32,
    height: u32,
) -> Option<Candidate> {
    let options = crate::calibration::Options {
        model: crate::refine::Model::K1K2,
        outlier_k: None,
        ..crate::calibration::Options::default()
    };
    let mut pairs = start.pairs.clone();
    let mut last = None;
    for _ in 0..MAX_DISTORTION_ROUNDS {
        let observations: Vec<crate::calibration::Observation> = pairs
            .iter()
            .map(|&(i, j, _)| crate::calibration::Observation {
                id: i as u32,
                world: world[i],
                pixel: detections[j],
                sphere_diameter: None,
            })
            .collect();
        let camera = crate::calibration::calibrate(&observations, width, height, &options)
            .ok()?
            .camera;
        let positions: Vec<Option<Point2<f64>>> =
            world.iter().map(|x| camera.project(x).ok()).collect();
        let (next, sigma, gate) = reassign(&pairs, &positions, detections, grid, gate0);
        let stable = same_pairs(&next, &pairs);
        if next.len() < pairs.len() {
            // A worse assignment than the DLT's: keep what we had.
            return last;
        }
        last = Some(Candidate {
            pairs: next.clone(),
            projection: camera.projection_matrix(),
            positions,
            sigma,
            gate,
        });
        if stable {
            break;
        }
        pairs = next;
    }
    last
}

/// Rounds of the distortion-aware re-assignment at most.
const MAX_DISTORTION_ROUNDS: usize = 4;

/// The matched pairs (marker, detection) whose assignment is a guess: a
/// matched marker with a second detection within the final gate, or a
/// matched detection within the gate of a second marker (both markers).
fn local_ambiguities(
    best: &Candidate,
    markers: &[Marker],
    detections: &[Point2<f64>],
    grid: &Grid,
) -> Vec<((usize, usize), Ambiguity)> {
    let mut found = Vec::new();
    for &(i, j, d) in &best.pairs {
        let Some(p) = best.positions[i] else { continue };
        if let Some((k, dk)) = grid
            .near(&p, best.gate, detections)
            .filter(|&(k, _)| k != j)
            .min_by(|a, b| a.1.total_cmp(&b.1))
        {
            found.push((
                (i, j),
                Ambiguity::TwoDetections {
                    marker: markers[i].id,
                    gate_px: best.gate,
                    detection: j,
                    distance_px: d,
                    second: k,
                    second_px: dk,
                },
            ));
            continue;
        }
        let q = detections[j];
        if let Some((k, _)) = best
            .positions
            .iter()
            .enumerate()
            .filter(|&(k, _)| k != i)
            .filter_map(|(k, p)| p.map(|p| (k, (p - q).norm())))
            .find(|&(_, dk)| dk <= best.gate)
        {
            let ambiguity = Ambiguity::TwoMarkers {
                detection: j,
                gate_px: best.gate,
                marker: markers[i].id,
                second: markers[k].id,
            };
            found.push(((i, j), ambiguity.clone()));
            found.push(((k, j), ambiguity));
        }
    }
    found
}
