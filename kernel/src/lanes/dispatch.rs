//! Runs a lane job at the instruction set level [`crate::cpu::isa`]
//! chose: the job's generic body is compiled once per level, inside a
//! `#[target_feature]` function of that level, with that level's lane
//! types ([`Level`]).
//!
//! Everything the job's `run` inlines is compiled with the level's
//! features, so the jobs' bodies (the packet walks, the leaf lane tests)
//! are `#[inline(always)]` down to their hot loops; each wrapper below is
//! one out-of-line function per job and level, with its own registers.

use super::Lanes;

/// The lane types of one instruction set level.
pub(crate) trait Level {
    /// 4 lanes.
    type X4: Lanes<4>;
    /// 8 lanes.
    type X8: Lanes<8>;
    /// 16 lanes.
    type X16: Lanes<16>;
    /// Whether the level has x86-64-v3 (AVX2): jobs with intrinsics of
    /// their own run them only then.
    #[cfg(target_arch = "x86_64")]
    const X86_V3: bool = false;
}

/// The build's own target features: `wide`'s vectors as it compiled them.
pub(crate) struct Baseline;

impl Level for Baseline {
    type X4 = wide::f32x4;
    type X8 = wide::f32x8;
    type X16 = wide::f32x16;
}

/// x86-64-v3: 8 lanes in one AVX register. (16 lanes stay `wide`'s, as
/// compiled: a batch traces those 8 at a time here.)
#[cfg(target_arch = "x86_64")]
pub(crate) struct Avx2;

#[cfg(target_arch = "x86_64")]
impl Level for Avx2 {
    type X4 = wide::f32x4;
    type X8 = super::x86::Avx8;
    type X16 = wide::f32x16;
    const X86_V3: bool = true;
}

/// x86-64-v4: 16 lanes in one AVX-512 register.
#[cfg(target_arch = "x86_64")]
pub(crate) struct Avx512;

#[cfg(target_arch = "x86_64")]
impl Level for Avx512 {
    type X4 = wide::f32x4;
    type X8 = super::x86::Avx8;
    type X16 = super::x86::Avx16;
    const X86_V3: bool = true;
}

/// Work generic over the level's lane types.
pub(crate) trait Job {
    /// What the job returns.
    type Out;
    /// The job with `L`'s lane types; `#[inline(always)]` in every impl,
    /// so that it is compiled inside the level's wrapper.
    fn run<L: Level>(self) -> Self::Out;
}

/// Runs `job` at the current level ([`crate::cpu::isa`]).
#[inline(always)]
pub(crate) fn dispatch<J: Job>(job: J) -> J::Out {
    #[cfg(target_arch = "x86_64")]
    match crate::cpu::isa() {
        // SAFETY: `isa()` is `Avx512` only when `cpu` detected every
        // feature of `run_avx512` (cpuid) and the OS saving the ZMM and
        // mask registers (xgetbv); `set_isa` refuses levels above that.
        crate::cpu::Isa::Avx512 => return unsafe { run_avx512(job) },
        // SAFETY: as above, for x86-64-v3's features and YMM registers.
        crate::cpu::Isa::Avx2 => return unsafe { run_avx2(job) },
        crate::cpu::Isa::Baseline => {}
    }
    run_baseline(job)
}

/// `job` compiled for the build's own target features.
#[inline(never)]
fn run_baseline<J: Job>(job: J) -> J::Out {
    job.run::<Baseline>()
}

/// `job` compiled for x86-64-v3.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
#[target_feature(enable = "avx,avx2,fma,bmi1,bmi2,lzcnt,popcnt,f16c,movbe")]
fn run_avx2<J: Job>(job: J) -> J::Out {
    job.run::<Avx2>()
}

/// `job` compiled for x86-64-v4.
#[cfg(target_arch = "x86_64")]
#[inline(never)]
#[target_feature(
    enable = "avx,avx2,fma,bmi1,bmi2,lzcnt,popcnt,f16c,movbe,avx512f,avx512bw,avx512dq,avx512vl"
)]
fn run_avx512<J: Job>(job: J) -> J::Out {
    job.run::<Avx512>()
}
