//! Matching blobs to spheres by diameter (METHODS.md §1, matching).
//!
//! A blob of apparent diameter a (px) imaging a sphere of diameter D lies at
//! distance `d ≈ f·D/a` from a camera of focal length f (px). The spheres sit
//! close together on the table, so a correct assignment puts them at nearly
//! the same distance, while swapping two spheres of diameters D1 ≠ D2 shifts
//! the implied distances apart by the factor D1/D2. An assignment is accepted
//! when its implied distances agree within half the smallest log-ratio of two
//! sphere diameters and lie within the distances the campaign's travel allows
//! (the working distance ± half the largest commanded extent + 50 mm);
//! extra blobs (reflections, stray light) are left unassigned; a sphere with
//! no consistent blob is missing, and two near-equally good assignments make
//! the frame ambiguous. Never a guess.

use crate::observe::Candidate;

/// Largest log-distance spread tolerated, whatever the diameters.
const MAX_SPREAD: f64 = 0.2;
/// At most this many candidates enter the exhaustive search (the largest first).
const MAX_CANDIDATES: usize = 12;

/// Why a frame's blobs could not be matched.
#[derive(Debug, Clone, PartialEq)]
pub enum MatchFailure {
    /// These spheres (indices) have no consistent blob.
    Missing(Vec<usize>),
    /// More than one assignment fits about equally well.
    Ambiguous,
}

/// Tolerance on the spread of implied log-distances: half the smallest
/// `|ln D_j − ln D_k|` over pairs of spheres, at most 0.2.
/// `None` when two spheres share a diameter within
/// [`formats::campaign::SAME_DIAMETER`] (they cannot be told apart).
pub fn spread_tolerance(diameters: &[f64]) -> Option<f64> {
    let mut tol = MAX_SPREAD;
    for (j, a) in diameters.iter().enumerate() {
        for b in &diameters[j + 1..] {
            let d = (a.ln() - b.ln()).abs();
            if d <= formats::campaign::SAME_DIAMETER {
                return None;
            }
            tol = tol.min(0.5 * d);
        }
    }
    Some(tol)
}

/// Exhaustive search over injective sphere → candidate maps.
struct Search<'a> {
    /// `[sphere][candidate]` implied log-distance; `None` outside the window.
    logs: &'a [Vec<Option<f64>>],
    tol: f64,
    spheres: &'a [usize],
    used: Vec<bool>,
    pick: Vec<usize>,
    /// Every consistent assignment: (spread, candidate of each sphere).
    found: Vec<(f64, Vec<usize>)>,
}

impl Search<'_> {
    fn visit(&mut self) {
        let depth = self.pick.len();
        if depth == self.spheres.len() {
            let vals = self
                .spheres
                .iter()
                .zip(&self.pick)
                .filter_map(|(&s, &c)| self.logs[s][c]);
            let (lo, hi) = vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
            if hi - lo <= self.tol {
                self.found.push((hi - lo, self.pick.clone()));
            }
            return;
        }
        let s = self.spheres[depth];
        for c in 0..self.used.len() {
            if self.used[c] || self.logs[s][c].is_none() {
                continue;
            }
            self.used[c] = true;
            self.pick.push(c);
            self.visit();
            self.pick.pop();
            self.used[c] = false;
        }
    }
}

/// All consistent assignments of `spheres`, best (smallest spread) first.
fn consistent(
    logs: &[Vec<Option<f64>>],
    tol: f64,
    spheres: &[usize],
    candidates: usize,
) -> Vec<(f64, Vec<usize>)> {
    let mut s = Search {
        logs,
        tol,
        spheres,
        used: vec![false; candidates],
        pick: Vec::new(),
        found: Vec::new(),
    };
    s.visit();
    s.found.sort_by(|a, b| a.0.total_cmp(&b.0));
    s.found
}

