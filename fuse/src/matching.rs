//! Matching blobs to spheres by diameter (docs/methods.md, matching).
//!
//! A blob of apparent diameter a (px) imaging a sphere of diameter D lies at
//! distance `d ≈ f·D/a` from a camera of focal length f (px). The spheres sit
//! close together on the table, so a correct assignment puts them at nearly
//! the same distance, while swapping two spheres of diameters D1 ≠ D2 shifts
//! the implied distances apart by the factor D1/D2. An assignment is accepted
//! when its implied distances agree within half the smallest log-ratio of two
//! sphere diameters and lie within the distances the campaign's travel allows
//! (the working distance ± half the largest commanded extent + 50 mm);
//! extra blobs (reflections, stray light) are left unassigned.
//!
//! When no blob fits a sphere (clipped by the image border, out of view) the
//! largest set of spheres that still fits — at least two, so that their
//! implied distances check each other — is assigned and the rest is missing.
//! A sphere is assigned only when every assignment about as good as the best
//! gives it the same blob; otherwise it is ambiguous. Never a guess.

use crate::observe::Candidate;

/// Largest log-distance spread tolerated, whatever the diameters.
const MAX_SPREAD: f64 = 0.2;
/// At most this many candidates enter the exhaustive search (the largest first).
const MAX_CANDIDATES: usize = 12;
/// Fewest spheres of a partial assignment: one blob alone would be identified
/// by the distance window only; two or more also check each other's implied
/// distances.
const MIN_PARTIAL: usize = 2;

/// What one frame says about one sphere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SphereMatch {
    /// The candidate (index into the frame's candidates) that images the sphere.
    Found(usize),
    /// No blob consistent with the other spheres images it.
    Missing,
    /// Blobs fit it in more than one way about equally well.
    Ambiguous,
}

