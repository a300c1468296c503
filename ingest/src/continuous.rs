//! Continuous capture: the cameras run free at `fps` through the whole
//! campaign, on one frame clock (synchronised sensors), each stamping frames
//! with its own clock. The dwells are found in the images: where the
//! spheres' blobs stop moving.
//!
//! Per camera: frames get slot numbers on the frame clock from their local
//! gaps (a gap of n periods is n − 1 dropped frames; local gaps keep clock
//! drift out). Every `stride`-th frame is decoded (at least three samples
//! fall in the shortest stay the program allows: `settle_s` plus the
//! captures); runs of samples whose blobs stay within the camera's still
//! bound `ε` of the run's first sample are candidate stays, aligned with the
//! program's dwells by [`crate::align`] (pauses at reversals and before the
//! first move are strays there; a stay from the first frame on, whose
//! arrival was not recorded, is irregular: matched only at half a stray's
//! cost more, so the rest before a short first move is not taken for the
//! first dwell). `ε` is measured, not assumed: per blob
//! measure (centre u, v and diameter of each blob), [`STILL_SIGMAS`] times
//! the spread of its difference between still samples of the camera's own
//! frames ([`StillBound::measured`]), so it follows the image size, the
//! frame rate and the noise; `still_px` fixes it instead. The first still
//! frame of each matched stay is found by bisection between the last moving
//! sample and the first still one (`log₂ stride` decodes); it is *sharp*
//! when the frame before it is at least `3·ε` from rest (a camera that sees
//! the motion creep by less than `2·ε` a frame finds a still frame early,
//! and the frame before that one within `3·ε`).
//!
//! Across cameras: the slot offset of each camera from a reference (the one
//! with the most sharp arrivals) is the most frequent difference of sharp
//! arrivals at the same dwells; a camera looking along the motion sees it
//! only as a change of scale and finds arrivals early, so the arrival of a
//! dwell is the latest sharp one of all cameras, on the reference clock. The
//! instant is the `captures` frames from `⌈settle_s·fps⌉` frames after it, in
//! every camera through its offset; that the table is still through the last
//! of them is checked in the image. Frames at no instant (in motion, or
//! still but not taken) are counted, not listed.
//!
//! Pure but for [`Signatures`], which the caller implements (decoding and
//! extraction), so the logic is tested with synthetic blobs.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::{Arc, Mutex};

use formats::Dwell;
use rayon::prelude::*;

use crate::align::{AlignParams, Event, align};
use crate::triggered::{CameraFrames, Fault, Placed, Placement, TimedFrame, describe};

/// A blob of a frame: sub-pixel centre and size (px; a smooth measure such
/// as the mean axis of the moment ellipse, not the whole-pixel area).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spot {
    /// Centre u (px).
    pub u: f64,
    /// Centre v (px).
    pub v: f64,
    /// Diameter (px).
    pub diameter: f64,
}

/// The blobs of frames, by the caller's file index (decoding is the caller's).
pub trait Signatures: Sync {
    /// The blobs of `file`, or why they cannot be had.
    fn spots(&self, file: usize) -> Result<Vec<Spot>, String>;
}

/// Settings of continuous capture.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContinuousParams {
    /// Blobs within this of a stay's first sample (px, in u, v and diameter)
    /// are at rest; `None`: each camera's bound measured from the spread of
    /// its still frames (the module's documentation).
    pub still_px: Option<f64>,
    /// Alignment of stays with the program's dwells.
    pub align: AlignParams,
}

/// How two frames' blobs differ, measure by measure: blobs paired in order
/// of size, per blob `|Δu|, |Δv|, |Δdiameter|` (px). `None` when the counts
/// differ or there is no blob.
fn differences(a: &[Spot], b: &[Spot]) -> Option<Vec<f64>> {
    if a.len() != b.len() || a.is_empty() {
        return None;
    }
    let sorted = |s: &[Spot]| {
        let mut v = s.to_vec();
        v.sort_by(|x, y| y.diameter.total_cmp(&x.diameter));
        v
    };
    Some(
        sorted(a)
            .iter()
            .zip(sorted(b).iter())
            .flat_map(|(x, y)| {
                [
                    (x.u - y.u).abs(),
                    (x.v - y.v).abs(),
                    (x.diameter - y.diameter).abs(),
                ]
            })
            .collect(),
    )
}

/// How many spreads a blob measure of a still frame may be from rest: the
/// chance that one of 9 measures (3 blobs) of a still frame lies beyond
/// 6σ of Gaussian noise is 2·10⁻⁸.
const STILL_SIGMAS: f64 = 6.0;

