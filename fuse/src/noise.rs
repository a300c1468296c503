//! The noise model of each camera's images, which the centroids'
//! covariances are computed from (docs/uncertainty.md): the system gain K
//! (DN/e⁻; the background's noise is measured around every blob).
//!
//! K comes from the sensor's photon transfer when the rig was calibrated
//! with flat and dark stacks (`rig.json` `sensor.gain_dn_per_e`); otherwise
//! from the campaign's own images: pairs of repeated captures of one instant
//! (`sensor::gain_from_repeats`). Without either it is unknown, and the
//! centroids carry no covariance — said so, never guessed.

use std::collections::BTreeMap;

use extract::FrameReader;
use formats::InstantKey;

use crate::plan::InstantPlan;

/// Pairs of repeated captures read per camera for K.
const REPEAT_PAIRS: usize = 2;

/// Where a camera's noise model comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum NoiseSource {
    /// The sensor's photon transfer from flat and dark stacks (`rig.json`).
    Stacks,
    /// Photon transfer on pairs of repeated captures of the campaign.
    Repeats {
        /// Pairs used.
        pairs: usize,
        /// Pixel differences used.
        pixels: u64,
    },
    /// Unknown, and why.
    Unknown(String),
}

/// A camera's noise model.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraNoise {
    /// The system gain K (DN/e⁻), when known.
    pub gain_dn_per_e: Option<f64>,
    /// Where it comes from.
    pub source: NoiseSource,
}

impl CameraNoise {
    /// In words, for the command's output.
    pub fn describe(&self) -> String {
        match (&self.source, self.gain_dn_per_e) {
            (NoiseSource::Stacks, Some(k)) => {
                format!("K = {k:.3} DN/e⁻ from the flat and dark stacks (rig.json)")
            }
            (NoiseSource::Repeats { pairs, pixels }, Some(k)) => format!(
                "K = {k:.3} DN/e⁻ from {pairs} pair{} of repeated captures ({pixels} pixel differences)",
                if *pairs == 1 { "" } else { "s" }
            ),
            (NoiseSource::Unknown(why), _) => format!("unknown: {why}"),
            (_, None) => "unknown".into(),
        }
    }
}

/// The first [`REPEAT_PAIRS`] pairs of images of `camera` taken at one
/// instant: captures 1 and 2 of the same axis, direction, run and target.
fn repeat_pairs(plans: &[InstantPlan], camera: u8) -> Vec<(&std::path::Path, &std::path::Path)> {
    let by_key: BTreeMap<InstantKey, &InstantPlan> = plans.iter().map(|p| (p.key, p)).collect();
    plans
        .iter()
        .filter(|p| p.key.capture == 1)
        .filter_map(|p| {
            let second = by_key.get(&InstantKey {
                capture: 2,
                ..p.key
            })?;
            Some((
                p.images.get(&camera)?.as_path(),
                second.images.get(&camera)?.as_path(),
            ))
        })
        .take(REPEAT_PAIRS)
        .collect()
}

/// A frame read into memory: pixels, width, height, bit depth, exposure (s).
type OwnedFrame = (Vec<u16>, u32, u32, u8, Option<f64>);

/// K from pairs of repeated captures of `camera`, read with `max_pixels`.
fn from_repeats(plans: &[InstantPlan], camera: u8, max_pixels: u64) -> CameraNoise {
    let unknown = |why: String| CameraNoise {
        gain_dn_per_e: None,
        source: NoiseSource::Unknown(why),
    };
    let pairs = repeat_pairs(plans, camera);
    if pairs.is_empty() {
        return unknown(
            "no flat and dark stacks in the rig and no instant captured twice to estimate the sensor's \
             gain from"
                .into(),
        );
    }
    let mut reader = FrameReader::new().limit_pixels(max_pixels);
    let mut frames: Vec<OwnedFrame> = Vec::new();
    for path in pairs.iter().flat_map(|(a, b)| [*a, *b]) {
        match reader.read(path) {
            Ok((f, meta)) => frames.push((
                f.pixels.to_vec(),
                f.width,
                f.height,
                f.bit_depth,
                meta.exposure_s,
            )),
            Err(e) => return unknown(format!("repeated captures cannot be read: {e}")),
        }
    }
    fn view(f: &OwnedFrame) -> sensor::Frame<'_> {
        sensor::Frame {
            values: &f.0,
            width: f.1,
            height: f.2,
            container_bits: f.3,
            exposure_s: f.4,
        }
    }
    let frame_pairs: Vec<(sensor::Frame<'_>, sensor::Frame<'_>)> = frames
        .chunks_exact(2)
        .map(|p| (view(&p[0]), view(&p[1])))
        .collect();
    let saturation = frames.first().map_or(u16::MAX, |f| {
        if f.3 == 8 {
            u16::from(u8::MAX)
        } else {
            u16::MAX
        }
    });
    match sensor::gain_from_repeats(&frame_pairs, saturation) {
        Ok(g) => CameraNoise {
            gain_dn_per_e: Some(g.gain_dn_per_e),
            source: NoiseSource::Repeats {
                pairs: g.pairs,
                pixels: g.pixels,
            },
        },
        Err(e) => unknown(format!(
            "the repeated captures ({}) give no gain: {e}",
            pairs[0].0.display()
        )),
    }
}

/// Each camera's noise model: from the rig's sensor record, else from the
/// campaign's repeated captures.
pub fn noise_models(
    rig: &formats::Rig,
    plans: &[InstantPlan],
    max_pixels: u64,
) -> BTreeMap<u8, CameraNoise> {
    rig.cameras
        .iter()
        .map(|c| {
            let id = c.model.id;
            let from_stacks = c.sensor.as_ref().and_then(|s| s.gain_dn_per_e);
            let noise = match from_stacks {
                Some(k) => CameraNoise {
                    gain_dn_per_e: Some(k),
                    source: NoiseSource::Stacks,
                },
                None => from_repeats(plans, id, max_pixels),
            };
            (id, noise)
        })
        .collect()
}
