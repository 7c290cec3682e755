//! CRC-32C (Castagnoli), the blob checksum.
//!
//! Its polynomial (0x1EDC6F41, reflected 0x82F63B78) has Hamming distance
//! 4 for messages up to 5,243 bytes and 3 beyond (up to 2^31 bits): every
//! error of up to 3 flipped bits anywhere in a blob changes the checksum,
//! where a word-wise multiplicative hash lets two flipped sign bits cancel.
//! Any burst of up to 32 bits is caught too.
//!
//! Three ways to compute it, all giving the same value:
//! - 64-bit targets: slicing-by-8 (eight 256-entry tables, 8 KiB; 8 bytes
//!   per step);
//! - 32-bit targets (the Cortex-M image, wasm32): one 256-entry table
//!   (1 KiB), a byte per step;
//! - x86-64 processors at [`Isa::Avx2`](crate::cpu::Isa::Avx2) or above (x86-64-v3, which
//!   includes SSE4.2): the `crc32` instruction, 8 bytes per instruction,
//!   chosen at run time by [`crate::cpu::isa`].

#[cfg(target_arch = "x86_64")]
use crate::cpu::{isa, Isa};

/// The reflected Castagnoli polynomial.
const POLY: u32 = 0x82F6_3B78;

/// How many slicing tables the software path uses: 8 on 64-bit targets,
/// 1 (the plain byte table) elsewhere, where memory is scarce.
#[cfg(target_pointer_width = "64")]
const SLICES: usize = 8;
#[cfg(not(target_pointer_width = "64"))]
const SLICES: usize = 1;

/// `TABLES[0][b]` is the CRC of byte `b`; `TABLES[s][b]` that of `b`
/// followed by `s` zero bytes (slicing-by-N).
static TABLES: [[u32; 256]; SLICES] = tables();

const fn tables() -> [[u32; 256]; SLICES] {
    let mut t = [[0u32; 256]; SLICES];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 == 1 { (c >> 1) ^ POLY } else { c >> 1 };
            k += 1;
        }
        t[0][i] = c;
        i += 1;
    }
    let mut s = 1;
    while s < SLICES {
        let mut i = 0;
        while i < 256 {
            let prev = t[s - 1][i];
            t[s][i] = (prev >> 8) ^ t[0][(prev & 0xFF) as usize];
            i += 1;
        }
        s += 1;
    }
    t
}

/// A CRC-32C in progress: start with [`Crc32c::new`], feed bytes with
/// [`Crc32c::update`], read the value with [`Crc32c::finish`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Crc32c(u32);

impl Crc32c {
    /// The empty message's state.
    pub(crate) const fn new() -> Self {
        Crc32c(!0)
    }

    /// Feeds `bytes`, by the fastest path this processor runs.
    pub(crate) fn update(self, bytes: &[u8]) -> Self {
        #[cfg(target_arch = "x86_64")]
        if isa() >= Isa::Avx2 {
            // SAFETY: `isa()` returns `Avx2` or above only when the
            // processor reports x86-64-v3 (`cpu::detect`), which includes
            // SSE4.2 (its bit is checked there), or when `set_isa` chose a
            // level not above the detected one.
            return Crc32c(unsafe { update_sse42(self.0, bytes) });
        }
        Crc32c(update_table(self.0, bytes))
    }

    /// The checksum of everything fed.
    pub(crate) const fn finish(self) -> u32 {
        !self.0
    }
}

/// One byte through the byte table.
#[inline]
fn byte_step(crc: u32, b: u8) -> u32 {
    TABLES[0][usize::from(crc as u8 ^ b)] ^ (crc >> 8)
}

/// The software path: slicing-by-8 on 64-bit targets, a byte at a time
/// elsewhere.
fn update_table(mut crc: u32, bytes: &[u8]) -> u32 {
    #[cfg(target_pointer_width = "64")]
    let bytes = {
        let t = &TABLES;
        let mut chunks = bytes.chunks_exact(8);
        for w in &mut chunks {
            let lo = crc ^ u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
            let hi = u32::from_le_bytes([w[4], w[5], w[6], w[7]]);
            let [l0, l1, l2, l3] = lo.to_le_bytes();
            let [h0, h1, h2, h3] = hi.to_le_bytes();
            crc = t[7][usize::from(l0)]
                ^ t[6][usize::from(l1)]
                ^ t[5][usize::from(l2)]
                ^ t[4][usize::from(l3)]
                ^ t[3][usize::from(h0)]
                ^ t[2][usize::from(h1)]
                ^ t[1][usize::from(h2)]
                ^ t[0][usize::from(h3)];
        }
        chunks.remainder()
    };
    for &b in bytes {
        crc = byte_step(crc, b);
    }
    crc
}

