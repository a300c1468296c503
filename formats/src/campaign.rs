//! The campaign manifest (`manifest.csv`) and sphere set (`spheres.csv`).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::table::{Invalid, Record, Row, finite, read_csv};
use crate::{FormatError, Result};

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

    /// Unit vector of the axis in the machine frame.
    pub fn unit(self) -> geom::Vector3<f64> {
        geom::Vector3::ith(self.index(), 1.0)
    }

    /// The machine axis camera `id` looks along, by the rig's numbering
    /// (docs/formats.md): 1 ∥ X, 2 ∥ Y, 3 ∥ Z; `None` for any other number.
    /// A camera is not used for motion along its own axis (its image would
    /// change depth and leave the depth of field, docs/methods.md).
    pub fn of_camera(id: u8) -> Option<Axis> {
        Axis::from_index(usize::from(id).checked_sub(1)?)
    }

    /// `[roll, pitch, yaw]` of a rotation vector `w` (rad) for motion along
    /// this axis: roll is the rotation about the moving axis, pitch and yaw
    /// about the other two — X → (εx, εy, εz), Y → (εy, εx, εz), Z → (εz, εx, εy).
    pub fn roll_pitch_yaw(self, w: &geom::Vector3<f64>) -> [f64; 3] {
        match self {
            Axis::X => [w.x, w.y, w.z],
            Axis::Y => [w.y, w.x, w.z],
            Axis::Z => [w.z, w.x, w.y],
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

/// `X + run 1 target 0 capture 1 at (−75, 0, 0)`: how messages name an instant.
impl std::fmt::Display for InstantKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [x, y, z] = self.nominal();
        write!(
            f,
            "{} {} run {} target {} capture {} at ({x}, {y}, {z})",
            self.axis, self.direction, self.run, self.target, self.capture
        )
    }
}

impl InstantKey {
    /// The key of (axis, direction), [run, target, capture] and the commanded
    /// position (mm), compared bit for bit.
    pub fn new(
        (axis, direction): (Axis, Direction),
        [run, target, capture]: [u32; 3],
        nominal: [f64; 3],
    ) -> Self {
        Self {
            axis,
            direction,
            run,
            target,
            capture,
            nominal_bits: nominal.map(f64::to_bits),
        }
    }

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

instant_row! {
    /// One row of `manifest.csv`: an image and the instant it was taken at.
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub struct ManifestRow {
        /// Image path, relative to the manifest.
        pub image: String,
        /// Camera number 1, 2 or 3.
        pub camera: u8,
        ..InstantKey,
    }
}

impl Record for ManifestRow {
    const COLUMNS: &'static [&'static str] = instant_columns!["image", "camera"; ..InstantKey];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        if self.image.trim().is_empty() {
            return Err(Invalid::new("image", "empty image path"));
        }
        if !(1..=3).contains(&self.camera) {
            return Err(Invalid::new(
                "camera",
                format!("camera {} is not 1, 2 or 3", self.camera),
            ));
        }
        self.validate_instant()
    }
}

/// The images `manifest` lists, in its order, each path resolved against
/// the manifest's folder (paths in `manifest.csv` are relative to it).
pub fn read_manifest_images(manifest: &Path) -> Result<Vec<PathBuf>> {
    let rows: Vec<Row<ManifestRow>> = read_csv(manifest)?;
    let base = manifest.parent().unwrap_or(Path::new("."));
    Ok(rows.iter().map(|r| base.join(&r.record.image)).collect())
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

    fn validate(&self) -> std::result::Result<(), Invalid> {
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

/// Two diameters closer than this fraction are the same to the matching of
/// blobs to spheres by size (`fuse::matching`).
pub const SAME_DIAMETER: f64 = 1e-6;

/// What is wrong with a sphere set as a whole.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SphereSetProblem {
    /// No sphere at all.
    #[error("no spheres")]
    Empty,
    /// A name given to two spheres.
    #[error("sphere {name} is listed twice")]
    Twice {
        /// Index of the second sphere of that name.
        index: usize,
        /// The name.
        name: String,
    },
    /// Two diameters within [`SAME_DIAMETER`] of each other.
    #[error(
        "spheres {other} ({other_mm} mm) and {name} ({diameter_mm} mm) share a diameter: \
         blobs are matched to spheres by size, so they could not be told apart"
    )]
    SharedDiameter {
        /// Index of the later sphere of the two.
        index: usize,
        /// Its name.
        name: String,
        /// Its diameter (mm).
        diameter_mm: f64,
        /// The earlier sphere of the same diameter.
        other: String,
        /// Its diameter (mm).
        other_mm: f64,
    },
}

impl SphereSetProblem {
    /// Index of the sphere at fault (0 for an empty set).
    pub fn index(&self) -> usize {
        match self {
            SphereSetProblem::Empty => 0,
            SphereSetProblem::Twice { index, .. }
            | SphereSetProblem::SharedDiameter { index, .. } => *index,
        }
    }

