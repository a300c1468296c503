//! Triggered capture: the cameras expose `captures` frames `1/fps` apart at
//! each dwell. Per camera the frame times are cut into bursts (a gap longer
//! than a burst can have, shorter than the program's shortest stop between
//! dwells), the bursts are aligned with the program's dwells
//! ([`crate::align`]), and the frames of each burst get their capture
//! number from their place on the burst's `1/fps` grid. Where a burst is not
//! complete, the grid comes from another camera's complete burst at the same
//! dwell through the two clocks' offset, measured at the nearest dwells both
//! captured completely (clocks drift; the offset is local). Every frame that
//! cannot be placed this way is a [`Fault`] with the reason; nothing is
//! placed by guess.
//!
//! Pure: takes `(camera, file, time)` lists, returns placements and faults.

use std::collections::{BTreeMap, BTreeSet};

use formats::Dwell;

use crate::align::{AlignParams, Alignment, Event, align};
use crate::{IngestError, Result};

/// A frame on its camera's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimedFrame {
    /// The caller's index of the file.
    pub file: usize,
    /// Time of exposure (ns, camera clock).
    pub ns: i64,
    /// Resolution of the time stamp (ns).
    pub resolution_ns: i64,
}

/// The frames of one camera, in increasing time (ties in the caller's file order).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraFrames {
    /// Camera number.
    pub camera: u8,
    /// Its frames.
    pub frames: Vec<TimedFrame>,
}

/// A frame placed at an instant of the program.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Placement {
    /// The caller's index of the file.
    pub file: usize,
    /// Camera number.
    pub camera: u8,
    /// Dwell index in the program.
    pub dwell: usize,
    /// Capture at the dwell (≥ 1).
    pub capture: u32,
}

/// Something that could not be placed, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Fault {
    /// The file, when one is at fault.
    pub file: Option<usize>,
    /// The camera, when one is concerned.
    pub camera: Option<u8>,
    /// The dwell concerned, when known.
    pub dwell: Option<usize>,
    /// The capture concerned, when known.
    pub capture: Option<u32>,
    /// What is wrong.
    pub reason: String,
    /// Files that bear on it (e.g. the rest of a burst that lost a frame).
    pub related: Vec<usize>,
}

/// Placements and faults.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Placed {
    /// Frames at their instants.
    pub placements: Vec<Placement>,
    /// Everything left out, with the reason.
    pub faults: Vec<Fault>,
    /// Per camera, the slowness of the campaign its alignment found.
    pub scales: Vec<(u8, f64)>,
    /// Frames whose pixels were decoded (continuous capture).
    pub decoded: usize,
    /// Continuous: per camera, the largest still bound of a blob measure (px).
    pub still_px: Vec<(u8, f64)>,
}

/// A dwell in words: `X line 1 run 2 + target 3`.
pub fn describe(d: &Dwell) -> String {
    format!(
        "{} line {} run {} {} target {}",
        d.axis,
        d.line + 1,
        d.run,
        d.direction,
        d.target
    )
}

/// How a program's frames are told apart in time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BurstTiming {
    /// Longest gap inside a burst (s): its whole span plus half a period.
    pub within_s: f64,
    /// Shortest programmed stop from one dwell's last capture to the next
    /// one's first (s).
    pub between_s: f64,
    /// Gaps longer than this separate bursts (s): the geometric mean of
    /// `within_s` and half of `between_s`.
    pub cut_s: f64,
}

/// The burst timing of a program, or why its bursts cannot be told apart.
pub fn burst_timing(dwells: &[Dwell], captures: u32, fps: f64) -> Result<BurstTiming> {
    let span = f64::from(captures.saturating_sub(1)) / fps;
    let within_s = span + 0.5 / fps;
    let between_s = dwells
        .windows(2)
        .map(|w| w[1].time_s - w[0].time_s - span)
        .fold(f64::INFINITY, f64::min);
    if !between_s.is_finite() {
        return Ok(BurstTiming {
            within_s,
            between_s,
            cut_s: 4.0 * within_s,
        });
    }
    if within_s >= 0.5 * between_s {
        return Err(IngestError::BurstsOverlap {
            between_s,
            captures,
            fps,
            span_s: span,
        });
    }
    Ok(BurstTiming {
        within_s,
        between_s,
        cut_s: (within_s * 0.5 * between_s).sqrt(),
    })
}

