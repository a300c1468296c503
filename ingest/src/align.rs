//! Matching one camera's sequence of events (bursts of frames, or dwells
//! found in its images) to the program's sequence of dwells, by order and by
//! relative gaps — never by absolute time: the camera's clock may be off by
//! any amount, and the machine's moves need not last distance/feed.
//!
//! Dynamic programming over monotone matchings. An alignment matches some
//! events to distinct dwells in order; every other event is a stray (cost
//! `skip_event`), every other dwell is missing from the camera
//! (`skip_dwell`). Between two consecutive matches (i′ → j′, i → j) the
//! camera's gap `Δt = t_i − t_i′` is compared with the programmed gap
//! `Δτ = τ_j − τ_j′` scaled by the campaign's common slowness `s`:
//! `r = ln(Δt / (s·Δτ))`, cost `(r/σ)²`, capped at `pause_cost` when the
//! camera's gap is longer (an operator pause, a slow move) but not when it
//! is shorter (nothing makes a machine faster than its program by much).
//! A match costs `size_cost` per frame the event has more or fewer than the
//! program's captures (capped at half a stray's cost), and half a stray's
//! cost more when it is unlike a dwell's event (frames off the `1/fps`
//! grid; a stay whose arrival was not recorded). `s` starts as the
//! ratio of the median gaps and is refined from the matched single steps.
//!
//! Ambiguity is measured, not guessed: forward and backward passes give, for
//! every event and dwell, the cost of the best alignment that matches them
//! (min-marginals). An event is ambiguous when an alignment that places it
//! differently (another dwell, or none) costs less than `margin` more than
//! the best one.
//!
//! Limits: between two matched events at most `max_event_skip` strays and
//! `max_dwell_skip` missing dwells; in all at most `band` more strays and
//! missing dwells than the difference of the two counts.

/// An event on a camera's clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event {
    /// Time (s) on the camera's clock, any origin; events in increasing time.
    pub time_s: f64,
    /// Frames in it.
    pub size: usize,
    /// Unlike a dwell's event: a burst whose frames are not on a `1/fps`
    /// grid (two closer than that, or a gap off a whole number of periods),
    /// or a stay that began before the recording (its time is not an arrival).
    pub irregular: bool,
}

/// Costs and limits of the alignment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlignParams {
    /// Relative spread (log ratio) of a gap around the programmed gap × s.
    pub sigma: f64,
    /// Most a longer-than-expected gap costs.
    pub pause_cost: f64,
    /// Cost of an event matched to no dwell.
    pub skip_event: f64,
    /// Cost of a dwell matched to no event.
    pub skip_dwell: f64,
    /// Cost per frame an event has more or fewer than expected; an
    /// irregular event costs as much as half a stray more.
    pub size_cost: f64,
    /// Cost difference below which another placement is an ambiguity.
    pub margin: f64,
    /// Strays and missing dwells beyond the count difference (band half-width).
    pub band: usize,
    /// Most strays between two matched events.
    pub max_event_skip: usize,
    /// Most missing dwells between two matched events.
    pub max_dwell_skip: usize,
}

impl Default for AlignParams {
    fn default() -> Self {
        Self {
            sigma: 0.15,
            pause_cost: 9.0,
            skip_event: 12.0,
            skip_dwell: 12.0,
            size_cost: 1.0,
            margin: 4.0,
            band: 32,
            max_event_skip: 4,
            max_dwell_skip: 64,
        }
    }
}

/// An event whose placement is not unique.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ambiguity {
    /// The event.
    pub event: usize,
    /// Its dwell in the best alignment (`None`: a stray there).
    pub chosen: Option<usize>,
    /// Its dwell in the close alternative (`None`: a stray there).
    pub alternative: Option<usize>,
    /// How much more the alternative costs.
    pub margin: f64,
}

/// The best alignment.
#[derive(Debug, Clone, PartialEq)]
pub struct Alignment {
    /// Per event, its dwell (`None`: matched to no dwell).
    pub dwell_of: Vec<Option<usize>>,
    /// Events whose placement is not unique (their `dwell_of` is kept for reference).
    pub ambiguous: Vec<Ambiguity>,
    /// The campaign's slowness: real gaps ÷ programmed gaps.
    pub scale: f64,
    /// Cost of the alignment.
    pub cost: f64,
}

