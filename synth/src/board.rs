//! A printed chessboard under even light, placed by hand before the cameras
//! (`trinocular synth board`, `[board]`): planar views for `calibrate --views
//! --board`, with the exact image of every inner corner.
//!
//! Rendering: the board's frame is traced through each pixel's corners (the
//! camera's rays, distortion included, cut with the board's plane); a pixel
//! whose four corners fall in one region (black square, white paper, or off
//! the board) is that region wholly, any other is sampled 8 × 8 with the
//! board coordinates interpolated bilinearly inside it (the map from pixel to
//! board is smooth at the scale of a pixel), giving each region's area and
//! first moments per pixel. The paper and the squares are two layers through
//! the lens's relative illumination and the blur at the board centre's depth
//! (the depth of field's variation over a tilted board left out), exposed on
//! the sensor with its noise like every frame.
//!
//! Placements: each faces a pair of cameras less than 100° apart (the
//! bisector of their optical axes; the seed's perpendicular rig: pairs 1–2,
//! 2–3, 1–3 in turn), or one camera where the rig has no such pair, tilted
//! at random up to `tilt_deg`, rolled up to ±15°, its centre within
//! `spread_mm` of the working point, redrawn until every corner lies inside
//! the frame of each of its cameras; until every camera has
//! `views_per_camera` views.

use geom::nalgebra::{
    Isometry3, Matrix3, Point3, Rotation3, Translation3, Unit, UnitQuaternion, Vector3,
};
use geom::{Camera, Point2};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardUniform};

use crate::config::{BoardConfig, Config};
use crate::coverage::Coverage;
use crate::psf::blur;
use crate::rig::{BOARD_FRAME, SynthCamera, SynthRig, stack_frame};
use crate::sensor::{Exposure, Image16, NoiseKey, chacha_key};
use crate::{Result, SynthError};

/// Purpose tag of the placements' random stream.
const PLACEMENT_PURPOSE: u64 = 7;
/// Sub-samples per side of a pixel on a region's edge.
const SUBSAMPLES: usize = 8;
/// Largest angle between two cameras' optical axes for a shared placement (deg).
const PAIR_ANGLE_DEG: f64 = 100.0;
/// Largest random roll of a placement about its normal (deg).
const ROLL_DEG: f64 = 15.0;
/// Margin of every corner from the frame's edge (px).
const CORNER_MARGIN_PX: f64 = 8.0;
/// Draws per placement before giving up.
const MAX_DRAWS: usize = 200;

/// What a point of the board's plane shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Region {
    Off,
    White,
    Black,
}

/// The inner corners: id `1 + j·COLS + i` at `(i·s, j·s, 0)`, board frame.
pub fn corners(b: &BoardConfig) -> Vec<(u32, Point3<f64>)> {
    let [cols, rows] = b.inner;
    (0..rows)
        .flat_map(|j| {
            (0..cols).map(move |i| {
                (
                    1 + j * cols + i,
                    Point3::new(f64::from(i) * b.square_mm, f64::from(j) * b.square_mm, 0.0),
                )
            })
        })
        .collect()
}

/// The region at board coordinates (x, y): squares (a, b) = ⌊(x, y)/s⌋ for
/// a ∈ −1..COLS, b ∈ −1..ROWS, black where a + b is even; white paper for
/// `margin_squares` around them; off the board beyond.
fn region(b: &BoardConfig, x: f64, y: f64) -> Region {
    let s = b.square_mm;
    let [cols, rows] = b.inner.map(f64::from);
    let (a, c) = ((x / s).floor(), (y / s).floor());
    if (-1.0..cols).contains(&a) && (-1.0..rows).contains(&c) {
        return if (a + c).rem_euclid(2.0) == 0.0 {
            Region::Black
        } else {
            Region::White
        };
    }
    let m = b.margin_squares * s;
    if x >= -s - m && x <= cols * s + m && y >= -s - m && y <= rows * s + m {
        Region::White
    } else {
        Region::Off
    }
}

