//! Which walk each block of a batch takes, timed on the batch itself.
//!
//! The batch calls (`batch.rs`) sort each block of rays into coherent
//! (origins close together: camera tiles, shadow rays in pixel or Morton
//! order) or scattered (random rays, bounces) and give each kind two
//! candidate walks: coherent blocks packets at the widest width one
//! register holds, or single rays; scattered blocks single rays, or rays
//! walked in turns (closest hit: through the treelets where the tree has
//! them) or in packets (any hit). Which is cheaper depends on the tree,
//! the rays and the machine (rays in turns ran 0.84x of single rays on
//! one machine's sponza random rays and 1.7x on another's), so it is not
//! guessed from the tree's size but timed, by the processor's time-stamp
//! counter, in trials: a trial block walks its first half with one
//! candidate and its second half with the other (neighbouring rays, so
//! alike: blocks of a camera image differ far more from one another, all
//! background or all mesh, than two candidates do on one block), the
//! order swapped from one trial to the next. A kind's first blocks are
//! trials (the first one only warms the caches), the cheaper per ray takes
//! the blocks after, and a trial now and then follows a batch that
//! changes character. Every walk gives each ray its single ray's answer
//! bit for bit, so the choice changes only the time.
//!
//! Where no counter is read (off x86-64, and under Miri and fuzzing, which
//! stay deterministic), and for a block of fewer than 32 rays (too few for
//! two halves of whole packets), the choice is fixed: a kind's first
//! candidate, packets for coherent blocks and single rays for scattered
//! ones.

use super::packet::PacketWidth;

/// A walk a block of rays can take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Walk {
    /// Each ray walked alone, one after the other.
    Single,
    /// Packets of consecutive rays.
    Packets(PacketWidth),
    /// Single rays walked in turns (`turns.rs`, `treelets/walk.rs`).
    InTurns,
}

/// How a batch's blocks choose among their candidate walks
/// ([`Batch::trial`](crate::Batch::trial)): timed, or fixed for tests,
/// fuzz targets and benchmarks that must reach a given walk. Any choice
/// gives each ray its single ray's answer.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Trial {
    /// Timed on the batch where a counter is read, else the first
    /// candidate.
    #[default]
    Timed,
    /// Every block its kind's first candidate: packets for coherent
    /// blocks, single rays for scattered ones.
    First,
    /// Every block its kind's second candidate: single rays for coherent
    /// blocks; for scattered ones rays in turns (closest hit) or packets
    /// (any hit).
    Second,
}

/// A kind's first blocks are trials (the first one's times not counted:
/// its misses are the caches' cold start, not the walks').
const ROUND: u32 = 4;

/// Candidate 1's cost relative to candidate 0's, in 1/256: equal.
const EVEN: u32 = 256;

/// The trials after the first come after this many blocks of the winner
/// times the loser's cost relative to the winner's: a trial's losing half
/// then takes about 1/128 of the kind's time, however much slower it is.
const RETRY: u64 = 64;

/// At most this many blocks between trials (128k rays), so a batch whose
/// rays change character is followed within two such gaps.
const RETRY_MAX: u64 = 512;

/// What a block does ([`Trials::next`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Step {
    /// The whole block takes this walk.
    Take(Walk),
    /// A trial: the block's first half takes candidate `order[0]`, its
    /// second half candidate `order[1]`, each timed
    /// ([`Trials::record`]).
    Trial {
        /// Indices into the candidates.
        order: [usize; 2],
    },
}

/// One kind of block's candidate walks and what each costs per ray.
#[derive(Debug)]
pub(super) struct Trials {
    /// The candidates, first the one taken without a counter.
    pub(super) walks: [Walk; 2],
    /// How many of `walks` compete: 1 (no trials) or 2.
    count: usize,
    /// The last three trials' cost of candidate 1 relative to candidate
    /// 0's per ray (1/256ths, [`EVEN`] where equal), within 4x either way:
    /// their median decides, so one trial the thread was switched out in
    /// (the counter runs on) cannot.
    ratios: [u32; 3],
    /// The trials so far.
    pub(super) trials: u32,
    /// The candidate taken between trials.
    best: usize,
    /// Blocks the best took since the last trial.
    since: u64,
}

