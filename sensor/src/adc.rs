//! The bit depth of the ADC behind a 16-bit file (issue 24 item 5): a 10-,
//! 12- or 14-bit converter whose values are written left-shifted, so that
//! every value is a multiple of `2^(16 − bits)`.

use crate::frame::Frame;

/// ADC depths reported behind a 16-bit container; any other shift is taken
/// as the container's own depth (a 15-bit or 13-bit converter does not exist
/// in practice, and a large shift is more likely an almost-empty frame).
const ADC_BITS: [u8; 4] = [8, 10, 12, 14];

/// The ADC depth behind a file's container depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AdcDepth {
    /// The file's bit depth (8 or 16).
    pub container_bits: u8,
    /// The converter's bit depth (≤ `container_bits`).
    pub adc_bits: u8,
}

impl AdcDepth {
    /// The depth of a container written at full depth.
    pub fn container(container_bits: u8) -> Self {
        Self {
            container_bits,
            adc_bits: container_bits,
        }
    }

    /// The left shift: `container_bits − adc_bits`.
    pub fn shift(&self) -> u8 {
        self.container_bits.saturating_sub(self.adc_bits)
    }

    /// One ADC step in file DN: `2^shift`.
    pub fn step_dn(&self) -> f64 {
        f64::from(1u32 << self.shift().min(16))
    }

    /// Quantisation noise variance in file DN², `step²/12` (EMVA 1288 §6.3,
    /// `σ²_q` of a uniform quantiser).
    pub fn quantisation_var_dn2(&self) -> f64 {
        self.step_dn().powi(2) / 12.0
    }

    /// The largest value the ADC writes (file DN): `(2^adc_bits − 1)·2^shift`.
    pub fn saturation_dn(&self) -> u16 {
        let bits = u32::from(self.adc_bits.min(16));
        let top = ((1u32 << bits) - 1) << u32::from(self.shift().min(16));
        u16::try_from(top).unwrap_or(u16::MAX)
    }
}

/// The ADC depth from every value of the frames: the trailing zeros of the
/// OR of all values give the shift. An all-zero set gives the container
/// depth; so does any shift but those giving 8, 10, 12 or 14 bits in a
/// 16-bit container (an 8-bit container is always 8-bit).
pub fn adc_depth(frames: &[Frame<'_>]) -> AdcDepth {
    let container_bits = frames.first().map_or(16, |f| f.container_bits);
    depth_of(container_bits, values_or(frames))
}

/// The OR of every value of the frames.
pub(crate) fn values_or(frames: &[Frame<'_>]) -> u16 {
    frames
        .iter()
        .flat_map(|f| f.values.iter())
        .fold(0u16, |acc, &v| acc | v)
}

/// [`adc_depth`] from the OR of all values, `all`.
pub(crate) fn depth_of(container_bits: u8, all: u16) -> AdcDepth {
    if container_bits != 16 || all == 0 {
        return AdcDepth::container(container_bits);
    }
    let shift = u8::try_from(all.trailing_zeros()).unwrap_or(0);
    let adc_bits = container_bits.saturating_sub(shift);
    if ADC_BITS.contains(&adc_bits) {
        AdcDepth {
            container_bits,
            adc_bits,
        }
    } else {
        AdcDepth::container(container_bits)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(values: &[u16], bits: u8) -> Frame<'_> {
        Frame {
            values,
            width: u32::try_from(values.len()).unwrap_or(0),
            height: 1,
            container_bits: bits,
            exposure_s: None,
        }
    }

    #[test]
    fn left_shifted_depths_are_found_from_the_or_of_all_values() {
        for (adc, shift) in [(10u8, 6u32), (12, 4), (14, 2)] {
            // One frame with only high multiples, one with the lowest step:
            // the OR of both frames sets the shift.
            let a: Vec<u16> = [3u16, 64, 1000].iter().map(|v| v << (shift + 1)).collect();
            let b: Vec<u16> = [5u16, 7].iter().map(|v| v << shift).collect();
            let depth = adc_depth(&[frame(&a, 16), frame(&b, 16)]);
            assert_eq!(depth.adc_bits, adc);
            assert_eq!(depth.shift(), 16 - adc);
            assert_eq!(depth.step_dn(), f64::from(1u32 << shift));
        }
    }

    #[test]
    fn other_shifts_and_empty_data_are_the_container() {
        let odd: Vec<u16> = vec![1, 2, 3];
        assert_eq!(adc_depth(&[frame(&odd, 16)]), AdcDepth::container(16));
        // A shift of 3 would be a 13-bit ADC: not reported.
        let thirteen: Vec<u16> = vec![8, 24];
        assert_eq!(adc_depth(&[frame(&thirteen, 16)]), AdcDepth::container(16));
        let zero: Vec<u16> = vec![0; 4];
        assert_eq!(adc_depth(&[frame(&zero, 16)]), AdcDepth::container(16));
        let eight: Vec<u16> = vec![4, 8];
        assert_eq!(adc_depth(&[frame(&eight, 8)]), AdcDepth::container(8));
        assert_eq!(adc_depth(&[]), AdcDepth::container(16));
    }

    #[test]
    fn saturation_is_the_top_code_shifted() {
        let twelve = AdcDepth {
            container_bits: 16,
            adc_bits: 12,
        };
        assert_eq!(twelve.saturation_dn(), 4095 << 4);
        assert_eq!(AdcDepth::container(16).saturation_dn(), 65535);
        assert_eq!(AdcDepth::container(8).saturation_dn(), 255);
        assert!((twelve.quantisation_var_dn2() - 256.0 / 12.0).abs() < 1e-12);
    }
}
