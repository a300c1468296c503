//! The kinematic chain and the volumetric error (docs/probe-volumetric.md): carriage
//! transforms `T_j(q) = Trans(q·a_j + δ_j(q))·Rot(ε_j(q))` (Rot by Rodrigues'
//! formula), squareness directions `a_X = (1, 0, 0)`,
//! `a_Y = (−sin EC0Y, cos EC0Y, 0)`, `a_Z = Ry(EB0Z)·Rx(EA0Z)·(0, 0, 1)`, the
//! chain string `W a1 … ak F b1 … bl T`, `T_W = T_ak ⋯ T_a1`,
//! `T_T = T_b1 ⋯ T_bl`, and the tool point in the workpiece frame
//! `w = T_W⁻¹·T_T·t`; the volumetric error is `w` minus the same with every
//! error and squareness zero.

use formats::Axis;
use geom::{Isometry3, Point3, Rotation3, Vector3};

pub use formats::probe::volumetric::Squareness;

use super::model::{ErrorModel, Evaluation};
use crate::{ChainFault, ProbeError, Result, VolumetricFault};

/// The source's chain: the workpiece rides on X, X on Y, Y on the frame; Z on
/// the frame, the tool on Z.
pub const DEFAULT_CHAIN: &str = "WXYFZT";

/// Which end of the chain an axis carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Between the workpiece and the frame: moving it moves the workpiece.
    Workpiece,
    /// Between the frame and the tool.
    Tool,
}

impl Side {
    /// `s` of the circular test: −1 on the workpiece side, +1 on the tool side.
    pub fn sign(self) -> f64 {
        match self {
            Side::Workpiece => -1.0,
            Side::Tool => 1.0,
        }
    }
}

/// A kinematic chain `W a1 … ak F b1 … bl T`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chain {
    /// The string it was parsed from, upper case.
    pub text: String,
    /// `a1 … ak`: from the workpiece towards the frame.
    pub workpiece: Vec<Axis>,
    /// `b1 … bl`: from the frame towards the tool.
    pub tool: Vec<Axis>,
}

fn chain_error(text: &str, fault: ChainFault) -> ProbeError {
    ProbeError::Chain {
        text: text.to_string(),
        fault,
    }
}

impl Chain {
    /// Parse `W a1 … ak F b1 … bl T` (letters W, X, Y, Z, F, T; case
    /// ignored): W first, F once, T last, each axis at most once.
    pub fn parse(text: &str) -> Result<Chain> {
        let upper: String = text.trim().to_uppercase();
        let letters: Vec<char> = upper.chars().collect();
        for (k, c) in letters.iter().enumerate() {
            if !"WXYZFT".contains(*c) {
                return Err(chain_error(
                    text,
                    ChainFault::Letter {
                        position: k + 1,
                        letter: *c,
                    },
                ));
            }
        }
        for (c, name) in [('W', "workpiece"), ('F', "frame"), ('T', "tool")] {
            match letters.iter().filter(|&&l| l == c).count() {
                0 => {
                    return Err(chain_error(text, ChainFault::Missing { letter: c, name }));
                }
                1 => {}
                count => {
                    return Err(chain_error(
                        text,
                        ChainFault::Repeated {
                            letter: c,
                            name,
                            count,
                        },
                    ));
                }
            }
        }
        if letters.first() != Some(&'W') {
            return Err(chain_error(text, ChainFault::NoStartW));
        }
        if letters.last() != Some(&'T') {
            return Err(chain_error(text, ChainFault::NoEndT));
        }
        let f = letters.iter().position(|&c| c == 'F').unwrap_or(0);
        let axes =
            |l: &[char]| -> Vec<Axis> { l.iter().copied().filter_map(axis_letter).collect() };
        let workpiece = axes(&letters[1..f]);
        let tool = axes(&letters[f + 1..letters.len() - 1]);
        for a in [Axis::X, Axis::Y, Axis::Z] {
            let count = workpiece.iter().chain(&tool).filter(|&&b| b == a).count();
            if count > 1 {
                return Err(chain_error(
                    text,
                    ChainFault::RepeatedAxis { axis: a, count },
                ));
            }
        }
        Ok(Chain {
            text: upper,
            workpiece,
            tool,
        })
    }

    /// The side of the chain `axis` is on, if it is in the chain.
    pub fn side(&self, axis: Axis) -> Option<Side> {
        if self.workpiece.contains(&axis) {
            Some(Side::Workpiece)
        } else if self.tool.contains(&axis) {
            Some(Side::Tool)
        } else {
            None
        }
    }