impl Trials {
    /// Trials between `walks`; `count` of them (1 or 2) compete.
    pub(super) const fn new(walks: [Walk; 2], count: usize) -> Trials {
        Trials {
            walks,
            count,
            ratios: [EVEN; 3],
            trials: 0,
            best: 0,
            since: 0,
        }
    }

    /// Candidate `i`'s walk.
    pub(super) fn walk(&self, i: usize) -> Walk {
        // Two candidates: `& 1` keeps every index in bounds (no panic path).
        self.walks[i & 1]
    }

    /// What the next block does.
    pub(super) fn next(&mut self, trial: Trial, clock: bool) -> Step {
        let i = match trial {
            _ if self.count < 2 => 0,
            Trial::First => 0,
            Trial::Second => 1,
            Trial::Timed if !clock => 0,
            Trial::Timed => {
                if self.trials < ROUND || self.since >= self.retry_after() {
                    let first = (self.trials & 1) as usize;
                    return Step::Trial {
                        order: [first, 1 - first],
                    };
                }
                self.since += 1;
                self.best
            }
        };
        Step::Take(self.walk(i))
    }

    /// The median of the last three trials' ratios.
    fn ratio(&self) -> u32 {
        let [a, b, c] = self.ratios;
        a.max(b).min(a.min(b).max(c))
    }

    /// Blocks of the best between trials.
    fn retry_after(&self) -> u64 {
        let r = u64::from(self.ratio().max(1));
        let loser = if self.best == 1 {
            u64::from(EVEN * EVEN) / r
        } else {
            r
        };
        (RETRY * loser / u64::from(EVEN)).clamp(RETRY, RETRY_MAX)
    }

    /// A trial's times: `ticks[k]` for the `rays[k]` rays of its half `k`,
    /// walked by candidate `order[k]`.
    pub(super) fn record(&mut self, order: [usize; 2], ticks: [u64; 2], rays: [usize; 2]) {
        if self.trials > 0 {
            let mut per_ray = [0u64; 2];
            for k in 0..2 {
                per_ray[order[k] & 1] = ticks[k] / (rays[k] as u64).max(1);
            }
            let r = per_ray[1].saturating_mul(u64::from(EVEN)) / per_ray[0].max(1);
            let at = self.trials as usize % 3;
            if let Some(slot) = self.ratios.get_mut(at) {
                *slot = r.clamp(u64::from(EVEN / 4), u64::from(EVEN * 4)) as u32;
            }
        }
        self.trials = self.trials.saturating_add(1);
        self.since = 0;
        if self.trials >= ROUND {
            self.best = usize::from(self.ratio() < EVEN);
        }
    }
}

/// Whether [`ticks`] reads a counter.
pub(super) const CLOCK: bool = cfg!(all(target_arch = "x86_64", not(miri), not(fuzzing)));