/// Consecutive samples at most this many times the still distance `δ`
/// ([`StillBound::measured`]) apart are taken for still when the spread is
/// measured: still pairs scatter a few `δ`, moves between samples lie far beyond.
const STILL_PAIR_DELTAS: f64 = 5.0;

/// σ of a Gaussian from the median of its absolute values.
const MEDIAN_ABS_TO_SIGMA: f64 = 1.0 / 0.674_49;

/// A camera's still bound `ε`: per blob measure (blobs largest first; u, v,
/// diameter), how far from rest (px) a frame may be and still be at rest.
#[derive(Debug, Clone, PartialEq)]
enum StillBound {
    /// The same for every measure (`still_px`).
    Fixed(f64),
    /// Per number of blobs, [`STILL_SIGMAS`] × each measure's spread between still frames.
    Measured(BTreeMap<usize, Vec<f64>>),
}

impl StillBound {
    /// The bound measured on a camera's samples (in time order). A pair of
    /// consecutive samples is as far apart as the largest of its
    /// [`differences`]; `δ` is the `n`-th smallest of these distances, `n` the
    /// program's dwells. Each dwell's stay holds at least three samples (the
    /// stride is a third of the shortest stay), so at least `2n` of the pairs
    /// are still and `δ` is at most their median. The pairs within
    /// [`STILL_PAIR_DELTAS`]·`δ` are taken for still; each measure's spread
    /// is `median |Δ| / 0.6745` over them (the σ of the difference of two
    /// frames). No pixel size, frame rate or noise level is assumed.
    fn measured(spots: &[Option<Vec<Spot>>], dwells: usize) -> Self {
        let pairs: Vec<Vec<f64>> = spots
            .windows(2)
            .filter_map(|w| differences(w[0].as_ref()?, w[1].as_ref()?))
            .collect();
        let largest = |d: &[f64]| d.iter().copied().fold(0.0, f64::max);
        let mut sorted: Vec<f64> = pairs.iter().map(|d| largest(d)).collect();
        sorted.sort_by(f64::total_cmp);
        let Some(&delta) = sorted.get(dwells.clamp(1, sorted.len().max(1)) - 1) else {
            return Self::Measured(BTreeMap::new());
        };
        let mut by_count: BTreeMap<usize, Vec<&Vec<f64>>> = BTreeMap::new();
        for d in pairs
            .iter()
            .filter(|d| largest(d) <= STILL_PAIR_DELTAS * delta)
        {
            by_count.entry(d.len() / 3).or_default().push(d);
        }
        let bounds = by_count
            .into_iter()
            .map(|(count, still)| {
                let bound: Vec<f64> = (0..3 * count)
                    .map(|q| {
                        let v: Vec<f64> = still.iter().map(|d| d[q]).collect();
                        STILL_SIGMAS * MEDIAN_ABS_TO_SIGMA * crate::align::median(v).unwrap_or(0.0)
                    })
                    .collect();
                (count, bound)
            })
            .collect();
        Self::Measured(bounds)
    }

    /// How far `b` is from `a` in units of the bound (at most 1: at rest;
    /// any change of a measure whose bound is 0 is motion); infinite when the
    /// blob counts differ.
    fn distance(&self, a: &[Spot], b: &[Spot]) -> f64 {
        let Some(d) = differences(a, b) else {
            return f64::INFINITY;
        };
        let bound = |q: usize| match self {
            Self::Fixed(e) => *e,
            Self::Measured(m) => m
                .get(&a.len())
                .and_then(|v| v.get(q))
                .copied()
                .unwrap_or(0.0),
        };
        d.iter()
            .enumerate()
            .map(|(q, &x)| if x == 0.0 { 0.0 } else { x / bound(q) })
            .fold(0.0, f64::max)
    }

    /// The largest bound of a measure (px), for the report.
    fn largest_px(&self) -> f64 {
        match self {
            Self::Fixed(e) => *e,
            Self::Measured(m) => m.values().flatten().copied().fold(0.0, f64::max),
        }
    }
}

/// One camera's stream on the frame clock.
struct Stream {
    camera: u8,
    frames: Vec<TimedFrame>,
    /// Slot of each kept frame, and the frame at each slot.
    by_slot: BTreeMap<i64, usize>,
}

/// A stay found in one camera: its blobs within `still` of `anchor`.
#[derive(Debug, Clone)]
struct Stay {
    first_sample: i64,
    before: Option<i64>,
    anchor: Vec<Spot>,
    /// The camera's still bound.
    still: Arc<StillBound>,
}

impl Stay {
    /// How far the blobs `spots` are from this stay's rest, in units of the still bound.
    fn away_from_rest(&self, spots: &[Spot]) -> f64 {
        self.still.distance(&self.anchor, spots)
    }
}

