//! The instruction set the lane code runs with, chosen at run time.
//!
//! A plain `cargo build --release` targets the baseline of its
//! architecture (SSE2 on x86-64), where an 8-lane vector is two 4-lane
//! registers and a 16-lane one four. The packet walks and the leaf lane
//! tests are therefore compiled a second and third time, inside
//! `#[target_feature]` functions for x86-64-v3 (AVX2, FMA, BMI; SSE4.2,
//! whose `crc32` computes the blob checksum) and
//! x86-64-v4 (AVX-512 F/BW/DQ/VL), and the entry points pick one by the
//! processor they run on, as Embree does. The processor is asked once
//! (`cpuid`, and `xgetbv` for whether the operating system saves the
//! AVX and AVX-512 registers); the answer is kept in an atomic.
//!
//! Every level performs the same IEEE operations in the same order: no
//! fused multiply-add (Rust never contracts `a * b + c`, whatever the
//! target features), true division, the same `min`/`max` selects. The
//! answers are bit for bit the same at every level (tests force each one,
//! [`set_isa`]).
//!
//! Off x86-64 (and under Miri, which does not model `cpuid`) the only
//! level is [`Isa::Baseline`].

use core::sync::atomic::{AtomicU8, Ordering};

/// An instruction set level the lane code can run with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Isa {
    /// The target features the crate was compiled with (SSE2 for a plain
    /// x86-64 build; whatever `-C target-cpu` or `-C target-feature` gave).
    Baseline,
    /// x86-64-v3: AVX2, FMA (never contracted: the answers stay the
    /// baseline's), BMI1/2, LZCNT. 8-lane vectors are one register.
    Avx2,
    /// x86-64-v4: x86-64-v3 and AVX-512 F, BW, DQ and VL. 16-lane vectors
    /// are one register.
    Avx512,
}

impl Isa {
    /// The level's name as [`Isa::from_name`] reads it: `baseline`,
    /// `avx2` or `avx512`.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// The level named `name` (`baseline` or its alias `sse2`, `avx2`,
    /// `avx512`), case-sensitive; `None` for any other name.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Isa> {
        match name {
            "baseline" | "sse2" => Some(Isa::Baseline),
            "avx2" => Some(Isa::Avx2),
            "avx512" => Some(Isa::Avx512),
            _ => None,
        }
    }

    /// All levels, lowest first.
    pub const ALL: [Isa; 3] = [Isa::Baseline, Isa::Avx2, Isa::Avx512];

    const fn code(self) -> u8 {
        match self {
            Isa::Baseline => 1,
            Isa::Avx2 => 2,
            Isa::Avx512 => 3,
        }
    }
}

/// [`set_isa`] asked for a level this processor (or build) cannot run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IsaUnsupported {
    /// The level asked for.
    pub wanted: Isa,
    /// The highest level this processor runs ([`detected_isa`]).
    pub detected: Isa,
}

impl core::fmt::Display for IsaUnsupported {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "instruction set {} is not supported here (the processor runs up to {})",
            self.wanted.name(),
            self.detected.name()
        )
    }
}

/// The level in use: 0 until first asked, else [`Isa::code`].
static CURRENT: AtomicU8 = AtomicU8::new(0);

/// The highest level this processor and operating system run (asked of
/// the processor on every call; [`isa`] caches it).
#[must_use]
pub fn detected_isa() -> Isa {
    detect()
}

/// The level the lane code runs with: [`detected_isa`] unless
/// [`set_isa`] chose another. One relaxed atomic load after the first call.
#[inline]
#[must_use]
pub fn isa() -> Isa {
    match CURRENT.load(Ordering::Relaxed) {
        1 => Isa::Baseline,
        2 => Isa::Avx2,
        3 => Isa::Avx512,
        _ => {
            let isa = detect();
            CURRENT.store(isa.code(), Ordering::Relaxed);
            isa
        }
    }
}