/// The counter the trials read: the time-stamp counter on x86-64 (not
/// under Miri, which does not model it, nor under fuzzing, which wants
/// the same walks for the same input); `None` elsewhere.
#[inline]
pub(super) fn ticks() -> Option<u64> {
    #[cfg(all(target_arch = "x86_64", not(miri), not(fuzzing)))]
    {
        // SAFETY: `rdtsc` reads the time-stamp counter into registers: no
        // memory, no precondition, on every x86-64 processor.
        Some(unsafe { core::arch::x86_64::_rdtsc() })
    }
    #[cfg(not(all(target_arch = "x86_64", not(miri), not(fuzzing))))]
    {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PACKETS: Walk = Walk::Packets(PacketWidth::Sixteen);

    /// Runs `N` blocks of 256 rays through `t`, candidate `i` costing
    /// `cost(block, i)` ticks a ray; returns for each block the share of
    /// its rays candidate 1 walked, in quarters (0, 2: a trial, or 4).
    fn run<const N: usize>(t: &mut Trials, cost: impl Fn(usize, usize) -> u64) -> [u8; N] {
        core::array::from_fn(|b| match t.next(Trial::Timed, true) {
            Step::Take(w) => 4 * u8::from(w == t.walks[1]),
            Step::Trial { order } => {
                t.record(order, order.map(|i| cost(b, i) * 128), [128; 2]);
                2
            }
        })
    }

    #[test]
    fn the_cheaper_walk_takes_the_blocks_and_trials_recur() {
        for (cheap, want) in [(0, 0), (1, 4)] {
            let mut t = Trials::new([PACKETS, Walk::Single], 2);
            let blocks: [u8; 1000] = run(&mut t, |_, i| if i == cheap { 100 } else { 300 });
            assert_eq!(&blocks[..4], &[2, 2, 2, 2]);
            let trials = blocks[4..].iter().filter(|&&b| b == 2).count();
            // Three times the cost: a trial every 192 blocks.
            assert!((4..=6).contains(&trials), "{trials} trials");
            assert!(blocks[4..190].iter().all(|&b| b == want));
        }
    }

    #[test]
    fn blocks_that_differ_from_one_another_do_not_mislead() {
        // Every other block ten times dearer (background and mesh in a
        // camera image), whichever walks it: packets still win.
        let mut t = Trials::new([PACKETS, Walk::Single], 2);
        let blocks: [u8; 300] = run(&mut t, |b, i| {
            let per = if i == 0 { 100 } else { 150 };
            if b % 2 == 1 {
                per * 10
            } else {
                per
            }
        });
        assert!(blocks[4..].iter().filter(|&&b| b == 0).count() >= 280);
    }

    #[test]
    fn a_trial_interrupted_does_not_decide_alone() {
        let mut t = Trials::new([Walk::Single, Walk::InTurns], 2);
        // In turns 1.2x single rays; one trial's single-ray half switched out.
        let blocks: [u8; 40] = run(&mut t, |b, i| match (b, i) {
            (1, 0) => 100_000,
            (_, 0) => 100,
            _ => 120,
        });
        assert!(blocks[4..].iter().all(|&b| b == 0), "{blocks:?}");
    }

    #[test]
    fn a_batch_that_changes_character_is_followed() {
        let mut t = Trials::new([Walk::Single, Walk::InTurns], 2);
        // Rays in turns cheaper for the first 300 blocks, then dearer.
        let blocks: [u8; 2000] = run(&mut t, |b, i| match (b < 300, i) {
            (true, 1) | (false, 0) => 100,
            _ => 150,
        });
        assert!(blocks[4..300].iter().filter(|&&b| b == 4).count() > 280);
        // Found within two of the longest gaps between trials.
        let late = &blocks[300 + 2 * RETRY_MAX as usize..];
        assert!(late.iter().filter(|&&b| b == 0).count() > late.len() * 9 / 10);
    }

    #[test]
    fn without_a_counter_or_when_fixed_the_choice_is_the_fixed_one() {
        let mut t = Trials::new([PACKETS, Walk::Single], 2);
        for _ in 0..5 {
            assert_eq!(t.next(Trial::Timed, false), Step::Take(PACKETS));
            assert_eq!(t.next(Trial::First, true), Step::Take(PACKETS));
            assert_eq!(t.next(Trial::Second, true), Step::Take(Walk::Single));
        }
        // One candidate: never a trial.
        let mut one = Trials::new([Walk::Single, Walk::InTurns], 1);
        assert_eq!(one.next(Trial::Timed, true), Step::Take(Walk::Single));
        assert_eq!(one.next(Trial::Second, true), Step::Take(Walk::Single));
    }

    #[test]
    fn the_counter_runs_where_there_is_one() {
        match (ticks(), ticks()) {
            (Some(a), Some(b)) => assert!(CLOCK && b >= a),
            (a, b) => assert_eq!((a, b, CLOCK), (None, None, false)),
        }
    }
}
