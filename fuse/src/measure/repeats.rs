//! The sensor's gain K from the campaign's own repeated captures, before
//! the instants are measured (`crate::noise`): the pairs read, their frames
//! observed as they are read, their photon transfers summed.

use super::*;

impl Context<'_> {
    /// Each camera's noise model (`crate::noise`): K from the rig's stacks,
    /// else from the campaign's first pairs of repeated captures. Those
    /// frames are observed as they are read for K — their covariances as
    /// forms, given K once it is known — and kept for their instants
    /// (`done` ones aside), so that no frame is decoded twice. The pairs of
    /// every camera are read in parallel, one job a pair (two frames in
    /// memory each); a pair that cannot be used is passed over for the
    /// camera's next one, in a round of its own.
    pub(super) fn noise_models(
        &mut self,
        rig: &formats::Rig,
        plans: &[InstantPlan],
        done: &std::collections::HashSet<InstantKey>,
    ) {
        struct FromRepeats<'p> {
            camera: u8,
            pairs: Vec<noise_model::RepeatPair<'p>>,
            read: noise_model::RepeatsRead,
            next: usize,
            observed: Vec<(InstantKey, Observation)>,
        }
        let mut models = BTreeMap::new();
        let mut repeats = Vec::new();
        for (camera, stacks) in noise_model::from_stacks(rig) {
            let pairs = noise_model::repeat_pairs(plans, camera);
            match stacks {
                Some(noise) => {
                    models.insert(camera, noise);
                }
                None if pairs.is_empty() => {
                    models.insert(camera, noise_model::without_repeats());
                }
                None => repeats.push(FromRepeats {
                    camera,
                    pairs,
                    read: noise_model::RepeatsRead::default(),
                    next: 0,
                    observed: Vec::new(),
                }),
            }
        }
        loop {
            let jobs: Vec<(usize, usize)> = repeats
                .iter()
                .enumerate()
                .flat_map(|(r, c)| {
                    let n = c.read.still_needed().min(c.pairs.len() - c.next);
                    (c.next..c.next + n).map(move |p| (r, p))
                })
                .collect();
            if jobs.is_empty() {
                break;
            }
            let this = &*self;
            let outcomes: Vec<_> = jobs
                .par_iter()
                .map(|&(r, p)| {
                    let c = &repeats[r];
                    this.read_repeat_pair(c.camera, p, &c.pairs[p], done)
                })
                .collect();
            for (&(r, _), (outcome, observed)) in jobs.iter().zip(outcomes) {
                let c = &mut repeats[r];
                c.read.take(outcome);
                c.observed.extend(observed);
                c.next += 1;
            }
        }
        for c in repeats {
            let noise = c.read.finish(c.pairs[0][0].1);
            if let Ok(mut kept) = self.observed.lock() {
                for (key, mut observation) in c.observed {
                    for o in observation.iter_mut().flatten().flatten() {
                        o.covariance = noise
                            .gain_dn_per_e
                            .zip(o.covariance_form)
                            .map(|(k, form)| covariance_matrix(&form.at(k)));
                    }
                    kept.insert((key, c.camera), observation);
                }
            }
            models.insert(c.camera, noise);
        }
        self.noise = models;
    }

    /// Pair `index` of `camera`'s repeated captures: its photon transfer
    /// (or why it gives none), and its instants' observations (covariances
    /// as forms), `done` instants and those the camera does not serve left
    /// out. Each frame is read by a reader of the pool: two frames in
    /// memory, no copy.
    fn read_repeat_pair(
        &self,
        camera: u8,
        index: usize,
        pair: &noise_model::RepeatPair<'_>,
        done: &std::collections::HashSet<InstantKey>,
    ) -> (
        std::result::Result<sensor::PairTransfer, String>,
        Vec<(InstantKey, Observation)>,
    ) {
        let observe = |ip: &InstantPlan, path: &Path, raw: FrameView<'_>| {
            let wanted = !done.contains(&ip.key)
                && self
                    .rig
                    .cameras_for(ip.key.axis, self.options.all_cameras)
                    .contains(&camera);
            wanted.then(|| {
                (
                    ip.key,
                    self.observe_frame(ip, camera, path, raw, Covariance::Form),
                )
            })
        };
        let [(ip_a, _), (ip_b, _)] = pair;
        let mut observed = Vec::new();
        let read = self.with_frame(ip_a, camera, |path_a, a, metadata_a| {
            observed.extend(observe(ip_a, path_a, a));
            self.with_frame(ip_b, camera, |path_b, b, metadata_b| {
                let transfer = noise_model::pair_transfer(
                    index,
                    &a,
                    metadata_a.exposure_s,
                    &b,
                    metadata_b.exposure_s,
                );
                observed.extend(observe(ip_b, path_b, b));
                Ok(transfer)
            })
        });
        let outcome = read.unwrap_or_else(|f| Err(format!("cannot be read: {}", f.reason)));
        (outcome, observed)
    }
}
