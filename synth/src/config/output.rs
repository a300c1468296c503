//! The `[output]` table (image files) and the `[render]` table (rendering accuracy).

use serde::{Deserialize, Serialize};

use super::check::bad;
use crate::Result;

/// Image file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    /// TIFF (what the cameras write), metadata in TIFF and EXIF tags.
    Tiff,
    /// PNG, metadata in an eXIf chunk.
    Png,
}

impl ImageFormat {
    /// File extension without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            ImageFormat::Tiff => "tif",
            ImageFormat::Png => "png",
        }
    }
}

/// TIFF compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TiffCompression {
    /// Uncompressed (fastest; 2 bytes per pixel at 16 bits).
    None,
    /// Deflate with horizontal differencing.
    Deflate,
    /// LZW with horizontal differencing.
    Lzw,
}

/// Image files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputConfig {
    /// `tiff` or `png`.
    pub format: ImageFormat,
    /// TIFF compression: `none`, `deflate` or `lzw`.
    pub compression: TiffCompression,
    /// EXIF Make.
    pub make: String,
    /// EXIF Model.
    pub model: String,
}

/// Rendering accuracy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderConfig {
    /// Depth of the adaptive pixel subdivision at silhouette edges: leaves are
    /// 2^−depth px squares, cut exactly by the local tangent line.
    pub max_depth: u8,
}

impl Default for RenderConfig {
    fn default() -> Self {
        Self { max_depth: 4 }
    }
}

impl Default for OutputConfig {
    fn default() -> Self {
        Self {
            format: ImageFormat::Tiff,
            compression: TiffCompression::None,
            make: "trinocular".into(),
            model: "synth".into(),
        }
    }
}

impl OutputConfig {
    /// Check the EXIF strings and the compression; the error names the key.
    pub(crate) fn validate(&self) -> Result<()> {
        if !self.make.is_ascii() || !self.model.is_ascii() {
            return Err(bad("output.make/model", "must be ASCII"));
        }
        if self.format == ImageFormat::Png && self.compression != TiffCompression::None {
            return Err(bad(
                "output.compression",
                "applies to TIFF only (PNG is always deflated)",
            ));
        }
        Ok(())
    }
}

impl RenderConfig {
    /// Check the subdivision depth; the error names the key.
    pub(crate) fn validate(&self) -> Result<()> {
        if !(1..=8).contains(&self.max_depth) {
            return Err(bad(
                "render.max_depth",
                format!("{} must be 1..=8", self.max_depth),
            ));
        }
        Ok(())
    }
}
