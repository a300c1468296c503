//! Many frames: decode and extract in parallel, deliver results in input
//! order, carry on past a bad file. Memory stays bounded: files are taken in
//! chunks, [`FrameReader`]s (and so their buffers) are pooled and reused for
//! the whole batch, and blob runs are dropped.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use rayon::prelude::*;

use geom::RadialIllumination;
use sensor::SensorMaps;

use crate::Result;
use crate::backend::{Backend, ExtractParams, Extraction};
use crate::blob::Blob;
use crate::correction::{FlatFieldMap, mapped_light};
use crate::decode::FrameReader;
use crate::denoise::Denoise;
use crate::frame::FrameView;
use crate::label::Weighting;
use crate::metadata::FrameMetadata;
use crate::noise::{CentroidCovariance, Covariance};

/// How a camera's frames are corrected before their centroids are taken:
/// the sensor's per-pixel maps (master dark, gain map, defective pixels)
/// applied to the whole frame before extraction, and the lens's relative
/// illumination applied to each blob's pixels (`crate::correction`).
#[derive(Debug, Clone, Copy)]
pub struct Radiometry<'a> {
    /// The lens's relative illumination.
    pub illumination: &'a RadialIllumination,
    /// The sensor's per-pixel maps, when calibrated from stacks.
    pub sensor: Option<&'a SensorMaps>,
    /// The system gain K (DN/e⁻), when known: each corrected centroid then
    /// gets its covariance from the image noise (`crate::noise`; not with a
    /// denoised frame, whose pixels are correlated).
    pub gain_dn_per_e: Option<f64>,
}

/// Files processed together; results of a chunk are delivered in order.
const CHUNK_FILES: usize = 32;

/// What one file gave.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameBlobs {
    /// Acquisition metadata from the image tags.
    pub metadata: FrameMetadata,
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Bit depth (8 or 16).
    pub bit_depth: u8,
    /// Threshold used, described.
    pub threshold: String,
    /// Blobs within the area limits, without their runs.
    pub blobs: Vec<Blob>,
    /// Blobs whose flat-field correction failed (their centroid is the plain
    /// one), with the reason; empty without a flat field.
    pub uncorrected: Vec<(usize, String)>,
    /// Per blob, the covariance of its corrected centroid from the image
    /// noise (px²); empty without a system gain K.
    pub covariance: Vec<Option<CentroidCovariance>>,
    /// Per blob, the defective pixels (of the sensor's defect map) inside it,
    /// replaced by their neighbours before the centroid; empty without maps.
    pub defect_pixels: Vec<u32>,
    /// Saturated blobs, kept or dropped for want of weight
    /// ([`Extraction::saturation_note`]); `None` when there are none.
    pub saturation: Option<String>,
}

/// A file's result from its frame, metadata and extraction (blob runs
/// dropped); with a flat field, each blob's centroid is the flat-field
/// corrected one (`crate::correction`), with its covariance when the
/// radiometry knows K and `denoise` is none.
pub(crate) fn frame_blobs(
    frame: &FrameView<'_>,
    metadata: FrameMetadata,
    extraction: Extraction,
    weighting: Weighting,
    radiometry: Option<Radiometry<'_>>,
    denoise: Denoise,
) -> FrameBlobs {
    let mut uncorrected = Vec::new();
    let gain = radiometry
        .and_then(|r| r.gain_dn_per_e)
        .filter(|_| denoise == Denoise::None);
    let mut covariance = Vec::new();
    let flat_field = radiometry.map(|r| r.illumination);
    let defect_pixels = match radiometry.and_then(|r| r.sensor) {
        Some(maps) => extraction
            .blobs
            .iter()
            .map(|b| {
                b.runs
                    .iter()
                    .map(|r| {
                        (r.x0..=r.x1)
                            .filter(|&x| maps.defects.is_defect(x, r.y))
                            .count() as u32
                    })
                    .sum()
            })
            .collect(),
        None => Vec::new(),
    };
    let saturation = extraction.saturation_note(frame.max_value());
    let blobs = extraction
        .blobs
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let mut b = b.clone();
            if let Some(ri) = flat_field {
                let map = FlatFieldMap(ri);
                let light = mapped_light(
                    frame,
                    &b,
                    &extraction.level,
                    weighting,
                    &map,
                    Covariance::at_gain(gain),
                );
                match light {
                    Some(l) => (b.u, b.v) = (l.centroid[0], l.centroid[1]),
                    None => uncorrected.push((
                        i,
                        "no flat-field correction: too little background around the blob".into(),
                    )),
                }
                if gain.is_some() {
                    covariance.push(light.and_then(|l| l.covariance));
                }
            }
            b.runs = Vec::new();
            b
        })
        .collect();
    FrameBlobs {
        metadata,
        width: frame.width,
        height: frame.height,
        bit_depth: frame.bit_depth,
        threshold: extraction.level.describe(),
        blobs,
        uncorrected,
        covariance,
        defect_pixels,
        saturation,
    }
}