/// Makes every later query run with `level` (process-wide), for
/// comparing levels or pinning one; the answers are the same at every
/// level. A level above [`detected_isa`] is refused: its instructions
/// would fault.
///
/// # Errors
/// [`IsaUnsupported`] when `level` is above [`detected_isa`].
pub fn set_isa(level: Isa) -> Result<(), IsaUnsupported> {
    let detected = detect();
    if level > detected {
        return Err(IsaUnsupported {
            wanted: level,
            detected,
        });
    }
    CURRENT.store(level.code(), Ordering::Relaxed);
    Ok(())
}

#[cfg(all(target_arch = "x86_64", not(miri)))]
fn detect() -> Isa {
    use core::arch::x86_64::{__cpuid, __cpuid_count, _xgetbv};
    let bit = |reg: u32, b: u32| reg >> b & 1 == 1;
    // Leaf 0's eax is the highest standard leaf.
    let max_leaf = __cpuid(0).eax;
    if max_leaf < 7 {
        return Isa::Baseline;
    }
    let l1 = __cpuid(1);
    let l7 = __cpuid_count(7, 0);
    let l81 = __cpuid(0x8000_0001);
    // OSXSAVE: xgetbv is available and tells which register states the
    // operating system saves on a context switch.
    if !bit(l1.ecx, 27) {
        return Isa::Baseline;
    }
    // SAFETY: `xgetbv` exists when cpuid reports OSXSAVE (checked above);
    // register 0 (XCR0) is always readable.
    let xcr0 = unsafe { _xgetbv(0) };
    let ymm_saved = xcr0 & 0b110 == 0b110; // SSE and AVX state
    let zmm_saved = xcr0 & 0b1110_0110 == 0b1110_0110; // and opmask, ZMM
    let v3 = ymm_saved
        && bit(l1.ecx, 12) // FMA
        && bit(l1.ecx, 20) // SSE4.2 (x86-64-v2; the blob checksum's crc32)
        && bit(l1.ecx, 23) // POPCNT
        && bit(l1.ecx, 28) // AVX
        && bit(l1.ecx, 29) // F16C
        && bit(l1.ecx, 22) // MOVBE
        && bit(l7.ebx, 3) // BMI1
        && bit(l7.ebx, 5) // AVX2
        && bit(l7.ebx, 8) // BMI2
        && bit(l81.ecx, 5); // LZCNT
    let v4 = v3
        && zmm_saved
        && bit(l7.ebx, 16) // AVX512F
        && bit(l7.ebx, 17) // AVX512DQ
        && bit(l7.ebx, 30) // AVX512BW
        && bit(l7.ebx, 31); // AVX512VL
    if v4 {
        Isa::Avx512
    } else if v3 {
        Isa::Avx2
    } else {
        Isa::Baseline
    }
}

#[cfg(not(all(target_arch = "x86_64", not(miri))))]
fn detect() -> Isa {
    Isa::Baseline
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    extern crate std;

    /// Held by tests that set the level, so that each sees its own.
    pub(crate) static LEVEL: std::sync::Mutex<()> = std::sync::Mutex::new(());

    #[test]
    fn names_round_trip_and_levels_above_the_processor_are_refused() {
        let _level = LEVEL.lock();
        for level in Isa::ALL {
            assert_eq!(Isa::from_name(level.name()), Some(level));
        }
        assert_eq!(Isa::from_name("sse2"), Some(Isa::Baseline));
        assert_eq!(Isa::from_name("AVX2"), None);
        let detected = detected_isa();
        for level in Isa::ALL {
            let r = set_isa(level);
            assert_eq!(r.is_ok(), level <= detected, "{level:?} on {detected:?}");
        }
        set_isa(detected).unwrap();
        assert_eq!(isa(), detected);
        if cfg!(miri) || !cfg!(target_arch = "x86_64") {
            assert_eq!(detected, Isa::Baseline);
        }
    }
}