/// Cut time-ordered frames into bursts at gaps longer than `cut_ns`.
pub fn cut_bursts(frames: &[TimedFrame], cut_ns: i64) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=frames.len() {
        if i == frames.len() || frames[i].ns - frames[i - 1].ns > cut_ns {
            if i > start {
                out.push(start..i);
            }
            start = i;
        }
    }
    out
}

const NS: f64 = 1e9;

/// A matched burst.
#[derive(Debug, Clone)]
struct Burst {
    frames: Vec<TimedFrame>,
}

impl Placed {
    /// The same fault for every frame of a burst of camera `camera`.
    pub(crate) fn fault_frames<'a>(
        &mut self,
        frames: impl IntoIterator<Item = &'a TimedFrame>,
        camera: u8,
        dwell: Option<usize>,
        reason: &str,
    ) {
        for f in frames {
            self.faults.push(Fault {
                file: Some(f.file),
                camera: Some(camera),
                dwell,
                capture: None,
                reason: reason.to_string(),
                related: Vec::new(),
            });
        }
    }
}

/// Place the frames of triggered capture.
pub fn place_triggered(
    cameras: &[CameraFrames],
    dwells: &[Dwell],
    captures: u32,
    fps: f64,
    params: &AlignParams,
) -> Result<Placed> {
    let timing = burst_timing(dwells, captures, fps)?;
    let period = 1.0 / fps;
    let cut_ns = (timing.cut_s * NS) as i64;
    let program: Vec<f64> = dwells.iter().map(|d| d.time_s).collect();
    let mut placed = Placed::default();
    // (camera, dwell) → its burst.
    let mut bursts: BTreeMap<(u8, usize), Burst> = BTreeMap::new();
    for cam in cameras {
        let Some(first) = cam.frames.first() else {
            continue;
        };
        if stamps_too_coarse(cam, timing.cut_s, &mut placed) {
            continue;
        }
        // The camera's bursts aligned with the program's dwells.
        let ranges = cut_bursts(&cam.frames, cut_ns);
        let events: Vec<Event> = ranges
            .iter()
            .map(|r| Event {
                time_s: (cam.frames[r.start].ns - first.ns) as f64 / NS,
                size: r.len(),
                irregular: !on_grid(&cam.frames[r.clone()], period),
            })
            .collect();
        let a = align(&events, &program, captures as usize, params);
        placed.scales.push((cam.camera, a.scale));
        match_bursts(cam, &ranges, &a, dwells, &mut bursts, &mut placed);
    }
    assign_captures(&bursts, dwells, captures, period, &mut placed);
    report_missing(cameras, &bursts, dwells, captures, &mut placed);
    placed
        .placements
        .sort_by_key(|p| (p.dwell, p.capture, p.camera));
    Ok(placed)
}

/// Whether the camera's time stamps resolve more coarsely than half the gap
/// that tells bursts apart (its frames then faults).
fn stamps_too_coarse(cam: &CameraFrames, cut_s: f64, placed: &mut Placed) -> bool {
    let c = cam.camera;
    let resolution = cam
        .frames
        .iter()
        .map(|f| f.resolution_ns)
        .max()
        .unwrap_or(0);
    if resolution as f64 / NS > 0.5 * cut_s {
        placed.fault_frames(
            &cam.frames,
            c,
            None,
            &format!(
                "camera {c}'s time stamps resolve only {} s: bursts {:.4} s apart \
                 cannot be told apart",
                resolution as f64 / NS,
                cut_s
            ),
        );
        return true;
    }
    false
}