/// Decode and extract one file with a reader whose buffers are reused;
/// with `radiometry`, the frame corrected with the sensor's maps and the
/// centroids flat-field corrected.
pub fn extract_file<B: Backend + ?Sized>(
    reader: &mut FrameReader,
    path: &Path,
    backend: &B,
    params: &ExtractParams,
    radiometry: Option<Radiometry<'_>>,
) -> Result<FrameBlobs> {
    let (raw, metadata) = reader.read(path)?;
    let corrected = raw
        .corrected(radiometry.and_then(|r| r.sensor))
        .map_err(|e| e.in_file(path))?;
    let frame = corrected.as_ref().map_or(raw, |f| f.view());
    let extraction = backend
        .extract(frame, params)
        .map_err(|e| e.in_file(path))?;
    // Corrected centroids are taken over the frame the blobs came from.
    let denoised = radiometry.and_then(|_| crate::denoise::apply(&frame, params.denoise));
    let view = denoised.as_ref().map_or(frame, |f| f.view());
    Ok(frame_blobs(
        &view,
        metadata,
        extraction,
        params.weighting,
        radiometry,
        params.denoise,
    ))
}

/// Extract every file; `sink(index, path, result)` is called once per file,
/// in input order. A failed file is reported to the sink and the batch goes on.
/// `expected_depth` rejects frames of another bit depth. The backend decides
/// how ([`Backend::extract_batch`]): the CPU decodes and extracts in parallel,
/// the GPU pipelines.
pub fn extract_files<F>(
    paths: &[PathBuf],
    backend: &dyn Backend,
    params: &ExtractParams,
    expected_depth: Option<u8>,
    mut sink: F,
) where
    F: FnMut(usize, &Path, Result<FrameBlobs>),
{
    backend.extract_batch(paths, params, expected_depth, &mut sink);
}

/// [`extract_files`] with every frame corrected by `radiometry` (the
/// sensor's maps, then each centroid flat-field corrected by the lens's
/// relative illumination; frames decoded and extracted in parallel, one
/// frame per backend call).
pub fn extract_files_flat<F>(
    paths: &[PathBuf],
    backend: &dyn Backend,
    params: &ExtractParams,
    expected_depth: Option<u8>,
    radiometry: Radiometry<'_>,
    mut sink: F,
) where
    F: FnMut(usize, &Path, Result<FrameBlobs>),
{
    extract_parallel(
        paths,
        backend,
        params,
        expected_depth,
        Some(radiometry),
        &mut sink,
    );
}

/// The default batch path: frames decoded and extracted in parallel on the
/// rayon pool, in chunks, readers pooled; results in input order.
pub fn extract_parallel<B: Backend + ?Sized>(
    paths: &[PathBuf],
    backend: &B,
    params: &ExtractParams,
    expected_depth: Option<u8>,
    radiometry: Option<Radiometry<'_>>,
    sink: &mut dyn FnMut(usize, &Path, Result<FrameBlobs>),
) {
    // A pool, not `map_init`: rayon calls `map_init`'s init once per job split,
    // which would allocate fresh 25 MB buffers for most frames.
    let pool: Mutex<Vec<FrameReader>> = Mutex::new(Vec::new());
    let take = || {
        pool.lock()
            .ok()
            .and_then(|mut p| p.pop())
            .unwrap_or_else(|| {
                FrameReader::new()
                    .expect_bit_depth(expected_depth)
                    .limit_pixels(params.max_pixels)
            })
    };
    let give_back = |reader: FrameReader| {
        if let Ok(mut p) = pool.lock() {
            p.push(reader);
        }
    };
    for (c, chunk) in paths.chunks(CHUNK_FILES).enumerate() {
        let results: Vec<Result<FrameBlobs>> = chunk
            .par_iter()
            .map(|path| {
                let mut reader = take();
                let result = extract_file(&mut reader, path, backend, params, radiometry);
                give_back(reader);
                result
            })
            .collect();
        for (i, (path, result)) in chunk.iter().zip(results).enumerate() {
            sink(c * CHUNK_FILES + i, path, result);
        }
    }
}
