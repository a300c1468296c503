//! What `measure` writes and resumes from: the partial outputs and their
//! fingerprint, the rows appended as instants are measured, the finished
//! files sorted into the manifest's order, the problems file.

use super::*;

/// Every row of a partial output (a torn last line is dropped).
pub(super) fn read_partial<T: formats::Record>(path: &Path) -> Result<Vec<T>> {
    let bytes = std::fs::read(path).map_err(|e| formats::FormatError::io(path, e))?;
    let end = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    let rows = read_csv_from::<T, _>(&bytes[..end], path).map_err(FuseError::Format)?;
    Ok(rows.into_iter().map(|r| r.record).collect())
}

/// Rows of the instants of a partial output that have every sphere, each
/// measured from every camera used (`cameras` of the row's axis): those a
/// resumed run keeps. An instant with fewer rows — torn by the interruption,
/// or lacking a sphere — or measured without a camera, whose problems are
/// not in the partial output, is measured again.
pub(super) fn load_partial(
    path: &Path,
    spheres: usize,
    cameras: &dyn Fn(formats::Axis) -> String,
) -> Result<Vec<PointRow>> {
    let rows = read_partial::<PointRow>(path)?;
    // Instant → (rows, every row from every camera).
    let mut whole: BTreeMap<InstantKey, (usize, bool)> = BTreeMap::new();
    for r in &rows {
        let w = whole.entry(r.instant()).or_insert((0, true));
        w.0 += 1;
        w.1 &= r.cameras == cameras(r.axis);
    }
    Ok(rows
        .into_iter()
        .filter(|p| whole[&p.instant()] == (spheres, true))
        .collect())
}

/// What [`write_outputs`] wrote besides the points.
pub(super) struct Written {
    /// Instants without a pose.
    pub(super) without_pose: usize,
    /// Problems.
    pub(super) problems: usize,
    /// The first problem, described.
    pub(super) first_problem: Option<String>,
    /// The problems file, when it lists problems.
    pub(super) problems_file: Option<PathBuf>,
}

/// Write `points.csv` (the rows sorted into manifest order), the poses
/// and the problems (with the instants whose pose failed), and remove the
/// partial files.
pub(super) fn write_outputs(
    rows: &mut [PointRow],
    mut problems: Vec<(usize, InstantProblemRow)>,
    index_of: &HashMap<InstantKey, usize>,
    inputs: &Inputs<'_>,
    out: &Path,
    paths: &Paths,
    output: &mut OutputPlan,
) -> Result<Written> {
    sort_rows(rows, index_of, inputs.spheres);
    output.write_records(out, &*rows)?;
    let mut observations = read_partial::<ObservationRow>(&paths.observations_partial)?;
    let kept: std::collections::HashSet<(InstantKey, &str)> = rows
        .iter()
        .map(|r| (r.instant(), r.sphere.as_str()))
        .collect();
    observations.retain(|o| kept.contains(&(o.instant(), o.sphere.as_str())));
    sort_observations(&mut observations, index_of, inputs.spheres);
    output.write_records(&paths.observations, &observations)?;
    let names: Vec<String> = inputs.spheres.iter().map(|s| s.name.clone()).collect();
    let fitted = poses(rows, &names);
    output.write_records(&paths.poses, &fitted.rows)?;
    let without_pose = fitted.failed.len();
    problems.extend(fitted.failed.into_iter().map(|(key, reason)| {
        (
            index_of[&key],
            InstantProblemRow::of(&key, Missing::Pose, None, None, None, reason),
        )
    }));
    let problem_count = problems.len();
    let (problems_file, first_problem) = write_problems(problems, &paths.problems, output)?;
    for f in [&paths.partial, &paths.observations_partial, &paths.sidecar] {
        std::fs::remove_file(f).map_err(|e| formats::FormatError::io(f, e))?;
    }
    Ok(Written {
        without_pose,
        problems: problem_count,
        first_problem,
        problems_file,
    })
}

/// The files of a measure run beside its `points.csv`.
pub(super) struct Paths {
    /// Rows so far (`points.csv.partial`).
    pub(super) partial: PathBuf,
    /// Fingerprint of the inputs and options (`points.csv.resume.json`).
    pub(super) sidecar: PathBuf,
    /// `<stem>.poses.csv`.
    pub(super) poses: PathBuf,
    /// `<stem>.problems.csv`.
    pub(super) problems: PathBuf,
    /// `<stem>.observations.csv`.
    pub(super) observations: PathBuf,
    /// Its rows so far (`<stem>.observations.csv.partial`).
    pub(super) observations_partial: PathBuf,
}

impl Paths {
    pub(super) fn of(out: &Path) -> Self {
        let observations = formats::beside(out, "points", ".observations.csv");
        Self {
            partial: with_suffix(out, ".partial"),
            sidecar: with_suffix(out, ".resume.json"),
            poses: formats::beside(out, "points", ".poses.csv"),
            problems: formats::beside(out, "points", ".problems.csv"),
            observations: observations.clone(),
            observations_partial: with_suffix(&observations, ".partial"),
        }
    }
}