/// Each burst of the camera (`ranges` of its frames) at the dwell the
/// alignment `a` matched it to; an ambiguous or unmatched burst's frames are faults.
fn match_bursts(
    cam: &CameraFrames,
    ranges: &[std::ops::Range<usize>],
    a: &Alignment,
    dwells: &[Dwell],
    bursts: &mut BTreeMap<(u8, usize), Burst>,
    placed: &mut Placed,
) {
    let c = cam.camera;
    let ambiguous: BTreeMap<usize, _> = a.ambiguous.iter().map(|x| (x.event, *x)).collect();
    for (e, r) in ranges.iter().enumerate() {
        let frames = &cam.frames[r.clone()];
        if let Some(x) = ambiguous.get(&e) {
            let name = |d: Option<usize>| {
                d.map_or("no dwell (a stray)".to_string(), |j| {
                    format!("dwell {}", describe(&dwells[j]))
                })
            };
            placed.fault_frames(
                frames,
                c,
                x.chosen,
                &format!(
                    "burst of {} frame(s) cannot be matched to the program unambiguously: \
                     {} or {} (costs differ by {:.1})",
                    frames.len(),
                    name(x.chosen),
                    name(x.alternative),
                    x.margin
                ),
            );
            continue;
        }
        match a.dwell_of[e] {
            Some(j) => {
                bursts.insert(
                    (c, j),
                    Burst {
                        frames: frames.to_vec(),
                    },
                );
            }
            None => {
                let before = (0..e).rev().find_map(|k| a.dwell_of[k]);
                let after = (e + 1..ranges.len()).find_map(|k| a.dwell_of[k]);
                let place = match (before, after) {
                    (Some(b), Some(n)) => format!(
                        "between the captures of {} and {}",
                        describe(&dwells[b]),
                        describe(&dwells[n])
                    ),
                    (Some(b), None) => {
                        format!("after the captures of {}", describe(&dwells[b]))
                    }
                    (None, Some(n)) => {
                        format!("before the captures of {}", describe(&dwells[n]))
                    }
                    (None, None) => "with no burst of this camera matched".into(),
                };
                placed.fault_frames(
                    frames,
                    c,
                    None,
                    &format!(
                        "frame in no dwell (a stray trigger?): a burst of {} frame(s) {place}",
                        frames.len()
                    ),
                );
            }
        }
    }
}

/// Whether frames lie on a `1/fps` grid: every gap a whole number (≥ 1) of
/// periods, within the tolerance (time stamps too coarse to tell pass).
fn on_grid(frames: &[TimedFrame], period: f64) -> bool {
    let tol = tolerance_ns(period, frames) as f64 / NS;
    frames.windows(2).all(|w| {
        let gap = (w[1].ns - w[0].ns) as f64 / NS;
        let n = (gap / period).round();
        gap + tol >= 0.75 * period && (gap - n * period).abs() <= tol
            || w[1].resolution_ns.max(w[0].resolution_ns) as f64 / NS > 0.25 * period
    })
}

/// Tolerance (ns) of a frame's place on a burst's grid.
fn tolerance_ns(period: f64, frames: &[TimedFrame]) -> i64 {
    let res = frames.iter().map(|f| f.resolution_ns).max().unwrap_or(0);
    (0.25 * period * NS) as i64 + res
}

/// The first capture's time of a complete, regular burst.
fn regular_start(b: &Burst, captures: u32, period: f64) -> Option<i64> {
    if b.frames.len() != captures as usize {
        return None;
    }
    let tol = tolerance_ns(period, &b.frames);
    let p = (period * NS) as i64;
    b.frames
        .windows(2)
        .all(|w| (w[1].ns - w[0].ns - p).abs() <= tol)
        .then(|| b.frames[0].ns)
}

fn median_i64(mut v: Vec<i64>) -> Option<i64> {
    v.sort_unstable();
    let n = v.len();
    (n > 0).then(|| {
        if n % 2 == 1 {
            v[n / 2]
        } else {
            v[n / 2 - 1] + (v[n / 2] - v[n / 2 - 1]) / 2
        }
    })
}

/// Offset of camera `c`'s clock from camera `r`'s near dwell `j`: the median
/// of the differences of the first captures of the (up to) 8 nearest dwells
/// both captured completely.
fn local_offset(starts: &BTreeMap<(u8, usize), i64>, c: u8, r: u8, j: usize) -> Option<i64> {
    let mut common: Vec<(usize, i64)> = starts
        .iter()
        .filter(|((cam, _), _)| *cam == c)
        .filter_map(|((_, d), t)| starts.get(&(r, *d)).map(|u| (*d, t - u)))
        .collect();
    common.sort_by_key(|(d, _)| (d.abs_diff(j), *d));
    median_i64(common.iter().take(8).map(|(_, o)| *o).collect())
}

/// Whether a burst's time stamps resolve more coarsely than a quarter period.
fn coarse(b: &Burst, period: f64) -> bool {
    b.frames.iter().map(|f| f.resolution_ns).max().unwrap_or(0) as f64 / NS > 0.25 * period
}