/// One placement: the board → world transform and the cameras that see it.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// Pose id (0, 1, …).
    pub pose: u32,
    /// Board frame → world.
    pub board_to_world: Isometry3<f64>,
    /// Ids of the cameras it faces.
    pub cameras: Vec<u8>,
}

/// A camera's optical axis and image x axis, world frame.
fn axes(c: &Camera) -> (Vector3<f64>, Vector3<f64>) {
    let r = c.pose.rotation.inverse();
    (r * Vector3::z(), r * Vector3::x())
}

/// The groups of cameras a placement faces, in turn: pairs less than
/// [`PAIR_ANGLE_DEG`] apart, else each camera alone.
fn groups(rig: &SynthRig) -> Vec<Vec<usize>> {
    let n = rig.cameras.len();
    let mut pairs = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            let (za, _) = axes(&rig.cameras[a].camera);
            let (zb, _) = axes(&rig.cameras[b].camera);
            if za.angle(&zb).to_degrees() < PAIR_ANGLE_DEG {
                pairs.push(vec![a, b]);
            }
        }
    }
    if pairs.is_empty() {
        (0..n).map(|a| vec![a]).collect()
    } else {
        pairs
    }
}

/// Whether every corner of the board at `pose` lies inside camera `c`'s
/// frame, with the printed face towards it.
fn fits(c: &Camera, b: &BoardConfig, pose: &Isometry3<f64>) -> bool {
    let normal = pose.rotation * Vector3::z();
    let origin = pose.translation.vector;
    if (c.centre().coords - origin).dot(&normal) >= 0.0 {
        return false;
    }
    let (w, h) = (f64::from(c.width), f64::from(c.height));
    corners(b).iter().all(|(_, p)| {
        c.project(&(pose * p)).is_ok_and(|q| {
            q.x >= CORNER_MARGIN_PX
                && q.y >= CORNER_MARGIN_PX
                && q.x <= w - 1.0 - CORNER_MARGIN_PX
                && q.y <= h - 1.0 - CORNER_MARGIN_PX
        })
    })
}

/// The placements of the board for `rig` (module docs).
pub fn placements(config: &Config, rig: &SynthRig) -> Result<Vec<Placement>> {
    let b = &config.board;
    let groups = groups(rig);
    let mut rng = ChaCha8Rng::from_seed(chacha_key(PLACEMENT_PURPOSE, &[config.seed]));
    let mut uniform = move || -> f64 { StandardUniform.sample(&mut rng) };
    let mut views = vec![0u32; rig.cameras.len()];
    let mut out: Vec<Placement> = Vec::new();
    let half = Vector3::new(
        f64::from(b.inner[0] - 1) * b.square_mm / 2.0,
        f64::from(b.inner[1] - 1) * b.square_mm / 2.0,
        0.0,
    );
    let work = Vector3::from(config.rig.working_point);
    while views.iter().any(|&v| v < b.views_per_camera) {
        let group = &groups[out.len() % groups.len()];
        let facing: Vector3<f64> = group
            .iter()
            .map(|&k| axes(&rig.cameras[k].camera).0)
            .sum::<Vector3<f64>>()
            .normalize();
        let x0 = axes(&rig.cameras[group[0]].camera).1;
        let mut found = None;
        for _ in 0..MAX_DRAWS {
            // A tilt about a random axis ⟂ the facing direction, a roll about it.
            let any = if facing.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let u = facing.cross(&any).normalize();
            let v = facing.cross(&u);
            let phi = std::f64::consts::TAU * uniform();
            let axis = Unit::new_normalize(u * phi.cos() + v * phi.sin());
            let tilt = Rotation3::from_axis_angle(&axis, b.tilt_deg.to_radians() * uniform());
            let z = tilt * facing;
            let roll = Rotation3::from_axis_angle(
                &Unit::new_normalize(z),
                ROLL_DEG.to_radians() * (2.0 * uniform() - 1.0),
            );
            let x = roll * (x0 - z * x0.dot(&z)).normalize();
            let y = z.cross(&x);
            let rotation = UnitQuaternion::from_matrix(&Matrix3::from_columns(&[x, y, z]));
            let offset = Vector3::new(uniform(), uniform(), uniform())
                .map(|t| (2.0 * t - 1.0) * b.spread_mm);
            let centre = work + offset;
            let pose =
                Isometry3::from_parts(Translation3::from(centre - rotation * half), rotation);
            if group
                .iter()
                .all(|&k| fits(&rig.cameras[k].camera, b, &pose))
            {
                found = Some(pose);
                break;
            }
        }
        let Some(pose) = found else {
            let ids: Vec<String> = group
                .iter()
                .map(|&k| rig.cameras[k].id.to_string())
                .collect();
            return Err(SynthError::config(format!(
                "board: no placement in {MAX_DRAWS} draws puts every corner inside the frame of \
                 camera{} {}: make the board smaller (board.inner, board.square_mm) or \
                 board.spread_mm and board.tilt_deg smaller",
                if ids.len() > 1 { "s" } else { "" },
                ids.join(" and ")
            )));
        };
        for &k in group {
            views[k] += 1;
        }
        out.push(Placement {
            pose: out.len() as u32,
            board_to_world: pose,
            cameras: group.iter().map(|&k| rig.cameras[k].id).collect(),
        });
    }
    Ok(out)
}

