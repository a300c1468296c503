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
pub(crate) const REPEAT_PAIRS: usize = 2;
/// Pairs tried at most per camera: a pair that cannot be read or gives no
/// sums is passed over for the next one, up to this many.
const REPEAT_TRIES: usize = 3 * REPEAT_PAIRS;

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
        /// Pairs passed over (unreadable, or refused by the photon
        /// transfer), and the first one's reason.
        passed_over: Option<(usize, String)>,
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
            (
                NoiseSource::Repeats {
                    pairs,
                    pixels,
                    passed_over,
                },
                Some(k),
            ) => {
                let passed = passed_over.as_ref().map_or(String::new(), |(n, why)| {
                    format!(
                        "; {n} pair{} passed over, the first because its images {why}",
                        if *n == 1 { "" } else { "s" }
                    )
                });
                format!(
                    "K = {k:.3} DN/e⁻ from {pairs} pair{} of repeated captures ({pixels} pixel \
                     differences{passed})",
                    if *pairs == 1 { "" } else { "s" }
                )
            }
            (NoiseSource::Unknown(why), _) => format!("unknown: {why}"),
            (_, None) => "unknown".into(),
        }
    }
}

/// Two images of one camera at one instant, captures 1 and 2, with their
/// instants.
pub(crate) type RepeatPair<'p> = [(&'p InstantPlan, &'p std::path::Path); 2];

/// The first [`REPEAT_TRIES`] pairs of images of `camera` taken at one
/// instant: captures 1 and 2 of the same axis, direction, run and target,
/// with their instants; K is taken from the first [`REPEAT_PAIRS`] of them
/// that can be used.
pub(crate) fn repeat_pairs(plans: &[InstantPlan], camera: u8) -> Vec<RepeatPair<'_>> {
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
        .take(REPEAT_TRIES)
        .collect()
}

/// The photon transfer of pair `index` of a camera's repeated captures,
/// frames `a` and `b` taken with exposures `exposure_a` and `exposure_b`
/// (s), or why it gives none.
pub(crate) fn pair_transfer(
    index: usize,
    a: &extract::FrameView<'_>,
    exposure_a: Option<f64>,
    b: &extract::FrameView<'_>,
    exposure_b: Option<f64>,
) -> Result<sensor::PairTransfer, String> {
    // The container's top code: saturated pixels are left out.
    let saturation = if a.bit_depth == 8 {
        u16::from(u8::MAX)
    } else {
        u16::MAX
    };
    sensor::RepeatGainEstimate::new(saturation)
        .transfer(index, &as_frame(a, exposure_a), &as_frame(b, exposure_b))
        .map_err(|e| format!("give no gain: {e}"))
}

/// K from the pairs of repeated captures as they are read, in their order:
/// the pairs used, and those passed over with the first one's reason.
#[derive(Default)]
pub(crate) struct RepeatsRead {
    estimate: Option<sensor::RepeatGainEstimate>,
    used: usize,
    passed_over: usize,
    first_failure: Option<String>,
}

impl RepeatsRead {
    /// Pairs still to be used.
    pub(crate) fn still_needed(&self) -> usize {
        REPEAT_PAIRS.saturating_sub(self.used)
    }

    /// Takes in the next pair's photon transfer, or passes the pair over
    /// with the reason it gives none.
    pub(crate) fn take(&mut self, outcome: Result<sensor::PairTransfer, String>) {
        let estimate = self
            .estimate
            .get_or_insert_with(|| sensor::RepeatGainEstimate::new(u16::MAX));
        let added = outcome.and_then(|t| estimate.add(t).map_err(|e| format!("give no gain: {e}")));
        match added {
            Ok(()) => self.used += 1,
            Err(why) => {
                self.passed_over += 1;
                self.first_failure.get_or_insert(why);
            }
        }
    }

    /// The camera's noise model from the pairs read (the first of them from
    /// `first`).
    pub(crate) fn finish(self, first: &std::path::Path) -> CameraNoise {
        let gain = match (self.used, self.estimate) {
            (0, _) | (_, None) => Err(self
                .first_failure
                .clone()
                .unwrap_or_else(|| "give no gain: no pair was read".to_owned())),
            (_, Some(estimate)) => estimate.finish().map_err(|e| format!("give no gain: {e}")),
        };
        let passed_over = self.first_failure.map(|why| (self.passed_over, why));
        match gain {
            Ok(g) => CameraNoise {
                gain_dn_per_e: Some(g.gain_dn_per_e),
                source: NoiseSource::Repeats {
                    pairs: g.pairs,
                    pixels: g.pixels,
                    passed_over,
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
