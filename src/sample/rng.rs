//! Seed derivation and the one random primitive the sampler uses.
//!
//! Reproducibility across machines and crate upgrades is the point: the stream is ChaCha8
//! (specified, portable), the seed is a SHA-256 of fixed-width little-endian inputs, and floats
//! are made from raw `u64`s here rather than through `rand`'s distribution code, whose
//! algorithms may change between releases.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::ir::{ConceptSet, Domain};

/// The domain's identity as hex ([`Domain::identity`]): the same digest seeds the scene stream
/// and identifies the domain of a run folder.
pub fn domain_hash(domain: &Domain) -> String {
    domain.identity().to_string()
}

pub(crate) fn domain_digest(domain: &Domain) -> [u8; 32] {
    domain.identity().0
}

/// The scene stream of `(domain, set, seed)`.
pub(crate) fn scene_rng(domain_digest: &[u8; 32], set: ConceptSet, seed: u64) -> ChaCha8Rng {
    let input = [&b"revelio.sample.v1"[..], domain_digest, &set.hash_bytes(), &seed.to_le_bytes()].concat();
    ChaCha8Rng::from_seed(crate::hash::sha256(&input))
}

/// Uniform in `[lo, hi]` (returns `lo` when the range is a point).
pub(crate) fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    // 53 random bits give every representable step of [0, 1); the clamp guards the rounding of
    // `lo + u * (hi - lo)` so the result never leaves the range.
    let u = (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
    (lo + u * (hi - lo)).clamp(lo.min(hi), hi.max(lo))
}

/// Uniform integer in `0..n` (`n > 0`), by rejection so that no value is favoured.
pub(crate) fn below(rng: &mut ChaCha8Rng, n: u64) -> u64 {
    let zone = u64::MAX - u64::MAX % n;
    loop {
        let x = rng.next_u64();
        if x < zone {
            return x % n;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stream_is_fixed_for_inputs() {
        let d = [7u8; 32];
        let a: Vec<u64> = (0..4).map(|_| scene_rng(&d, ConceptSet::from_bits(5), 9).next_u64()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        assert_ne!(
            scene_rng(&d, ConceptSet::from_bits(5), 9).next_u64(),
            scene_rng(&d, ConceptSet::from_bits(5), 10).next_u64()
        );
        assert_ne!(
            scene_rng(&d, ConceptSet::from_bits(5), 9).next_u64(),
            scene_rng(&d, ConceptSet::from_bits(4), 9).next_u64()
        );
    }

    #[test]
    fn uniform_stays_in_range() {
        let mut r = scene_rng(&[0; 32], ConceptSet::from_bits(1), 1);
        for _ in 0..10_000 {
            let x = uniform(&mut r, 2.0, 4.0);
            assert!((2.0..=4.0).contains(&x));
        }
        assert_eq!(uniform(&mut r, 3.0, 3.0), 3.0);
        assert!((0..1000).all(|_| below(&mut r, 3) < 3));
    }
}
