#![allow(clippy::unwrap_used, clippy::expect_used)]
use std::path::Path;
use formats::Axis;
use probe::volumetric::*;

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/probe/volumetric").join(name)
}

fn rows(name: &str) -> Vec<csv::StringRecord> {
    csv::Reader::from_path(data(name)).unwrap().records().map(|r| r.unwrap()).collect()
}

fn curves() -> Vec<AxisCurves> {
    let mut out = Vec::new();
    for axis in [Axis::X, Axis::Y, Axis::Z] {
        let r: Vec<[f64; 7]> = rows("errors.csv").iter().filter(|r| &r[0] == axis.name())
            .map(|r| std::array::from_fn(|k| r[k + 1].parse().unwrap())).collect();
        out.push(AxisCurves::new(MeasuredAxis::from_rows(axis, &r)).unwrap());
    }
    out
}

#[test]
fn check_vector() {
    let model = ErrorModel::new(curves(), Order::Fixed(3)).unwrap();
    let mut worst = 0.0f64;
    for r in rows("expected_fits.csv") {
        let axis = match &r[0] { "X" => Axis::X, "Y" => Axis::Y, _ => Axis::Z };
        let m = Motion::from_name(&r[1]).unwrap();
        let s = if &r[2] == "fourier" { Series::Fourier } else { Series::Polynomial };
        let f = model.axis(axis).unwrap().fits[m.index()].get(s).figures;
        for (got, want) in [(f.r2.unwrap(), &r[3]), (f.sse, &r[4]), (f.rmse, &r[5]), (f.emax, &r[6])] {
            let want: f64 = want.parse().unwrap();
            worst = worst.max(((got - want) / want).abs());
            if ((got - want) / want).abs() > 1e-9 { println!("{} {} {} {got} {want}", &r[0], &r[1], &r[2]); }
        }
    }
    println!("fits worst relative {worst:e}");
    let chain = Chain::parse("WXYFZT").unwrap();
    let sq = Squareness { ec0y: 1.8e-5, eb0z: -1.1e-5, ea0z: 7e-6 };
    let m = Machine::new(&chain, sq, geom::Vector3::new(0.0, 0.0, -100.0), &model).unwrap();
    let mut worst = 0.0f64;
    for r in rows("expected_volumetric.csv") {
        let how = match &r[0] { "raw" => Model::Raw, "fourier" => Model::Fourier, _ => Model::Polynomial };
        let q = [r[1].parse().unwrap(), r[2].parse().unwrap(), r[3].parse().unwrap()];
        let d = m.volumetric_error(&q, Evaluation::Model(how)).unwrap();
        for k in 0..3 { let want: f64 = r[4 + k].parse().unwrap(); worst = worst.max((d[k] - want).abs()); }
    }
    println!("volumetric worst {:e} um", worst * 1e3);
    let spec = CircleSpec { centre: [-300.0, -200.0, 40.0], radius: 100.0 };
    let c = circle::predict(&m, &spec, Evaluation::Model(Model::Raw)).unwrap();
    let mut worst = 0.0f64;
    for (r, p) in rows("expected_circle.csv").iter().zip(&c.points) {
        for k in 0..3 { let want: f64 = r[1 + k].parse().unwrap(); worst = worst.max((p.delta[k] - want).abs()); }
        let want: f64 = r[4].parse().unwrap(); worst = worst.max((p.radial - want).abs());
    }
    println!("circle worst {:e} um; range {} dev {}", worst * 1e3, c.radial_range * 1e3, c.circular_deviation * 1e3);
    let c = circle::predict(&m, &spec, Evaluation::Model(Model::Fourier)).unwrap();
    println!("fourier range {} dev {}", c.radial_range * 1e3, c.circular_deviation * 1e3);
}

#[test]
fn explore_omega() {
    use geom::nalgebra::{DMatrix, DVector};
    let r: Vec<[f64; 7]> = rows("errors.csv").iter().filter(|r| &r[0] == "X")
        .map(|r| std::array::from_fn(|k| r[k + 1].parse().unwrap())).collect();
    let p: Vec<f64> = r.iter().map(|r| r[0]).collect();
    let v: Vec<f64> = r.iter().map(|r| r[1]).collect();
    for li in 0..200 {
        let l = 560.0 + li as f64 * 0.5;
        let w = std::f64::consts::TAU / l;
        let a = DMatrix::from_fn(p.len(), 7, |i, j| if j == 0 { 1.0 } else { let n = ((j + 1) / 2) as f64; if j % 2 == 1 { (n * w * p[i]).sin() } else { (n * w * p[i]).cos() } });
        let b = DVector::from_vec(v.clone());
        let x = a.clone().svd(true, true).solve(&b, 0.0).unwrap();
        let res = &b - &a * x.clone();
        let sse = res.norm_squared();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let sst: f64 = v.iter().map(|x| (x - mean).powi(2)).sum();
        let r2 = 1.0 - sse / sst;
        if (r2 - 0.842096912113).abs() < 2e-6 { println!("L {l} r2 {r2} {:?}", x.as_slice()); }
    }
}

#[test]
fn explore_mine() {
    let r: Vec<[f64; 7]> = rows("errors.csv").iter().filter(|r| &r[0] == "X")
        .map(|r| std::array::from_fn(|k| r[k + 1].parse().unwrap())).collect();
    let p: Vec<f64> = r.iter().map(|r| r[0]).collect();
    let v: Vec<f64> = r.iter().map(|r| r[1]).collect();
    let f = SeriesFit::fit(Series::Fourier, 3, &p, &v, "x").unwrap();
    println!("mine {:?} {:?}", f.figures, f.coefficients);
    let c = AxisCurves::new(MeasuredAxis::from_rows(Axis::X, &r)).unwrap();
    println!("same data {}", c.curve(Motion::Ex) == &v[..]);
}
