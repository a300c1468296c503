//! The sensor's per-pixel calibration on the command line (docs/sensor.md):
//! a stack of flat fields and one of dark frames per camera, each a file or a
//! folder of frames, calibrated by `sensor::calibrate`; the maps written
//! beside `rig.json` (`R.cam{k}.dark.tif`, `.gain.tif`, `.defects.tif`) and
//! recorded in it with their checksums (`measure` reads them back through
//! `fuse::CalibratedRig`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use extract::{Frame, FrameReader};
use formats::commissioning::FlatFieldFit;
use formats::{OutputPlan, SensorJson, SensorMapFiles};
use sensor::maps::MapKind;
use sensor::{SensorCalibration, SensorMaps, StackKind};

use super::images::{Subfolders, expand_images};

/// The frames of one stack, in file-name order.
pub struct Stack {
    /// What the user named: a file or a folder.
    pub input: PathBuf,
    /// The frames' files.
    pub paths: Vec<PathBuf>,
    frames: Vec<Frame>,
    exposures: Vec<Option<f64>>,
    /// Each frame's camera serial from its tags, where it has one.
    serials: Vec<Option<String>>,
}

impl Stack {
    /// Read the frames of `input` (a file, or a folder of TIFF and PNG
    /// frames); each must be `size` px when given (`camera` names it).
    pub fn read(
        input: &Path,
        reader: &mut FrameReader,
        size: Option<(u32, u32)>,
        camera: &str,
    ) -> Result<Self> {
        let paths = expand_images(
            std::slice::from_ref(&input.to_path_buf()),
            Subfolders::NotSearched,
        )?;
        let mut frames = Vec::with_capacity(paths.len());
        let mut exposures = Vec::with_capacity(paths.len());
        let mut serials = Vec::with_capacity(paths.len());
        for path in &paths {
            let (view, meta) = reader.read(path)?;
            if let Some((w, h)) = size
                && (view.width, view.height) != (w, h)
            {
                bail!(
                    "{}: the image is {}×{} px, but {camera} is {w}×{h} px",
                    path.display(),
                    view.width,
                    view.height
                );
            }
            frames.push(Frame {
                width: view.width,
                height: view.height,
                bit_depth: view.bit_depth,
                pixels: view.pixels.to_vec(),
            });
            exposures.push(meta.exposure_s);
            serials.push(meta.serial);
        }
        Ok(Self {
            input: input.to_path_buf(),
            paths,
            frames,
            exposures,
            serials,
        })
    }

    /// The camera serial of the first frame that has one in its tags.
    pub fn serial(&self) -> Option<&str> {
        self.serials.iter().flatten().next().map(String::as_str)
    }

    /// Refuses a frame whose tags name another camera than `serial` (of
    /// `what`, e.g. the camera's calibration image): a flat field or dark
    /// frame of another camera would correct this one with the wrong lens
    /// and sensor. Frames without a serial, or no serial to compare with,
    /// pass.
    pub fn check_camera(&self, serial: Option<&str>, what: &str) -> Result<()> {
        let Some(want) = serial else {
            return Ok(());
        };
        for (path, got) in self.paths.iter().zip(&self.serials) {
            if let Some(got) = got.as_deref()
                && got != want
            {
                bail!(
                    "{}: taken by the camera of serial {got}, but {what} is serial {want}: is \
                     this the right frame for this camera (the order of the cameras)?",
                    path.display()
                );
            }
        }
        Ok(())
    }

    /// The frames as the sensor crate takes them.
    pub fn frames(&self) -> Vec<sensor::Frame<'_>> {
        self.frames
            .iter()
            .zip(&self.exposures)
            .map(|(f, &exposure_s)| sensor::Frame {
                values: &f.pixels,
                width: f.width,
                height: f.height,
                container_bits: f.bit_depth,
                exposure_s,
            })
            .collect()
    }

    /// Whether the user gave a folder: a stack, from which per-pixel maps
    /// are wanted. A single file gives the lens's relative illumination only.
    pub fn is_stack(&self) -> bool {
        self.input.is_dir()
    }

    /// The first frame (a stack is never empty).
    pub fn first(&self) -> Option<&Frame> {
        self.frames.first()
    }

    /// How the stack is named in messages: the file, or the folder and its count.
    fn describe(&self) -> String {
        match self.paths.as_slice() {
            [one] if one == &self.input => one.display().to_string(),
            paths => format!("{} ({} frames)", self.input.display(), paths.len()),
        }
    }

    /// An error of the sensor crate about this stack, naming the file of the
    /// frame it names.
    fn error(&self, e: sensor::SensorError) -> anyhow::Error {
        match e.frame().and_then(|i| self.paths.get(i)) {
            Some(path) => anyhow::anyhow!("{}: {e}", path.display()),
            None => anyhow::anyhow!("{}: {e}", self.describe()),
        }
    }
}

