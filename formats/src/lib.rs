//! The trinocular file contract (INTERFACES.md): typed records of every CSV
//! and JSON file the tools read or write, validation whose errors name the
//! file, row and column, and atomic output (write, then rename).
//!
//! # Conventions
//! Lengths in files are millimetres, angles radians; pixel coordinates put the
//! centre of the top-left pixel at (0, 0). CSV: comma separated, one header
//! row, `.` decimal point, UTF-8; extra columns are ignored on reading.

mod error;

pub mod atomic;
pub mod blobs;
pub mod campaign;
pub mod capture;
pub mod json;
pub mod measure;
pub mod points;
pub mod probe;
pub mod rig;
pub mod table;
pub mod target;
pub mod truth;

pub use atomic::{AtomicFile, write_atomic};
pub use blobs::{BlobRow, ProblemRow};
pub use campaign::{Axis, Direction, InstantKey, LineKey, ManifestRow, SphereRow};
pub use capture::{AxisProcedure, Dwell, ManifestProblemRow, ProcedureConfig};
pub use error::{FormatError, Result};
pub use json::{read_json, write_json};
pub use measure::{InstantProblemRow, PoseRow};
pub use points::PointRow;
pub use rig::{
    CameraJson, DistortionJson, IlluminationJson, NominalCamera, NominalRig, Rig, RigCamera,
};
pub use table::{Invalid, Record, Row, read_csv, read_csv_from, write_csv, write_records};
pub use target::{CorrespondenceRow, TargetRow};
pub use truth::{Truth, TruthCamera, TruthInstant};