/// What the capture numbers of the bursts are found from.
struct Grids<'a> {
    dwells: &'a [Dwell],
    captures: u32,
    period: f64,
    /// (camera, dwell) → the first capture's time of its complete, regular,
    /// finely stamped burst.
    starts: BTreeMap<(u8, usize), i64>,
    /// The cameras with bursts.
    cams: BTreeSet<u8>,
}

/// A burst of camera `camera` matched to dwell `dwell`.
struct BurstAt<'a> {
    camera: u8,
    dwell: usize,
    burst: &'a Burst,
    /// The burst in words, for its faults.
    what: String,
}

impl BurstAt<'_> {
    /// A fault of frame `f` of this burst (at capture `capture` when known).
    fn fault(&self, placed: &mut Placed, f: &TimedFrame, capture: Option<u32>, reason: String) {
        placed.faults.push(Fault {
            file: Some(f.file),
            camera: Some(self.camera),
            dwell: Some(self.dwell),
            capture,
            reason,
            related: Vec::new(),
        });
    }
}

/// Capture numbers of the matched bursts' frames, from each frame's place on
/// its burst's `1/fps` grid; the frames that have none are faults.
fn assign_captures(
    bursts: &BTreeMap<(u8, usize), Burst>,
    dwells: &[Dwell],
    captures: u32,
    period: f64,
    placed: &mut Placed,
) {
    let starts: BTreeMap<(u8, usize), i64> = bursts
        .iter()
        .filter(|(_, b)| !coarse(b, period))
        .filter_map(|(k, b)| regular_start(b, captures, period).map(|t| (*k, t)))
        .collect();
    let cams: BTreeSet<u8> = bursts.keys().map(|(c, _)| *c).collect();
    let grids = Grids {
        dwells,
        captures,
        period,
        starts,
        cams,
    };
    for (&(c, j), b) in bursts {
        let at = BurstAt {
            camera: c,
            dwell: j,
            burst: b,
            what: format!(
                "burst of {} frame(s) at {} (program: {captures} captures)",
                b.frames.len(),
                describe(&dwells[j])
            ),
        };
        if coarse(b, period) {
            grids.place_coarse(&at, placed);
            continue;
        }
        let tol = tolerance_ns(period, &b.frames);
        let Some(start) = grids.start(&at, tol, placed) else {
            continue;
        };
        grids.place_on_grid(&at, start, tol, placed);
    }
}

