//! Finding the captured frames: every TIFF and PNG file under the given
//! folders (recursively, in natural name order), its serial and time of
//! exposure read from its metadata alone (in parallel), the serial mapped to
//! a camera number. A file whose metadata is unreadable, lacks the serial or
//! the time, or carries a serial no camera is mapped to is a problem of that
//! file, never skipped silently.

use std::cmp::Ordering;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::stamp::{FrameTime, parse_time, read_metadata};
use crate::{IngestError, Result};

/// A frame with its camera and time.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The image file.
    pub path: PathBuf,
    /// Camera number.
    pub camera: u8,
    /// Time of exposure on the camera's clock.
    pub time: FrameTime,
}

/// A file that cannot be used, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Unusable {
    /// The file.
    pub path: PathBuf,
    /// Its serial, when read.
    pub serial: Option<String>,
    /// Its camera, when known.
    pub camera: Option<u8>,
    /// Its time stamp as written, when read.
    pub time: Option<String>,
    /// Why.
    pub reason: String,
}

/// What a scan found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scan {
    /// Usable frames, in natural path order.
    pub frames: Vec<Frame>,
    /// Files that are not usable.
    pub unusable: Vec<Unusable>,
    /// Files skipped for not being TIFF or PNG by their extension.
    pub other_files: usize,
}

/// Compare names so that embedded numbers sort by value (`IMG_9` < `IMG_10`).
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut x, mut y) = (a.as_bytes(), b.as_bytes());
    loop {
        match (x.first(), y.first()) {
            (None, None) => return a.cmp(b),
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(c), Some(d)) if c.is_ascii_digit() && d.is_ascii_digit() => {
                let n = x.iter().take_while(|c| c.is_ascii_digit()).count();
                let m = y.iter().take_while(|c| c.is_ascii_digit()).count();
                let (p, q) = (&x[..n], &y[..m]);
                let p = &p[p.iter().take_while(|&&c| c == b'0').count()..];
                let q = &q[q.iter().take_while(|&&c| c == b'0').count()..];
                let o = p.len().cmp(&q.len()).then_with(|| p.cmp(q));
                if o != Ordering::Equal {
                    return o;
                }
                x = &x[n..];
                y = &y[m..];
            }
            (Some(c), Some(d)) => {
                if c != d {
                    return c.cmp(d);
                }
                x = &x[1..];
                y = &y[1..];
            }
        }
    }
}

fn is_image(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| matches!(e.to_ascii_lowercase().as_str(), "tif" | "tiff" | "png"))
}

/// Every file under `dir` (or `dir` itself when it is a file), natural order.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    if dir.is_file() {
        out.push(dir.to_path_buf());
        return Ok(());
    }
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| IngestError::io(dir, e))?
        .map(|e| e.map(|e| e.path()).map_err(|e| IngestError::io(dir, e)))
        .collect::<Result<_>>()?;
    entries.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    for p in entries {
        if p.is_dir() {
            walk(&p, out)?;
        } else {
            out.push(p);
        }
    }
    Ok(())
}

/// Scan `dirs` for frames of the cameras `serials` (serial → camera number).
pub fn scan(dirs: &[PathBuf], serials: &[(String, u8)]) -> Result<Scan> {
    let mut files = Vec::new();
    for d in dirs {
        if !d.exists() {
            return Err(IngestError::io(
                d,
                std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or folder"),
            ));
        }
        walk(d, &mut files)?;
    }
    let mut seen = std::collections::HashSet::new();
    files.retain(|f| seen.insert(f.clone()));
    let (images, others): (Vec<PathBuf>, Vec<PathBuf>) =
        files.into_iter().partition(|p| is_image(p));
    let read: Vec<std::result::Result<Frame, Unusable>> = images
        .par_iter()
        .map(|path| {
            let unusable = |serial: Option<String>, camera, time, reason: String| Unusable {
                path: path.clone(),
                serial,
                camera,
                time,
                reason,
            };
            let meta = read_metadata(path).map_err(|e| {
                let reason = match e {
                    IngestError::Metadata { message, .. } => message,
                    other => other.to_string(),
                };
                unusable(None, None, None, format!("metadata unreadable: {reason}"))
            })?;
            let Some(serial) = meta.serial.clone() else {
                return Err(unusable(
                    None,
                    None,
                    meta.datetime.clone(),
                    "no camera serial in the metadata (EXIF BodySerialNumber)".into(),
                ));
            };
            let Some(&(_, camera)) = serials.iter().find(|(s, _)| *s == serial) else {
                return Err(unusable(
                    Some(serial.clone()),
                    None,
                    meta.datetime.clone(),
                    format!("unknown camera serial '{serial}' (no --camera {serial}=ID)"),
                ));
            };
            let Some(text) = meta.datetime.clone() else {
                return Err(unusable(
                    Some(serial),
                    Some(camera),
                    None,
                    "no time of exposure in the metadata (EXIF DateTimeOriginal)".into(),
                ));
            };
            let time = parse_time(&text).map_err(|reason| {
                unusable(
                    Some(serial.clone()),
                    Some(camera),
                    Some(text.clone()),
                    reason.to_string(),
                )
            })?;
            Ok(Frame {
                path: path.clone(),
                camera,
                time,
            })
        })
        .collect();
    let mut scan = Scan {
        other_files: others.len(),
        ..Scan::default()
    };
    for r in read {
        match r {
            Ok(f) => scan.frames.push(f),
            Err(u) => scan.unusable.push(u),
        }
    }
    Ok(scan)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order() {
        let mut v = vec![
            "IMG_10.tif",
            "IMG_9.tif",
            "IMG_009a.tif",
            "a",
            "IMG_0100.tif",
        ];
        v.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            v,
            [
                "IMG_9.tif",
                "IMG_009a.tif",
                "IMG_10.tif",
                "IMG_0100.tif",
                "a"
            ]
        );
    }
}
