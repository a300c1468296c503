//! `trinocular evaluate --points points.csv --out DIR`: ISO 230-2
//! positioning, straightness, flatness and angular errors from `points.csv`;
//! writes `DIR/report.json`, `DIR/report.html` and CSV tables, and prints
//! the headline figures. With the rig (`--rig`) and the images the points
//! were fused from (`<stem>.observations.csv` beside the points), every
//! figure carries its expanded uncertainty U (k = 2) by Monte Carlo.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use crate::cmd::Usage;
use report::num_u_in;

/// Arguments of `trinocular evaluate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Measured sphere centres (`points.csv`, docs/formats.md).
    #[arg(long)]
    points: PathBuf,
    /// Output directory (created if missing), written as one set: an
    /// existing report in it is replaced only with --force, and as a whole.
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing report in the output directory.
    #[arg(long)]
    force: bool,
    /// Sphere that carries positioning, straightness and flatness (default: A,
    /// or the first sphere in the file).
    #[arg(long)]
    sphere: Option<String>,
    /// Also compute the VDI/DGQ 3441 figures (P, Ps, U, Pa).
    #[arg(long)]
    vdi3441: bool,
    /// The rig the points were measured with (`rig.json` with each camera's
    /// covariance): needed for the figures' uncertainty.
    #[arg(long)]
    rig: Option<PathBuf>,
    /// The images the points were fused from (default: `<stem>.observations.csv`
    /// beside the points, as `measure` writes it).
    #[arg(long)]
    observations: Option<PathBuf>,
    /// The campaign's manifest: the test conditions' date defaults to the
    /// earliest–latest capture time of its images (their EXIF times).
    #[arg(long, value_name = "FILE")]
    manifest: Option<PathBuf>,
    #[command(flatten)]
    signoff: super::signoff::SignoffArgs,
    /// Monte Carlo trials of the uncertainty (0: figures without U).
    #[arg(long, default_value_t = evaluate::uncertainty::DEFAULT_TRIALS)]
    trials: usize,
    /// Seed of the Monte Carlo draws (the same seed gives the same U).
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// The keys of evaluate's tolerance file.
const KEYS: formats::conformance::Keys<'static> = formats::conformance::Keys {
    tables: &["X", "Y", "Z"],
    figure: &evaluate::tolerances::figure,
    names: evaluate::tolerances::KNOWN,
};

/// The figures' uncertainty: propagated from the observations beside the
/// points and the rig, or why there is none.
fn uncertainty(
    args: &Args,
    report: &evaluate::Report,
    options: &evaluate::Options,
) -> Result<formats::uncertainty::Uncertainty> {
    use formats::uncertainty::Uncertainty;
    let not_given = |reason: String| Ok(Uncertainty::NotGiven { reason });
    if args.trials == 0 {
        return not_given(formats::uncertainty::TRIALS_OFF.into());
    }
    let observations = args
        .observations
        .clone()
        .unwrap_or_else(|| formats::beside(&args.points, "points", ".observations.csv"));
    if !observations.exists() {
        return not_given(format!(
            "no observations: {} does not exist (points measured elsewhere carry no record of their \
             images, and an uncertainty is never invented)",
            observations.display()
        ));
    }
    let Some(rig_path) = &args.rig else {
        return not_given(
            "no rig given (--rig rig.json): the calibration's covariance is unknown".into(),
        );
    };
    let inputs = Propagated::read(&args.points, &observations, rig_path)?;
    Ok(inputs.propagate(
        report,
        options,
        evaluate::uncertainty::Propagation {
            trials: args.trials,
            seed: args.seed,
        },
    ))
}

/// What the propagation reads: the points, the images they were fused
/// from, and the rig's cameras and covariances by id.
struct Propagated {
    points: Vec<formats::PointRow>,
    observations: Vec<formats::ObservationRow>,
    cameras: BTreeMap<u8, geom::Camera>,
    covariance: BTreeMap<u8, formats::CameraCovariance>,
}

impl Propagated {
    fn read(points: &Path, observations: &Path, rig: &Path) -> Result<Self> {
        let rig = formats::read_rig(rig)?;
        let mut cameras = BTreeMap::new();
        let mut covariance = BTreeMap::new();
        for c in &rig.cameras {
            cameras.insert(c.model.id, c.validate()?);
            if let Some(cov) = &c.covariance {
                covariance.insert(c.model.id, cov.clone());
            }
        }
        Ok(Self {
            points: evaluate::read_points(points)?
                .into_iter()
                .map(|r| r.record)
                .collect(),
            observations: formats::read_csv(observations)?
                .into_iter()
                .map(|r| r.record)
                .collect(),
            cameras,
            covariance,
        })
    }