/// The median of the finite values; `None` when there is none.
pub(crate) fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// The band of `i − j` and the tables of log gaps.
struct Grid {
    m: usize,
    n: usize,
    lo: i64,
    hi: i64,
    width: usize,
    ke: usize,
    kd: usize,
    /// `ln(t_i − t_{i−k})`, k = 1..=ke, at `i·ke + k − 1`.
    log_dt: Vec<f64>,
    /// `ln(τ_j − τ_{j−k})`, k = 1..=kd, at `j·kd + k − 1`.
    log_dtau: Vec<f64>,
}

impl Grid {
    fn new(events: &[Event], dwells: &[f64], p: &AlignParams) -> Self {
        let (m, n) = (events.len(), dwells.len());
        let diff = m as i64 - n as i64;
        let band = p.band as i64;
        let (lo, hi) = (diff.min(0) - band, diff.max(0) + band);
        let ke = p.max_event_skip + 1;
        let kd = p.max_dwell_skip + 1;
        let ln = |x: f64| if x > 0.0 { x.ln() } else { f64::NEG_INFINITY };
        let mut log_dt = vec![f64::NEG_INFINITY; m * ke];
        for i in 0..m {
            for k in 1..=ke.min(i) {
                log_dt[i * ke + k - 1] = ln(events[i].time_s - events[i - k].time_s);
            }
        }
        let mut log_dtau = vec![f64::NEG_INFINITY; n * kd];
        for j in 0..n {
            for k in 1..=kd.min(j) {
                log_dtau[j * kd + k - 1] = ln(dwells[j] - dwells[j - k]);
            }
        }
        Self {
            m,
            n,
            lo,
            hi,
            width: (hi - lo + 1) as usize,
            ke,
            kd,
            log_dt,
            log_dtau,
        }
    }

    /// State index of (i, j), when in the band.
    fn idx(&self, i: usize, j: usize) -> Option<usize> {
        let d = i as i64 - j as i64;
        (d >= self.lo && d <= self.hi && j < self.n && i < self.m)
            .then(|| i * self.width + (d - self.lo) as usize)
    }

    /// Dwells of event i inside the band.
    fn dwells_of(&self, i: usize) -> std::ops::Range<usize> {
        let a = (i as i64 - self.hi).max(0) as usize;
        let b = ((i as i64 - self.lo + 1).max(0) as usize).min(self.n);
        a..b.max(a)
    }
}

/// Costs of a matching problem at a given scale.
struct Costs<'a> {
    grid: &'a Grid,
    events: &'a [Event],
    expected: usize,
    p: &'a AlignParams,
    ln_scale: f64,
}

impl Costs<'_> {
    fn matched(&self, i: usize) -> f64 {
        let e = &self.events[i];
        let d = e.size.abs_diff(self.expected) as f64;
        (d * self.p.size_cost).min(0.5 * self.p.skip_event)
            + if e.irregular {
                0.5 * self.p.skip_event
            } else {
                0.0
            }
    }

    /// Transition (i − di, j − dj) → (i, j).
    fn step(&self, i: usize, j: usize, di: usize, dj: usize) -> f64 {
        let g = self.grid;
        let r = g.log_dt[i * g.ke + di - 1] - self.ln_scale - g.log_dtau[j * g.kd + dj - 1];
        let mut c = if r.is_nan() || r == f64::NEG_INFINITY {
            f64::INFINITY
        } else {
            (r / self.p.sigma).powi(2)
        };
        if r > 0.0 {
            c = c.min(self.p.pause_cost);
        }
        c + self.p.skip_event * (di - 1) as f64 + self.p.skip_dwell * (dj - 1) as f64
    }

    fn start(&self, i: usize, j: usize) -> f64 {
        self.p.skip_event * i as f64 + self.p.skip_dwell * j as f64
    }

    fn end(&self, i: usize, j: usize) -> f64 {
        let g = self.grid;
        self.p.skip_event * (g.m - 1 - i) as f64 + self.p.skip_dwell * (g.n - 1 - j) as f64
    }
}

/// Forward costs, predecessors (0: start) and backward costs.
struct Passes {
    forward: Vec<f64>,
    pred: Vec<(u8, u8)>,
    backward: Vec<f64>,
}