/// The sensor calibration of one camera from its stacks; `smooth` is the
/// lens's relative illumination (any scale) the gain map is taken against.
/// `None` when neither is a stack (a single flat field and dark frame give
/// the relative illumination alone, as before stacks). Every refusal names
/// the file (or the stack) and what is wrong; a stack needs ≥ 2 frames.
pub fn calibrate(
    flats: &Stack,
    darks: &Stack,
    smooth: &dyn Fn(f64, f64) -> f64,
) -> Result<Option<SensorCalibration>> {
    if !flats.is_stack() && !darks.is_stack() {
        return Ok(None);
    }
    let (f, d) = (flats.frames(), darks.frames());
    sensor::check_stack(&f, StackKind::Flat).map_err(|e| flats.error(e))?;
    sensor::check_stack(&d, StackKind::Dark).map_err(|e| darks.error(e))?;
    let cal =
        sensor::calibrate(&f, &d, smooth, &sensor::Options::default()).map_err(|e| {
            match e.stack() {
                Some(StackKind::Dark) => darks.error(e),
                Some(StackKind::Flat) => flats.error(e),
                Some(StackKind::Repeat) | None => anyhow::anyhow!(
                    "flat fields {} with dark frames {}: {e}",
                    flats.describe(),
                    darks.describe()
                ),
            }
        })?;
    Ok(Some(cal))
}

/// What a camera's maps correct, for notes: "master dark, gain map, 12 defective pixels".
pub fn describe(maps: &SensorMaps) -> String {
    let mut parts = Vec::new();
    if maps.dark.is_some() {
        parts.push("master dark".to_string());
    }
    if maps.gain.is_some() {
        parts.push("gain map".to_string());
    }
    let n = maps.defects.defects.len();
    if n > 0 || parts.is_empty() {
        parts.push(format!(
            "{n} defective pixel{}",
            if n == 1 { "" } else { "s" }
        ));
    }
    parts.join(", ")
}

/// The lens's relative illumination fitted to the first flat field and dark
/// frame of the stacks (`calib::fit_flat_field`, its centre started at
/// `centre`, ρ scaled by `scale_px`), then the sensor's per-pixel
/// calibration from the stacks against it (`None` for single files).
pub fn fit(
    flats: &Stack,
    darks: &Stack,
    centre: [f64; 2],
    scale_px: f64,
) -> Result<(FlatFieldFit, Option<SensorCalibration>)> {
    let (Some(f), Some(d)) = (flats.first(), darks.first()) else {
        bail!("an empty stack of flat fields or dark frames");
    };
    let flat_pixels = calib::Pixels {
        values: &f.pixels,
        width: f.width,
        height: f.height,
        saturation: f.view().max_value(),
    };
    let dark_pixels = calib::Pixels {
        values: &d.pixels,
        ..flat_pixels
    };
    let fit =
        calib::fit_flat_field(&flat_pixels, &dark_pixels, centre, scale_px).with_context(|| {
            format!(
                "flat field {} with dark frame {}",
                flats.paths[0].display(),
                darks.paths[0].display()
            )
        })?;
    let sensor = calibrate(flats, darks, &|u, v| fit.model.at(u, v))?;
    Ok((fit, sensor))
}

/// The map file of kind `kind` of camera `id` beside `out` (`rig.json`):
/// `R.cam{id}.{kind}.tif`.
fn map_path(out: &Path, id: u8, kind: MapKind) -> PathBuf {
    formats::beside(out, "rig", &format!(".cam{id}.{kind}.tif"))
}

/// Plan the map files of camera `id`.
pub fn plan_maps(output: &mut OutputPlan, out: &Path, id: u8) {
    for kind in MapKind::ALL {
        output.file(map_path(out, id, kind));
    }
}

/// A map file to write: its path and bytes.
pub type MapBytes = (PathBuf, Vec<u8>);

/// The encoded map files of a calibration (`sensor::maps::encode_maps`: only
/// the maps that are applied, and the defect map) beside `out`, with the
/// record that names them.
pub fn encode_maps(
    cal: &SensorCalibration,
    out: &Path,
    id: u8,
) -> Result<(Vec<MapBytes>, SensorMapFiles)> {
    let (files, record) = sensor::maps::encode_maps(&cal.maps, |kind| {
        map_path(out, id, kind)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    })?;
    let files = files
        .into_iter()
        .map(|(kind, bytes)| (map_path(out, id, kind), bytes))
        .collect();
    Ok((files, record))
}

/// `rig.json`'s `sensor` record of a calibration whose maps are `maps`.
pub fn record(cal: &SensorCalibration, maps: SensorMapFiles) -> SensorJson {
    let d = &cal.maps.defects;
    let clusters = d.clusters.iter().filter(|c| c.pixels > 1).count();
    let mut extra = serde_json::Map::new();
    extra.insert("dark_note".into(), cal.dark_note.clone().into());
    extra.insert("gain_note".into(), cal.gain_note.clone().into());
    if let Some(note) = &cal.transfer_note {
        extra.insert("transfer_note".into(), note.clone().into());
    }
    SensorJson {
        adc_bits: cal.adc.adc_bits,
        container_bits: cal.adc.container_bits,
        gain_dn_per_e: cal.transfer.as_ref().map(|t| t.gain_dn_per_e),
        read_noise_e: cal.transfer.as_ref().map(|t| t.read_noise_e),
        prnu: cal.prnu,
        dsnu_dn: cal.dsnu_dn,
        column_dsnu_dn: cal.column_dsnu_dn,
        black_level_dn: f64::from(cal.maps.black_level_dn),
        saturation_dn: cal.maps.saturation,
        defects: formats::DefectCounts {
            hot: d.count(sensor::DefectKind::Hot),
            dead: d.count(sensor::DefectKind::Dead),
            weak: d.count(sensor::DefectKind::Weak),
            strong: d.count(sensor::DefectKind::Strong),
            clusters,
        },
        stack: formats::StackRecord {
            flats: cal.flats,
            darks: cal.darks,
            flat_noise_dn: cal.flat_noise_dn,
            dark_noise_dn: cal.dark_noise_dn,
        },
        maps,
        extra,
    }
}