/// One camera's stays matched to dwells: dwell → (arrival, stay).
type Found = BTreeMap<usize, (Arrival, Stay)>;

/// A dwell's arrival in one camera.
#[derive(Debug, Clone, Copy)]
struct Arrival {
    slot: i64,
    sharp: bool,
}

const NS: f64 = 1e9;

/// Cached blobs.
struct Cache<'a> {
    source: &'a dyn Signatures,
    seen: Mutex<HashMap<usize, Result<Vec<Spot>, String>>>,
}

impl Cache<'_> {
    fn get(&self, file: usize) -> Result<Vec<Spot>, String> {
        if let Ok(seen) = self.seen.lock()
            && let Some(r) = seen.get(&file)
        {
            return r.clone();
        }
        let r = self.source.spots(file);
        if let Ok(mut seen) = self.seen.lock() {
            seen.insert(file, r.clone());
        }
        r
    }

    fn decoded(&self) -> usize {
        self.seen.lock().map_or(0, |s| s.len())
    }

    fn failed(&self) -> Vec<(usize, String)> {
        self.seen.lock().map_or_else(
            |_| Vec::new(),
            |s| {
                let mut v: Vec<(usize, String)> = s
                    .iter()
                    .filter_map(|(f, r)| r.as_ref().err().map(|e| (*f, e.clone())))
                    .collect();
                v.sort();
                v
            },
        )
    }
}

/// Slot numbers from local gaps; frames off the clock are faults.
fn stream(cam: &CameraFrames, fps: f64, faults: &mut Vec<Fault>) -> Stream {
    let mut by_slot = BTreeMap::new();
    let mut last: Option<(i64, i64)> = None;
    for (i, f) in cam.frames.iter().enumerate() {
        let slot = match last {
            None => 0,
            Some((ns, slot)) => {
                let x = (f.ns - ns) as f64 / NS * fps;
                let n = x.round();
                let tol = 0.25 + f.resolution_ns as f64 / NS * fps;
                if n < 1.0 || (x - n).abs() > tol {
                    faults.push(Fault {
                        file: Some(f.file),
                        camera: Some(cam.camera),
                        dwell: None,
                        capture: None,
                        reason: format!(
                            "frame time off camera {}'s frame clock: {:.3} frame periods after \
                             the previous frame",
                            cam.camera, x
                        ),
                        related: Vec::new(),
                    });
                    continue;
                }
                slot + n as i64
            }
        };
        by_slot.insert(slot, i);
        last = Some((f.ns, slot));
    }
    Stream {
        camera: cam.camera,
        frames: cam.frames.clone(),
        by_slot,
    }
}

impl Stream {
    fn file(&self, slot: i64) -> Option<usize> {
        self.by_slot.get(&slot).map(|&i| self.frames[i].file)
    }

    fn time_s(&self, slot: i64) -> Option<f64> {
        let first = self.frames.first()?.ns;
        self.by_slot
            .get(&slot)
            .map(|&i| (self.frames[i].ns - first) as f64 / NS)
    }
}

/// What the steps of continuous placement share: the frame counts of a stay,
/// the stillness bound and the decoded blobs.
struct Sampling<'a> {
    /// Dwells of the program.
    dwells: usize,
    /// Frames per instant.
    captures: u32,
    /// `⌈settle_s·fps⌉`: frames from a dwell's arrival to its first capture.
    settle_frames: i64,
    /// One frame in `stride` is sampled: three samples in the shortest stay.
    stride: i64,
    /// `still_px`: blobs within this of rest are still (`None`: measured per camera).
    still_px: Option<f64>,
    /// Blobs of the frames decoded so far.
    cache: Cache<'a>,
}

impl<'a> Sampling<'a> {
    /// `stride = ⌊(⌈settle_s·fps⌉ + captures) / 3⌋`, at least 1.
    fn new(
        dwells: usize,
        captures: u32,
        (settle_s, fps): (f64, f64),
        still_px: Option<f64>,
        source: &'a dyn Signatures,
    ) -> Self {
        let settle_frames = (settle_s * fps - 1e-9).ceil().max(0.0) as i64;
        let stay_frames = settle_frames + i64::from(captures);
        let stride = (stay_frames / 3).max(1);
        Self {
            dwells,
            captures,
            settle_frames,
            stride,
            still_px,
            cache: Cache {
                source,
                seen: Mutex::new(HashMap::new()),
            },
        }
    }
}

/// One camera's stays matched to dwells, and how much slower than programmed
/// its alignment found the campaign.
struct CameraStays {
    camera: u8,
    found: Found,
    scale: f64,
    /// The largest still bound of a blob measure (px).
    still_px: f64,
}