/// Tolerance on the spread of implied log-distances: half the smallest
/// `|ln D_j − ln D_k|` over pairs of spheres, at most 0.2.
/// `None` when two spheres share a diameter within
/// [`formats::SAME_DIAMETER`] (they cannot be told apart).
pub fn spread_tolerance(diameters: &[f64]) -> Option<f64> {
    let mut tol = MAX_SPREAD;
    for (j, a) in diameters.iter().enumerate() {
        for b in &diameters[j + 1..] {
            let d = (a.ln() - b.ln()).abs();
            if d <= formats::SAME_DIAMETER {
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

/// The `k`-element subsets of `0..n`, in lexicographic order.
fn subsets(n: usize, k: usize) -> Vec<Vec<usize>> {
    fn extend(n: usize, k: usize, from: usize, cur: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
        if cur.len() == k {
            out.push(cur.clone());
            return;
        }
        for i in from..n {
            if n - i < k - cur.len() {
                break;
            }
            cur.push(i);
            extend(n, k, i + 1, cur, out);
            cur.pop();
        }
    }
    let mut out = Vec::new();
    extend(n, k, 0, &mut Vec::with_capacity(k), &mut out);
    out
}

/// Assign candidates to spheres. `candidates` are the frame's blobs,
/// `diameters` the spheres' (mm), `focal_px` the camera's focal length,
/// `distances` (mm) the range of distances from the camera at which the
/// spheres can be. Returns, per sphere, the candidate that images it, or why
/// none does.
///
/// The largest set of spheres with a consistent assignment is used (all of
/// them when possible, else at least [`MIN_PARTIAL`]); every assignment of a
/// set of that size within half the tolerance of the best one is a rival,
/// and a sphere is found only when all rivals give it the same blob.
pub fn assign(
    candidates: &[Candidate],
    diameters: &[f64],
    focal_px: f64,
    distances: (f64, f64),
) -> Vec<SphereMatch> {
    let n = diameters.len();
    let Some(tol) = spread_tolerance(diameters) else {
        return vec![SphereMatch::Ambiguous; n];
    };
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
    for size in (MIN_PARTIAL.min(n).max(1)..=n).rev() {
        // Every consistent assignment of every set of `size` spheres:
        // (spread, sphere → usable candidate).
        let mut rivals: Vec<(f64, Vec<Option<usize>>)> = Vec::new();
        for set in subsets(n, size) {
            for (spread, pick) in consistent(&logs, tol, &set, usable.len()) {
                let mut of_sphere = vec![None; n];
                for (&s, &c) in set.iter().zip(&pick) {
                    of_sphere[s] = Some(usable[c]);
                }
                rivals.push((spread, of_sphere));
            }
        }
        let Some(best) = rivals.iter().map(|r| r.0).min_by(f64::total_cmp) else {
            continue;
        };
        rivals.retain(|r| r.0 - best < 0.5 * tol);
        return (0..n)
            .map(|s| {
                let first = rivals.first().and_then(|r| r.1[s]);
                if rivals.iter().any(|r| r.1[s] != first) {
                    SphereMatch::Ambiguous
                } else {
                    first.map_or(SphereMatch::Missing, SphereMatch::Found)
                }
            })
            .collect();
    }
    vec![SphereMatch::Missing; n]
}

#[cfg(test)]
mod tests {
    use super::SphereMatch::{Ambiguous, Found, Missing};
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
            covariance: None,
            covariance_form: None,
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
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            vec![Found(2), Found(3), Found(0)]
        );
    }

    #[test]
    fn consistent_even_far_from_the_working_distance() {
        // Camera 1 during an X sweep: everything 75 mm nearer.
        let c = vec![
            cand(px(20.0, 385.0)),
            cand(px(15.0, 392.0)),
            cand(px(10.0, 380.0)),
        ];
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            vec![Found(0), Found(1), Found(2)]
        );
    }

    #[test]
    fn a_missing_sphere_leaves_the_others_found() {
        let c = vec![cand(px(20.0, 460.0)), cand(px(10.0, 462.0))];
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            vec![Found(0), Missing, Found(1)]
        );
    }

    #[test]
    fn one_blob_alone_is_not_identified() {
        // Sphere A's blob alone: nothing checks its implied distance.
        let c = vec![cand(px(20.0, 460.0))];
        assert_eq!(assign(&c, &DIAMETERS, F, D0), vec![Missing; 3]);
        // A single sphere set has nothing to check against: its blob is used.
        assert_eq!(assign(&c, &[20.0], F, D0), vec![Found(0)]);
    }

    #[test]
    fn twin_of_a_sphere_is_ambiguous_and_the_others_found() {
        // A reflection the size of sphere B next to B itself.
        let c = vec![
            cand(px(20.0, 460.0)),
            cand(px(15.0, 461.0)),
            cand(px(15.0, 459.0)),
            cand(px(10.0, 460.0)),
        ];
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            vec![Found(0), Ambiguous, Found(3)]
        );
    }

    #[test]
    fn two_equally_good_partial_sets_are_ambiguous() {
        // Two blobs whose size ratio √2 lies halfway between A:B (4/3) and
        // B:C (3/2): A + B at ≈ 470 mm and B + C at ≈ 335 mm fit equally well
        // (both inside a wide window), so which sphere is missing is
        // undecided and nothing is assigned.
        let a = px(20.0, 460.0);
        let c = vec![cand(a), cand(a / 2f64.sqrt())];
        let wide = (300.0, 700.0);
        assert_eq!(assign(&c, &DIAMETERS, F, wide), vec![Ambiguous; 3]);
    }

    #[test]
    fn the_distance_range_decides_which_sphere_is_missing() {
        // C is gone; A's and B's blobs could also be B and C at ≈ 0.72 of
        // the distance — which the travel does not allow.
        let c = vec![cand(px(20.0, 460.0)), cand(px(15.0, 480.0))];
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            vec![Found(0), Found(1), Missing]
        );
    }

    #[test]
    fn rejected_blobs_are_not_used() {
        let mut b = cand(px(15.0, 460.0));
        b.rejected = Some("touches the image border");
        let c = vec![cand(px(20.0, 460.0)), b, cand(px(10.0, 460.0))];
        assert_eq!(
            assign(&c, &DIAMETERS, F, D0),
            vec![Found(0), Missing, Found(2)]
        );
    }

    #[test]
    fn subsets_are_every_combination_once() {
        assert_eq!(
            subsets(4, 2),
            vec![
                vec![0, 1],
                vec![0, 2],
                vec![0, 3],
                vec![1, 2],
                vec![1, 3],
                vec![2, 3]
            ]
        );
        assert_eq!(subsets(3, 3), vec![vec![0, 1, 2]]);
    }

    #[test]
    fn equal_diameters_cannot_be_matched() {
        assert_eq!(spread_tolerance(&[10.0, 10.0]), None);
        assert_eq!(
            assign(&[cand(40.0)], &[10.0, 10.0], F, D0),
            vec![Ambiguous; 2]
        );
        assert!(
            (spread_tolerance(&DIAMETERS).unwrap() - 0.5 * (20.0f64 / 15.0).ln()).abs() < 1e-12
        );
    }
}
