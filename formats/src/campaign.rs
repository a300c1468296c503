//! The campaign manifest (`manifest.csv`) and sphere set (`spheres.csv`).

use serde::{Deserialize, Serialize};

use crate::table::{Invalid, Record, finite};

/// A machine axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Axis {
    /// X axis.
    X,
    /// Y axis.
    Y,
    /// Z axis.
    Z,
}

impl Axis {
    /// Index 0, 1, 2 of the axis in a coordinate triple.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// The axis with index 0, 1 or 2.
    pub fn from_index(i: usize) -> Option<Axis> {
        [Axis::X, Axis::Y, Axis::Z].get(i).copied()
    }

    /// The two other axes, in cyclic order (X → Y, Z; Y → Z, X; Z → X, Y).
    pub fn others(self) -> [Axis; 2] {
        match self {
            Axis::X => [Axis::Y, Axis::Z],
            Axis::Y => [Axis::Z, Axis::X],
            Axis::Z => [Axis::X, Axis::Y],
        }
    }

    /// "X", "Y" or "Z".
    pub fn name(self) -> &'static str {
        match self {
            Axis::X => "X",
            Axis::Y => "Y",
            Axis::Z => "Z",
        }
    }
}

impl std::fmt::Display for Axis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Approach direction of a positioning run (ISO 230-2 ↑ and ↓).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Direction {
    /// Approach in the positive direction (↑), written `+`.
    #[serde(rename = "+")]
    Up,
    /// Approach in the negative direction (↓), written `-`.
    #[serde(rename = "-")]
    Down,
}

impl Direction {
    /// "+" or "-".
    pub fn sign(self) -> &'static str {
        match self {
            Direction::Up => "+",
            Direction::Down => "-",
        }
    }
}

impl std::fmt::Display for Direction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.sign())
    }
}

/// The key shared by the images of one instant (all manifest columns but
/// `image` and `camera`); nominal coordinates are compared bit for bit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct InstantKey {
    /// Axis moved.
    pub axis: Axis,
    /// Approach direction.
    pub direction: Direction,
    /// Run number (≥ 1).
    pub run: u32,
    /// Target index (≥ 0).
    pub target: u32,
    /// Capture number at the target (≥ 1).
    pub capture: u32,
    /// Commanded position, as `f64::to_bits` of x, y, z.
    pub nominal_bits: [u64; 3],
}

impl InstantKey {
    /// Commanded position (mm).
    pub fn nominal(&self) -> [f64; 3] {
        self.nominal_bits.map(f64::from_bits)
    }

    /// The sweep line the instant lies on.
    pub fn line(&self) -> LineKey {
        let [a, b] = self.axis.others();
        LineKey {
            axis: self.axis,
            offsets: [self.nominal_bits[a.index()], self.nominal_bits[b.index()]],
        }
    }
}

/// A line of a sweep: the axis moved and the nominal coordinates of the two
/// other axes (as `f64::to_bits`, in the order of [`Axis::others`]). A
/// campaign may sweep an axis along several lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LineKey {
    /// Axis moved.
    pub axis: Axis,
    /// Nominal coordinates of the two other axes.
    pub offsets: [u64; 2],
}

/// One row of `manifest.csv`: an image and the instant it was taken at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManifestRow {
    /// Image path, relative to the manifest.
    pub image: String,
    /// Camera number 1, 2 or 3.
    pub camera: u8,
    /// Axis moved.
    pub axis: Axis,
    /// Approach direction.
    pub direction: Direction,
    /// Run number (≥ 1).
    pub run: u32,
    /// Target index (≥ 0).
    pub target: u32,
    /// Capture number at the target (≥ 1).
    pub capture: u32,
    /// Commanded x (mm).
    pub nominal_x: f64,
    /// Commanded y (mm).
    pub nominal_y: f64,
    /// Commanded z (mm).
    pub nominal_z: f64,
}

impl ManifestRow {
    /// The instant this image belongs to.
    pub fn instant(&self) -> InstantKey {
        InstantKey {
            axis: self.axis,
            direction: self.direction,
            run: self.run,
            target: self.target,
            capture: self.capture,
            nominal_bits: [self.nominal_x, self.nominal_y, self.nominal_z].map(f64::to_bits),
        }
    }
}

impl Record for ManifestRow {
    const COLUMNS: &'static [&'static str] = &[
        "image",
        "camera",
        "axis",
        "direction",
        "run",
        "target",
        "capture",
        "nominal_x",
        "nominal_y",
        "nominal_z",
    ];

    fn validate(&self) -> Result<(), Invalid> {
        if self.image.trim().is_empty() {
            return Err(Invalid::new("image", "empty image path"));
        }
        if !(1..=3).contains(&self.camera) {
            return Err(Invalid::new(
                "camera",
                format!("camera {} is not 1, 2 or 3", self.camera),
            ));
        }
        if self.run < 1 {
            return Err(Invalid::new("run", "runs are numbered from 1"));
        }
        if self.capture < 1 {
            return Err(Invalid::new("capture", "captures are numbered from 1"));
        }
        finite("nominal_x", self.nominal_x)?;
        finite("nominal_y", self.nominal_y)?;
        finite("nominal_z", self.nominal_z)
    }
}

/// One row of `spheres.csv`: a sphere's name and diameter (mm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SphereRow {
    /// Name used in reports (e.g. A, B, C).
    pub name: String,
    /// Diameter (mm).
    pub diameter: f64,
}

impl Record for SphereRow {
    const COLUMNS: &'static [&'static str] = &["name", "diameter"];

    fn validate(&self) -> Result<(), Invalid> {
        if self.name.trim().is_empty() {
            return Err(Invalid::new("name", "empty sphere name"));
        }
        finite("diameter", self.diameter)?;
        if self.diameter <= 0.0 {
            return Err(Invalid::new(
                "diameter",
                format!("diameter {} mm is not positive", self.diameter),
            ));
        }
        Ok(())
    }
}
