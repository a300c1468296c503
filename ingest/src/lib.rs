//! From what the cameras saved to a campaign manifest: the frames under
//! captured folders (each camera's serial and time of exposure from EXIF),
//! the motion program (`program.toml`), and the rows of `manifest.csv` with
//! every frame at its instant — or, for a frame that cannot be placed, a
//! [`Problem`] with the reason. Nothing is placed by guess.
//!
//! - `program`: `program.toml`, the renderer's `[procedure]` table.
//! - `stamp`: serial and time of a frame from its metadata alone.
//! - `scan`: the frames under the folders, mapped to camera numbers.
//! - `align`: a camera's events matched to the program's dwells by order
//!   and relative gaps (dynamic programming, ambiguity measured).
//! - `triggered`: bursts of `captures` frames at each dwell.
//! - `continuous`: free-running cameras; dwells found in the images.
//!
//! # Conventions
//! - Camera clocks are never trusted to agree with each other or with the
//!   program: only each camera's own time differences are used, and moves
//!   need not last distance/feed.
//! - Times are nanoseconds of the camera's civil clock (no time zone).
//! - Image paths in the manifest are relative to its folder, `/`-separated.
//! - Deterministic: the same folders give the same manifest and problems.
//! - The library never prints and decodes pixels only in continuous mode.

#![deny(missing_docs)]

mod error;

mod align;
mod continuous;
mod program;
mod scan;
mod stamp;
mod triggered;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};

use extract::{Backend, CpuBackend, ExtractParams, FrameReader};
use formats::{Dwell, ManifestProblemRow, ManifestRow, ProcedureConfig};

pub use align::AlignParams;
pub use continuous::{ContinuousParams, Signatures, Spot};
pub use error::{IngestError, Result, TimeError};
pub use program::{parse_program, read_program};
pub use stamp::{FrameTime, parse_time, read_metadata};
pub use triggered::{CameraFrames, Fault, Placed, Placement, TimedFrame};

/// A frame, camera or instant left out of the manifest, and why.
pub type Problem = ManifestProblemRow;

/// How the cameras took the frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Capture {
    /// `captures` frames at each dwell, on a trigger.
    #[default]
    Triggered,
    /// Free-running through the whole campaign.
    Continuous,
}

/// What the manifest is built from.
#[derive(Debug, Clone, Copy)]
pub struct Inputs<'a> {
    /// The motion program.
    pub program: &'a ProcedureConfig,
    /// Camera serial → camera number (1, 2, 3).
    pub cameras: &'a [(String, u8)],
    /// Folders (or files) holding the frames.
    pub dirs: &'a [PathBuf],
    /// The manifest to be written; image paths are relative to its folder,
    /// which must exist.
    pub manifest: &'a Path,
}

/// How the manifest is built.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// Triggered or continuous capture.
    pub capture: Capture,
    /// Leave out every instant that lacks a camera (each of its frames a problem).
    pub complete_only: bool,
    /// Alignment of bursts or stays with the program's dwells.
    pub align: AlignParams,
    /// Continuous: blobs within this of rest (px) are still; `None`: each
    /// camera's bound measured from the noise of its still frames.
    pub still_px: Option<f64>,
    /// Continuous: blob extraction.
    pub extract: ExtractParams,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            capture: Capture::Triggered,
            complete_only: false,
            align: AlignParams::default(),
            still_px: ContinuousParams::default().still_px,
            extract: ExtractParams::default(),
        }
    }
}

/// Counts of a build.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Summary {
    /// Image files found (TIFF or PNG).
    pub files: usize,
    /// Files skipped for not being TIFF or PNG.
    pub other_files: usize,
    /// Frames placed at instants (manifest rows).
    pub placed: usize,
    /// Instants with at least one frame.
    pub instants: usize,
    /// Instants with a frame of every camera.
    pub complete_instants: usize,
    /// Dwells of the program.
    pub dwells: usize,
    /// Continuous: usable frames at no instant (in motion, or still but not taken).
    pub not_at_instants: usize,
    /// Per camera, how much slower than programmed the campaign ran (gaps ÷ programmed gaps).
    pub scales: Vec<(u8, f64)>,
    /// Frames whose pixels were decoded (continuous capture only).
    pub decoded: usize,
    /// Continuous: per camera, the largest still bound of a blob measure (px),
    /// measured from the spread of its still frames unless `still_px` fixes it.
    pub still_px: Vec<(u8, f64)>,
}

