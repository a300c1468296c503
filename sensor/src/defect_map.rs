//! The defect map of a sensor (EMVA 1288 defect pixels): each pixel's kind,
//! the list of defective pixels and their 8-connected clusters.

use crate::{Result, SensorError};

/// The kind of a defective pixel; its code in the map file (0 = good).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DefectKind {
    /// Far above its column/row pattern in the master dark (code 1).
    Hot,
    /// No response in the gain map (code 2).
    Dead,
    /// Gain well below 1 (code 3).
    Weak,
    /// Gain well above 1 (code 4).
    Strong,
}

impl DefectKind {
    /// The code in the map file.
    pub fn code(self) -> u8 {
        match self {
            DefectKind::Hot => 1,
            DefectKind::Dead => 2,
            DefectKind::Weak => 3,
            DefectKind::Strong => 4,
        }
    }

    /// The kind of a code; `None` for 0 (good) and unknown codes.
    pub fn from_code(code: u8) -> Option<Self> {
        match code {
            1 => Some(DefectKind::Hot),
            2 => Some(DefectKind::Dead),
            3 => Some(DefectKind::Weak),
            4 => Some(DefectKind::Strong),
            _ => None,
        }
    }
}

impl std::fmt::Display for DefectKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            DefectKind::Hot => "hot",
            DefectKind::Dead => "dead",
            DefectKind::Weak => "weak",
            DefectKind::Strong => "strong",
        })
    }
}

/// One defective pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Defect {
    /// Column.
    pub x: u32,
    /// Row.
    pub y: u32,
    /// Its kind.
    pub kind: DefectKind,
}

/// An 8-connected group of ≥ 2 defective pixels and its bounding box
/// (inclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cluster {
    /// Pixels in the group.
    pub pixels: usize,
    /// Smallest column.
    pub x0: u32,
    /// Smallest row.
    pub y0: u32,
    /// Largest column.
    pub x1: u32,
    /// Largest row.
    pub y1: u32,
}

/// The defective pixels of a sensor, in raster order, and their clusters.
#[derive(Clone, Debug, PartialEq)]
pub struct DefectMap {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// Defective pixels, raster order.
    pub defects: Vec<Defect>,
    /// 8-connected groups of ≥ 2 defective pixels, in the raster order of
    /// their first pixel.
    pub clusters: Vec<Cluster>,
    /// Code per pixel (0 good), for O(1) look-up.
    codes: Vec<u8>,
}

impl DefectMap {
    /// A map without defects.
    pub fn empty(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            defects: Vec::new(),
            clusters: Vec::new(),
            codes: vec![0; width as usize * height as usize],
        }
    }

    /// Number of defects of a kind.
    pub fn count(&self, kind: DefectKind) -> usize {
        self.defects.iter().filter(|d| d.kind == kind).count()
    }

    /// Whether pixel (x, y) is defective (false outside the map); O(1).
    pub fn is_defect(&self, x: u32, y: u32) -> bool {
        self.kind(x, y).is_some()
    }

    /// The kind of pixel (x, y) when defective.
    pub fn kind(&self, x: u32, y: u32) -> Option<DefectKind> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = y as usize * self.width as usize + x as usize;
        self.codes.get(i).copied().and_then(DefectKind::from_code)
    }

    /// `width × height` codes for the map file (0 good, else
    /// [`DefectKind::code`]).
    pub fn codes(&self) -> Vec<u8> {
        self.codes.clone()
    }

    /// The map from its codes; refuses a wrong length or an unknown code.
    pub fn from_codes(width: u32, height: u32, codes: &[u8]) -> Result<Self> {
        let n = width as usize * height as usize;
        if codes.len() != n {
            return Err(SensorError::MapSize {
                what: "defect map".into(),
                message: format!("{} codes for a {width}×{height} map", codes.len()),
            });
        }
        let mut defects = Vec::new();
        for (i, &code) in codes.iter().enumerate() {
            if code == 0 {
                continue;
            }
            let (x, y) = pixel(i, width);
            let kind = DefectKind::from_code(code).ok_or_else(|| SensorError::MapValue {
                what: "defect map".into(),
                x,
                y,
                value: f64::from(code),
                expected: "codes are 0 (good), 1 hot, 2 dead, 3 weak, 4 strong".into(),
            })?;
            defects.push(Defect { x, y, kind });
        }
        let clusters = clusters(&defects, codes, width, height);
        Ok(Self {
            width,
            height,
            defects,
            clusters,
            codes: codes.to_vec(),
        })
    }

    /// Whether there are no defects.
    pub fn is_empty(&self) -> bool {
        self.defects.is_empty()
    }
}