impl Grids<'_> {
    /// A coarsely stamped burst: its frames in order when it is complete,
    /// else all faults (which captures they are cannot be told).
    fn place_coarse(&self, at: &BurstAt<'_>, placed: &mut Placed) {
        let (c, j, b) = (at.camera, at.dwell, at.burst);
        if b.frames.len() == self.captures as usize {
            for (k, f) in b.frames.iter().enumerate() {
                placed.placements.push(Placement {
                    file: f.file,
                    camera: c,
                    dwell: j,
                    capture: k as u32 + 1,
                });
            }
        } else {
            for f in &b.frames {
                let reason = format!(
                    "{}: which captures these are cannot be told with time stamps \
                     resolving {} s",
                    at.what,
                    f.resolution_ns as f64 / NS
                );
                placed.fault_frames([f], c, Some(j), &reason);
            }
        }
    }

    /// The first capture's time of the burst's grid: its own (complete and
    /// regular), else another camera's complete burst at the same dwell
    /// through the local clock offset, else its own span when that is the
    /// full one. `None`, its frames faults, when they disagree or none is had.
    fn start(&self, at: &BurstAt<'_>, tol: i64, placed: &mut Placed) -> Option<i64> {
        let (c, j, b, what) = (at.camera, at.dwell, at.burst, &at.what);
        let (captures, period) = (self.captures, self.period);
        // The grid of this burst: from another camera's complete burst where there is one.
        let from_other = self.cams.iter().filter(|&&r| r != c).find_map(|&r| {
            let t = self.starts.get(&(r, j))?;
            Some((r, t + local_offset(&self.starts, c, r, j)?))
        });
        let own = self.starts.get(&(c, j)).copied();
        match (own, from_other) {
            (Some(o), Some((r, t))) if (o - t).abs() > tol => {
                placed.fault_frames(
                    &b.frames,
                    c,
                    Some(j),
                    &format!(
                        "{what}: its first frame is {:.4} s off camera {r}'s at the same \
                         dwell (clock offset taken from the nearest dwells)",
                        (o - t) as f64 / NS
                    ),
                );
                None
            }
            (Some(o), _) => Some(o),
            (None, Some((_, t))) => Some(t),
            (None, None) => {
                let span = b.frames.last().map_or(0, |l| l.ns) - b.frames[0].ns;
                let full = (f64::from(captures.saturating_sub(1)) * period * NS) as i64;
                if (span - full).abs() <= tol {
                    Some(b.frames[0].ns)
                } else {
                    placed.fault_frames(
                        &b.frames,
                        c,
                        Some(j),
                        &format!(
                            "{what}: which captures these are cannot be told (no other camera \
                             has a complete burst at this dwell)"
                        ),
                    );
                    None
                }
            }
        }
    }

    /// Each frame at its capture on the grid from `start`; a frame off the
    /// grid, or two at one capture, are faults.
    fn place_on_grid(&self, at: &BurstAt<'_>, start: i64, tol: i64, placed: &mut Placed) {
        let (c, j, b) = (at.camera, at.dwell, at.burst);
        let (captures, period, dwells) = (self.captures, self.period, self.dwells);
        let mut by_capture: BTreeMap<u32, Vec<&TimedFrame>> = BTreeMap::new();
        for f in &b.frames {
            let x = (f.ns - start) as f64 / NS / period;
            let k = x.round();
            let off = ((x - k) * period * NS).abs() as i64;
            if off > tol || k < 0.0 || k >= f64::from(captures) {
                at.fault(
                    placed,
                    f,
                    None,
                    format!(
                        "frame off the captures of {} (a stray trigger?): {:+.4} s from the \
                         first capture, {:.2} frame periods",
                        describe(&dwells[j]),
                        (f.ns - start) as f64 / NS,
                        x
                    ),
                );
                continue;
            }
            by_capture.entry(k as u32 + 1).or_default().push(f);
        }
        for (k, fs) in by_capture {
            if let [f] = fs.as_slice() {
                placed.placements.push(Placement {
                    file: f.file,
                    camera: c,
                    dwell: j,
                    capture: k,
                });
            } else {
                for f in fs {
                    at.fault(
                        placed,
                        f,
                        Some(k),
                        format!(
                            "two or more frames of camera {c} for capture {k} of {}",
                            describe(&dwells[j])
                        ),
                    );
                }
            }
        }
    }
}

/// Every instant that has frames but lacks a camera's.
fn report_missing(
    cameras: &[CameraFrames],
    bursts: &BTreeMap<(u8, usize), Burst>,
    dwells: &[Dwell],
    captures: u32,
    placed: &mut Placed,
) {
    let mut at: BTreeMap<(usize, u32), BTreeSet<u8>> = BTreeMap::new();
    for p in &placed.placements {
        at.entry((p.dwell, p.capture)).or_default().insert(p.camera);
    }
    let placing: BTreeSet<u8> = placed.placements.iter().map(|p| p.camera).collect();
    for cam in cameras {
        let c = cam.camera;
        if !placing.contains(&c) {
            placed.faults.push(Fault {
                file: None,
                camera: Some(c),
                dwell: None,
                capture: None,
                reason: if cam.frames.is_empty() {
                    format!("camera {c} has no frames")
                } else {
                    format!(
                        "none of camera {c}'s {} frames could be placed",
                        cam.frames.len()
                    )
                },
                related: Vec::new(),
            });
        }
    }
    for (j, d) in dwells.iter().enumerate() {
        for k in 1..=captures {
            let Some(present) = at.get(&(j, k)) else {
                continue;
            };
            for c in placing.iter().filter(|c| !present.contains(c)) {
                let (why, related) = match bursts.get(&(*c, j)) {
                    Some(b) => (
                        format!("its burst at this dwell has {} frame(s)", b.frames.len()),
                        b.frames.iter().map(|f| f.file).collect(),
                    ),
                    None => ("it has no burst placed at this dwell".into(), Vec::new()),
                };
                placed.faults.push(Fault {
                    file: None,
                    camera: Some(*c),
                    dwell: Some(j),
                    capture: Some(k),
                    reason: format!(
                        "instant {} capture {k} has no frame of camera {c} ({why})",
                        describe(d)
                    ),
                    related,
                });
            }
        }
    }
    let _ = captures;
}

