//! The hash functions of the grid, bit-identical twins of `hash.wgsl` (Jarzynski & Olano 2020,
//! "Hash Functions for GPU Rendering"): `pcg` is h1 (bucket), `xxhash32` is h2 (checksum), as
//! Boissé 2021 recommends.
//!
//! This crate keeps its own copy of `pcg`: hashing keys is its own concern and it must not
//! depend on the renderer's random-number generator.

const PRIME32_2: u32 = 2_246_822_519;
const PRIME32_3: u32 = 3_266_489_917;
const PRIME32_4: u32 = 668_265_263;
const PRIME32_5: u32 = 374_761_393;

/// `pcg_hash`: one LCG step of PCG followed by the RXS-M-XS output permutation.
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// `xxhash32` of one word as published by Jarzynski & Olano: the XXH32 tail round and avalanche
/// applied to `p` directly. It equals the standard XXH32 (seed 0) of the 4 little-endian bytes
/// of `(p - 4) * PRIME32_3^-1`; see [`xxh32_word`] and [`xxhash32_as_standard_input`].
pub fn xxhash32(p: u32) -> u32 {
    let mut h = p.wrapping_add(PRIME32_5);
    h = PRIME32_4.wrapping_mul(h.rotate_left(17));
    h = PRIME32_2.wrapping_mul(h ^ (h >> 15));
    h = PRIME32_3.wrapping_mul(h ^ (h >> 13));
    h ^ (h >> 16)
}

/// The standard XXH32 (Collet) of the 4 little-endian bytes of `word` with `seed`.
pub fn xxh32_word(word: u32, seed: u32) -> u32 {
    let mut h = seed.wrapping_add(PRIME32_5).wrapping_add(4);
    h = h.wrapping_add(word.wrapping_mul(PRIME32_3));
    h = PRIME32_4.wrapping_mul(h.rotate_left(17));
    h = PRIME32_2.wrapping_mul(h ^ (h >> 15));
    h = PRIME32_3.wrapping_mul(h ^ (h >> 13));
    h ^ (h >> 16)
}

/// Multiplicative inverse of an odd `a` modulo 2^32 (Newton iteration).
const fn inverse_mod_2_32(a: u32) -> u32 {
    let mut x = a; // correct to 3 bits for odd a
    let mut i = 0;
    while i < 5 {
        x = x.wrapping_mul(2u32.wrapping_sub(a.wrapping_mul(x)));
        i += 1;
    }
    x
}

const PRIME32_3_INV: u32 = inverse_mod_2_32(PRIME32_3);

/// The word whose standard XXH32 (seed 0) equals `xxhash32(p)`:
/// `xxh32_word(xxhash32_as_standard_input(p), 0) == xxhash32(p)` for every `p`.
pub fn xxhash32_as_standard_input(p: u32) -> u32 {
    p.wrapping_sub(4).wrapping_mul(PRIME32_3_INV)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_is_an_inverse() {
        assert_eq!(PRIME32_3.wrapping_mul(PRIME32_3_INV), 1);
    }

    #[test]
    fn pcg_matches_published_reference_values() {
        // pcg_hash evaluated independently (arbitrary-precision integers masked to 32 bits).
        assert_eq!(pcg(0), 129_708_002);
        assert_eq!(pcg(1), 2_831_084_092);
        assert_eq!(pcg(0xdead_beef), 1_730_779_506);
    }

    #[test]
    fn xxh32_word_matches_published_sanity_vector() {
        // xxHash's sanity buffer (tests/sanity_test_vectors.h): byte i = top byte of
        // PRIME32 * PRIME64^i; XXH32 of its first 4 bytes with seed 0 is 0xA9DE7CE9.
        let mut byte_gen: u64 = 2_654_435_761;
        let mut bytes = [0u8; 4];
        for b in &mut bytes {
            *b = (byte_gen >> 56) as u8;
            byte_gen = byte_gen.wrapping_mul(11_400_714_785_074_694_797);
        }
        assert_eq!(xxh32_word(u32::from_le_bytes(bytes), 0), 0xA9DE_7CE9);
    }

    #[test]
    fn xxh32_word_matches_independent_implementation() {
        let mut x = 0x1234_5678u32;
        for seed in [0u32, 1, 2_654_435_761, u32::MAX] {
            for _ in 0..20_000 {
                x = pcg(x);
                let want = xxhash_rust::xxh32::xxh32(&x.to_le_bytes(), seed);
                assert_eq!(xxh32_word(x, seed), want, "word {x:#x} seed {seed}");
            }
        }
        for w in [0u32, 1, 4, u32::MAX, 0x8000_0000] {
            assert_eq!(
                xxh32_word(w, 0),
                xxhash_rust::xxh32::xxh32(&w.to_le_bytes(), 0)
            );
        }
    }

    #[test]
    fn jcgt_xxhash32_is_standard_xxh32_of_a_transformed_word() {
        let mut x = 7u32;
        for _ in 0..50_000 {
            x = pcg(x);
            let word = xxhash32_as_standard_input(x);
            assert_eq!(
                xxhash32(x),
                xxhash_rust::xxh32::xxh32(&word.to_le_bytes(), 0),
                "p = {x:#x}"
            );
        }
        for p in [0u32, 1, 3, 4, 5, u32::MAX] {
            let word = xxhash32_as_standard_input(p);
            assert_eq!(
                xxhash32(p),
                xxhash_rust::xxh32::xxh32(&word.to_le_bytes(), 0)
            );
        }
    }
}
