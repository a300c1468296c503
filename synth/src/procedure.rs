//! The measurement procedure: every instant of a campaign, in the order the
//! machine runs it, with its time stamp and the table's true pose error.
//!
//! Per axis, per line, per run (ISO 230-2 linear cycle, the dwells of
//! [`formats::ProcedureConfig::dwells`]): go to the first target
//! minus the overshoot, approach every target upward (+) taking `captures`
//! frames at each; go past the last target by the overshoot and approach
//! every target downward (−). The overshoot takes up the backlash, so the
//! approach direction decides the reversal error.

use formats::{Axis, Direction, InstantKey, ManifestRow, PointRow};
use geom::nalgebra::{Point3, Vector3};
use geom::transform::SmallError;

use crate::Result;
use crate::config::Config;
use crate::machine::{ApproachKey, approach_offset, capture_offset, table_error};
use crate::scene::Sphere;

/// One instant: the three cameras expose together.
#[derive(Debug, Clone, PartialEq)]
pub struct Instant {
    /// Sequence number in the campaign (the frame number of its images).
    pub index: u64,
    /// Axis moved.
    pub axis: Axis,
    /// Line index (into the axis' `lines_mm`).
    pub line: u32,
    /// Approach direction.
    pub direction: Direction,
    /// Run (≥ 1).
    pub run: u32,
    /// Target index (≥ 0).
    pub target: u32,
    /// Capture at the target (≥ 1).
    pub capture: u32,
    /// Commanded position (mm).
    pub nominal: [f64; 3],
    /// Seconds since the campaign start.
    pub time_s: f64,
    /// True table error (δ in mm, ε in rad), random offsets included.
    pub error: SmallError,
}

impl Instant {
    /// Directory of this instant's images, relative to the campaign root.
    pub fn image_dir(&self) -> String {
        let dir = match self.direction {
            Direction::Up => "up",
            Direction::Down => "down",
        };
        format!(
            "images/{}{}/run{}-{dir}",
            self.axis,
            self.line + 1,
            self.run
        )
    }

    /// Image path of camera `camera`, relative to the campaign root.
    pub fn image_path(&self, camera: u8, extension: &str) -> String {
        format!(
            "{}/t{:03}_c{:02}_cam{camera}.{extension}",
            self.image_dir(),
            self.target,
            self.capture
        )
    }

    /// The manifest row of camera `camera`'s image.
    pub fn manifest_row(&self, camera: u8, extension: &str) -> ManifestRow {
        ManifestRow {
            image: self.image_path(camera, extension),
            camera,
            axis: self.axis,
            direction: self.direction,
            run: self.run,
            target: self.target,
            capture: self.capture,
            nominal_x: self.nominal[0],
            nominal_y: self.nominal[1],
            nominal_z: self.nominal[2],
        }
    }
}

/// A sphere on the table.
#[derive(Debug, Clone, PartialEq)]
pub struct TableSphere {
    /// Name.
    pub name: String,
    /// Centre relative to the table reference point (mm).
    pub position: Point3<f64>,
    /// Radius (mm).
    pub radius: f64,
    /// Electrons per fully covered pixel.
    pub radiance_e: f64,
}

/// Every instant of a campaign, and the spheres on the table.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The instants in campaign order.
    pub instants: Vec<Instant>,
    /// The spheres.
    pub spheres: Vec<TableSphere>,
    /// Campaign start, seconds since 1970.
    pub start_time_s: f64,
}

impl Plan {
    /// The plan of a configuration.
    pub fn new(config: &Config) -> Result<Self> {
        config.validate()?;
        let p = &config.procedure;
        let start_time_s = crate::datetime::parse(&p.start_time)?;
        let mut instants = Vec::new();
        for dwell in p.dwells() {
            let Some(errors) = config.machine.axis(dwell.axis) else {
                continue;
            };
            let key = ApproachKey {
                axis: dwell.axis,
                line: dwell.line,
                run: dwell.run,
                direction: dwell.direction,
                target: dwell.target,
            };
            let approach_d = approach_offset(config.seed, &key, errors);
            let mut time = dwell.time_s;
            for capture in 1..=p.captures {
                let random = approach_d + capture_offset(config.seed, &key, capture, errors);
                instants.push(Instant {
                    index: instants.len() as u64,
                    axis: dwell.axis,
                    line: dwell.line,
                    direction: dwell.direction,
                    run: dwell.run,
                    target: dwell.target,
                    capture,
                    nominal: dwell.nominal,
                    time_s: time,
                    error: table_error(config, dwell.axis, dwell.direction, dwell.nominal, random),
                });
                time += 1.0 / p.fps;
            }
        }
        let spheres = config
            .spheres
            .iter()
            .map(|s| TableSphere {
                name: s.name.clone(),
                position: Point3::from(s.position_mm),
                radius: s.diameter_mm / 2.0,
                radiance_e: s.radiance_e,
            })
            .collect();
        Ok(Self {
            instants,
            spheres,
            start_time_s,
        })
    }