/// Board coordinates (x, y) where the ray of pixel position `px` meets the
/// board's plane, or `None` (parallel, behind the camera).
fn on_board(c: &Camera, world_to_board: &Isometry3<f64>, px: Point2<f64>) -> Option<[f64; 2]> {
    let (o, d) = c.ray(px).ok()?;
    let o = world_to_board * o;
    let d = world_to_board * d.into_inner();
    if d.z.abs() < 1e-12 {
        return None;
    }
    let t = -o.z / d.z;
    (t > 0.0).then(|| [o.x + t * d.x, o.y + t * d.y])
}

/// The board at `placement` in camera `cam`: its noisy frame.
pub fn render_board(cam: &SynthCamera, config: &Config, placement: &Placement) -> Result<Image16> {
    let c = &cam.camera;
    let b = &config.board;
    let (w, h) = (c.width as usize, c.height as usize);
    let to_board = placement.board_to_world.inverse();
    // Board coordinates at the pixel corners (u − ½, v − ½), u ∈ 0..=w, v ∈ 0..=h.
    let grid: Vec<Option<[f64; 2]>> = (0..=h)
        .flat_map(|v| (0..=w).map(move |u| (u, v)))
        .map(|(u, v)| on_board(c, &to_board, Point2::new(u as f64 - 0.5, v as f64 - 0.5)))
        .collect();
    let at = |u: usize, v: usize| grid[v * (w + 1) + u];
    let layer = || Coverage {
        x0: 0,
        y0: 0,
        width: w,
        height: h,
        area: vec![0.0; w * h],
        moment_u: vec![0.0; w * h],
        moment_v: vec![0.0; w * h],
    };
    let (mut white, mut black) = (layer(), layer());
    let class = |p: Option<[f64; 2]>| p.map_or(Region::Off, |[x, y]| region(b, x, y));
    for v in 0..h {
        for u in 0..w {
            let k = v * w + u;
            let q = [at(u, v), at(u + 1, v), at(u, v + 1), at(u + 1, v + 1)];
            let classes = q.map(class);
            if classes.iter().all(|r| *r == classes[0]) {
                match classes[0] {
                    Region::White => white.area[k] = 1.0,
                    Region::Black => black.area[k] = 1.0,
                    Region::Off => {}
                }
                continue;
            }
            let [Some(a), Some(bb), Some(cc), Some(d)] = q else {
                // A pixel the board's plane does not wholly cross: its corners' regions alone.
                for r in classes {
                    match r {
                        Region::White => white.area[k] += 0.25,
                        Region::Black => black.area[k] += 0.25,
                        Region::Off => {}
                    }
                }
                continue;
            };
            let n = SUBSAMPLES as f64;
            let weight = 1.0 / (n * n);
            for j in 0..SUBSAMPLES {
                let t = (j as f64 + 0.5) / n;
                for i in 0..SUBSAMPLES {
                    let s = (i as f64 + 0.5) / n;
                    let p = [0, 1].map(|e| {
                        (1.0 - s) * (1.0 - t) * a[e]
                            + s * (1.0 - t) * bb[e]
                            + (1.0 - s) * t * cc[e]
                            + s * t * d[e]
                    });
                    let layer = match region(b, p[0], p[1]) {
                        Region::White => &mut white,
                        Region::Black => &mut black,
                        Region::Off => continue,
                    };
                    layer.area[k] += weight;
                    layer.moment_u[k] += weight * (s - 0.5);
                    layer.moment_v[k] += weight * (t - 0.5);
                }
            }
        }
    }
    if let Some(lens) = &cam.lens {
        lens.weigh(&mut white);
        lens.weigh(&mut black);
    }
    let centre = placement.board_to_world
        * Point3::new(
            f64::from(b.inner[0] - 1) * b.square_mm / 2.0,
            f64::from(b.inner[1] - 1) * b.square_mm / 2.0,
            0.0,
        );
    let sigma = cam.optics.blur_sigma_px((c.pose * centre).z);
    if !sigma.is_finite() {
        return Err(SynthError::BlurSigma(sigma));
    }
    let (white, black) = (blur(&white, sigma), blur(&black, sigma));
    Ok(cam.expose(
        &[
            Exposure {
                signal: &white,
                radiance_e: b.white_e,
            },
            Exposure {
                signal: &black,
                radiance_e: b.black_e,
            },
        ],
        NoiseKey {
            seed: config.seed,
            frame: stack_frame(BOARD_FRAME, placement.pose),
            camera: cam.id,
        },
    ))
}

