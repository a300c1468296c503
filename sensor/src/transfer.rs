//! Photon transfer (EMVA 1288 §6, one illumination level): the system gain
//! K from the rise of the temporal variance with the signal,
//! `σ²_y − σ²_y.dark = K·(μ_y − μ_y.dark)`, and the read noise from the
//! dark's temporal variance less the quantisation noise,
//! `σ_d = √(σ²_y.dark − σ²_q)/K`, `σ²_q = step²/12`.

use crate::adc::AdcDepth;
use crate::frame::StackKind;
use crate::master::Master;
use crate::{Result, SensorError};

/// Frames a stack needs for a temporal variance (one consecutive pair).
pub(crate) const TRANSFER_FRAMES: usize = 2;

/// EMVA 1288 photon transfer from one flat level and the dark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhotonTransfer {
    /// K, in the file's DN per electron.
    pub gain_dn_per_e: f64,
    /// `σ_d = √(max(σ²_y.dark − σ²_q, 0))/K` (e⁻); 0 when the dark's noise
    /// is below the quantisation noise (EMVA 1288: then only an upper bound
    /// `σ_y.dark/K` is known).
    pub read_noise_e: f64,
    /// `σ_d·K` (file DN).
    pub read_noise_dn: f64,
    /// `μ_y.dark` (DN).
    pub dark_level_dn: f64,
    /// `μ_y` of the flat (DN).
    pub flat_level_dn: f64,
    /// `σ_y.dark`, temporal, per frame (DN).
    pub dark_temporal_dn: f64,
    /// `σ_y` of the flat, temporal, per frame (DN).
    pub flat_temporal_dn: f64,
    /// `(μ_y − μ_y.dark)/K`: electrons of the flat.
    pub signal_e: f64,
    /// Full well (e⁻); `None`: one flat level measures none (it needs a ramp
    /// of levels up to where `σ²_y` stops rising).
    pub full_well_e: Option<f64>,
}

/// K and σ_d from a flat master and a dark master of ≥ 2 frames each, with
/// the ADC's quantisation step. Refuses a stack of one, a flat not brighter
/// than its dark and a flat whose temporal variance does not exceed the
/// dark's.
pub fn photon_transfer(flat: &Master, dark: &Master, adc: AdcDepth) -> Result<PhotonTransfer> {
    let flat_var = temporal_var(flat, StackKind::Flat)?;
    let dark_var = temporal_var(dark, StackKind::Dark)?;
    let signal_dn = flat.level_dn - dark.level_dn;
    if signal_dn <= 0.0 {
        return Err(SensorError::FlatDarkerThanDark {
            flat_dn: flat.level_dn,
            dark_dn: dark.level_dn,
        });
    }
    if flat_var <= dark_var {
        return Err(SensorError::NoShotNoise {
            flat_var_dn2: flat_var,
            dark_var_dn2: dark_var,
        });
    }
    let gain = (flat_var - dark_var) / signal_dn;
    let read_noise_e = (dark_var - adc.quantisation_var_dn2()).max(0.0).sqrt() / gain;
    Ok(PhotonTransfer {
        gain_dn_per_e: gain,
        read_noise_e,
        read_noise_dn: read_noise_e * gain,
        dark_level_dn: dark.level_dn,
        flat_level_dn: flat.level_dn,
        dark_temporal_dn: dark_var.sqrt(),
        flat_temporal_dn: flat_var.sqrt(),
        signal_e: signal_dn / gain,
        full_well_e: None,
    })
}

/// `σ²_y` of a master, or why there is none.
fn temporal_var(master: &Master, kind: StackKind) -> Result<f64> {
    match master.temporal_var_dn2 {
        Some(v) if master.frames >= TRANSFER_FRAMES => Ok(v),
        _ => Err(SensorError::StackTooSmall {
            kind,
            frames: master.frames,
            needed: TRANSFER_FRAMES,
            what: "photon transfer (a temporal variance from a pair of frames)".into(),
        }),
    }
}