fn passes(c: &Costs<'_>) -> Passes {
    let g = c.grid;
    let size = g.m * g.width;
    let mut forward = vec![f64::INFINITY; size];
    let mut pred = vec![(0u8, 0u8); size];
    for i in 0..g.m {
        for j in g.dwells_of(i) {
            let Some(s) = g.idx(i, j) else { continue };
            let mut best = c.start(i, j);
            let mut from = (0u8, 0u8);
            for di in 1..=g.ke.min(i) {
                for dj in 1..=g.kd.min(j) {
                    let Some(p) = g.idx(i - di, j - dj) else {
                        continue;
                    };
                    let f = forward[p];
                    if f.is_finite() {
                        let v = f + c.step(i, j, di, dj);
                        if v < best {
                            best = v;
                            from = (di as u8, dj as u8);
                        }
                    }
                }
            }
            forward[s] = best + c.matched(i);
            pred[s] = from;
        }
    }
    let mut backward = vec![f64::INFINITY; size];
    for i in (0..g.m).rev() {
        for j in g.dwells_of(i) {
            let Some(s) = g.idx(i, j) else { continue };
            let mut best = c.end(i, j);
            for di in 1..=g.ke.min(g.m - 1 - i) {
                for dj in 1..=g.kd.min(g.n - 1 - j) {
                    let Some(q) = g.idx(i + di, j + dj) else {
                        continue;
                    };
                    let b = backward[q];
                    if b.is_finite() {
                        let v = c.step(i + di, j + dj, di, dj) + c.matched(i + di) + b;
                        if v < best {
                            best = v;
                        }
                    }
                }
            }
            backward[s] = best;
        }
    }
    Passes {
        forward,
        pred,
        backward,
    }
}

/// Align `events` (one camera) to the programmed dwell times `dwells` (s).
pub fn align(events: &[Event], dwells: &[f64], expected: usize, p: &AlignParams) -> Alignment {
    let (m, n) = (events.len(), dwells.len());
    if m == 0 || n == 0 {
        return Alignment {
            dwell_of: vec![None; m],
            ambiguous: Vec::new(),
            scale: 1.0,
            cost: p.skip_event * m as f64 + p.skip_dwell * n as f64,
        };
    }
    let grid = Grid::new(events, dwells, p);
    let gaps = |t: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = t.collect();
        median(
            v.windows(2)
                .map(|w| w[1] - w[0])
                .filter(|g| *g > 0.0)
                .collect(),
        )
    };
    let mut scale = match (
        gaps(&mut events.iter().map(|e| e.time_s)),
        gaps(&mut dwells.iter().copied()),
    ) {
        (Some(a), Some(b)) if b > 0.0 => a / b,
        _ => 1.0,
    };
    let mut result = None;
    for _ in 0..4 {
        let costs = Costs {
            grid: &grid,
            events,
            expected,
            p,
            ln_scale: scale.ln(),
        };
        let r = solve(&costs);
        let steps: Vec<f64> = (1..m)
            .filter_map(|i| {
                let (a, b) = (r.dwell_of[i - 1]?, r.dwell_of[i]?);
                (b == a + 1)
                    .then(|| (events[i].time_s - events[i - 1].time_s) / (dwells[b] - dwells[a]))
            })
            .collect();
        let refined = median(steps).filter(|s| *s > 0.0).unwrap_or(scale);
        let settled = (refined / scale).ln().abs() < 0.01;
        result = Some(Alignment { scale, ..r });
        if settled {
            break;
        }
        scale = refined;
    }
    result.unwrap_or(Alignment {
        dwell_of: vec![None; m],
        ambiguous: Vec::new(),
        scale,
        cost: f64::INFINITY,
    })
}

