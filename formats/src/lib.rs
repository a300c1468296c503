//! The trinocular file contract (docs/formats.md): typed records of every CSV
//! and JSON file the tools read or write, validation whose errors name the
//! file, row and column, and atomic output (write, then rename).
//!
//! # Conventions
//! Lengths in files are millimetres, angles radians; pixel coordinates put the
//! centre of the top-left pixel at (0, 0). CSV: comma separated, one header
//! row, `.` decimal point, UTF-8; extra columns are ignored on reading.
//!
//! # Outputs
//! Every command declares what it writes in an [`OutputPlan`] (checked
//! against its inputs and the files that exist before anything is written;
//! existing outputs replaced only with `--force`), writes through it
//! atomically ([`AtomicFile`]), locks its output folder when it is a long
//! batch ([`lock`]), and lists its temporary files for removal on
//! interruption ([`interrupt`]).

mod error;

pub mod atomic;
pub mod blobs;
pub mod campaign;
pub mod capture;
pub mod figures;
pub mod interrupt;
pub mod json;
pub mod limits;
pub mod lock;
pub mod measure;
pub mod nist;
pub mod output;
pub mod points;
pub mod probe;
pub mod rig;
pub mod table;
pub mod target;
pub mod truth;

pub use atomic::{AtomicFile, write_atomic};
pub use blobs::{BlobRow, ProblemRow};
pub use campaign::{
    Axis, Direction, InstantKey, LineKey, ManifestRow, SphereRow, check_sphere_set, read_spheres,
};
pub use capture::{AxisProcedure, Dwell, ManifestProblemRow, ProcedureConfig};
pub use error::{FormatError, Result, RigError};
pub use figures::ReportFigures;
pub use json::{read_json, write_json};
pub use lock::OutputLock;
pub use measure::{InstantProblemRow, Missing, PoseRow};
pub use output::{OutputPlan, Stage};
pub use points::PointRow;
pub use rig::{
    CameraJson, DistortionJson, IlluminationJson, NominalCamera, NominalOptics, NominalRig, Rig,
    RigCamera, read_nominal, read_rig,
};
pub use table::{Invalid, Record, Row, read_csv, read_csv_from, write_csv, write_records};
pub use target::{CorrespondenceRow, TargetRow, read_correspondences, read_target};
pub use truth::{Truth, TruthCamera, TruthInstant};