    /// True world centres of the spheres at an instant: `n + s + δ + ε × s`.
    pub fn centres(&self, instant: &Instant) -> Vec<Point3<f64>> {
        let n = Vector3::from(instant.nominal);
        self.spheres
            .iter()
            .map(|s| instant.error.apply(&s.position) + n)
            .collect()
    }

    /// The spheres as the renderer needs them at an instant.
    pub fn spheres_at(&self, instant: &Instant) -> Vec<Sphere> {
        self.spheres_at_pose(instant.nominal, &instant.error)
    }

    /// The spheres at a commanded position `nominal` with the table error
    /// `error` (a pose between instants: in a move, or still between captures).
    pub fn spheres_at_pose(&self, nominal: [f64; 3], error: &SmallError) -> Vec<Sphere> {
        let n = Vector3::from(nominal);
        self.spheres
            .iter()
            .map(|s| error.apply(&s.position) + n)
            .zip(&self.spheres)
            .map(|(centre, s)| Sphere {
                centre,
                radius: s.radius,
                radiance_e: s.radiance_e,
            })
            .collect()
    }

    /// `truth_points.csv` rows: the exact centres, `cameras = "truth"`, zero residual.
    pub fn truth_points(&self) -> Vec<PointRow> {
        let mut rows = Vec::with_capacity(self.instants.len() * self.spheres.len());
        for i in &self.instants {
            for (c, s) in self.centres(i).iter().zip(&self.spheres) {
                rows.push(PointRow::new(
                    InstantKey::new(
                        (i.axis, i.direction),
                        [i.run, i.target, i.capture],
                        i.nominal,
                    ),
                    &s.name,
                    [c.x, c.y, c.z],
                    "truth",
                    0.0,
                ));
            }
        }
        rows
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_plan_has_the_seed_size_and_order() {
        let config = Config::default();
        let plan = Plan::new(&config).unwrap();
        // X: 51 targets × 2 directions × 5 runs × 10 captures × 2 lines; Y: 11 × 2 × 5 × 10.
        assert_eq!(plan.instants.len(), 51 * 2 * 5 * 10 * 2 + 11 * 2 * 5 * 10);
        let first = &plan.instants[0];
        assert_eq!(
            (
                first.axis,
                first.direction,
                first.run,
                first.target,
                first.capture
            ),
            (Axis::X, Direction::Up, 1, 0, 1)
        );
        assert_eq!(first.nominal, [-75.0, 0.0, 0.0]);
        // The down pass visits the last target first.
        let down = plan
            .instants
            .iter()
            .find(|i| i.direction == Direction::Down)
            .unwrap();
        assert_eq!(down.target, 50);
        // Time runs forward; captures are 1/fps apart.
        assert!(plan.instants.windows(2).all(|w| w[1].time_s > w[0].time_s));
        assert!((plan.instants[1].time_s - first.time_s - 1.0 / 180.0).abs() < 1e-12);
        // Y sweeps at x = 0.
        let y = plan.instants.iter().find(|i| i.axis == Axis::Y).unwrap();
        assert_eq!(y.nominal, [0.0, -50.0, 0.0]);
        // Centres move with the commanded position, plus µm-level errors.
        let c = plan.centres(first);
        assert!((c[0] - Point3::new(-75.0, 0.0, 30.0)).norm() < 0.05);
    }

    #[test]
    fn reversal_shows_in_the_centres() {
        let mut config = Config::default();
        config.machine.x.repeatability_um = 0.0;
        config.machine.x.repeatability_perp_um = 0.0;
        config.machine.x.capture_noise_um = 0.0;
        let plan = Plan::new(&config).unwrap();
        let at = |d: Direction| {
            plan.instants
                .iter()
                .find(|i| i.axis == Axis::X && i.line == 0 && i.target == 20 && i.direction == d)
                .map(|i| plan.centres(i)[0])
                .unwrap()
        };
        let b = (at(Direction::Up) - at(Direction::Down)).x * 1e3;
        assert!(
            (b - config.machine.x.reversal_um).abs() < 1e-9,
            "B = {b} µm"
        );
    }
}