fn solve(c: &Costs<'_>) -> Alignment {
    let g = c.grid;
    let ps = passes(c);
    let empty = c.p.skip_event * g.m as f64 + c.p.skip_dwell * g.n as f64;
    let mut best = (empty, None);
    for i in 0..g.m {
        for j in g.dwells_of(i) {
            if let Some(s) = g.idx(i, j) {
                let v = ps.forward[s] + c.end(i, j);
                if v < best.0 {
                    best = (v, Some((i, j)));
                }
            }
        }
    }
    let mut dwell_of = vec![None; g.m];
    let mut at = best.1;
    while let Some((i, j)) = at {
        dwell_of[i] = Some(j);
        at = g.idx(i, j).and_then(|s| {
            let (di, dj) = ps.pred[s];
            (di > 0).then(|| (i - usize::from(di), j - usize::from(dj)))
        });
    }
    let opt = best.0;
    let mut ambiguous = Vec::new();
    for (i, chosen) in dwell_of.iter().enumerate() {
        let mut alt: Option<(f64, usize)> = None;
        for j in g.dwells_of(i) {
            if Some(j) == *chosen {
                continue;
            }
            if let Some(s) = g.idx(i, j) {
                let v = ps.forward[s] + ps.backward[s];
                if alt.is_none_or(|(a, _)| v < a) {
                    alt = Some((v, j));
                }
            }
        }
        if let Some((v, j)) = alt
            && v - opt < c.p.margin
        {
            ambiguous.push(Ambiguity {
                event: i,
                chosen: *chosen,
                alternative: Some(j),
                margin: v - opt,
            });
        }
    }
    // A stray that could take a matched event's dwell makes that event ambiguous too.
    let strays: Vec<Ambiguity> = ambiguous
        .iter()
        .filter(|a| a.chosen.is_none())
        .copied()
        .collect();
    for a in strays {
        if let Some(e) = dwell_of.iter().position(|d| *d == a.alternative)
            && !ambiguous.iter().any(|x| x.event == e)
        {
            ambiguous.push(Ambiguity {
                event: e,
                chosen: a.alternative,
                alternative: None,
                margin: a.margin,
            });
        }
    }
    ambiguous.sort_by_key(|a| a.event);
    Alignment {
        dwell_of,
        ambiguous,
        scale: 1.0,
        cost: opt,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Program: dwells every 1 s, a long reversal gap every 4 dwells.
    fn program(n: usize) -> Vec<f64> {
        let mut t = Vec::new();
        let mut time = 0.0;
        for j in 0..n {
            t.push(time);
            time += if j % 4 == 3 { 3.0 } else { 1.0 };
        }
        t
    }

    fn events(times: &[f64], size: usize) -> Vec<Event> {
        times
            .iter()
            .map(|&t| Event {
                time_s: t,
                size,
                irregular: false,
            })
            .collect()
    }

    #[test]
    fn slow_moves_and_a_clock_offset_align_one_to_one() {
        let d = program(20);
        let e = events(&d.iter().map(|t| 1234.5 + 1.15 * t).collect::<Vec<_>>(), 3);
        let a = align(&e, &d, 3, &AlignParams::default());
        assert_eq!(a.dwell_of, (0..20).map(Some).collect::<Vec<_>>());
        assert!(a.ambiguous.is_empty(), "{:?}", a.ambiguous);
        assert!((a.scale - 1.15).abs() < 1e-9);
    }

    #[test]
    fn a_stray_and_a_missing_dwell_are_found() {
        let d = program(20);
        let mut t: Vec<f64> = d.iter().map(|t| 1.15 * t).collect();
        t.remove(9); // dwell 9 missing
        t.insert(5, 0.5 * (t[4] + t[5])); // a stray between dwells 4 and 5
        let mut e = events(&t, 3);
        e[5].size = 1;
        let a = align(&e, &d, 3, &AlignParams::default());
        let mut want: Vec<Option<usize>> = (0..20).filter(|&j| j != 9).map(Some).collect();
        want.insert(5, None);
        assert_eq!(a.dwell_of, want);
        assert!(a.ambiguous.is_empty(), "{:?}", a.ambiguous);
    }

    #[test]
    fn a_pause_costs_no_misalignment() {
        let d = program(16);
        let t: Vec<f64> = d
            .iter()
            .enumerate()
            .map(|(j, t)| 1.1 * t + if j >= 7 { 40.0 } else { 0.0 })
            .collect();
        let a = align(&events(&t, 2), &d, 2, &AlignParams::default());
        assert_eq!(a.dwell_of, (0..16).map(Some).collect::<Vec<_>>());
    }

    #[test]
    fn a_regular_program_with_one_event_missing_at_an_end_is_ambiguous() {
        // Equal gaps everywhere: which end lost its event cannot be told.
        let d: Vec<f64> = (0..6).map(f64::from).collect();
        let t: Vec<f64> = (0..5).map(f64::from).collect();
        let a = align(&events(&t, 2), &d, 2, &AlignParams::default());
        assert!(!a.ambiguous.is_empty());
    }
}
