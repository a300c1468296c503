//! The noise model of each camera's images, which the centroids'
//! covariances are computed from (docs/uncertainty.md): the system gain K
//! (DN/e⁻; the background's noise is measured around every blob).
//!
//! K comes from the sensor's photon transfer when the rig was calibrated
//! with flat and dark stacks (`rig.json` `sensor.gain_dn_per_e`); otherwise
//! from the campaign's own images: pairs of repeated captures of one instant
//! (`sensor::gain_from_repeats`), whose frames `measure` measures as it reads
//! them for K, their centroids' covariances given K once it is known
//! (`extract::CovarianceForm`), so that no frame is decoded twice. Without
//! either it is unknown, and the centroids carry no covariance — said so,
//! never guessed.

use std::collections::BTreeMap;

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
/// instant: captures 1 and 2 of the same axis, direction, run and target,
/// with their instants.
pub(crate) fn repeat_pairs(
    plans: &[InstantPlan],
    camera: u8,
) -> Vec<[(&InstantPlan, &std::path::Path); 2]> {
    let by_key: BTreeMap<InstantKey, &InstantPlan> = plans.iter().map(|p| (p.key, p)).collect();
    plans
        .iter()
        .filter(|p| p.key.capture == 1)
        .filter_map(|p| {
            let second = by_key.get(&InstantKey {
                capture: 2,
                ..p.key
            })?;
            Some([
                (p, p.images.get(&camera)?.as_path()),
                (*second, second.images.get(&camera)?.as_path()),
            ])
        })
        .take(REPEAT_PAIRS)
        .collect()
}

/// K from the pairs of repeated captures as they are read, and the first
/// reason none can be given.
#[derive(Default)]
pub(crate) struct RepeatsRead {
    estimate: Option<sensor::RepeatGainEstimate>,
    failure: Option<String>,
}

impl RepeatsRead {
    /// Takes in the pair of frames `a` and `b`, taken with exposures
    /// `exposure_a` and `exposure_b` (s).
    pub(crate) fn add_pair(
        &mut self,
        a: &extract::FrameView<'_>,
        exposure_a: Option<f64>,
        b: &extract::FrameView<'_>,
        exposure_b: Option<f64>,
    ) {
        if self.failure.is_some() {
            return;
        }
        // The container's top code: saturated pixels are left out.
        let saturation = if a.bit_depth == 8 {
            u16::from(u8::MAX)
        } else {
            u16::MAX
        };
        let estimate = self
            .estimate
            .get_or_insert_with(|| sensor::RepeatGainEstimate::new(saturation));
        if let Err(e) = estimate.add_pair(&as_frame(a, exposure_a), &as_frame(b, exposure_b)) {
            self.failure = Some(format!("give no gain: {e}"));
        }
    }

    /// A frame that could not be read, and why: no K.
    pub(crate) fn unreadable(&mut self, why: String) {
        self.failure.get_or_insert(format!("cannot be read: {why}"));
    }

    /// The camera's noise model from the pairs read (the first of them from
    /// `first`).
    pub(crate) fn finish(self, first: &std::path::Path) -> CameraNoise {
        let gain = match (self.failure, self.estimate) {
            (Some(why), _) => Err(why),
            (None, None) => Err("give no gain: no pair was read".to_owned()),
            (None, Some(estimate)) => estimate.finish().map_err(|e| format!("give no gain: {e}")),
        };
        match gain {
            Ok(g) => CameraNoise {
                gain_dn_per_e: Some(g.gain_dn_per_e),
                source: NoiseSource::Repeats {
                    pairs: g.pairs,
                    pixels: g.pixels,
                },
            },
            Err(why) => unknown(format!("the repeated captures ({}) {why}", first.display())),
        }
    }
}

/// A decoded frame as the photon transfer takes it.
fn as_frame<'a>(frame: &extract::FrameView<'a>, exposure_s: Option<f64>) -> sensor::Frame<'a> {
    sensor::Frame {
        values: frame.pixels,
        width: frame.width,
        height: frame.height,
        container_bits: frame.bit_depth,
        exposure_s,
    }
}

/// A camera whose K is unknown, and why.
pub(crate) fn unknown(why: String) -> CameraNoise {
    CameraNoise {
        gain_dn_per_e: None,
        source: NoiseSource::Unknown(why),
    }
}

/// Without flat and dark stacks and without repeated captures.
pub(crate) fn without_repeats() -> CameraNoise {
    unknown(
        "no flat and dark stacks in the rig and no instant captured twice to estimate the sensor's \
         gain from"
            .into(),
    )
}

/// Each camera's noise model from the rig's sensor record; `None` for a
/// camera whose K is to come from the campaign's repeated captures.
pub(crate) fn from_stacks(rig: &formats::Rig) -> BTreeMap<u8, Option<CameraNoise>> {
    rig.cameras
        .iter()
        .map(|c| {
            let from_stacks = c.sensor.as_ref().and_then(|s| s.gain_dn_per_e);
            let noise = from_stacks.map(|k| CameraNoise {
                gain_dn_per_e: Some(k),
                source: NoiseSource::Stacks,
            });
            (c.model.id, noise)
        })
        .collect()
}
