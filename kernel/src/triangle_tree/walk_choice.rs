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
//! guessed from the tree's size but timed: a kind's first three blocks
//! take its candidates in turn (the first again once the caches are warm,
//! so that the first block's cold misses do not count against it), the
//! cheaper per ray by the processor's time-stamp counter takes the blocks
//! after, and the other is tried again now and then so that a batch that
//! changes character is followed. Every walk gives each ray its single
//! ray's answer bit for bit, so the choice changes only the time.
//!
//! Where no counter is read (off x86-64, and under Miri and fuzzing, which
//! stay deterministic) the choice is fixed: a kind's first candidate,
//! packets for coherent blocks and single rays for scattered ones.

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

/// A kind's first three blocks try its candidates in this order.
const ROUND: [usize; 3] = [0, 1, 0];

/// The losing candidate is tried again after this many blocks of the
/// winner times its cost relative to the winner's: its tries then take
/// about 1/32 of the kind's time, however much slower it is.
const RETRY: u64 = 32;

/// At most this many blocks between tries of the loser (64k rays), so a
/// batch whose rays change character is followed within that.
const RETRY_MAX: u64 = 256;

/// One kind of block's candidate walks and what each cost per ray.
#[derive(Debug)]
pub(super) struct Trials {
    /// The candidates, first the one taken without a counter.
    pub(super) walks: [Walk; 2],
    /// How many of `walks` compete: 1 (no trials) or 2.
    count: usize,
    /// Counter ticks per ray of each candidate's last blocks (0: not yet
    /// timed).
    cost: [u64; 2],
    /// The kind's blocks timed so far, up to the end of [`ROUND`].
    pub(super) timed: usize,
    /// The candidate taken between tries.
    best: usize,
    /// Blocks the best took since the other was last tried.
    since: u64,
}

impl Trials {
    /// Trials between `walks`; `count` of them (1 or 2) compete.
    pub(super) const fn new(walks: [Walk; 2], count: usize) -> Trials {
        Trials {
            walks,
            count,
            cost: [0; 2],
            timed: 0,
            best: 0,
            since: 0,
        }
    }

    /// The candidate the next block takes (its index into the walks and
    /// the walk), and whether its time is wanted ([`Trials::record`]).
    pub(super) fn next(&mut self, trial: Trial, clock: bool) -> (usize, Walk, bool) {
        let i = match trial {
            _ if self.count < 2 => 0,
            Trial::First => 0,
            Trial::Second => 1,
            Trial::Timed if !clock => 0,
            Trial::Timed => match ROUND.get(self.timed) {
                Some(&i) => i,
                None if self.since >= self.retry_after() => !self.best & 1,
                None => self.best,
            },
        };
        let timed = trial == Trial::Timed && clock && self.count == 2;
        (i, self.walks[i & 1], timed)
    }

    /// Blocks of the best between tries of the other.
    fn retry_after(&self) -> u64 {
        let (b, o) = (self.cost[self.best & 1], self.cost[!self.best & 1]);
        (RETRY.saturating_mul(o) / b.max(1)).clamp(RETRY, RETRY_MAX)
    }