/// (x, y) of raster index `i`.
pub(crate) fn pixel(i: usize, width: u32) -> (u32, u32) {
    let w = width.max(1) as usize;
    ((i % w) as u32, (i / w) as u32)
}

/// The 8-connected groups of ≥ 2 defects (depth-first from each defect not
/// yet reached, in raster order).
fn clusters(defects: &[Defect], codes: &[u8], width: u32, height: u32) -> Vec<Cluster> {
    let mut reached = vec![false; if defects.is_empty() { 0 } else { codes.len() }];
    let index = |x: u32, y: u32| y as usize * width as usize + x as usize;
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for d in defects {
        if reached[index(d.x, d.y)] {
            continue;
        }
        reached[index(d.x, d.y)] = true;
        stack.push((d.x, d.y));
        let mut c = Cluster {
            pixels: 0,
            x0: d.x,
            y0: d.y,
            x1: d.x,
            y1: d.y,
        };
        while let Some((x, y)) = stack.pop() {
            c.pixels += 1;
            (c.x0, c.y0, c.x1, c.y1) = (c.x0.min(x), c.y0.min(y), c.x1.max(x), c.y1.max(y));
            for (nx, ny) in neighbours8(x, y, width, height) {
                let i = index(nx, ny);
                if codes[i] != 0 && !reached[i] {
                    reached[i] = true;
                    stack.push((nx, ny));
                }
            }
        }
        if c.pixels >= 2 {
            out.push(c);
        }
    }
    out
}

/// The in-frame 8-neighbours of (x, y).
pub(crate) fn neighbours8(
    x: u32,
    y: u32,
    width: u32,
    height: u32,
) -> impl Iterator<Item = (u32, u32)> {
    ring(x, y, 1, width, height)
}

/// The in-frame pixels at Chebyshev distance exactly `r` from (x, y).
pub(crate) fn ring(
    x: u32,
    y: u32,
    r: i64,
    width: u32,
    height: u32,
) -> impl Iterator<Item = (u32, u32)> {
    let (x, y) = (i64::from(x), i64::from(y));
    (-r..=r)
        .flat_map(move |dy| (-r..=r).map(move |dx| (dx, dy)))
        .filter(move |&(dx, dy)| dx.abs().max(dy.abs()) == r)
        .map(move |(dx, dy)| (x + dx, y + dy))
        .filter(move |&(nx, ny)| {
            nx >= 0 && ny >= 0 && nx < i64::from(width) && ny < i64::from(height)
        })
        .map(|(nx, ny)| (nx as u32, ny as u32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_clusters_are_8_connected() {
        // 5×4: a diagonal pair (8-connected), an isolated pixel, a 2-pixel row.
        let mut codes = vec![0u8; 20];
        codes[0] = 1; // (0,0)
        codes[6] = 2; // (1,1) diagonal to (0,0)
        codes[4] = 3; // (4,0) isolated
        codes[17] = 4; // (2,3)
        codes[18] = 4; // (3,3)
        let map = DefectMap::from_codes(5, 4, &codes).unwrap();
        assert_eq!(map.codes(), codes);
        assert_eq!(map.defects.len(), 5);
        assert_eq!(map.count(DefectKind::Strong), 2);
        assert!(map.is_defect(1, 1) && !map.is_defect(2, 2) && !map.is_defect(9, 9));
        assert_eq!(
            map.clusters,
            vec![
                Cluster {
                    pixels: 2,
                    x0: 0,
                    y0: 0,
                    x1: 1,
                    y1: 1
                },
                Cluster {
                    pixels: 2,
                    x0: 2,
                    y0: 3,
                    x1: 3,
                    y1: 3
                },
            ]
        );
    }

    #[test]
    fn bad_codes_and_lengths_are_refused() {
        let e = DefectMap::from_codes(2, 2, &[0, 0, 7, 0]).unwrap_err();
        assert!(e.to_string().contains("(0, 1)"), "{e}");
        assert!(DefectMap::from_codes(2, 2, &[0; 3]).is_err());
    }

    #[test]
    fn rings_stay_in_the_frame() {
        assert_eq!(neighbours8(0, 0, 3, 3).count(), 3);
        assert_eq!(neighbours8(1, 1, 3, 3).count(), 8);
        assert_eq!(ring(2, 2, 2, 5, 5).count(), 16);
    }
}