/// The cameras on the reference camera's frame clock: what the instants are
/// placed from.
struct OnReference<'a> {
    streams: &'a [Stream],
    /// Camera → its stays matched to dwells.
    found: BTreeMap<u8, &'a Found>,
    /// Camera → its slot offset from the reference camera (only the cameras put on its clock).
    offsets: BTreeMap<u8, i64>,
}

/// Place the frames of continuous capture.
pub fn place_continuous(
    cameras: &[CameraFrames],
    dwells: &[Dwell],
    captures: u32,
    settle_s: f64,
    fps: f64,
    source: &dyn Signatures,
    params: &ContinuousParams,
) -> Placed {
    let mut placed = Placed::default();
    let sampling = Sampling::new(
        dwells.len(),
        captures,
        (settle_s, fps),
        params.still_px,
        source,
    );
    let program: Vec<f64> = dwells.iter().map(|d| d.time_s).collect();
    let streams = camera_streams(cameras, fps, &mut placed);

    // Per camera: sampled stays, aligned with the program, arrivals refined.
    let per_camera: Vec<CameraStays> = streams
        .par_iter()
        .map(|s| camera_stays(s, &program, &sampling, &params.align))
        .collect();
    for c in &per_camera {
        placed.scales.push((c.camera, c.scale));
        placed.still_px.push((c.camera, c.still_px));
    }

    // Offsets of the cameras' slots from the reference camera's.
    let found: BTreeMap<u8, &Found> = per_camera.iter().map(|c| (c.camera, &c.found)).collect();
    let Some(offsets) = slot_offsets(&found, &streams, &mut placed) else {
        return placed;
    };
    let on_reference = OnReference {
        streams: &streams,
        found,
        offsets,
    };

    // Arrivals on the reference clock; the instants; the check that the table stays still.
    for (j, d) in dwells.iter().enumerate() {
        on_reference.place_instant(j, d, &sampling, &mut placed);
    }

    // The frames that failed: none of a fault's frames is placed.
    unreadable_frames(&streams, &sampling.cache, &mut placed);
    placed.decoded = sampling.cache.decoded();
    let bad: BTreeSet<usize> = placed.faults.iter().filter_map(|f| f.file).collect();
    placed.placements.retain(|p| !bad.contains(&p.file));
    placed
        .placements
        .sort_by_key(|p| (p.dwell, p.capture, p.camera));
    placed
}

/// Each camera's stream on the frame clock; a camera without frames is a fault.
fn camera_streams(cameras: &[CameraFrames], fps: f64, placed: &mut Placed) -> Vec<Stream> {
    let mut streams = Vec::new();
    for cam in cameras {
        if cam.frames.is_empty() {
            placed.faults.push(Fault {
                file: None,
                camera: Some(cam.camera),
                dwell: None,
                capture: None,
                reason: format!("camera {} has no frames", cam.camera),
                related: Vec::new(),
            });
            continue;
        }
        streams.push(stream(cam, fps, &mut placed.faults));
    }
    streams
}

/// One camera's sampled stays aligned with the program's dwells, each
/// matched one with its arrival refined.
fn camera_stays(
    s: &Stream,
    program: &[f64],
    sampling: &Sampling<'_>,
    params: &AlignParams,
) -> CameraStays {
    let Some((stays, still)) = sampled_stays(s, sampling) else {
        return CameraStays {
            camera: s.camera,
            found: BTreeMap::new(),
            scale: 1.0,
            still_px: 0.0,
        };
    };
    let (found, scale) = matched_arrivals(s, &stays, program, sampling, params);
    CameraStays {
        camera: s.camera,
        found,
        scale,
        still_px: still.largest_px(),
    }
}

