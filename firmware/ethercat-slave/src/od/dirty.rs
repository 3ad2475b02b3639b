//! Which bytes of an OD RAM copy were written: what the ESC-event context, working on its own
//! copy of the OD RAM, hands back to the process-data side (see `crate::slave::mailbox_side`).

use core::ops::Range;

/// Largest OD RAM whose writes can be tracked, in bytes.
pub const MAX_TRACKED_RAM: usize = 8192;
const BITS: usize = u32::BITS as usize;
const WORDS: usize = MAX_TRACKED_RAM / BITS;

/// One bit per OD RAM byte: set when [`super::Dictionary::set_value`] wrote it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DirtyMap {
    words: [u32; WORDS],
}

impl Default for DirtyMap {
    fn default() -> Self {
        Self::new()
    }
}

impl DirtyMap {
    /// Nothing written.
    pub const fn new() -> Self {
        Self { words: [0; WORDS] }
    }

    /// Marks `bytes` written (bytes beyond [`MAX_TRACKED_RAM`] are not tracked; the slave
    /// refuses a larger RAM).
    pub fn mark(&mut self, bytes: Range<usize>) {
        for b in bytes.take_while(|&b| b < MAX_TRACKED_RAM) {
            if let Some(w) = self.words.get_mut(b / BITS) {
                *w |= 1 << (b % BITS);
            }
        }
    }

    /// Whether anything was written.
    pub fn any(&self) -> bool {
        self.words.iter().any(|&w| w != 0)
    }

    /// Forgets every mark.
    pub fn clear(&mut self) {
        self.words = [0; WORDS];
    }

    /// Copies every marked byte of `from` to `to` (same layout), then clears the marks. Only the
    /// words that cover `from` are visited, so the work is bounded by the OD RAM, not by
    /// [`MAX_TRACKED_RAM`] (writes never mark bytes beyond the RAM they went to); marked bytes
    /// outside `to` are skipped.
    pub fn copy_marked(&mut self, from: &[u8], to: &mut [u8]) {
        // Word i covers the chunk i of BITS bytes on both sides.
        let mut to_chunks = to.chunks_mut(BITS);
        for (word, src) in self.words.iter_mut().zip(from.chunks(BITS)) {
            let mut w = core::mem::take(word);
            let Some(dst) = to_chunks.next() else {
                continue; // beyond `to`: only the marks are cleared
            };
            while w != 0 {
                let bit = w.trailing_zeros();
                // Clears the bit just found (below 32, as `w` is not 0).
                w ^= 1 << bit;
                let at = bit as usize;
                if let (Some(&v), Some(d)) = (src.get(at), dst.get_mut(at)) {
                    *d = v;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_marked_bytes_are_copied_and_the_marks_clear() {
        let mut d = DirtyMap::new();
        assert!(!d.any());
        d.mark(2..4);
        d.mark(40..41);
        assert!(d.any());
        let from = [0xAAu8; 64];
        let mut to = [0u8; 64];
        d.copy_marked(&from, &mut to);
        for (i, &b) in to.iter().enumerate() {
            let expected = if (2..4).contains(&i) || i == 40 {
                0xAA
            } else {
                0
            };
            assert_eq!(b, expected, "byte {i}");
        }
        assert!(!d.any(), "copying clears the marks");
    }

    #[test]
    fn marks_beyond_the_tracked_size_or_the_slices_are_ignored() {
        let mut d = DirtyMap::new();
        d.mark(MAX_TRACKED_RAM - 1..MAX_TRACKED_RAM + 10);
        let from = [1u8; 8];
        let mut to = [0u8; 8];
        d.copy_marked(&from, &mut to);
        assert_eq!(to, [0; 8]);
    }
}