/// The complete instants' rows (every sphere from every camera of `rig`
/// used) of a partial output of the same inputs and options (none when starting afresh); the partial file rewritten with them
/// and the fingerprint beside it.
pub(super) fn resume(
    inputs: &Inputs<'_>,
    options: &MeasureOptions,
    rig: &RigModel,
    paths: &Paths,
    output: &mut OutputPlan,
) -> Result<Vec<PointRow>> {
    let print = fingerprint(inputs, options)?;
    let mut done_rows: Vec<PointRow> = Vec::new();
    let mut done_observations: Vec<ObservationRow> = Vec::new();
    if paths.partial.exists() && !output.force() {
        let previous: Option<Fingerprint> = formats::read_json(&paths.sidecar).ok();
        if previous.as_ref() != Some(&print) {
            return Err(FuseError::ResumeMismatch(paths.partial.clone()));
        }
        output.resume();
        let cameras = |axis| camera_set(&rig.cameras_for(axis, options.all_cameras));
        done_rows = load_partial(&paths.partial, inputs.spheres.len(), &cameras)?;
        // The images of the instants kept (written before their points, so
        // a kept instant has all of them; a torn row is dropped).
        if paths.observations_partial.exists() {
            let done: std::collections::HashSet<InstantKey> =
                done_rows.iter().map(PointRow::instant).collect();
            done_observations = read_partial(&paths.observations_partial)?;
            done_observations.retain(|o| done.contains(&o.instant()));
        }
    }
    output.check()?;
    output.write_json(&paths.sidecar, &print)?;
    // Rewrite the partials with the complete instants only, then append to them.
    output.write_records(&paths.observations_partial, &done_observations)?;
    output.write_records(&paths.partial, &done_rows)?;
    Ok(done_rows)
}

/// A partial output open for appending rows (no header), each append synced.
pub(super) struct Appender<'p> {
    pub(super) path: &'p Path,
    pub(super) file: std::fs::File,
}

impl<'p> Appender<'p> {
    pub(super) fn open(path: &'p Path) -> Result<Self> {
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| formats::FormatError::io(path, e))?;
        Ok(Self { path, file })
    }

    pub(super) fn append<T: Serialize>(&mut self, rows: &[T]) -> Result<()> {
        let mut bytes = Vec::new();
        {
            let mut w = csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(&mut bytes);
            for row in rows {
                w.serialize(row)
                    .map_err(|e| formats::FormatError::file(self.path, e.to_string()))?;
            }
            w.flush()
                .map_err(|e| formats::FormatError::io(self.path, e))?;
        }
        self.file
            .write_all(&bytes)
            .and_then(|()| self.file.sync_data())
            .map_err(|e| formats::FormatError::io(self.path, e))?;
        Ok(())
    }
}

/// Every row of the partial file of a planned instant, as written (the gate
/// sees the same residuals whether or not the run was interrupted), less the
/// instants the campaign's residual gate refuses; the gate and the refusals.
#[allow(clippy::type_complexity)]
pub(super) fn gated_rows(
    partial: &Path,
    index_of: &HashMap<InstantKey, usize>,
) -> Result<(
    Vec<PointRow>,
    Option<ResidualGate>,
    BTreeMap<InstantKey, Failure>,
)> {
    let mut rows = read_partial::<PointRow>(partial)?;
    rows.retain(|r| index_of.contains_key(&r.instant()));
    let residuals = instant_residuals(&rows);
    let all: Vec<f64> = residuals.values().map(|r| r.0).collect();
    let gate = ResidualGate::from_residuals(&all);
    let refused = gate
        .map(|g| implausible(&residuals, &g))
        .unwrap_or_default();
    rows.retain(|r| !refused.contains_key(&r.instant()));
    Ok((rows, gate, refused))
}

/// The rank of a row in the finished files: its instant's place in the
/// manifest, then its sphere's in `spheres` (unknown ones last).
fn manifest_rank<'s>(
    index_of: &'s HashMap<InstantKey, usize>,
    spheres: &'s [SphereRow],
) -> impl Fn(InstantKey, &str) -> (usize, usize) + 's {
    let sphere_rank: HashMap<&str, usize> = spheres
        .iter()
        .enumerate()
        .map(|(i, s)| (s.name.as_str(), i))
        .collect();
    move |key, sphere| {
        (
            index_of.get(&key).copied().unwrap_or(usize::MAX),
            sphere_rank.get(sphere).copied().unwrap_or(usize::MAX),
        )
    }
}

/// Rows in manifest order, the spheres of an instant in the order of `spheres`.
pub(super) fn sort_rows(
    rows: &mut [PointRow],
    index_of: &HashMap<InstantKey, usize>,
    spheres: &[SphereRow],
) {
    let rank = manifest_rank(index_of, spheres);
    rows.sort_by_key(|p| rank(p.instant(), &p.sphere));
}

/// Observations in manifest order, then sphere order, then camera.
pub(super) fn sort_observations(
    rows: &mut [ObservationRow],
    index_of: &HashMap<InstantKey, usize>,
    spheres: &[SphereRow],
) {
    let rank = manifest_rank(index_of, spheres);
    rows.sort_by_key(|o| (rank(o.instant(), &o.sphere), o.camera));
}

/// Write the problems in manifest order (within an instant, as found): the
/// header alone when there is none; its path when it lists any, and the
/// first problem described.
pub(super) fn write_problems(
    mut problems: Vec<(usize, InstantProblemRow)>,
    path: &Path,
    output: &mut OutputPlan,
) -> Result<(Option<PathBuf>, Option<String>)> {
    // A stable sort.
    problems.sort_by_key(|(i, _)| *i);
    let Some((_, first)) = problems.first() else {
        // Written whatever it holds: a file of no problems says none were
        // found (and replaces a stale one).
        output.write_records(path, &Vec::<InstantProblemRow>::new())?;
        return Ok((None, None));
    };
    let first = match &first.image {
        Some(image) => format!("{image}: {}", first.reason),
        None => first.reason.clone(),
    };
    let list: Vec<InstantProblemRow> = problems.into_iter().map(|(_, p)| p).collect();
    output.write_records(path, &list)?;
    Ok((Some(path.to_path_buf()), Some(first)))
}