#[cfg(test)]
mod tests {
    use super::*;
    use formats::{Axis, AxisProcedure, ProcedureConfig};

    fn program() -> (Vec<Dwell>, u32, f64) {
        let p = ProcedureConfig {
            axes: vec![AxisProcedure {
                axis: Axis::X,
                start_mm: 0.0,
                length_mm: 30.0,
                segments: 3,
                lines_mm: vec![0.0],
            }],
            runs: 2,
            captures: 3,
            overshoot_mm: 5.0,
            fps: 100.0,
            feed_mm_per_s: 20.0,
            settle_s: 0.3,
            start_time: String::new(),
        };
        (p.dwells(), p.captures, p.fps)
    }

    /// Frames as cameras with clock offsets and 15 % slower moves take them.
    fn capture(dwells: &[Dwell], captures: u32, fps: f64) -> Vec<CameraFrames> {
        let settle = 0.3;
        let mut cams = Vec::new();
        for (c, offset) in [(1u8, 0.0), (2, 7.25), (3, -3.5)] {
            let mut frames = Vec::new();
            let mut t = 0.0;
            let mut prev = 0.0;
            for (j, d) in dwells.iter().enumerate() {
                if j > 0 {
                    let moving = d.time_s - prev - settle - f64::from(captures) / fps;
                    t += 1.15 * moving + settle + f64::from(captures) / fps;
                }
                prev = d.time_s;
                for k in 0..captures {
                    let time = offset + t + f64::from(k) / fps;
                    frames.push(TimedFrame {
                        file: 0,
                        ns: (time * NS).round() as i64,
                        resolution_ns: 100_000,
                    });
                }
            }
            cams.push(CameraFrames { camera: c, frames });
        }
        let mut n = 0;
        for cam in &mut cams {
            for f in &mut cam.frames {
                f.file = n;
                n += 1;
            }
        }
        cams
    }

    #[test]
    fn clean_capture_places_every_frame() {
        let (d, captures, fps) = program();
        let cams = capture(&d, captures, fps);
        let p = place_triggered(&cams, &d, captures, fps, &AlignParams::default()).unwrap();
        assert!(p.faults.is_empty(), "{:?}", p.faults);
        assert_eq!(p.placements.len(), d.len() * 3 * 3);
        // File n of camera c is dwell n / 3, capture n % 3 + 1.
        for pl in &p.placements {
            let local = pl.file - usize::from(pl.camera - 1) * d.len() * 3;
            assert_eq!((pl.dwell, pl.capture), (local / 3, local as u32 % 3 + 1));
        }
    }

    #[test]
    fn dropped_first_frame_is_placed_from_another_camera() {
        let (d, captures, fps) = program();
        let mut cams = capture(&d, captures, fps);
        let dropped = cams[1].frames.remove(3 * 5); // camera 2, dwell 5, capture 1
        let stray_time = (cams[0].frames[3 * 7].ns + cams[0].frames[3 * 7 - 1].ns) / 2;
        cams[0].frames.insert(
            3 * 7,
            TimedFrame {
                file: 999,
                ns: stray_time,
                resolution_ns: 100_000,
            },
        );
        let p = place_triggered(&cams, &d, captures, fps, &AlignParams::default()).unwrap();
        let stray: Vec<&Fault> = p.faults.iter().filter(|f| f.file == Some(999)).collect();
        assert_eq!(stray.len(), 1, "{:?}", p.faults);
        assert!(stray[0].reason.contains("stray"), "{}", stray[0].reason);
        let missing: Vec<&Fault> = p.faults.iter().filter(|f| f.file.is_none()).collect();
        assert_eq!(missing.len(), 1, "{:?}", p.faults);
        assert_eq!(
            (missing[0].camera, missing[0].dwell, missing[0].capture),
            (Some(2), Some(5), Some(1))
        );
        assert_eq!(p.faults.len(), 2, "{:?}", p.faults);
        assert_eq!(p.placements.len(), d.len() * 9 - 1);
        assert!(p.placements.iter().all(|pl| pl.file != dropped.file));
        let second = p
            .placements
            .iter()
            .find(|pl| pl.file == dropped.file + 1)
            .unwrap();
        assert_eq!((second.dwell, second.capture), (5, 2));
    }
}
