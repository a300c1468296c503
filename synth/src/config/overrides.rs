//! Command-line overrides of a configuration.

use super::Config;
use super::check::bad;
use crate::Result;

/// Command-line overrides for quick runs (`--width --height --targets --runs --captures --seed`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Overrides {
    /// Image width (px). The sensor's physical width is kept: the pixel pitch
    /// becomes `pixel_mm·width_before/width`, so the field of view, the lens,
    /// the PSF in µm and the distortion are unchanged and every image-space
    /// length in px scales by `width/width_before`.
    pub width: Option<u32>,
    /// Image height (px), same pixel pitch as the width gives (square pixels);
    /// keep 4:3 to keep the vertical field.
    pub height: Option<u32>,
    /// Number of targets on every axis (segments = targets − 1, same travel).
    pub targets: Option<u32>,
    /// Runs.
    pub runs: Option<u32>,
    /// Captures per target.
    pub captures: Option<u32>,
    /// Random seed.
    pub seed: Option<u64>,
}

impl Config {
    /// Apply command-line overrides, then validate.
    pub fn apply(&mut self, o: &Overrides) -> Result<()> {
        if let Some(w) = o.width {
            if w == 0 {
                return Err(bad("--width", "must be positive"));
            }
            self.sensor.pixel_mm *= f64::from(self.sensor.width) / f64::from(w);
            self.sensor.width = w;
        }
        if let Some(h) = o.height {
            self.sensor.height = h;
        }
        if let Some(n) = o.targets {
            if n < 2 {
                return Err(bad(
                    "--targets",
                    format!("{n}: at least 2 targets are needed"),
                ));
            }
            for a in &mut self.procedure.axes {
                a.segments = n - 1;
            }
        }
        if let Some(r) = o.runs {
            self.procedure.runs = r;
        }
        if let Some(c) = o.captures {
            self.procedure.captures = c;
        }
        if let Some(s) = o.seed {
            self.seed = s;
        }
        self.validate()
    }
}