    fn propagate(
        &self,
        report: &evaluate::Report,
        options: &evaluate::Options,
        propagation: evaluate::uncertainty::Propagation,
    ) -> formats::uncertainty::Uncertainty {
        evaluate::uncertainty::propagate(
            report,
            &self.points,
            &self.observations,
            evaluate::uncertainty::Instrument {
                cameras: &self.cameras,
                covariance: &self.covariance,
            },
            options,
            propagation,
        )
    }
}

/// Arguments of `trinocular bench uncertainty`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Monte Carlo trials.
    #[arg(long, default_value_t = evaluate::uncertainty::DEFAULT_TRIALS)]
    trials: usize,
    /// Timed propagations (the median is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
    repeat: usize,
}

/// `trinocular bench uncertainty`: a campaign of 108 instants × 3 spheres
/// (the seed's 3 axes × 6 targets × 3 runs × 2 directions) rendered small
/// (384×288 px, two captures so that the noise model is found from them),
/// calibrated and measured by this binary, then the Monte Carlo of
/// `evaluate` over its first captures timed on all threads and on one,
/// minimum-zone fits included.
pub fn bench(args: &BenchArgs) -> Result<()> {
    let dir = formats::interrupt::ScratchFolder::new()?;
    let at = |name: &str| dir.path().join(name);
    let exe = std::env::current_exe().context("finding this program")?;
    let step = |what: &[&std::ffi::OsStr]| -> Result<()> {
        let out = std::process::Command::new(&exe)
            .args(what)
            .output()
            .context("running this program")?;
        anyhow::ensure!(
            out.status.success(),
            "trinocular {} failed: {}",
            what.first()
                .map_or(String::new(), |w| w.to_string_lossy().into_owned()),
            String::from_utf8_lossy(&out.stderr).trim()
        );
        Ok(())
    };
    let (c, rig, points) = (at("campaign"), at("rig.json"), at("points.csv"));
    let cal = |name: &str| c.join("calib").join(name).into_os_string();
    let os = |s: &str| std::ffi::OsString::from(s);
    eprintln!("rendering, calibrating and measuring 108 instants (384×288 px) …");
    // The stages on a bar: the three commands, then every timed Monte Carlo
    // run (an untimed one and `repeat`, on all threads and on one).
    let progress = crate::cmd::progress::bar(3 + 2 * (args.repeat as u64 + 1), "bench");
    let mut render: Vec<std::ffi::OsString> = [
        "synth",
        "campaign",
        "--width",
        "384",
        "--height",
        "288",
        "--targets",
        "6",
        "--runs",
        "3",
        "--captures",
        "2",
        "--out",
    ]
    .map(os)
    .into();
    render.push(c.clone().into());
    for command in [
        render,
        vec![
            os("calibrate"),
            os("--target"),
            c.join("target.csv").into(),
            os("--nominal"),
            c.join("nominal.json").into(),
            os("--images"),
            cal("cam1.tif"),
            cal("cam2.tif"),
            cal("cam3.tif"),
            os("--flat-fields"),
            cal("flat_cam1.tif"),
            cal("flat_cam2.tif"),
            cal("flat_cam3.tif"),
            os("--dark-frames"),
            cal("dark_cam1.tif"),
            cal("dark_cam2.tif"),
            cal("dark_cam3.tif"),
            os("--out"),
            rig.clone().into(),
        ],
        vec![
            os("measure"),
            os("--rig"),
            rig.clone().into(),
            os("--manifest"),
            c.join("manifest.csv").into(),
            os("--spheres"),
            c.join("spheres.csv").into(),
            os("--out"),
            points.clone().into(),
        ],
    ] {
        let refs: Vec<&std::ffi::OsStr> = command.iter().map(|a| a.as_os_str()).collect();
        step(&refs)?;
        progress.inc(1);
    }
    let mut inputs = Propagated::read(&points, &at("points.observations.csv"), &rig)?;
    inputs.points.retain(|p| p.capture == 1);
    inputs.observations.retain(|o| o.capture == 1);
    let instants: std::collections::HashSet<_> = inputs
        .points
        .iter()
        .map(formats::PointRow::instant)
        .collect();
    let options = evaluate::Options::default();
    let report = evaluate::evaluate(&inputs.points, &options)?;
    let propagation = evaluate::uncertainty::Propagation {
        trials: args.trials,
        seed: 1,
    };
    let timed = |f: &dyn Fn() -> formats::uncertainty::Uncertainty| {
        let mut times = Vec::new();
        let mut last = f();
        progress.inc(1);
        for _ in 0..args.repeat {
            let start = std::time::Instant::now();
            last = f();
            times.push(start.elapsed());
            progress.inc(1);
        }
        times.sort();
        (times[times.len() / 2], last)
    };
    let (all, u) = timed(&|| inputs.propagate(&report, &options, propagation));
    let one_pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let (one, _) = timed(&|| one_pool.install(|| inputs.propagate(&report, &options, propagation)));
    progress.finish_and_clear();
    let given = match &u {
        formats::uncertainty::Uncertainty::Given(p) => p,
        formats::uncertainty::Uncertainty::NotGiven { reason } => {
            anyhow::bail!("the benchmark's campaign gave no uncertainty: {reason}")
        }
    };
    println!(
        "uncertainty: {} instants × {} spheres ({} centres, {} images), {} trials, {} figures \
         (minimum zones included)",
        instants.len(),
        report.spheres.len(),
        inputs.points.len(),
        inputs.observations.len(),
        args.trials,
        given.expanded.len()
    );
    let threads = rayon::current_num_threads();
    println!(
        "  {threads} threads: {:.2} s ({:.1} ms a trial with its budget runs); 1 thread: {:.2} s (median of {})",
        all.as_secs_f64(),
        all.as_secs_f64() * 1e3 / args.trials.max(1) as f64,
        one.as_secs_f64(),
        args.repeat
    );
    Ok(())
}