/// Candidate stays: runs of samples (one frame in `stride`) whose blobs stay
/// within the camera's still bound of the run's first sample, and the bound.
/// `None` for a stream without slots.
fn sampled_stays(s: &Stream, sampling: &Sampling<'_>) -> Option<(Vec<Stay>, Arc<StillBound>)> {
    let stride = sampling.stride;
    let (lo, hi) = match (s.by_slot.keys().next(), s.by_slot.keys().next_back()) {
        (Some(&a), Some(&b)) => (a, b),
        _ => return None,
    };
    let samples: Vec<i64> = (0..)
        .map(|k| lo + k * stride)
        .take_while(|&slot| slot <= hi)
        .filter_map(|slot| s.by_slot.range(slot..slot + stride).next().map(|(k, _)| *k))
        .collect();
    let spots: Vec<Option<Vec<Spot>>> = samples
        .par_iter()
        .map(|&slot| s.file(slot).and_then(|f| sampling.cache.get(f).ok()))
        .collect();
    let still = Arc::new(match sampling.still_px {
        Some(px) => StillBound::Fixed(px),
        None => StillBound::measured(&spots, sampling.dwells),
    });
    let mut stays: Vec<Stay> = Vec::new();
    let mut run: Option<(usize, usize)> = None;
    let close = |run: Option<(usize, usize)>, stays: &mut Vec<Stay>| {
        if let Some((a, b)) = run
            && b > a
            && let Some(anchor) = spots[a].clone()
        {
            stays.push(Stay {
                first_sample: samples[a],
                before: a.checked_sub(1).map(|p| samples[p]),
                anchor,
                still: Arc::clone(&still),
            });
        }
    };
    for k in 0..samples.len() {
        match (&run, &spots[k]) {
            (Some((a, _)), Some(sp))
                if spots[*a]
                    .as_ref()
                    .is_some_and(|an| still.distance(an, sp) <= 1.0) =>
            {
                run = run.map(|(a, _)| (a, k));
            }
            (_, Some(_)) => {
                close(run, &mut stays);
                run = Some((k, k));
            }
            (_, None) => {
                close(run, &mut stays);
                run = None;
            }
        }
    }
    close(run, &mut stays);
    Some((stays, still))
}

/// The stays aligned with the program's dwells (ambiguous ones left out),
/// each with its arrival refined; and the alignment's scale.
fn matched_arrivals(
    s: &Stream,
    stays: &[Stay],
    program: &[f64],
    sampling: &Sampling<'_>,
    params: &AlignParams,
) -> (Found, f64) {
    let captures = sampling.captures;
    let events: Vec<Event> = stays
        .iter()
        .filter_map(|st| {
            Some(Event {
                time_s: s.time_s(st.first_sample)?,
                size: captures as usize,
                // Still from the first frame on: its arrival was not recorded (the
                // rest before the first move), and its time is not one.
                irregular: st.before.is_none(),
            })
        })
        .collect();
    let a = align(&events, program, captures as usize, params);
    let ambiguous: BTreeSet<usize> = a.ambiguous.iter().map(|x| x.event).collect();
    let mut found = BTreeMap::new();
    for (e, st) in stays.iter().enumerate() {
        let Some(j) = a.dwell_of[e] else { continue };
        if ambiguous.contains(&e) {
            continue;
        }
        let arrival = refine(s, st, sampling);
        found.insert(j, (arrival, st.clone()));
    }
    (found, a.scale)
}

/// The most frequent difference of the arrival slots of cameras `c` and `r`
/// at the same dwells (sharp arrivals only, or all), when it has at least 3
/// votes and a majority.
fn voted_offset(found: &BTreeMap<u8, &Found>, c: u8, r: u8, sharp_only: bool) -> Option<i64> {
    let (fc, fr) = (found.get(&c)?, found.get(&r)?);
    let mut votes: BTreeMap<i64, usize> = BTreeMap::new();
    let mut total = 0;
    for (j, (a, _)) in fc.iter() {
        if let Some((b, _)) = fr.get(j)
            && (!sharp_only || (a.sharp && b.sharp))
        {
            *votes.entry(a.slot - b.slot).or_default() += 1;
            total += 1;
        }
    }
    let (&d, &n) = votes
        .iter()
        .max_by_key(|(d, n)| (**n, std::cmp::Reverse(**d)))?;
    (n >= 3 && 2 * n > total).then_some(d)
}

/// Each camera's slot offset from the reference camera (the one with the
/// most sharp arrivals): directly, else through the third camera; a camera
/// with none has its frames as faults. `None` when there is no camera.
fn slot_offsets(
    found: &BTreeMap<u8, &Found>,
    streams: &[Stream],
    placed: &mut Placed,
) -> Option<BTreeMap<u8, i64>> {
    let reference = found
        .iter()
        .max_by_key(|(c, f)| {
            (
                f.values().filter(|(a, _)| a.sharp).count(),
                std::cmp::Reverse(**c),
            )
        })
        .map(|(c, _)| *c)?;
    let mut offsets: BTreeMap<u8, i64> = BTreeMap::new();
    offsets.insert(reference, 0);
    let pair =
        |c: u8, r: u8| voted_offset(found, c, r, true).or_else(|| voted_offset(found, c, r, false));
    for s in streams {
        let c = s.camera;
        if c == reference {
            continue;
        }
        let direct = pair(c, reference);
        let via = || {
            streams
                .iter()
                .map(|k| k.camera)
                .filter(|&k| k != c && k != reference)
                .find_map(|k| {
                    let a = pair(c, k)?;
                    let b = pair(k, reference)?;
                    Some(a + b)
                })
        };
        match direct.or_else(via) {
            Some(o) => {
                offsets.insert(c, o);
            }
            None => {
                placed.fault_frames(
                    &s.frames,
                    c,
                    None,
                    &format!(
                        "camera {c}'s frames cannot be put on camera {reference}'s frame \
                         clock: too few of the dwells found in both line up"
                    ),
                );
            }
        }
    }
    Some(offsets)
}