/// The manifest, the problems and the counts.
#[derive(Debug, Clone, PartialEq)]
pub struct Built {
    /// Manifest rows in program order (dwell, capture, camera).
    pub rows: Vec<ManifestRow>,
    /// Everything left out, with the reason.
    pub problems: Vec<Problem>,
    /// Counts.
    pub summary: Summary,
}

/// Check the serial → camera map.
fn check_cameras(cameras: &[(String, u8)]) -> Result<()> {
    if cameras.is_empty() {
        return Err(IngestError::NoCamera);
    }
    for (i, (serial, id)) in cameras.iter().enumerate() {
        if serial.trim().is_empty() {
            return Err(IngestError::EmptySerial(*id));
        }
        if !(1..=3).contains(id) {
            return Err(IngestError::CameraId {
                serial: serial.clone(),
                id: *id,
            });
        }
        if let Some((s, _)) = cameras[..i].iter().find(|(_, o)| o == id) {
            return Err(IngestError::CameraTwice {
                id: *id,
                first: s.clone(),
                second: serial.clone(),
            });
        }
        if cameras[..i].iter().any(|(s, _)| s == serial) {
            return Err(IngestError::SerialTwice(serial.clone()));
        }
    }
    Ok(())
}

/// `path` relative to the folder `base` (both absolute), `/`-separated.
fn relative(base: &Path, path: &Path) -> Option<String> {
    let b: Vec<Component<'_>> = base.components().collect();
    let p: Vec<Component<'_>> = path.components().collect();
    let common = b.iter().zip(&p).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".to_string(); b.len() - common];
    for c in &p[common..] {
        parts.push(c.as_os_str().to_str()?.to_string());
    }
    Some(parts.join("/"))
}

/// Blobs of image files through `extract` (continuous capture).
struct ImageSignatures<'a> {
    paths: &'a [PathBuf],
    params: &'a ExtractParams,
}

thread_local! {
    static READER: std::cell::RefCell<FrameReader> = std::cell::RefCell::new(FrameReader::new());
}

impl Signatures for ImageSignatures<'_> {
    fn spots(&self, file: usize) -> std::result::Result<Vec<Spot>, String> {
        let path = self
            .paths
            .get(file)
            .ok_or_else(|| format!("no file {file}"))?;
        READER.with(|r| {
            let mut reader = r.borrow_mut();
            let (frame, _) = reader.read(path).map_err(|e| e.to_string())?;
            let ex = CpuBackend
                .extract(frame, self.params)
                .map_err(|e| e.to_string())?;
            Ok(ex
                .blobs
                .iter()
                .filter(|b| !b.touches_border)
                .map(|b| {
                    // The moment ellipse's mean axis: weighted by the pixel values, it
                    // is free of the whole-pixel steps of the area.
                    let e = b.ellipse();
                    Spot {
                        u: b.u,
                        v: b.v,
                        diameter: 0.5 * (e.major_px + e.minor_px),
                    }
                })
                .collect())
        })
    }
}

/// Build the manifest of the frames under `inputs.dirs`.
pub fn build(inputs: &Inputs<'_>, options: &Options) -> Result<Built> {
    let dwells = checked_dwells(inputs)?;
    let base = manifest_folder(inputs.manifest)?;
    // The frames and what cannot be used.
    let found = scan::scan(inputs.dirs, inputs.cameras)?;
    let frames = &found.frames;
    let names = Names::new(base, inputs.cameras, frames);
    let mut problems = unusable_problems(&found.unusable, &names);
    // The frames at their instants, and the faults.
    let cameras = camera_frames(inputs.cameras, frames);
    let placed = place(&cameras, &dwells, frames, inputs.program, options)?;
    let mut placements = placed.placements;
    if options.complete_only {
        placements = complete_instants(placements, &dwells, frames, &names, &mut problems);
    }
    fault_problems(&placed.faults, &dwells, frames, &names, &mut problems);
    // The rows and the counts.
    let (rows, per_instant) = manifest_rows(&placements, &dwells, &names);
    let not_at_instants = not_at_instants(&placements, &problems, &names);
    let summary = Summary {
        files: frames.len() + found.unusable.len(),
        other_files: found.other_files,
        placed: rows.len(),
        instants: per_instant.len(),
        complete_instants: per_instant
            .values()
            .filter(|&&n| n == inputs.cameras.len())
            .count(),
        dwells: dwells.len(),
        not_at_instants,
        scales: placed.scales,
        decoded: placed.decoded,
        still_px: placed.still_px,
    };
    Ok(Built {
        rows,
        problems,
        summary,
    })
}

