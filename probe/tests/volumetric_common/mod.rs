//! An independent implementation of docs/probe-volumetric.md §5 with 4×4
//! matrices, on the generator's true curves: the truth of the volumetric
//! tests.

#![allow(clippy::unwrap_used, clippy::expect_used, dead_code)]

use geom::Vector3;
use probe::volumetric::{Chain, CircleSpec, Model, Motion, Order, Setup};
use synth::probe::volumetric::{VolumetricConfig, VolumetricData};

// ---- An independent implementation of §5 with 4×4 matrices ----

type M4 = [[f64; 4]; 4];

/// Rodrigues: R = I + sin θ·K + (1 − cos θ)·K², K the cross-product matrix of ε/θ.
fn rodrigues(e: Vector3<f64>) -> [[f64; 3]; 3] {
    let theta = e.norm();
    let mut r = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if theta == 0.0 {
        return r;
    }
    let u = e / theta;
    let k = [[0.0, -u.z, u.y], [u.z, 0.0, -u.x], [-u.y, u.x, 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            let k2: f64 = (0..3).map(|m| k[i][m] * k[m][j]).sum();
            r[i][j] += theta.sin() * k[i][j] + (1.0 - theta.cos()) * k2;
        }
    }
    r
}

fn homogeneous(r: [[f64; 3]; 3], t: Vector3<f64>) -> M4 {
    let mut m = [[0.0; 4]; 4];
    for i in 0..3 {
        m[i][..3].copy_from_slice(&r[i]);
        m[i][3] = t[i];
    }
    m[3][3] = 1.0;
    m
}

fn mul(a: &M4, b: &M4) -> M4 {
    let mut c = [[0.0; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            c[i][j] = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

/// Inverse of a rigid transform: [Rᵀ, −Rᵀt].
fn inverse(m: &M4) -> M4 {
    let mut r = [[0.0; 3]; 3];
    let mut t = Vector3::zeros();
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = m[j][i];
        }
    }
    for i in 0..3 {
        t[i] = -(0..3).map(|j| r[i][j] * m[j][3]).sum::<f64>();
    }
    homogeneous(r, t)
}

fn apply(m: &M4, p: Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
        m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
        m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3],
    )
}

/// What a compensation takes off motion m of axis a (0 = X) at q.
pub type Compensation = Box<dyn Fn(usize, usize, f64) -> f64>;

/// The true machine of the generator: per axis the §5 curves at the
/// positions, linear between them (less a compensation, when given).
pub struct TrueMachine {
    pub chain: String,
    pub squareness: [f64; 3],
    pub tool: Vector3<f64>,
    pub axes: Vec<(Vec<f64>, [Vec<f64>; 6])>,
    pub minus: Option<Compensation>,
}

impl TrueMachine {
    fn motion(&self, axis: usize, q: f64) -> (Vector3<f64>, Vector3<f64>) {
        let (p, v) = &self.axes[axis];
        let k = p.partition_point(|x| *x <= q).clamp(1, p.len() - 1);
        let w = (q - p[k - 1]) / (p[k] - p[k - 1]);
        let off = |m: usize| self.minus.as_ref().map_or(0.0, |f| f(axis, m, q));
        let at = |m: usize| v[m][k - 1] * (1.0 - w) + v[m][k] * w - off(m);
        (
            Vector3::new(at(0), at(1), at(2)),
            Vector3::new(at(3), at(4), at(5)),
        )
    }

    fn direction(&self, axis: usize) -> Vector3<f64> {
        let [c, b, a] = self.squareness;
        match axis {
            0 => Vector3::x(),
            1 => Vector3::new(-c.sin(), c.cos(), 0.0),
            _ => Vector3::new(b.sin() * a.cos(), -a.sin(), b.cos() * a.cos()),
        }
    }

    fn carriage(&self, axis: usize, q: f64, errors: bool) -> M4 {
        if !errors {
            return homogeneous(rodrigues(Vector3::zeros()), Vector3::ith(axis, q));
        }
        let (d, e) = self.motion(axis, q);
        homogeneous(rodrigues(e), self.direction(axis) * q + d)
    }

    /// w = T_W⁻¹·T_T·t.
    fn tool_point(&self, q: [f64; 3], errors: bool) -> Vector3<f64> {
        let c: Vec<char> = self.chain.chars().collect();
        let f = c.iter().position(|&l| l == 'F').unwrap();
        let index = |l: char| "XYZ".find(l).unwrap();
        let mut t_w = homogeneous(rodrigues(Vector3::zeros()), Vector3::zeros());
        for &l in &c[1..f] {
            t_w = mul(&self.carriage(index(l), q[index(l)], errors), &t_w);
        }
        let mut t_t = homogeneous(rodrigues(Vector3::zeros()), Vector3::zeros());
        for &l in &c[f + 1..c.len() - 1] {
            t_t = mul(&t_t, &self.carriage(index(l), q[index(l)], errors));
        }
        apply(&inverse(&t_w), apply(&t_t, self.tool))
    }

    pub fn error(&self, q: [f64; 3]) -> Vector3<f64> {
        self.tool_point(q, true) - self.tool_point(q, false)
    }

    fn side(&self, axis: usize) -> f64 {
        let f = self.chain.find('F').unwrap();
        let i = self.chain.find(["X", "Y", "Z"][axis]).unwrap();
        if i < f { -1.0 } else { 1.0 }
    }

    /// Radial deviations per degree and the circular deviation (mm).
    pub fn circle(&self, c: [f64; 3], r: f64) -> (Vec<f64>, f64) {
        let mut radial = Vec::new();
        let mut path = Vec::new();
        for d in 0..360 {
            let th = f64::from(d).to_radians();
            let w0 = Vector3::new(c[0] + r * th.cos(), c[1] + r * th.sin(), c[2]);
            let q: [f64; 3] = std::array::from_fn(|i| self.side(i) * (w0[i] - self.tool[i]));
            let e = self.error(q);
            radial.push(e.x * th.cos() + e.y * th.sin());
            path.push(geom::Point2::new(w0.x + e.x, w0.y + e.y));
        }
        let fit = geom::fit::circle_2d(&path).unwrap();
        (radial, geom::stats::range(&fit.residuals).unwrap())
    }
}

/// The set-up the generator's data name: its chain, squareness, tool, positions and
/// circle, the raw model, order 3.
pub fn generator_setup(d: &VolumetricData) -> Setup {
    let s = &d.setup;
    Setup {
        chain: Chain::parse(&s.chain).unwrap(),
        squareness: s.squareness_rad,
        tool: s.tool_mm,
        model: Model::Raw,
        order: Order::Fixed(3),
        at: d
            .at
            .iter()
            .map(|r| ("at".to_string(), [r.x, r.y, r.z]))
            .collect(),
        circle: Some(CircleSpec {
            centre: s.circle.centre_mm,
            radius: s.circle.radius_mm,
        }),
        source: "generator".into(),
        readings_u: None,
    }
}

/// The true machine of `d`, less `minus` (a compensation) when given.
pub fn true_machine(
    config: &VolumetricConfig,
    d: &VolumetricData,
    minus: Option<Compensation>,
) -> TrueMachine {
    TrueMachine {
        chain: config.chain.clone(),
        squareness: if minus.is_some() {
            [0.0; 3]
        } else {
            config.squareness_rad
        },
        tool: Vector3::from(config.tool_mm),
        minus,
        axes: d
            .truth
            .axes
            .iter()
            .map(|a| {
                (
                    a.positions_mm.clone(),
                    std::array::from_fn(|m| a.curves[Motion::ALL[m].name()].clone()),
                )
            })
            .collect(),
    }
}
