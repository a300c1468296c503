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
//! batch ([`OutputLock`]), lists its temporary files for removal on
//! interruption ([`interrupt`]) and records what it created, which a failed
//! run removes ([`created`]). The files a command writes beside an output
//! file (its sidecars) are named after that output's stem ([`beside`]:
//! `--out P.csv` → `P.problems.csv`), so runs of different outputs never
//! share one.

/// Declares the row of a file keyed by instant (`manifest.csv`, `points.csv`,
/// `<stem>.poses.csv`, `<stem>.problems.csv`): its leading fields, then the columns that
/// name the instant — axis, direction, run, target, capture, nominal_x,
/// nominal_y, nominal_z, declared here once — then its own fields; with
/// `instant()` and `nominal()`. A macro because the CSV rows are flat: the
/// csv crate does not serialise `#[serde(flatten)]`.
macro_rules! instant_row {
    (
        $(#[$attr:meta])*
        pub struct $name:ident {
            $( $(#[$lead_attr:meta])* pub $lead:ident: $lead_ty:ty, )*
            ..InstantKey,
            $( $(#[$own_attr:meta])* pub $own:ident: $own_ty:ty, )*
        }
    ) => {
        $(#[$attr])*
        pub struct $name {
            $( $(#[$lead_attr])* pub $lead: $lead_ty, )*
            /// Axis moved.
            pub axis: $crate::Axis,
            /// Approach direction.
            pub direction: $crate::Direction,
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
            $( $(#[$own_attr])* pub $own: $own_ty, )*
        }

        impl $name {
            /// Commanded position (mm).
            pub fn nominal(&self) -> [f64; 3] {
                [self.nominal_x, self.nominal_y, self.nominal_z]
            }

            /// The instant this row belongs to.
            pub fn instant(&self) -> $crate::InstantKey {
                $crate::InstantKey::new(
                    (self.axis, self.direction),
                    [self.run, self.target, self.capture],
                    self.nominal(),
                )
            }

            /// The instant's own checks: runs and captures numbered from 1,
            /// a finite commanded position.
            #[allow(dead_code)]
            fn validate_instant(&self) -> ::std::result::Result<(), $crate::table::Invalid> {
                use $crate::table::{Invalid, finite};
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
    };
}

/// The column names of a row declared with `instant_row!`, the instant's
/// eight in their place: `instant_columns!["image", "camera"; ..InstantKey]`,
/// `instant_columns![..InstantKey, "sphere", "x"]`.
macro_rules! instant_columns {
    (..InstantKey $(, $own:literal)* $(,)?) => {
        instant_columns![; ..InstantKey $(, $own)*]
    };
    ($($lead:literal),* ; ..InstantKey $(, $own:literal)* $(,)?) => {
        &[
            $($lead,)*
            "axis",
            "direction",
            "run",
            "target",
            "capture",
            "nominal_x",
            "nominal_y",
            "nominal_z",
            $($own),*
        ]
    };
}

mod error;

mod atomic;
mod blobs;
mod campaign;
mod capture;
pub mod commissioning;
pub mod conditions;
pub mod conformance;
pub mod created;
pub mod evaluation;
mod figures;
mod fit;
pub mod interrupt;
mod json;
pub mod limits;
mod lock;
mod measure;
mod nist;
mod output;
mod points;
pub mod probe;
mod rig;
mod rig_record;
mod sensor;
mod table;
mod target;
mod truth;
pub mod uncertainty;
mod views;

pub use atomic::{AtomicFile, beside, folder_of, write_atomic};
pub use blobs::{BlobRow, ProblemRow};
pub use campaign::{
    Axis, Direction, InstantKey, LineKey, ManifestRow, SAME_DIAMETER, SphereRow, SphereSetProblem,
    check_sphere_set, read_manifest_images, read_spheres,
};
pub use capture::{AxisProcedure, Dwell, MAX_INSTANTS, ManifestProblemRow, ProcedureConfig};
pub use error::{FormatError, Result, RigError};
pub use figures::{AxisFigures, PositioningFigures, ReportFigures, ZoneFigures};
pub use fit::{FitResult, ResidualSummary, read_cloud};
pub use json::{read_json, write_json};
pub use lock::OutputLock;
pub use measure::{InstantProblemRow, Missing, ObservationRow, PoseRow};
pub use nist::read_ds;
pub use output::{OutputPlan, Stage};
pub use points::PointRow;
pub use rig::{
    CameraCovariance, CameraJson, DistortionJson, IlluminationJson, NominalCamera, NominalOptics,
    NominalRig, Rig, RigCamera, read_nominal, read_rig,
};
pub use rig_record::{CalibrationRecord, Matching};
pub use sensor::{DefectCounts, MapFile, SensorJson, SensorMapFiles, StackRecord};
pub use table::{Invalid, Record, Row, finite, read_csv, read_csv_from, write_csv, write_records};
pub use target::{CorrespondenceRow, ResidualRow, TargetRow, read_correspondences, read_target};
pub use truth::{Truth, TruthCamera, TruthInstant};
pub use views::{ViewResidualRow, ViewRow, VolumeRow, read_views};
