//! What `calibrate` records beside each camera's model in `rig.json`: how
//! the camera was calibrated (model, standard deviations, outliers, source
//! and matching) and where its relative illumination came from. Written into
//! the camera's further keys ([`RigCamera::extra`](crate::RigCamera),
//! [`IlluminationJson`]), which a reader keeps as written.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;
use serde_json::{Map, Value};

use crate::IlluminationJson;
use crate::commissioning::FlatFieldFit;

/// The note of a camera whose relative illumination was assumed.
const ASSUMED_ILLUMINATION: &str = "assumed: no flat field was given (cos⁴θ natural vignetting, \
     energy-conserving under distortion)";

/// How a camera's image points were found (`matching`).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Matching {
    /// Detected in the camera's image and matched to the target's markers.
    Detected {
        /// Blobs detected (those touching the border left out).
        detections: usize,
        /// Detections matched to a marker.
        matched: usize,
        /// Detections matched to no marker.
        unmatched_detections: usize,
        /// Markers no detection was matched to.
        missing_markers: Vec<u32>,
        /// Spread of the final assignment (px).
        assignment_sigma_px: f64,
        /// Rounds of re-centroiding over undistorted pixels.
        corrected_centroids: usize,
    },
    /// Given as a correspondence file of this many points.
    Given {
        /// Rows of the file.
        points: usize,
    },
}

/// How one camera was calibrated.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CalibrationRecord {
    /// Distortion model (`pinhole`, `k1k2`, `k1k2p1p2`).
    pub model: &'static str,
    /// Whether k3 was estimated.
    pub k3_estimated: bool,
    /// Whether the skew was estimated.
    pub skew_estimated: bool,
    /// Whether the sphere markers of the target were used.
    pub sphere_markers: bool,
    /// Standard deviation of each estimated parameter, by name.
    pub std_dev: BTreeMap<&'static str, f64>,
    /// Standard deviation of unit weight (px).
    pub sigma_px: f64,
    /// RMS of the linear (DLT) start (px).
    pub dlt_rms_px: f64,
    /// Marker ids rejected as outliers.
    pub outliers: Vec<u32>,
    /// Outlier threshold in σ (`None`: no rejection).
    pub outlier_k: Option<f64>,
    /// The image or correspondence file calibrated from.
    pub source: String,
    /// How the image points were found.
    pub matching: Matching,
    /// The camera as the calibration image's metadata names it (TIFF/EXIF
    /// Make, Model, serial), when the image says.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_make: Option<String>,
    /// Its model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_model: Option<String>,
    /// Its serial number.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub camera_serial: Option<String>,
    /// When the calibration image was taken (its EXIF time, ISO 8601):
    /// the calibration's date on the reports that use the rig.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub captured: Option<String>,
}

impl CalibrationRecord {
    /// The record as the further keys of a `rig.json` camera.
    pub fn to_keys(&self) -> serde_json::Result<Map<String, Value>> {
        as_keys(self)
    }
}

impl IlluminationJson {
    /// Record where the relative illumination came from: a flat-field fit's
    /// figures and its source frames, or the note that it was assumed.
    pub fn record_source(
        &mut self,
        fit: Option<&FlatFieldFit>,
        flat_field: Option<&Path>,
        dark_frame: Option<&Path>,
    ) -> serde_json::Result<()> {
        let extra = self.extra_mut();
        match fit {
            Some(f) => {
                extra.extend(as_keys(f)?);
                for (key, file) in [("flat_field", flat_field), ("dark_frame", dark_frame)] {
                    if let Some(p) = file {
                        extra.insert(key.into(), Value::from(p.display().to_string()));
                    }
                }
            }
            None => {
                extra.insert("note".into(), Value::from(ASSUMED_ILLUMINATION));
            }
        }
        Ok(())
    }
}

/// The keys of a record that serialises as a JSON object (every record here
/// is a struct, so anything else is a serialisation error).
fn as_keys(record: &impl Serialize) -> serde_json::Result<Map<String, Value>> {
    match serde_json::to_value(record)? {
        Value::Object(m) => Ok(m),
        other => Err(serde::ser::Error::custom(format!(
            "expected a JSON object, got {other}"
        ))),
    }
}
