//! Per-pixel calibration of an image sensor from stacks of flat-field and
//! dark frames, after EMVA 1288: robust master frames, the bit depth of the
//! ADC, photon transfer (system gain, read noise), the fixed patterns
//! (DSNU, PRNU) as per-pixel maps, defective pixels, and the correction of a
//! frame with those maps before its blobs are extracted.
//!
//! The model of a pixel's value (DN, METHODS §6):
//! `y = K·(η·photons·(1 + g_px) + dark_px) + d_px + col_x + row_y + K·n`,
//! quantised in ADC steps.
//!
//! The crate does no file I/O: frames come decoded, maps are encoded to and
//! decoded from bytes (`maps`), and every check that refuses a frame names
//! the frame by its index in its stack, for the caller to name the file.
//!
//! # Conventions
//! DN are the file's values (a 12-bit ADC written left-shifted reads in
//! steps of 16); pixel (x, y) has its centre at (u, v) = (x, y); maps are
//! row-major, `width × height`. Statistics are f64, maps f32. Every sum
//! over a frame adds its rows in order (or is exact), so results do not
//! depend on the number of threads. See `docs/sensor.md`.
//!
//! # API
//! - [`Frame`], [`StackKind`]: a decoded frame with its metadata.
//! - [`check_stack`]: the refusals of METHODS §6 / issue 24 item 8.
//! - [`AdcDepth`], [`adc_depth`]: a 10/12/14-bit ADC written left-shifted.
//! - [`Master`], [`master`]: outlier-robust per-pixel mean of a stack, its
//!   temporal noise (`½·var(A − B)` over consecutive pairs) and mean level.
//! - [`PhotonTransfer`], [`photon_transfer`]: K (DN/e⁻), σ_d (e⁻) from a
//!   flat and a dark master (each of ≥ 2 frames).
//! - [`RepeatGain`], [`gain_from_repeats`]: K from pairs of repeated
//!   captures of one instant (the measurement images), without stacks.
//! - [`DefectMap`], [`Defect`], [`DefectKind`], [`Cluster`]: defective pixels.
//! - [`SensorMaps`]: master dark, gain map, defects; [`SensorMaps::correct`].
//! - [`calibrate`] with [`Options`] → [`SensorCalibration`]: all of the above
//!   and the decisions ([`DarkModel`]: per-pixel dark, column/row pattern or
//!   black level; gain map used or not; and why, with numbers).
//! - `maps::{encode_f32, decode_f32, encode_u8, decode_u8, checksum}`: the
//!   map files (32-bit float / 8-bit TIFF) and their CRC-32;
//!   `maps::{encode_maps, decode_maps}`: a camera's maps as the files its
//!   `rig.json` record names, and back from their bytes, checked against it.

mod adc;
mod calibrate;
mod correct;
mod decision;
mod defect_map;
mod detect;
mod error;
mod frame;
mod gain;
pub mod maps;
mod master;
mod order;
mod pattern;
mod refusal;
mod repeats;
mod sums;
mod temporal;
mod transfer;

pub use adc::{AdcDepth, adc_depth};
pub use calibrate::{DarkModel, Options, SensorCalibration, calibrate};
pub use correct::SensorMaps;
pub use defect_map::{Cluster, Defect, DefectKind, DefectMap};
pub use error::{Result, SensorError};
pub use frame::{Frame, StackKind, check_stack};
pub use master::{Master, master};
pub use repeats::{PairTransfer, RepeatGain, RepeatGainEstimate, gain_from_repeats};
pub use transfer::{PhotonTransfer, photon_transfer};