/// The exact image of every inner corner at `placement` in camera `c` (full model).
pub fn corner_images(
    c: &Camera,
    b: &BoardConfig,
    placement: &Placement,
) -> Result<Vec<(u32, Point2<f64>)>> {
    corners(b)
        .into_iter()
        .map(|(id, p)| {
            c.project(&(placement.board_to_world * p))
                .map(|q| (id, q))
                .map_err(|e| SynthError::geometry(format!("projecting board corner {id}"), e))
        })
        .collect()
}

/// What `trinocular synth board` produced.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardSummary {
    /// Placements of the board.
    pub placements: usize,
    /// Views written (placement × camera).
    pub views: usize,
}

/// Relative path of camera `id`'s view at `pose` (`what`: "pose" for the
/// image, "points_pose" for its exact corners).
fn board_path(what: &str, pose: u32, id: u8, ext: &str) -> String {
    format!("board/{what}{pose}_cam{id}.{ext}")
}

/// Seconds between two placements of the board (moved by hand).
const PLACEMENT_INTERVAL_S: f64 = 10.0;

/// Write the board scene under `out` (created if needed) through `output`:
/// `board.csv` (the inner corners as a planar target, `id,x,y,z`),
/// `nominal.json`, `truth.json` (true cameras; under `board` the board and
/// every placement's pose), per placement and camera that sees it
/// `board/pose{p}_cam{k}.*` and `board/points_pose{p}_cam{k}.csv` (exact
/// corners), `views.csv` (the images) and `views_points.csv` (the exact
/// corners' files).
pub fn write_board_scene(
    config: &Config,
    out: &std::path::Path,
    output: &mut formats::OutputPlan,
    progress: &dyn crate::Progress,
) -> Result<BoardSummary> {
    config.validate()?;
    let rig = SynthRig::from_config(config)?;
    let placements = placements(config, &rig)?;
    let ext = config.output.format.extension();
    output.folder(out).folder(out.join("board"));
    for name in [
        "board.csv",
        "nominal.json",
        "truth.json",
        "views.csv",
        "views_points.csv",
    ] {
        output.file(out.join(name));
    }
    for p in &placements {
        for id in &p.cameras {
            output.file(out.join(board_path("pose", p.pose, *id, ext)));
            output.file(out.join(board_path("points_pose", p.pose, *id, "csv")));
        }
    }
    output.lock(out, "synth board")?;
    if !output.force() && out.join("board.csv").exists() && !out.join("truth.json").exists() {
        return Err(SynthError::Incomplete {
            folder: out.to_path_buf(),
            last: out.join("truth.json"),
        });
    }
    output.check()?;

    let b = &config.board;
    let rows: Vec<formats::TargetRow> = corners(b)
        .into_iter()
        .map(|(id, p)| formats::TargetRow {
            id,
            x: p.x,
            y: p.y,
            z: p.z,
            diameter: None,
            u_mm: None,
        })
        .collect();
    output.write_csv(&out.join("board.csv"), &rows)?;
    output.write_json(&out.join("nominal.json"), &rig.nominal())?;
    let start = crate::datetime::parse(&config.procedure.start_time)?;
    let total: usize = placements.iter().map(|p| p.cameras.len()).sum();
    progress.begin("board views", total as u64);
    let mut views = Vec::new();
    let mut points = Vec::new();
    for p in &placements {
        for id in &p.cameras {
            let Some(cam) = rig.cameras.iter().find(|c| c.id == *id) else {
                continue;
            };
            let img = render_board(cam, config, p)?;
            let rel = board_path("pose", p.pose, cam.id, ext);
            crate::target::write_calibration_frame(
                config,
                cam,
                &img,
                &out.join(&rel),
                start + PLACEMENT_INTERVAL_S * f64::from(p.pose),
                format!("chessboard at pose {}, camera {}", p.pose, cam.id),
                output,
            )?;
            let exact: Vec<formats::CorrespondenceRow> = corner_images(&cam.camera, b, p)?
                .into_iter()
                .map(|(id, q)| formats::CorrespondenceRow { id, u: q.x, v: q.y })
                .collect();
            let points_rel = board_path("points_pose", p.pose, cam.id, "csv");
            output.write_csv(&out.join(&points_rel), &exact)?;
            let row = |image: String| formats::ViewRow {
                image,
                camera: cam.id,
                pose: p.pose,
                offset_x: None,
                offset_y: None,
                offset_z: None,
            };
            views.push(row(rel));
            points.push(row(points_rel));
            progress.advance(1);
        }
    }
    progress.finish();
    output.write_csv(&out.join("views.csv"), &views)?;
    output.write_csv(&out.join("views_points.csv"), &points)?;
    let mut extra = serde_json::Map::new();
    extra.insert("seed".into(), serde_json::json!(config.seed));
    let poses: Vec<serde_json::Value> = placements
        .iter()
        .map(|p| {
            let r = p.board_to_world.rotation.to_rotation_matrix();
            let m = r.matrix();
            serde_json::json!({
                "pose": p.pose,
                "cameras": p.cameras,
                "R": (0..3).map(|i| (0..3).map(|j| m[(i, j)]).collect::<Vec<f64>>()).collect::<Vec<_>>(),
                "t": p.board_to_world.translation.vector.iter().copied().collect::<Vec<f64>>(),
            })
        })
        .collect();
    extra.insert(
        "board".into(),
        serde_json::json!({
            "inner": b.inner,
            "square_mm": b.square_mm,
            "frame": "board → world: x_world = R·x_board + t",
            "placements": poses,
        }),
    );
    let truth = crate::truth::cameras_truth(&rig, config, extra);
    output.write_json(&out.join("truth.json"), &truth)?;
    Ok(BoardSummary {
        placements: placements.len(),
        views: total,
    })
}
