//! A frame's camera serial and time of exposure, read from its metadata
//! alone: a TIFF's tag directories are reached by seeking (the pixels, tens
//! of megabytes, are never read), a PNG's chunks are scanned up to its
//! `eXIf` chunk by kamadak-exif (the TIFF reader is `extract::tiff_fields`,
//! shared with the frame reader). The tags are interpreted by
//! [`extract::FrameMetadata::from_fields`] (the one home of EXIF reading:
//! serial from BodySerialNumber else CameraSerialNumber, time from
//! DateTimeOriginal + SubSecTimeOriginal else DateTime + SubSecTime), and
//! the time is parsed with `jiff` as a civil time (camera clocks keep local
//! time; no zone is applied or needed, since only differences are used).

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use extract::{FrameMetadata, tiff_fields};

use crate::{IngestError, Result, TimeError};

/// When a frame was exposed, on its camera's clock.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameTime {
    /// Nanoseconds since 1970-01-01T00:00:00 of the camera's civil clock.
    pub ns: i64,
    /// The resolution of the stamp (ns): 10^−digits s for the sub-second
    /// digits written, 1 s without them.
    pub resolution_ns: i64,
    /// The time as the camera wrote it (ISO 8601).
    pub text: String,
}

/// Parse an ISO 8601 civil time `YYYY-MM-DDTHH:MM:SS[.f…]` (as
/// [`FrameMetadata::datetime`] gives it).
pub fn parse_time(text: &str) -> std::result::Result<FrameTime, TimeError> {
    let dt: jiff::civil::DateTime = text.parse().map_err(|e: jiff::Error| TimeError::Syntax {
        text: text.to_string(),
        reason: e.to_string(),
    })?;
    let ts = jiff::tz::TimeZone::UTC
        .to_timestamp(dt)
        .map_err(|e| TimeError::Timestamp {
            text: text.to_string(),
            reason: e.to_string(),
        })?;
    let ns = i64::try_from(ts.as_nanosecond()).map_err(|_| TimeError::Range(text.to_string()))?;
    let digits = text.split_once('.').map_or(0, |(_, f)| {
        f.chars().take_while(char::is_ascii_digit).count()
    });
    let resolution_ns = 10i64.pow(9u32.saturating_sub(digits.min(9) as u32));
    Ok(FrameTime {
        ns,
        resolution_ns,
        text: text.to_string(),
    })
}

/// The metadata of an image file, read without its pixels.
pub fn read_metadata(path: &Path) -> Result<FrameMetadata> {
    let meta_err = |message: String| IngestError::Metadata {
        path: path.to_path_buf(),
        message,
    };
    let file = File::open(path).map_err(|e| IngestError::io(path, e))?;
    let mut reader = BufReader::with_capacity(4096, file);
    let mut magic = [0u8; 4];
    reader
        .read_exact(&mut magic)
        .map_err(|e| meta_err(format!("too short for an image ({e})")))?;
    reader
        .seek(SeekFrom::Start(0))
        .map_err(|e| IngestError::io(path, e))?;
    match magic {
        [b'I', b'I', 42 | 43, 0] | [b'M', b'M', 0, 42 | 43] => {
            let fields = tiff_fields(&mut reader).map_err(meta_err)?;
            Ok(FrameMetadata::from_fields(&fields))
        }
        [0x89, b'P', b'N', b'G'] => {
            match exif::Reader::new().read_from_container(&mut reader) {
                Ok(e) => Ok(FrameMetadata::from_fields(
                    &e.fields().cloned().collect::<Vec<_>>(),
                )),
                // A PNG without an eXIf chunk has no metadata; a broken one is an error.
                Err(exif::Error::NotFound(_)) => Ok(FrameMetadata::default()),
                Err(e) => Err(meta_err(format!("PNG metadata: {e}"))),
            }
        }
        _ => Err(meta_err("not a TIFF or PNG file".into())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_keep_their_resolution() {
        let t = parse_time("2025-06-02T08:00:00.0125").unwrap();
        assert_eq!(t.resolution_ns, 100_000);
        let u = parse_time("2025-06-02T08:00:01").unwrap();
        assert_eq!(u.resolution_ns, 1_000_000_000);
        assert_eq!(u.ns - t.ns, 987_500_000);
        assert!(parse_time("2025-02-31T00:00:00").is_err());
    }
}
