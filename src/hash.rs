//! Content hashes: SHA-256 of bytes, or of several parts at once. Every content address in
//! Revelio (images, prompts, cache keys, domain hashes, scene seeds, request signing) is made
//! here, so two places never disagree on how parts are joined.

use sha2::{Digest, Sha256};

/// SHA-256 of `bytes`.
pub fn sha256(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

/// SHA-256 of `bytes`, as 64 lowercase hex digits.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex::encode(sha256(bytes))
}

/// SHA-256 of the parts, each prefixed with its length (8 bytes, little-endian) so that
/// `("ab", "c")` and `("a", "bc")` differ.
pub fn parts<'a>(parts: impl IntoIterator<Item = &'a [u8]>) -> [u8; 32] {
    let mut h = Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    h.finalize().into()
}

/// [`parts`] after a fixed domain-separation `tag` (hashed as is, not length-prefixed), so that
/// digests of different kinds never coincide.
pub fn tagged_parts<'a>(tag: &[u8], parts: impl IntoIterator<Item = &'a [u8]>) -> [u8; 32] {
    let mut h = Sha256::new();
    h.update(tag);
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    h.finalize().into()
}

/// [`parts`] as 64 lowercase hex digits.
pub fn parts_hex<'a>(parts: impl IntoIterator<Item = &'a [u8]>) -> String {
    hex::encode(self::parts(parts))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_digest_and_part_boundaries() {
        assert_eq!(sha256_hex(b"abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
        assert_ne!(parts_hex([&b"ab"[..], b"c"]), parts_hex([&b"a"[..], b"bc"]));
        assert_ne!(parts_hex([&b"abc"[..]]), sha256_hex(b"abc"), "parts are length-prefixed");
        assert_eq!(parts_hex([&b"x"[..]]).len(), 64);
    }
}