/// The test's date from the capture times of the images `manifest` lists
/// (their metadata, read without the pixels): `earliest – latest`, with the
/// images whose time could not be read counted; `None` when none has one.
fn capture_dates(manifest: &Path) -> Result<Option<String>> {
    let images = formats::read_manifest_images(manifest)?;
    let mut times = Vec::new();
    for image in &images {
        let time = ingest::read_metadata(image)
            .ok()
            .and_then(|m| m.datetime)
            .and_then(|t| ingest::parse_time(&t).ok());
        times.extend(time);
    }
    let (Some(first), Some(last)) = (
        times.iter().min_by_key(|t| t.ns),
        times.iter().max_by_key(|t| t.ns),
    ) else {
        return Ok(None);
    };
    let missing = images.len() - times.len();
    Ok(Some(format!(
        "{} – {} (capture times of {} images of {}{})",
        first.text,
        last.text,
        times.len(),
        manifest.display(),
        if missing > 0 {
            format!("; {missing} without a readable time")
        } else {
            String::new()
        }
    )))
}

/// The measuring equipment as `rig.json` records it: each camera's make,
/// model and serial (from its calibration image) and when the rig was
/// calibrated; `None` when it records none of them.
fn rig_equipment(path: &Path) -> Result<Option<String>> {
    let rig = formats::read_rig(path)?;
    let text = |c: &formats::RigCamera, key: &str| {
        c.extra
            .get(key)
            .and_then(|v| v.as_str())
            .map(str::to_string)
    };
    let mut cameras = Vec::new();
    let mut captured = Vec::new();
    for c in &rig.cameras {
        let named: Vec<String> = [
            text(c, "camera_make"),
            text(c, "camera_model"),
            text(c, "camera_serial").map(|s| format!("serial {s}")),
        ]
        .into_iter()
        .flatten()
        .collect();
        if !named.is_empty() {
            cameras.push(format!("camera {}: {}", c.model.id, named.join(" ")));
        }
        captured.extend(text(c, "captured"));
    }
    captured.sort();
    let calibrated = match (captured.first(), captured.last()) {
        (Some(a), Some(b)) if a == b => Some(format!("calibrated {a}")),
        (Some(a), Some(b)) => Some(format!("calibrated {a} – {b}")),
        _ => None,
    };
    if cameras.is_empty() && calibrated.is_none() {
        return Ok(None);
    }
    Ok(Some(format!(
        "trinocular rig {}: {}",
        path.display(),
        cameras
            .into_iter()
            .chain(calibrated)
            .collect::<Vec<_>>()
            .join("; ")
    )))
}