    /// The axes of the chain, workpiece side first.
    pub fn axes(&self) -> impl Iterator<Item = Axis> + '_ {
        self.workpiece.iter().chain(&self.tool).copied()
    }

    /// The same chain with every axis outside `keep` left out, the order of
    /// the others unchanged (`WXYFZT` keeping X and Y is `WXYFT`).
    pub fn keeping(&self, keep: &[Axis]) -> Chain {
        let kept = |a: &Axis| keep.contains(a);
        Chain {
            text: self
                .text
                .chars()
                .filter(|c| axis_letter(*c).is_none_or(|a| kept(&a)))
                .collect(),
            workpiece: self.workpiece.iter().copied().filter(kept).collect(),
            tool: self.tool.iter().copied().filter(kept).collect(),
        }
    }
}

/// The axis a chain letter names (`X`, `Y`, `Z`), if it names one.
fn axis_letter(c: char) -> Option<Axis> {
    match c {
        'X' => Some(Axis::X),
        'Y' => Some(Axis::Y),
        'Z' => Some(Axis::Z),
        _ => None,
    }
}

/// The direction `a_j` of axis `j` (unit vector) under `squareness` (§5):
/// `a_X = (1, 0, 0)`, `a_Y = (−sin EC0Y, cos EC0Y, 0)`,
/// `a_Z = Ry(EB0Z)·Rx(EA0Z)·(0, 0, 1)`.
pub(crate) fn direction(squareness: &Squareness, axis: Axis) -> Vector3<f64> {
    match axis {
        Axis::X => Vector3::x(),
        Axis::Y => Vector3::new(-squareness.ec0y.sin(), squareness.ec0y.cos(), 0.0),
        Axis::Z => {
            Rotation3::from_axis_angle(&Vector3::y_axis(), squareness.eb0z)
                * Rotation3::from_axis_angle(&Vector3::x_axis(), squareness.ea0z)
                * Vector3::z()
        }
    }
}

/// A machine: chain, squareness, tool offset and error model.
#[derive(Debug, Clone, Copy)]
pub struct Machine<'a> {
    /// The kinematic chain.
    pub chain: &'a Chain,
    /// Squareness errors.
    pub squareness: Squareness,
    /// Tool point t in the tool frame (mm).
    pub tool: Vector3<f64>,
    /// Error curves of every axis in the chain.
    pub model: &'a ErrorModel,
}

/// Carriage positions (mm) indexed by axis X, Y, Z.
pub(crate) type Positions = [f64; 3];

impl Machine<'_> {
    /// A machine; fails unless every axis of the chain has error curves and
    /// every axis with curves is in the chain.
    pub fn new<'a>(
        chain: &'a Chain,
        squareness: Squareness,
        tool: Vector3<f64>,
        model: &'a ErrorModel,
    ) -> Result<Machine<'a>> {
        for a in chain.axes() {
            if model.axis(a).is_none() {
                return Err(ProbeError::Volumetric(
                    VolumetricFault::ChainAxisWithoutCurves {
                        axis: a,
                        chain: chain.text.clone(),
                    },
                ));
            }
        }
        for a in &model.axes {
            if chain.side(a.axis()).is_none() {
                return Err(ProbeError::Volumetric(VolumetricFault::CurvesOffChain {
                    axis: a.axis(),
                    chain: chain.text.clone(),
                }));
            }
        }
        if !(tool.iter().all(|v| v.is_finite())) {
            return Err(ProbeError::Volumetric(VolumetricFault::ToolNotFinite));
        }
        Ok(Machine {
            chain,
            squareness,
            tool,
            model,
        })
    }

    /// Fails unless every axis outside the chain stands at 0 in `q`.
    fn check_positions(&self, q: &Positions) -> Result<()> {
        for a in [Axis::X, Axis::Y, Axis::Z] {
            let v = q[a.index()];
            if !v.is_finite() {
                return Err(ProbeError::Volumetric(VolumetricFault::PositionNotFinite {
                    axis: a,
                    value: v,
                }));
            }
            if self.chain.side(a).is_none() && v != 0.0 {
                return Err(ProbeError::Volumetric(VolumetricFault::PositionOffChain {
                    axis: a,
                    value: v,
                    chain: self.chain.text.clone(),
                }));
            }
        }
        Ok(())
    }

    /// `T_j(q) = Trans(q·a_j + δ_j(q))·Rot(ε_j(q))`; with `how = None`, the
    /// nominal `Trans(q·e_j)`.
    fn carriage(&self, axis: Axis, q: f64, how: Option<Evaluation>) -> Result<Isometry3<f64>> {
        let Some(how) = how else {
            return Ok(geom::transform::rigid(
                Vector3::zeros(),
                Vector3::ith(axis.index(), q),
            ));
        };
        let model = self
            .model
            .axis(axis)
            .ok_or(ProbeError::Volumetric(VolumetricFault::NoCurves { axis }))?;
        let (delta, epsilon) = model.motions(q, how)?;
        let squareness = match how {
            Evaluation::Model(_) => self.squareness,
            // Compensation removes the squareness too: it is known exactly.
            Evaluation::Residual(_) => Squareness::default(),
        };
        // Trans(q·a_j + δ)·Rot(ε), Rot(ε) = exp([ε]×) (Rodrigues).
        Ok(geom::transform::rigid(
            epsilon,
            direction(&squareness, axis) * q + delta,
        ))
    }

    /// The tool point in the workpiece frame, `w = T_W⁻¹·T_T·t` (mm); with
    /// `how = None` the nominal `w₀` (no errors, no squareness).
    pub fn tool_point(&self, q: &Positions, how: Option<Evaluation>) -> Result<Vector3<f64>> {
        self.check_positions(q)?;
        let mut t_w = Isometry3::identity();
        for &a in &self.chain.workpiece {
            t_w = self.carriage(a, q[a.index()], how)? * t_w;
        }
        let mut t_t = Isometry3::identity();
        for &b in &self.chain.tool {
            t_t *= self.carriage(b, q[b.index()], how)?;
        }
        let w = t_w.inverse() * (t_t * Point3::from(self.tool));
        Ok(w.coords)
    }

    /// The volumetric error `w − w₀` at carriage positions `q` (mm).
    pub fn volumetric_error(&self, q: &Positions, how: Evaluation) -> Result<Vector3<f64>> {
        Ok(self.tool_point(q, Some(how))? - self.tool_point(q, None)?)
    }

    /// The carriage positions that put the tool at `w₀` in the workpiece
    /// frame nominally: `q_L = s_L·(w₀_L − t_L)` (s = −1 on the workpiece
    /// side, +1 on the tool side); an axis outside the chain needs
    /// `w₀_L = t_L`.
    pub fn positions_for(&self, w0: &Vector3<f64>) -> Result<Positions> {
        let mut q = [0.0; 3];
        for a in [Axis::X, Axis::Y, Axis::Z] {
            let i = a.index();
            match self.chain.side(a) {
                Some(side) => q[i] = side.sign() * (w0[i] - self.tool[i]),
                None if (w0[i] - self.tool[i]).abs() > POSITION_TOLERANCE_MM => {
                    return Err(ProbeError::Volumetric(VolumetricFault::PointOffChain {
                        point: [w0.x, w0.y, w0.z],
                        axis: a,
                        chain: self.chain.text.clone(),
                        tool_mm: self.tool[i],
                    }));
                }
                None => {}
            }
        }
        Ok(q)
    }
}