/// The hardware path: the SSE4.2 `crc32` instruction, 8 bytes at a time.
/// (One dependent chain: at 3 cycles a step it already runs several times
/// faster than the table, so the three-chain interleave is not worth its
/// combining code.)
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse4.2")]
fn update_sse42(crc: u32, bytes: &[u8]) -> u32 {
    use core::arch::x86_64::{_mm_crc32_u64, _mm_crc32_u8};
    let mut chunks = bytes.chunks_exact(8);
    let mut c = u64::from(crc);
    for w in &mut chunks {
        c = _mm_crc32_u64(
            c,
            u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]),
        );
    }
    // The instruction leaves the CRC in the low 32 bits.
    let mut crc = c as u32;
    for &b in chunks.remainder() {
        crc = _mm_crc32_u8(crc, b);
    }
    crc
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    fn crc(bytes: &[u8]) -> u32 {
        Crc32c::new().update(bytes).finish()
    }

    /// Bit by bit from the polynomial: the definition the tables unroll.
    fn crc_bitwise(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 == 1 { (c >> 1) ^ POLY } else { c >> 1 };
            }
        }
        !c
    }

    fn sample(len: usize) -> Vec<u8> {
        let mut rng = crate::test_rng::Rng(len as u64 + 1);
        (0..len).map(|_| (rng.f() * 256.0) as u8).collect()
    }

    #[test]
    fn check_values_match_the_standard() {
        // The catalogue's check value for CRC-32C, and RFC 3720's vectors.
        assert_eq!(crc(b"123456789"), 0xE306_9283);
        assert_eq!(crc(&[0u8; 32]), 0x8A91_36AA);
        assert_eq!(crc(&[0xFFu8; 32]), 0x62A8_AB43);
        assert_eq!(crc(b""), 0);
    }

    #[test]
    fn every_path_and_split_equals_the_bitwise_definition() {
        for len in [0, 1, 7, 8, 9, 63, 64, 65, 300] {
            let b = sample(len);
            let want = crc_bitwise(&b);
            assert_eq!(crc(&b), want, "len {len}");
            assert_eq!(!update_table(!0, &b), want, "table, len {len}");
            for cut in [0, 1, len / 2, len] {
                let (x, y) = b.split_at(cut.min(len));
                assert_eq!(Crc32c::new().update(x).update(y).finish(), want);
            }
        }
    }

    /// Runs the `crc32` instruction path where the processor has it (under
    /// Miri: when SSE4.2 is enabled at compile time,
    /// `-C target-feature=+sse4.2`).
    #[test]
    #[cfg(target_arch = "x86_64")]
    fn the_sse42_path_equals_the_table() {
        let _level = crate::cpu::tests::LEVEL.lock();
        if !(cfg!(target_feature = "sse4.2") || crate::cpu::detected_isa() >= Isa::Avx2) {
            return;
        }
        for len in [0, 1, 7, 8, 9, 65, 200] {
            let b = sample(len);
            // SAFETY: SSE4.2 is enabled at compile time or the processor
            // reports x86-64-v3, which includes it (checked above).
            let hw = unsafe { update_sse42(!0, &b) };
            assert_eq!(!hw, crc_bitwise(&b), "len {len}");
        }
    }

    /// Every 1-, 2- and 3-bit error in a 96-byte message changes the CRC
    /// (exhaustive over 2 bits, sampled over 3).
    #[test]
    fn up_to_three_flipped_bits_always_change_it() {
        let b = sample(96);
        let base = crc(&b);
        let bits = b.len() * 8;
        let flip = |m: &mut [u8], i: usize| m[i / 8] ^= 1 << (i % 8);
        // Under Miri the pairs start in the first 4 bits only.
        let firsts = if cfg!(miri) { 4 } else { bits };
        let mut m = b.clone();
        for i in 0..firsts {
            flip(&mut m, i);
            assert_ne!(crc(&m), base, "bit {i}");
            for j in i + 1..bits {
                flip(&mut m, j);
                assert_ne!(crc(&m), base, "bits {i} {j}");
                flip(&mut m, j);
            }
            flip(&mut m, i);
        }
        let mut rng = crate::test_rng::Rng(5);
        for _ in 0..if cfg!(miri) { 50 } else { 20_000 } {
            let mut m = b.clone();
            let mut picked = [0usize; 3];
            let mut n = 0;
            while n < 3 {
                let i = (rng.f() * bits as f32) as usize % bits;
                if !picked[..n].contains(&i) {
                    picked[n] = i;
                    n += 1;
                }
            }
            for i in picked {
                flip(&mut m, i);
            }
            assert_ne!(crc(&m), base, "bits {picked:?}");
        }
    }
}