/// What the correction to 20 °C did, as the report states it.
fn correction_statement(
    t: &formats::conditions::Temperature,
    machine: Option<&formats::conditions::MachineExpansion>,
) -> String {
    let mut parts = Vec::new();
    if let Some(m) = machine {
        let a = m.alpha_um_per_m_k;
        let applied = match (m.instants.is_empty(), m.temperature_c, m.range_c()) {
            (true, Some(tc), _) => format!(
                "T = {tc} °C, deviation − α·(T − 20 °C)·(P − P₀) = deviation − {:.2} µm/m·(P − P₀)",
                m.strain_of(tc) * 1e6
            ),
            (_, _, Some((lo, hi))) => format!(
                "T per instant from the manifest's machine_c column ({lo}–{hi} °C), deviation − \
                 α·(T − 20 °C)·(P − P₀) with each capture's T"
            ),
            _ => String::new(),
        };
        parts.push(format!(
            "positioning deviations corrected to 20 °C for the machine scale's nominal differential \
             expansion (ISO 230-2): α = {a} µm/(m·K), {applied}, P₀ the line's first target"
        ));
    }
    if let (Some(tc), Some(a), Some(e)) =
        (t.target_c, t.target_expansion_um_per_m_k, t.target_strain())
    {
        parts.push(format!(
            "the rig's lengths scaled by 1 + {:.2} µm/m for the calibration target at {tc} °C \
             (α = {a} µm/(m·K))",
            e * 1e6
        ));
    }
    format!(
        "{}; the figures before it under `uncorrected`",
        parts.join("; ")
    )
}

/// The machine's expansion for the correction to 20 °C: α from the
/// conditions, the temperature from them or per instant from the
/// `machine_c` column of `--manifest` (every instant of the `points` must
/// then have one).
fn machine_expansion(
    args: &Args,
    points: &[formats::Row<formats::PointRow>],
    temperature: Option<&formats::conditions::Temperature>,
) -> Result<Option<formats::conditions::MachineExpansion>> {
    let instants = match &args.manifest {
        Some(m) => formats::conditions::read_instant_temperatures(m)?,
        None => Default::default(),
    };
    let machine = temperature.and_then(|t| t.machine(instants.clone()));
    if let (Some(manifest), false, None) = (&args.manifest, instants.is_empty(), &machine) {
        return Err(Usage::error(format!(
            "{}: its machine_c column gives the machine's temperature per instant; the correction to \
             20 °C needs the machine's expansion coefficient too (--conditions with \
             temperature.expansion_um_per_m_k)",
            manifest.display()
        )));
    }
    if let (Some(m), Some(manifest)) = (&machine, &args.manifest)
        && !m.instants.is_empty()
    {
        for row in points {
            if m.temperature_at(&row.record.instant()).is_none() {
                return Err(formats::FormatError::Row {
                    path: args.points.clone(),
                    line: row.line,
                    column: None,
                    message: format!(
                        "instant {} has no machine temperature: it is not in {} (machine_c) and the \
                         conditions give no temperature.machine_c",
                        row.record.instant(),
                        manifest.display()
                    ),
                }
                .into());
            }
        }
    }
    Ok(machine)
}