impl OnReference<'_> {
    /// Dwell `j`'s instant: its arrival on the reference clock, the check
    /// that the table is still through the last capture, each camera's
    /// frames at the captures; or the fault that prevents it.
    fn place_instant(&self, j: usize, d: &Dwell, sampling: &Sampling<'_>, placed: &mut Placed) {
        let captures = sampling.captures;
        let Some((judge, stay, arrival)) = self.arrival(j) else {
            placed.faults.push(Fault {
                file: None,
                camera: None,
                dwell: Some(j),
                capture: None,
                reason: format!(
                    "dwell {} not found in any camera's images (no stay of the spheres lines up \
                     with it)",
                    describe(d)
                ),
                related: Vec::new(),
            });
            return;
        };
        let first = arrival + sampling.settle_frames;
        let last = first + i64::from(captures) - 1;
        // The table must still be at rest at the last capture (in the judging camera).
        if self.moved_again(judge, stay, last, sampling) {
            placed.faults.push(Fault {
                file: None,
                camera: Some(judge),
                dwell: Some(j),
                capture: Some(captures),
                reason: format!(
                    "dwell {}: the spheres move again before the last capture, {} frames after \
                     the arrival (settle_s and the captures do not fit in the stay)",
                    describe(d),
                    sampling.settle_frames + i64::from(captures) - 1
                ),
                related: Vec::new(),
            });
            return;
        }
        self.take_captures(j, d, first, captures, placed);
    }

    /// Dwell `j`'s arrival slot on the reference clock: the latest of the
    /// cameras' sharp arrivals (of all, when none is sharp), with the camera
    /// that judges it and its stay.
    fn arrival(&self, j: usize) -> Option<(u8, &Stay, i64)> {
        let candidates: Vec<(u8, Arrival, &Stay)> = self
            .found
            .iter()
            .filter(|(c, _)| self.offsets.contains_key(c))
            .filter_map(|(c, f)| f.get(&j).map(|(a, st)| (*c, *a, st)))
            .collect();
        let sharp: Vec<&(u8, Arrival, &Stay)> =
            candidates.iter().filter(|(_, a, _)| a.sharp).collect();
        let chosen: Vec<&(u8, Arrival, &Stay)> = if sharp.is_empty() {
            candidates.iter().collect()
        } else {
            sharp
        };
        let &&(judge, a, stay) = chosen
            .iter()
            .max_by_key(|(c, a, _)| (a.slot - self.offsets[c], std::cmp::Reverse(*c)))?;
        Some((judge, stay, a.slot - self.offsets[&judge]))
    }

    /// Whether the camera `judge` sees the spheres away from its stay's rest
    /// at slot `last` of the reference clock (unknown frames: not moved).
    fn moved_again(&self, judge: u8, stay: &Stay, last: i64, sampling: &Sampling<'_>) -> bool {
        let judge_stream = self.streams.iter().find(|s| s.camera == judge);
        let at_rest = judge_stream
            .and_then(|s| s.file(last + self.offsets[&judge]))
            .map(|f| {
                sampling
                    .cache
                    .get(f)
                    .map(|sp| stay.away_from_rest(&sp) <= 1.0)
            });
        matches!(at_rest, Some(Ok(false)))
    }

    /// Each camera's frames at the `captures` slots from `first` (reference
    /// clock); a missing one is a dropped frame.
    fn take_captures(&self, j: usize, d: &Dwell, first: i64, captures: u32, placed: &mut Placed) {
        for s in self.streams {
            let Some(o) = self.offsets.get(&s.camera) else {
                continue;
            };
            for k in 0..captures {
                let slot = first + i64::from(k) + o;
                match s.file(slot) {
                    Some(file) => placed.placements.push(Placement {
                        file,
                        camera: s.camera,
                        dwell: j,
                        capture: k + 1,
                    }),
                    None => placed.faults.push(Fault {
                        file: None,
                        camera: Some(s.camera),
                        dwell: Some(j),
                        capture: Some(k + 1),
                        reason: format!(
                            "instant {} capture {} has no frame of camera {} (its stream has no \
                             frame at that time: a dropped frame)",
                            describe(d),
                            k + 1,
                            s.camera
                        ),
                        related: Vec::new(),
                    }),
                }
            }
        }
    }
}