/// A workpiece point agrees with the tool's fixed coordinate on an axis
/// outside the chain to this (mm).
pub(crate) const POSITION_TOLERANCE_MM: f64 = 1e-9;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chains_parse_and_bad_ones_say_why() {
        let c = Chain::parse("WXYFZT").unwrap();
        assert_eq!(c.workpiece, vec![Axis::X, Axis::Y]);
        assert_eq!(c.tool, vec![Axis::Z]);
        assert_eq!(c.side(Axis::Z), Some(Side::Tool));
        let c = Chain::parse("wyfxzt").unwrap();
        assert_eq!(
            (c.workpiece.clone(), c.tool.clone()),
            (vec![Axis::Y], vec![Axis::X, Axis::Z])
        );
        assert_eq!(Chain::parse("WFT").unwrap().axes().count(), 0);
        for (bad, says) in [
            ("XYFZT", "no W"),
            ("WXYZT", "no F"),
            ("WXYFZ", "no T"),
            ("WXYFXT", "axis X appears 2 times"),
            ("WXFFZT", "F (frame) appears 2 times"),
            ("WXYFZTQ", "'Q'"),
            ("XWYFZT", "start with W"),
            ("WXYFTZ", "end with T"),
        ] {
            let e = Chain::parse(bad).unwrap_err().to_string();
            assert!(e.contains("--chain") && e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn keeping_leaves_out_the_other_axes_in_order() {
        let c = Chain::parse("WXYFZT").unwrap();
        let kept = c.keeping(&[Axis::Y, Axis::X]);
        assert_eq!(kept, Chain::parse("WXYFT").unwrap());
        let kept = Chain::parse("WYFXZT").unwrap().keeping(&[Axis::Z, Axis::Y]);
        assert_eq!(kept, Chain::parse("WYFZT").unwrap());
        assert_eq!(c.keeping(&[Axis::X, Axis::Y, Axis::Z]), c);
    }

    #[test]
    fn squareness_directions() {
        let s = Squareness {
            ec0y: 1e-3,
            eb0z: 2e-3,
            ea0z: -3e-3,
        };
        let y = direction(&s, Axis::Y);
        assert!((y - Vector3::new(-(1e-3f64).sin(), (1e-3f64).cos(), 0.0)).norm() < 1e-16);
        // Ry(b)·Rx(a)·ẑ = (sin b·cos a, −sin a, cos b·cos a).
        let (a, b) = (-3e-3f64, 2e-3f64);
        let z = direction(&s, Axis::Z);
        assert!((z - Vector3::new(b.sin() * a.cos(), -a.sin(), b.cos() * a.cos())).norm() < 1e-16);
    }
}