/// The program's dwells, once the camera map, the folders and the program are checked.
fn checked_dwells(inputs: &Inputs<'_>) -> Result<Vec<Dwell>> {
    check_cameras(inputs.cameras)?;
    if inputs.dirs.is_empty() {
        return Err(IngestError::NoFolder);
    }
    let program = inputs.program;
    program.validate().map_err(|e| IngestError::Program {
        path: PathBuf::from("program"),
        message: format!("{}: {}", e.key, e.message),
    })?;
    Ok(program.dwells())
}

/// The manifest's folder, absolute: image paths are relative to it.
fn manifest_folder(manifest: &Path) -> Result<PathBuf> {
    let folder = manifest
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::canonicalize(folder).map_err(|e| IngestError::io(folder, e))
}

/// How rows and problems name files and cameras.
struct Names<'a> {
    /// The manifest's folder, absolute.
    base: PathBuf,
    /// Camera serial → camera number.
    cameras: &'a [(String, u8)],
    /// Each scanned frame's path relative to `base`.
    rels: Vec<String>,
}

impl<'a> Names<'a> {
    /// The names of `frames`, relative to the folder `base`.
    fn new(base: PathBuf, cameras: &'a [(String, u8)], frames: &[scan::Frame]) -> Self {
        let mut names = Self {
            base,
            cameras,
            rels: Vec::new(),
        };
        names.rels = frames.iter().map(|f| names.rel(&f.path)).collect();
        names
    }

    /// `p` relative to the manifest's folder, else as given.
    fn rel(&self, p: &Path) -> String {
        std::fs::canonicalize(p)
            .ok()
            .and_then(|a| relative(&self.base, &a))
            .unwrap_or_else(|| p.to_string_lossy().into_owned())
    }

    /// The serial of camera `c`.
    fn serial_of(&self, c: u8) -> Option<String> {
        self.cameras
            .iter()
            .find(|(_, id)| *id == c)
            .map(|(s, _)| s.clone())
    }
}

/// The files the scan could not use, as problems.
fn unusable_problems(unusable: &[scan::Unusable], names: &Names<'_>) -> Vec<Problem> {
    unusable
        .iter()
        .map(|u| Problem {
            image: Some(names.rel(&u.path)),
            serial: u.serial.clone(),
            camera: u.camera,
            time: u.time.clone(),
            axis: None,
            direction: None,
            run: None,
            target: None,
            capture: None,
            reason: u.reason.clone(),
        })
        .collect()
}

/// Frames per camera in time order (ties: natural path order, the scan's order).
fn camera_frames(cameras: &[(String, u8)], frames: &[scan::Frame]) -> Vec<CameraFrames> {
    let mut cameras: Vec<CameraFrames> = cameras
        .iter()
        .map(|(_, c)| CameraFrames {
            camera: *c,
            frames: Vec::new(),
        })
        .collect();
    cameras.sort_by_key(|c| c.camera);
    for (i, f) in frames.iter().enumerate() {
        if let Some(c) = cameras.iter_mut().find(|c| c.camera == f.camera) {
            c.frames.push(TimedFrame {
                file: i,
                ns: f.time.ns,
                resolution_ns: f.time.resolution_ns,
            });
        }
    }
    for c in &mut cameras {
        c.frames.sort_by_key(|f| (f.ns, f.file));
    }
    cameras
}

/// The frames placed at instants, triggered or continuous.
fn place(
    cameras: &[CameraFrames],
    dwells: &[Dwell],
    frames: &[scan::Frame],
    program: &ProcedureConfig,
    options: &Options,
) -> Result<Placed> {
    Ok(match options.capture {
        Capture::Triggered => triggered::place_triggered(
            cameras,
            dwells,
            program.captures,
            program.fps,
            &options.align,
        )?,
        Capture::Continuous => {
            let paths: Vec<PathBuf> = frames.iter().map(|f| f.path.clone()).collect();
            let source = ImageSignatures {
                paths: &paths,
                params: &options.extract,
            };
            continuous::place_continuous(
                cameras,
                dwells,
                program.captures,
                program.settle_s,
                program.fps,
                &source,
                &ContinuousParams {
                    still_px: options.still_px,
                    align: options.align,
                },
            )
        }
    })
}