/// The frames whose blobs could not be read, as faults of their cameras.
fn unreadable_frames(streams: &[Stream], cache: &Cache<'_>, placed: &mut Placed) {
    for (file, why) in cache.failed() {
        let camera = streams
            .iter()
            .find(|s| s.frames.iter().any(|f| f.file == file))
            .map(|s| s.camera);
        placed.faults.push(Fault {
            file: Some(file),
            camera,
            dwell: None,
            capture: None,
            reason: format!("blobs unreadable: {why}"),
            related: Vec::new(),
        });
    }
}

/// The first still slot of a stay, by bisection between the moving sample
/// before it and its first still sample.
fn refine(s: &Stream, st: &Stay, sampling: &Sampling<'_>) -> Arrival {
    let (stride, cache) = (sampling.stride, &sampling.cache);
    let lo = st.before.unwrap_or(st.first_sample - stride);
    let between: Vec<i64> = s
        .by_slot
        .range(lo + 1..st.first_sample)
        .map(|(k, _)| *k)
        .collect();
    let dist = |slot: i64| -> f64 {
        s.file(slot)
            .and_then(|f| cache.get(f).ok())
            .map_or(f64::INFINITY, |sp| st.away_from_rest(&sp))
    };
    // Smallest index whose frame is at rest (still frames follow moving ones).
    let (mut a, mut b) = (0usize, between.len());
    while a < b {
        let mid = (a + b) / 2;
        if dist(between[mid]) <= 1.0 {
            b = mid;
        } else {
            a = mid + 1;
        }
    }
    let slot = between.get(a).copied().unwrap_or(st.first_sample);
    let previous = if a > 0 {
        Some(between[a - 1])
    } else {
        st.before.filter(|&p| p < slot)
    };
    let sharp = previous.is_some_and(|p| dist(p) >= 3.0);
    Arrival { slot, sharp }
}

#[cfg(test)]
mod tests {
    use super::*;
    use formats::{Axis, AxisProcedure, ProcedureConfig};

    /// The program and a renderer-like timeline: moves 15 % slow, ending
    /// half-way between frames; the instant `⌈settle·fps⌉` frames after arrival.
    struct World {
        dwells: Vec<Dwell>,
        captures: u32,
        fps: f64,
        settle: f64,
        /// Per slot: the table's x (mm).
        x: BTreeMap<i64, f64>,
        /// Per dwell: the true instant slots.
        instants: Vec<i64>,
    }

    fn world() -> World {
        let p = ProcedureConfig {
            axes: vec![AxisProcedure {
                axis: Axis::X,
                start_mm: 0.0,
                length_mm: 20.0,
                segments: 2,
                lines_mm: vec![0.0],
            }],
            runs: 2,
            captures: 2,
            overshoot_mm: 5.0,
            fps: 20.0,
            feed_mm_per_s: 20.0,
            settle_s: 0.2,
            start_time: String::new(),
        };
        let dwells = p.dwells();
        let period = 1.0 / p.fps;
        let settle_frames = (p.settle_s * p.fps - 1e-9).ceil() as i64;
        let mut x = BTreeMap::new();
        let mut instants = Vec::new();
        let mut slot = -5i64;
        let mut pos = -5.0;
        for d in &dwells {
            // Move to the dwell (through its path) at 20/1.15 mm/s, sampled per slot.
            let mut path = vec![pos];
            path.extend(d.path.iter().map(|q| q[0]));
            let length: f64 = path.windows(2).map(|w| (w[1] - w[0]).abs()).sum();
            let t0 = slot as f64 * period;
            let dur = length / 20.0 * 1.15;
            let k_s = ((t0 + dur) / period + 0.5).ceil() as i64;
            let arrive = (k_s as f64 - 0.5) * period;
            while slot < k_s {
                let f = ((slot as f64 * period - t0) / (arrive - t0)).clamp(0.0, 1.0);
                let mut along = f * length;
                let mut at = path[0];
                for w in path.windows(2) {
                    let l = (w[1] - w[0]).abs();
                    if along <= l {
                        at = w[0] + (w[1] - w[0]).signum() * along;
                        break;
                    }
                    along -= l;
                    at = w[1];
                }
                x.insert(slot, at);
                slot += 1;
            }
            instants.push(k_s + settle_frames);
            let last = k_s + settle_frames + i64::from(p.captures) - 1;
            while slot <= last {
                x.insert(slot, d.nominal[0]);
                slot += 1;
            }
            pos = d.nominal[0];
        }
        for _ in 0..5 {
            x.insert(slot, pos);
            slot += 1;
        }
        World {
            dwells,
            captures: p.captures,
            fps: p.fps,
            settle: p.settle_s,
            x,
            instants,
        }
    }