/// Run the evaluation and write the report.
pub fn run(args: &Args) -> Result<()> {
    // Found and read first, so that nothing is computed or written when
    // they fail.
    let browser = args.signoff.browser()?;
    let mut conditions = args.signoff.read_conditions()?;
    if args.manifest.is_some() && conditions.is_none() {
        conditions = Some(Default::default());
    }
    if let Some(c) = conditions.as_mut() {
        // Defaults for what the file does not say: the date from the
        // images, the equipment from the rig.
        if c.machine.date.is_none()
            && let Some(manifest) = &args.manifest
        {
            c.machine.date = capture_dates(manifest)?;
        }
        if c.machine.equipment.is_none()
            && let Some(rig) = &args.rig
        {
            c.machine.equipment = rig_equipment(rig)?;
        }
    }
    let limits = args.signoff.read_limits(KEYS)?;
    let temperature = conditions.as_ref().map(|c| &c.temperature);
    // Read once for the corrections' check and both evaluations.
    let points = evaluate::read_points(&args.points)?;
    let machine = machine_expansion(args, &points, temperature)?;
    let target_strain = temperature.and_then(|t| t.target_strain());
    let uncorrected = evaluate::Options {
        sphere: args.sphere.clone(),
        vdi3441: args.vdi3441,
        ..evaluate::Options::default()
    };
    let options = evaluate::Options {
        machine: machine.clone(),
        target_strain: target_strain.unwrap_or(0.0),
        ..uncorrected.clone()
    };
    let evaluate = |options: &evaluate::Options| {
        evaluate::evaluate_rows(&points, &args.points, options).map_err(|e| match e {
            // --sphere naming a sphere the points do not have.
            evaluate::EvaluateError::UnknownSphere { .. } => Usage::error(e),
            e => e.into(),
        })
    };
    let mut report = evaluate(&options)?;
    if machine.is_some() || target_strain.is_some() {
        let before = evaluate(&uncorrected)?;
        report.uncorrected = Some(formats::uncertainty::figures(
            &before,
            &evaluate::uncertainty::FIGURE_KEYS,
        )?);
        report.correction = temperature.map(|t| correction_statement(t, machine.as_ref()));
        report.conventions.extend(report.correction.clone());
    }
    if machine.is_none() && temperature.is_some_and(|t| t.expansion_um_per_m_k.is_some()) {
        report.warnings.push(
            "the machine's expansion coefficient is given without a machine temperature (conditions' \
             temperature.machine_c, or a machine_c column in --manifest): nothing is corrected to 20 °C"
                .into(),
        );
    }
    report.signoff.conditions = conditions.clone();
    report.uncertainty = Some(uncertainty(args, &report, &options)?);
    let figures = formats::uncertainty::figures(&report, &evaluate::uncertainty::FIGURE_KEYS)?;
    let expanded = report.uncertainty.as_ref().and_then(|u| u.expanded());
    args.signoff
        .judge(&mut report.signoff, limits.as_deref(), &figures, expanded)?;
    let mut output = formats::OutputPlan::new(args.force);
    output.input(&args.points);
    output.inputs(args.signoff.inputs());
    output.inputs(args.rig.iter());
    output.inputs(args.observations.iter());
    output.inputs(args.manifest.iter());
    let print = browser
        .as_deref()
        .map(|b| move |html: &Path| report::browser::print_pdf(b, html));
    let written = evaluate::write_outputs(
        &report,
        &args.out,
        &mut output,
        print.as_ref().map(|p| p as evaluate::Printer<'_>),
    )
    .with_context(|| format!("writing the report into {}", args.out.display()))?;
    if browser.is_some() {
        super::signoff::printed(&args.out.join("report.pdf"));
    }
    let u = |path: String| report.expanded(&path);
    // The figures below are corrected to 20 °C: said before them.
    if let Some(correction) = &report.correction {
        println!("conditions: {correction}");
    }
    for (axis, a) in report.axes.iter() {
        let p = &a.main.positioning;
        let at = |key: &str| format!("axes.{}.positioning.{key}", axis.name());
        let [(shown_a, key_a), (shown_e, key_e), (shown_r, key_r)] = p.shown_a_e_r();
        println!(
            "{axis}: A {}, E {}, M {}, R {}, B {}, 3σ band {}",
            num_u_in(shown_a, u(at(key_a)), "µm"),
            num_u_in(shown_e, u(at(key_e)), "µm"),
            num_u_in(p.m_um, u(at("M_um")), "µm"),
            num_u_in(shown_r, u(at(key_r)), "µm"),
            num_u_in(p.b_um, u(at("B_um")), "µm"),
            num_u_in(p.seed_3sigma_um, u(at("seed_3sigma_um")), "µm")
        );
        for (dir, s) in &a.main.straightness {
            let at = |key: &str| format!("axes.{}.straightness.{dir}.{key}", axis.name());
            println!(
                "{axis}: straightness in {dir}: LSQ {}, min zone {}",
                num_u_in(Some(s.lsq_um), u(at("lsq_um")), "µm"),
                num_u_in(Some(s.min_zone_um), u(at("min_zone_um")), "µm")
            );
        }
        if let Some(ang) = &a.main.angular {
            let at = |key: &str| format!("axes.{}.angular.{key}", axis.name());
            println!(
                "{axis}: roll {}, pitch {}, yaw {} (ranges)",
                num_u_in(Some(ang.roll_urad), u(at("roll_urad")), "µrad"),
                num_u_in(Some(ang.pitch_urad), u(at("pitch_urad")), "µrad"),
                num_u_in(Some(ang.yaw_urad), u(at("yaw_urad")), "µrad")
            );
        }
    }
    if let Some(f) = &report.flatness {
        println!(
            "flatness: LSQ {}, min zone {}",
            num_u_in(Some(f.lsq_um), u("flatness.lsq_um".into()), "µm"),
            num_u_in(Some(f.min_zone_um), u("flatness.min_zone_um".into()), "µm")
        );
    }
    match &report.uncertainty {
        Some(formats::uncertainty::Uncertainty::Given(p)) => println!(
            "uncertainty: U (k = 2) by Monte Carlo, {} trials, seed {}{}",
            p.trials,
            p.seed,
            if p.failed_trials > 0 {
                format!(" ({} trials failed and were left out)", p.failed_trials)
            } else {
                String::new()
            }
        ),
        Some(formats::uncertainty::Uncertainty::NotGiven { reason }) => {
            eprintln!("trinocular: note: the figures carry no uncertainty: {reason}");
        }
        None => {}
    }
    for w in &report.warnings {
        eprintln!("trinocular: warning: {w}");
    }
    println!("wrote {} files into {}", written.len(), args.out.display());
    args.signoff.finish(&report.signoff, &args.out)
}
