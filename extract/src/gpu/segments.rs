//! From the kernel's run segments to the CPU's runs and components.
//!
//! The kernel cuts every run at 32-pixel chunk boundaries and appends the
//! pieces in no particular order. Sorted by (row, column), pieces that abut
//! are joined back into maximal runs with their sums moved to the run's first
//! column (exact in `u64`: with d = x0′ − x0, ΣF·(x − x0) = ΣF·dx′ + d·ΣF and
//! ΣF·(x − x0)² = ΣF·dx′² + 2d·ΣF·dx′ + d²·ΣF). Runs of adjacent rows that
//! touch (8-connectivity) are joined by union–find whose roots are the
//! smallest index, and components are numbered by their first run in raster
//! order — the CPU labeller's numbering, so [`blob::collect`](crate::blob::collect)
//! gives the same blobs.

use bytemuck::{Pod, Zeroable};

use crate::Result;
use crate::label::{Labelling, Run};
use crate::threshold::Level;

/// One segment as the kernel writes it (`Segment` in runs.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub(crate) struct Segment {
    /// Frame row.
    pub y: u32,
    /// First column.
    pub x0: u32,
    /// Bits 0..4: length − 1; 8..13: saturated pixels; 16..31: peak.
    pub packed: u32,
    /// ΣF.
    pub sum_f: u32,
    /// ΣF·dx.
    pub sum_fdx: u32,
    /// ΣF·dx².
    pub sum_fdx2: u32,
}

/// Bytes of one segment.
pub(crate) const SEGMENT_BYTES: u64 = std::mem::size_of::<Segment>() as u64;

impl Segment {
    fn x1(&self) -> u32 {
        self.x0 + (self.packed & 0x1f)
    }

    fn to_run(self) -> Run {
        Run {
            y: self.y,
            x0: self.x0,
            x1: self.x1(),
            sum_f: u64::from(self.sum_f),
            sum_fdx: u64::from(self.sum_fdx),
            sum_fdx2: u64::from(self.sum_fdx2),
            peak: (self.packed >> 16) as u16,
            saturated: (self.packed >> 8) & 0x3f,
        }
    }
}

/// Join abutting segments into maximal runs, in raster order.
pub(crate) fn runs(mut segments: Vec<Segment>) -> Vec<Run> {
    segments.sort_unstable_by_key(|s| (u64::from(s.y) << 32) | u64::from(s.x0));
    let mut out: Vec<Run> = Vec::with_capacity(segments.len());
    for s in segments {
        let piece = s.to_run();
        match out.last_mut() {
            Some(r) if r.y == piece.y && r.x1 + 1 == piece.x0 => {
                let d = u64::from(piece.x0 - r.x0);
                r.sum_fdx2 += piece.sum_fdx2 + 2 * d * piece.sum_fdx + d * d * piece.sum_f;
                r.sum_fdx += piece.sum_fdx + d * piece.sum_f;
                r.sum_f += piece.sum_f;
                r.x1 = piece.x1;
                r.peak = r.peak.max(piece.peak);
                r.saturated += piece.saturated;
            }
            _ => out.push(piece),
        }
    }
    out
}

/// Components of runs in raster order: the CPU labeller's own union–find.
pub(crate) fn label(runs: Vec<Run>, level: &Level, max_runs: usize) -> Result<Labelling> {
    crate::label::label_runs(runs, level, max_runs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ExtractError;
    use crate::frame::FrameView;
    use crate::label::{self, Weighting};
    use proptest::prelude::*;

    /// The kernel's output, computed on the host: segments of 32-pixel chunks.
    #[allow(clippy::needless_range_loop)]
    fn segments_of(w: usize, px: &[u16], t: u16, sat: u16) -> Vec<Segment> {
        let mut out = Vec::new();
        for (y, row) in px.chunks(w).enumerate() {
            for c in (0..w).step_by(32) {
                let mut open: Option<Segment> = None;
                let end = (c + 32).min(w);
                for x in c..=end {
                    match (x < end && row[x] >= t, open.as_mut()) {
                        (true, o) => {
                            let p = u32::from(row[x]);
                            let s = o.map(|s| *s).unwrap_or(Segment {
                                y: y as u32,
                                x0: x as u32,
                                ..Segment::zeroed()
                            });
                            let dx = x as u32 - s.x0;
                            let f = p - u32::from(t);
                            let sat_n = ((s.packed >> 8) & 0x3f) + u32::from(p >= u32::from(sat));
                            let peak = (s.packed >> 16).max(p);
                            open = Some(Segment {
                                packed: dx | (sat_n << 8) | (peak << 16),
                                sum_f: s.sum_f + f,
                                sum_fdx: s.sum_fdx + f * dx,
                                sum_fdx2: s.sum_fdx2 + f * dx * dx,
                                ..s
                            });
                        }
                        (false, Some(_)) => out.extend(open.take()),
                        (false, None) => {}
                    }
                }
            }
        }
        // The kernel's order is arbitrary.
        out.reverse();
        out
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Segments joined and labelled on the host give the CPU labeller's runs and components.
        #[test]
        fn same_labelling_as_the_cpu(
            (w, h, px) in (1usize..100, 1usize..40).prop_flat_map(|(w, h)| {
                let px = proptest::collection::vec(prop_oneof![3 => Just(100u16), 2 => 1000u16..1100, 1 => Just(65535u16)], w * h);
                (Just(w), Just(h), px)
            })
        ) {
            let t = 1000;
            let frame = FrameView::new(w as u32, h as u32, 16, &px).unwrap();
            let cpu = label::label(&frame, &Level::Constant(t), Weighting::Subtracted, usize::MAX).unwrap();
            let gpu = label(runs(segments_of(w, &px, t, 65535)), &Level::Constant(t), usize::MAX).unwrap();
            prop_assert_eq!(&gpu.runs, &cpu.runs);
            prop_assert_eq!(&gpu.component, &cpu.component);
            prop_assert_eq!(gpu.components, cpu.components);
        }
    }

    #[test]
    fn too_many_runs() {
        let px: Vec<u16> = (0..64).map(|i| if i % 2 == 0 { 500 } else { 0 }).collect();
        let r = label(
            runs(segments_of(64, &px, 100, 65535)),
            &Level::Constant(100),
            10,
        );
        assert!(matches!(r, Err(ExtractError::TooManyRuns { runs: 32, .. })));
    }
}
