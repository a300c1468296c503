//! Acquisition metadata from TIFF/EXIF tags (kamadak-exif): camera model and
//! serial, date-time with sub-seconds, exposure.

use exif::{Field, In, Tag, Value};

/// What the camera recorded about a frame; each field is `None` when absent.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FrameMetadata {
    /// Camera maker (TIFF Make).
    pub make: Option<String>,
    /// Camera model (TIFF Model).
    pub model: Option<String>,
    /// Camera serial number (EXIF BodySerialNumber, else DNG CameraSerialNumber).
    pub serial: Option<String>,
    /// Acquisition time as ISO 8601 `YYYY-MM-DDTHH:MM:SS[.ffffff]` (EXIF
    /// DateTimeOriginal + SubSecTimeOriginal, else TIFF DateTime + SubSecTime).
    pub datetime: Option<String>,
    /// Exposure time (s).
    pub exposure_s: Option<f64>,
}

/// DNG CameraSerialNumber (0xC62F), an IFD0 tag.
const CAMERA_SERIAL_NUMBER: Tag = Tag(exif::Context::Tiff, 0xC62F);

fn find(fields: &[Field], tag: Tag) -> Option<&Field> {
    fields
        .iter()
        .find(|f| f.tag == tag && f.ifd_num == In::PRIMARY)
}

fn ascii(fields: &[Field], tag: Tag) -> Option<String> {
    match &find(fields, tag)?.value {
        Value::Ascii(parts) => {
            let s: String = parts
                .iter()
                .map(|p| String::from_utf8_lossy(p).into_owned())
                .collect::<Vec<_>>()
                .join(" ");
            let s = s.trim_matches(char::from(0)).trim().to_string();
            (!s.is_empty()).then_some(s)
        }
        _ => None,
    }
}

/// `YYYY:MM:DD HH:MM:SS` + sub-second digits → ISO 8601; `None` unless the
/// first 19 bytes have digits where the date and time have them (a damaged
/// tag may hold anything).
fn iso_datetime(raw: &str, subsec: Option<String>) -> Option<String> {
    let b = raw.as_bytes();
    const DIGITS: [usize; 14] = [0, 1, 2, 3, 5, 6, 8, 9, 11, 12, 14, 15, 17, 18];
    if b.len() < 19 || !b[..19].is_ascii() || !DIGITS.iter().all(|&i| b[i].is_ascii_digit()) {
        return None;
    }
    let mut s = format!(
        "{}-{}-{}T{}",
        &raw[0..4],
        &raw[5..7],
        &raw[8..10],
        &raw[11..19]
    );
    if let Some(sub) = subsec.filter(|d| d.chars().all(|c| c.is_ascii_digit()) && !d.is_empty()) {
        s.push('.');
        s.push_str(&sub);
    }
    Some(s)
}

impl FrameMetadata {
    /// Collect the fields of interest from parsed EXIF/TIFF tags.
    pub fn from_fields(fields: &[Field]) -> Self {
        let datetime = ascii(fields, Tag::DateTimeOriginal)
            .and_then(|d| iso_datetime(&d, ascii(fields, Tag::SubSecTimeOriginal)))
            .or_else(|| {
                ascii(fields, Tag::DateTime)
                    .and_then(|d| iso_datetime(&d, ascii(fields, Tag::SubSecTime)))
            });
        let exposure_s = find(fields, Tag::ExposureTime).and_then(|f| match &f.value {
            Value::Rational(r) if !r.is_empty() && r[0].denom != 0 => Some(r[0].to_f64()),
            _ => None,
        });
        Self {
            make: ascii(fields, Tag::Make),
            model: ascii(fields, Tag::Model),
            serial: ascii(fields, Tag::BodySerialNumber)
                .or_else(|| ascii(fields, CAMERA_SERIAL_NUMBER)),
            datetime,
            exposure_s,
        }
    }

    /// Parse the tags of a TIFF file (or a PNG's eXIf block, the same
    /// structure) held in memory; an unreadable tag block gives empty metadata.
    pub fn from_tiff_bytes(bytes: &[u8]) -> Self {
        match exif::parse_exif(bytes) {
            Ok((fields, _)) => Self::from_fields(&fields),
            Err(_) => Self::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iso_datetime_with_subseconds() {
        assert_eq!(
            iso_datetime("2026:11:21 10:15:30", Some("123456".into())).as_deref(),
            Some("2026-11-21T10:15:30.123456")
        );
        assert_eq!(
            iso_datetime("2026:11:21 10:15:30", None).as_deref(),
            Some("2026-11-21T10:15:30")
        );
        assert_eq!(iso_datetime("bad", None), None);
        // A damaged tag: non-ASCII inside the date, letters for digits.
        assert_eq!(iso_datetime("   i\u{fffd}    ?   20", None), None);
        assert_eq!(iso_datetime("2026:1x:21 10:15:30", None), None);
    }
}