/// The placements at instants with a frame of every mapped camera; the
/// others' frames become problems (`--complete-instants`).
fn complete_instants(
    placements: Vec<Placement>,
    dwells: &[Dwell],
    frames: &[scan::Frame],
    names: &Names<'_>,
    problems: &mut Vec<Problem>,
) -> Vec<Placement> {
    let mapped: BTreeSet<u8> = names.cameras.iter().map(|(_, c)| *c).collect();
    let mut at: BTreeMap<(usize, u32), BTreeSet<u8>> = BTreeMap::new();
    for p in &placements {
        at.entry((p.dwell, p.capture)).or_default().insert(p.camera);
    }
    let (keep, out): (Vec<Placement>, Vec<Placement>) = placements
        .into_iter()
        .partition(|p| at[&(p.dwell, p.capture)] == mapped);
    for p in &out {
        let f = &frames[p.file];
        let d = &dwells[p.dwell];
        problems.push(Problem {
            image: Some(names.rels[p.file].clone()),
            serial: names.serial_of(p.camera),
            camera: Some(p.camera),
            time: Some(f.time.text.clone()),
            axis: Some(d.axis),
            direction: Some(d.direction),
            run: Some(d.run),
            target: Some(d.target),
            capture: Some(p.capture),
            reason: "left out: its instant lacks a camera (--complete-instants)".into(),
        });
    }
    keep
}

/// The placement's faults as problems: what is known of the frame, camera
/// and dwell, and the related files' names after the reason.
fn fault_problems(
    faults: &[Fault],
    dwells: &[Dwell],
    frames: &[scan::Frame],
    names: &Names<'_>,
    problems: &mut Vec<Problem>,
) {
    let rels = &names.rels;
    for fault in faults {
        let f = fault.file.and_then(|i| frames.get(i));
        let d = fault.dwell.and_then(|j| dwells.get(j));
        let camera = fault.camera.or(f.map(|f| f.camera));
        problems.push(Problem {
            image: fault.file.and_then(|i| rels.get(i).cloned()),
            serial: camera.and_then(|c| names.serial_of(c)),
            camera,
            time: f.map(|f| f.time.text.clone()),
            axis: d.map(|d| d.axis),
            direction: d.map(|d| d.direction),
            run: d.map(|d| d.run),
            target: d.map(|d| d.target),
            capture: fault.capture,
            reason: if fault.related.is_empty() {
                fault.reason.clone()
            } else {
                let names: Vec<&str> = fault
                    .related
                    .iter()
                    .filter_map(|&i| rels.get(i).map(String::as_str))
                    .collect();
                format!("{} [{}]", fault.reason, names.join(", "))
            },
        });
    }
}

/// The manifest rows of the placements (commanded positions from the
/// program), and the count of frames at each instant.
fn manifest_rows(
    placements: &[Placement],
    dwells: &[Dwell],
    names: &Names<'_>,
) -> (Vec<ManifestRow>, BTreeMap<(usize, u32), usize>) {
    let mut rows = Vec::with_capacity(placements.len());
    let mut per_instant: BTreeMap<(usize, u32), usize> = BTreeMap::new();
    for p in placements {
        let d = &dwells[p.dwell];
        *per_instant.entry((p.dwell, p.capture)).or_default() += 1;
        rows.push(ManifestRow {
            image: names.rels[p.file].clone(),
            camera: p.camera,
            axis: d.axis,
            direction: d.direction,
            run: d.run,
            target: d.target,
            capture: p.capture,
            nominal_x: d.nominal[0],
            nominal_y: d.nominal[1],
            nominal_z: d.nominal[2],
        });
    }
    (rows, per_instant)
}

/// Frames neither placed nor listed in a problem: in motion, or still but not taken.
fn not_at_instants(placements: &[Placement], problems: &[Problem], names: &Names<'_>) -> usize {
    let placed_files: BTreeSet<usize> = placements.iter().map(|p| p.file).collect();
    let listed: BTreeSet<&str> = problems.iter().filter_map(|p| p.image.as_deref()).collect();
    (0..names.rels.len())
        .filter(|i| !placed_files.contains(i) && !listed.contains(names.rels[*i].as_str()))
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths() {
        assert_eq!(
            relative(Path::new("/a/b"), Path::new("/a/b/c/d.tif")).unwrap(),
            "c/d.tif"
        );
        assert_eq!(
            relative(Path::new("/a/b"), Path::new("/a/x/d.tif")).unwrap(),
            "../x/d.tif"
        );
    }

    #[test]
    fn camera_map_is_checked() {
        let e = |c: &[(&str, u8)]| {
            check_cameras(
                &c.iter()
                    .map(|(s, i)| (s.to_string(), *i))
                    .collect::<Vec<_>>(),
            )
            .unwrap_err()
            .to_string()
        };
        assert!(e(&[("A", 1), ("B", 1)]).contains("twice"));
        assert!(e(&[("A", 4)]).contains("1, 2 or 3"));
        assert!(e(&[("A", 1), ("A", 2)]).contains("twice"));
    }
}