    /// Blobs of the world's frames: camera `c` sees the spheres move
    /// `gains[c]` px per mm of X, each measure with Gaussian noise of
    /// `noise_px` (deterministic per file and measure).
    struct Blobs {
        x: Vec<f64>,
        gains: [f64; 3],
        noise_px: f64,
    }

    /// A standard normal number drawn from `(file, measure)` (splitmix64, Box–Muller).
    fn gaussian(file: usize, measure: u64) -> f64 {
        let mix = |mut z: u64| {
            z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        let key = (file as u64) << 8 | measure;
        let uniform = |z: u64| ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
        let (a, b) = (uniform(mix(2 * key)), uniform(mix(2 * key + 1)));
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }

    impl Signatures for Blobs {
        fn spots(&self, file: usize) -> Result<Vec<Spot>, String> {
            let n = self.x.len();
            let (camera, slot) = (file / n, file % n);
            let x = self.x[slot];
            let gain = self.gains[camera];
            let noise = |m: u64| self.noise_px * gaussian(file, m);
            Ok(vec![
                Spot {
                    u: 100.0 + gain * x + noise(0),
                    v: 80.0 + noise(1),
                    diameter: 20.0 + noise(2),
                },
                Spot {
                    u: 40.0 + gain * x + noise(3),
                    v: 50.0 + noise(4),
                    diameter: 10.0 + noise(5),
                },
            ])
        }
    }

    /// The world's frames in three cameras whose clocks are seconds apart;
    /// file `c·n + i` is camera `c + 1`'s frame at the `i`-th slot.
    fn cameras(w: &World) -> Vec<CameraFrames> {
        let offsets = [0.0, 7.31, -2.77];
        let n = w.x.len();
        (0..3)
            .map(|c| CameraFrames {
                camera: c as u8 + 1,
                frames: w
                    .x
                    .keys()
                    .enumerate()
                    .map(|(i, &k)| TimedFrame {
                        file: c * n + i,
                        ns: ((offsets[c] + k as f64 / w.fps) * NS).round() as i64,
                        resolution_ns: 100_000,
                    })
                    .collect(),
            })
            .collect()
    }

    /// The world's frames placed, with the default settings.
    fn place(w: &World, blobs: &Blobs) -> Placed {
        place_continuous(
            &cameras(w),
            &w.dwells,
            w.captures,
            w.settle,
            w.fps,
            blobs,
            &ContinuousParams::default(),
        )
    }

    /// Every camera's frames at every instant, each at the true slot.
    fn assert_true_instants(w: &World, p: &Placed) {
        assert!(p.faults.is_empty(), "{:?}", p.faults);
        assert_eq!(p.placements.len(), w.dwells.len() * 2 * 3);
        let (n, first) = (w.x.len(), w.x.keys().next().copied().unwrap_or(0));
        for pl in &p.placements {
            let slot = (pl.file % n) as i64 + first;
            assert_eq!(
                slot,
                w.instants[pl.dwell] + i64::from(pl.capture) - 1,
                "{pl:?}"
            );
        }
    }

    /// Camera 1 looks along X: an off-axis sphere moves 0.3 px per mm, cameras 2 and 3 see
    /// 1 px per mm; no noise.
    #[test]
    fn instants_are_found_through_the_cameras_that_see_the_motion() {
        let w = world();
        let blobs = Blobs {
            x: w.x.values().copied().collect(),
            gains: [0.3, 1.0, 1.0],
            noise_px: 0.0,
        };
        let p = place(&w, &blobs);
        assert_true_instants(&w, &p);
    }

    /// A small image at a high frame rate (as a 512-px image at 240 fps):
    /// every camera sees the last frame in motion 0.08 px from rest, every
    /// measure scatters 0.002 px. The still bound follows the noise, not a
    /// pixel size: every arrival is found to the frame (a bound of 0.1 px
    /// takes the last frame in motion for still).
    #[test]
    fn arrivals_a_tenth_of_a_pixel_from_rest_are_found_above_the_noise() {
        let w = world();
        let blobs = Blobs {
            x: w.x.values().copied().collect(),
            gains: [0.18; 3],
            noise_px: 0.002,
        };
        let p = place(&w, &blobs);
        assert_true_instants(&w, &p);
        // The bound: 6σ of the difference of two frames, 6·√2·0.002 = 0.017 px,
        // each camera's largest of 6 measures estimated from about 30 still pairs.
        for (c, e) in &p.still_px {
            assert!((0.012..0.034).contains(e), "camera {c}: {e}");
        }
    }
}