    /// Column at fault: `name` or `diameter`.
    pub fn column(&self) -> &'static str {
        match self {
            SphereSetProblem::SharedDiameter { .. } => "diameter",
            _ => "name",
        }
    }
}

/// Check a sphere set as a whole (`spheres.csv`, the renderer's `[[spheres]]`):
/// at least one sphere, names unique, and no two diameters within
/// [`SAME_DIAMETER`] of each other — blobs are matched to spheres by their
/// size, so spheres of one diameter cannot be told apart.
pub fn check_sphere_set<'a>(
    spheres: impl IntoIterator<Item = (&'a str, f64)>,
) -> std::result::Result<(), SphereSetProblem> {
    let spheres: Vec<(&str, f64)> = spheres.into_iter().collect();
    if spheres.is_empty() {
        return Err(SphereSetProblem::Empty);
    }
    for (i, &(name, diameter)) in spheres.iter().enumerate() {
        if let Some((first, _)) = spheres[..i].iter().find(|(n, _)| *n == name) {
            return Err(SphereSetProblem::Twice {
                index: i,
                name: (*first).to_string(),
            });
        }
        if let Some((other, d)) = spheres[..i]
            .iter()
            .find(|(_, d)| (d - diameter).abs() <= SAME_DIAMETER * d.abs().max(diameter.abs()))
        {
            return Err(SphereSetProblem::SharedDiameter {
                index: i,
                name: name.to_string(),
                diameter_mm: diameter,
                other: (*other).to_string(),
                other_mm: *d,
            });
        }
    }
    Ok(())
}

/// Read `spheres.csv`: every row ([`SphereRow`]) and the set as a whole
/// ([`check_sphere_set`]); errors name the file, line and column.
pub fn read_spheres(path: &Path) -> Result<Vec<Row<SphereRow>>> {
    let rows: Vec<Row<SphereRow>> = read_csv(path)?;
    check_sphere_set(
        rows.iter()
            .map(|r| (r.record.name.as_str(), r.record.diameter)),
    )
    .map_err(|problem| match rows.get(problem.index()) {
        Some(r) => FormatError::Row {
            path: path.to_path_buf(),
            line: r.line,
            column: Some(problem.column().into()),
            message: problem.to_string(),
        },
        None => FormatError::file(path, format!("{problem}: the file has a header only")),
    })?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_axes_and_roll_pitch_yaw_follow_the_rig_numbering() {
        assert_eq!(Axis::of_camera(1), Some(Axis::X));
        assert_eq!(Axis::of_camera(3), Some(Axis::Z));
        assert_eq!(Axis::of_camera(0), None);
        assert_eq!(Axis::of_camera(4), None);
        assert_eq!(Axis::Y.unit(), geom::Vector3::y());
        let w = geom::Vector3::new(1.0, 2.0, 3.0);
        assert_eq!(Axis::X.roll_pitch_yaw(&w), [1.0, 2.0, 3.0]);
        assert_eq!(Axis::Y.roll_pitch_yaw(&w), [2.0, 1.0, 3.0]);
        assert_eq!(Axis::Z.roll_pitch_yaw(&w), [3.0, 1.0, 2.0]);
    }

    #[test]
    fn sphere_sets_that_cannot_be_matched_are_refused() {
        assert!(check_sphere_set([("A", 20.0), ("B", 15.0), ("C", 10.0)]).is_ok());
        let p = check_sphere_set([("A", 20.0), ("B", 15.0), ("C", 15.0)]).unwrap_err();
        assert_eq!((p.index(), p.column()), (2, "diameter"));
        assert_eq!(
            p.to_string(),
            "spheres B (15 mm) and C (15 mm) share a diameter: blobs are matched to spheres by \
             size, so they could not be told apart"
        );
        let p = check_sphere_set([("A", 20.0), ("A", 15.0)]).unwrap_err();
        assert_eq!(
            (p.index(), p.column(), p.to_string().as_str()),
            (1, "name", "sphere A is listed twice")
        );
        assert_eq!(check_sphere_set([]), Err(SphereSetProblem::Empty));
        // One part in 10⁵ apart is still two spheres.
        assert!(check_sphere_set([("A", 20.0), ("B", 20.0002)]).is_ok());
    }

    #[test]
    fn the_spheres_file_names_the_line_at_fault() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("spheres.csv");
        std::fs::write(&path, "name,diameter\nA,20\nB,15\nC,15.0\n").unwrap();
        let e = read_spheres(&path).unwrap_err().to_string();
        assert!(e.contains("spheres.csv: line 4, column 'diameter'"), "{e}");
        std::fs::write(&path, "name,diameter\n").unwrap();
        let e = read_spheres(&path).unwrap_err().to_string();
        assert!(e.contains("no spheres"), "{e}");
    }
}
