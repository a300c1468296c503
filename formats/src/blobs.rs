//! Extracted blobs (`blobs.csv`), one row per blob.

use serde::{Deserialize, Serialize};

use crate::table::{Invalid, Record, finite};

/// One row of `blobs.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BlobRow {
    /// Image path as given.
    pub image: String,
    /// Blob index within the image (raster order of its first pixel).
    pub blob: u32,
    /// Centroid u (px; centre of the top-left pixel = 0).
    pub u: f64,
    /// Centroid v (px).
    pub v: f64,
    /// Pixels in the blob.
    pub area_px: u64,
    /// Equivalent diameter √(4·area/π) (px).
    pub diameter_px: f64,
    /// Largest pixel value (DN).
    pub peak: u16,
    /// Some pixel is at the saturation level.
    pub saturated: bool,
    /// The blob touches the image border.
    pub touches_border: bool,
    /// Sphere the blob was matched to, where matched.
    #[serde(default)]
    pub sphere: Option<String>,
    /// Σ F (DN·px).
    pub signal: f64,
    /// Major axis of the moment ellipse (px).
    pub major_px: f64,
    /// Minor axis of the moment ellipse (px).
    pub minor_px: f64,
    /// Orientation of the major axis from +u towards +v (rad).
    pub orientation_rad: f64,
    /// Minor/major axis ratio.
    pub circularity: f64,
    /// Threshold used (DN; for a local threshold, its range).
    pub threshold: String,
    /// Camera model from the image tags.
    #[serde(default)]
    pub camera_model: Option<String>,
    /// Camera serial number from the image tags.
    #[serde(default)]
    pub camera_serial: Option<String>,
    /// Acquisition time from the image tags (ISO 8601).
    #[serde(default)]
    pub datetime: Option<String>,
    /// Exposure time from the image tags (s).
    #[serde(default)]
    pub exposure_s: Option<f64>,
    /// Defective pixels of the sensor's defect map inside the blob, replaced
    /// by their neighbours' mean before the centroid; empty without a map.
    #[serde(default)]
    pub defect_pixels: Option<u32>,
    /// Standard uncertainty of `u` from the image noise (px), analytic from
    /// the camera's noise model (docs/uncertainty.md); empty when the noise
    /// model is unknown.
    #[serde(default)]
    pub u_sigma_px: Option<f64>,
    /// Standard uncertainty of `v` (px).
    #[serde(default)]
    pub v_sigma_px: Option<f64>,
    /// Correlation of the errors of `u` and `v`.
    #[serde(default)]
    pub uv_correlation: Option<f64>,
}

impl BlobRow {
    /// Every column of the file, in order: the header of a file of no blobs
    /// (a row's fields serialise in this order; a test holds them together).
    pub const HEADER: &'static [&'static str] = &[
        "image",
        "blob",
        "u",
        "v",
        "area_px",
        "diameter_px",
        "peak",
        "saturated",
        "touches_border",
        "sphere",
        "signal",
        "major_px",
        "minor_px",
        "orientation_rad",
        "circularity",
        "threshold",
        "camera_model",
        "camera_serial",
        "datetime",
        "exposure_s",
        "defect_pixels",
        "u_sigma_px",
        "v_sigma_px",
        "uv_correlation",
    ];
}

impl Record for BlobRow {
    const COLUMNS: &'static [&'static str] = &[
        "image",
        "blob",
        "u",
        "v",
        "area_px",
        "diameter_px",
        "peak",
        "saturated",
        "touches_border",
    ];

    fn validate(&self) -> Result<(), Invalid> {
        finite("u", self.u)?;
        finite("v", self.v)?;
        finite("diameter_px", self.diameter_px)
    }
}

/// One row of `<stem>.problems.csv` beside `extract`'s output: an input that
/// could not be used, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProblemRow {
    /// The file (or instant) at fault.
    pub item: String,
    /// What is wrong.
    pub reason: String,
}

impl Record for ProblemRow {
    const COLUMNS: &'static [&'static str] = &["item", "reason"];

    fn validate(&self) -> Result<(), Invalid> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header of a file of no blobs is the one rows are written under.
    #[test]
    fn the_header_is_the_rows_fields_in_order() {
        let row = BlobRow {
            image: "a.tif".into(),
            blob: 0,
            u: 1.0,
            v: 2.0,
            area_px: 3,
            diameter_px: 2.0,
            peak: 4,
            saturated: false,
            touches_border: false,
            sphere: None,
            signal: 5.0,
            major_px: 1.0,
            minor_px: 1.0,
            orientation_rad: 0.0,
            circularity: 1.0,
            threshold: "6".into(),
            camera_model: None,
            camera_serial: None,
            datetime: None,
            exposure_s: None,
            defect_pixels: None,
            u_sigma_px: None,
            v_sigma_px: None,
            uv_correlation: None,
        };
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(&row).unwrap();
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        assert_eq!(header, BlobRow::HEADER);
        assert!(BlobRow::HEADER.starts_with(BlobRow::COLUMNS));
    }
}