    /// What candidate `i` took for a block of `rays` rays: `ticks` of the
    /// counter.
    pub(super) fn record(&mut self, i: usize, ticks: u64, rays: usize) {
        let per_ray = ticks / (rays as u64).max(1);
        // Two candidates: `& 1` keeps every index in bounds (no panic path).
        let (i, best) = (i & 1, self.best & 1);
        if self.timed < ROUND.len() {
            // The first round: the new time replaces the old (the first
            // block's is cold), and the cheaper takes the blocks after.
            self.cost[i] = per_ray;
            self.timed += 1;
            self.best = usize::from(self.cost[1] < self.cost[0]);
        } else if i == best {
            // The best's blocks average, a quarter each: one slow block
            // (an interrupt) does not hand the batch to the other, a
            // lasting change brings the other's next try closer.
            self.cost[i] = (3 * self.cost[i] + per_ray) / 4;
            self.since += 1;
        } else {
            // A try of the other: it takes over if cheaper now.
            self.cost[i] = per_ray;
            self.since = 0;
            if per_ray < self.cost[best] {
                self.best = i;
            }
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

    /// Runs `N` blocks through `t`, candidate `i` costing `cost(block, i)`
    /// ticks a ray; returns the walks taken.
    fn run<const N: usize>(t: &mut Trials, cost: impl Fn(usize, usize) -> u64) -> [Walk; N] {
        core::array::from_fn(|b| {
            let (i, walk, timed) = t.next(Trial::Timed, true);
            assert!(timed);
            t.record(i, cost(b, i) * 256, 256);
            walk
        })
    }

    #[test]
    fn the_cheaper_walk_takes_the_blocks_and_the_other_is_retried() {
        for (cheap, want, other) in [(0, PACKETS, Walk::Single), (1, Walk::Single, PACKETS)] {
            let mut t = Trials::new([PACKETS, Walk::Single], 2);
            let walks: [Walk; 1000] = run(&mut t, |_, i| if i == cheap { 100 } else { 300 });
            assert_eq!(&walks[..3], &[PACKETS, Walk::Single, PACKETS]);
            let tries = walks[3..].iter().filter(|&&w| w == other).count();
            // Three times the cost: a try every 96 blocks.
            assert!((9..=11).contains(&tries), "{tries} tries of {other:?}");
            assert!(walks[3..99].iter().all(|&w| w == want));
        }
    }

    #[test]
    fn a_batch_that_changes_character_is_followed() {
        let mut t = Trials::new([Walk::Single, Walk::InTurns], 2);
        // Rays in turns cheaper for the first 300 blocks, then dearer.
        let walks: [Walk; 1000] = run(&mut t, |b, i| match (b < 300, i) {
            (true, 1) | (false, 0) => 100,
            _ => 150,
        });
        assert!(
            walks[3..300]
                .iter()
                .filter(|&&w| w == Walk::InTurns)
                .count()
                > 280
        );
        // Found within the longest gap between tries.
        let late = &walks[300 + RETRY_MAX as usize + 2..];
        assert!(late.iter().filter(|&&w| w == Walk::Single).count() > late.len() * 9 / 10);
    }

    #[test]
    fn without_a_counter_or_when_fixed_the_choice_is_the_fixed_one() {
        let mut t = Trials::new([PACKETS, Walk::Single], 2);
        for _ in 0..5 {
            assert_eq!(t.next(Trial::Timed, false), (0, PACKETS, false));
            assert_eq!(t.next(Trial::First, true), (0, PACKETS, false));
            assert_eq!(t.next(Trial::Second, true), (1, Walk::Single, false));
        }
        // One candidate: never timed.
        let mut one = Trials::new([Walk::Single, Walk::InTurns], 1);
        assert_eq!(one.next(Trial::Timed, true), (0, Walk::Single, false));
        assert_eq!(one.next(Trial::Second, true), (0, Walk::Single, false));
    }

    #[test]
    fn one_slow_block_does_not_hand_over_the_batch() {
        let mut t = Trials::new([Walk::Single, Walk::InTurns], 2);
        // Single rays 100 a ray, in turns 130, one interrupted block of 1000.
        let walks: [Walk; 40] = run(&mut t, |b, i| match (b, i) {
            (10, 0) => 1000,
            (_, 0) => 100,
            _ => 130,
        });
        assert!(walks[3..].iter().filter(|&&w| w == Walk::Single).count() >= 36);
    }

    #[test]
    fn the_counter_runs_where_there_is_one() {
        if let (Some(a), Some(b)) = (ticks(), ticks()) {
            assert!(b >= a);
        } else {
            assert!(cfg!(any(not(target_arch = "x86_64"), miri)));
        }
    }
}