/// Assign one candidate to each sphere. `candidates` are the frame's usable
/// blobs, `diameters` the spheres' (mm), `focal_px` the camera's focal length,
/// `distances` (mm) the range of distances from the camera at which the
/// spheres can be. Returns, per sphere, the index into `candidates`.
pub fn assign(
    candidates: &[Candidate],
    diameters: &[f64],
    focal_px: f64,
    distances: (f64, f64),
) -> Result<Vec<usize>, MatchFailure> {
    let tol = spread_tolerance(diameters).ok_or(MatchFailure::Ambiguous)?;
    let (lo, hi) = (distances.0.max(f64::MIN_POSITIVE).ln(), distances.1.ln());
    // Usable candidates, largest first, at most MAX_CANDIDATES.
    let mut usable: Vec<usize> = (0..candidates.len())
        .filter(|&i| candidates[i].rejected.is_none() && candidates[i].diameter_px > 0.0)
        .collect();
    usable.sort_by(|&a, &b| {
        candidates[b]
            .diameter_px
            .total_cmp(&candidates[a].diameter_px)
    });
    usable.truncate(MAX_CANDIDATES);
    let logs: Vec<Vec<Option<f64>>> = diameters
        .iter()
        .map(|d| {
            usable
                .iter()
                .map(|&i| {
                    let l = (focal_px * d / candidates[i].diameter_px).ln();
                    (l >= lo && l <= hi).then_some(l)
                })
                .collect()
        })
        .collect();
    let all: Vec<usize> = (0..diameters.len()).collect();
    let found = consistent(&logs, tol, &all, usable.len());
    match found.as_slice() {
        [] => {
            // Name the missing sphere: the one whose removal leaves the most
            // consistent assignment, when clearly more consistent than any
            // other removal; else every sphere whose removal leaves one.
            let mut drops: Vec<(f64, usize)> = (0..diameters.len())
                .filter_map(|drop| {
                    let rest: Vec<usize> = all.iter().copied().filter(|&s| s != drop).collect();
                    if rest.is_empty() {
                        return None;
                    }
                    consistent(&logs, tol, &rest, usable.len())
                        .first()
                        .map(|(spread, _)| (*spread, drop))
                })
                .collect();
            drops.sort_by(|a, b| a.0.total_cmp(&b.0));
            let missing = match drops.as_slice() {
                [] => all,
                [(_, only)] => vec![*only],
                [(best, one), (second, _), ..] if second - best >= 0.5 * tol => vec![*one],
                _ => {
                    let mut m: Vec<usize> = drops.iter().map(|(_, d)| *d).collect();
                    m.sort_unstable();
                    m
                }
            };
            Err(MatchFailure::Missing(missing))
        }
        // Another assignment within half the tolerance of the best one: ambiguous.
        [(best, _), (second, _), ..] if second - best < 0.5 * tol => Err(MatchFailure::Ambiguous),
        [(_, pick), ..] => Ok(pick.iter().map(|&c| usable[c]).collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::Point2;

    const F: f64 = 7966.0;
    /// Working distance ± (half of 150 mm of travel + the sphere layout allowance).
    const REACH: f64 = 75.0 + crate::measure::SPHERE_LAYOUT_MM;
    const D0: (f64, f64) = (460.0 - REACH, 460.0 + REACH);
    const DIAMETERS: [f64; 3] = [20.0, 15.0, 10.0];

    fn cand(diameter_px: f64) -> Candidate {
        Candidate {
            ideal_px: Point2::origin(),
            diameter_px,
            rejected: None,
        }
    }

    /// Apparent diameter of a sphere at distance d.
    fn px(d_mm: f64, dist: f64) -> f64 {
        F * d_mm / dist
    }

    #[test]
    fn assigns_by_size_in_any_order_with_extras() {
        let c = vec![
            cand(px(10.0, 470.0)),
            cand(25.0),
            cand(px(20.0, 455.0)),
            cand(px(15.0, 440.0)),
            cand(3000.0),
        ];
        assert_eq!(assign(&c, &DIAMETERS, F, D0), Ok(vec![2, 3, 0]));
    }

    #[test]
    fn consistent_even_far_from_the_working_distance() {
        // Camera 1 during an X sweep: everything 75 mm nearer.
        let c = vec![
            cand(px(20.0, 385.0)),
            cand(px(15.0, 392.0)),
            cand(px(10.0, 380.0)),
        ];
        assert_eq!(assign(&c, &DIAMETERS, F, D0), Ok(vec![0, 1, 2]));
    }

    #[test]
    fn missing_sphere_is_named() {
        let c = vec![cand(px(20.0, 460.0)), cand(px(10.0, 462.0))];
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            Err(MatchFailure::Missing(vec![1]))
        );
    }

    #[test]
    fn twin_of_a_sphere_is_ambiguous() {
        // A reflection the size of sphere B next to B itself.
        let c = vec![
            cand(px(20.0, 460.0)),
            cand(px(15.0, 461.0)),
            cand(px(15.0, 459.0)),
            cand(px(10.0, 460.0)),
        ];
        assert_eq!(assign(&c, &DIAMETERS, F, D0), Err(MatchFailure::Ambiguous));
    }

    #[test]
    fn the_distance_range_decides_which_sphere_is_missing() {
        // C is gone; A's and B's blobs could also be B and C at ≈ 0.72 of
        // the distance — which the travel does not allow.
        let c = vec![cand(px(20.0, 460.0)), cand(px(15.0, 480.0))];
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            Err(MatchFailure::Missing(vec![2]))
        );
    }

    #[test]
    fn rejected_blobs_are_not_used() {
        let mut b = cand(px(15.0, 460.0));
        b.rejected = Some("touches the image border");
        let c = vec![cand(px(20.0, 460.0)), b, cand(px(10.0, 460.0))];
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            Err(MatchFailure::Missing(vec![1]))
        );
    }

    #[test]
    fn equal_diameters_cannot_be_matched() {
        assert_eq!(spread_tolerance(&[10.0, 10.0]), None);
        assert!(
            (spread_tolerance(&DIAMETERS).unwrap() - 0.5 * (20.0f64 / 15.0).ln()).abs() < 1e-12
        );
    }
}
